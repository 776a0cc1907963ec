// Quantised stores: the linear map and its bound, every stored voxel against it, the range prep records and
// reads back, the first pass that finds an input's exact range, and the errors for bad options.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/format/Quantise.h"
#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickStore.h"
#include "support/ArraySource.h"
#include "support/TestSupport.h"

namespace voxbrick::store {
namespace {

using test::ArraySource;
using test::ScratchDir;

TEST(Quantisation, MapsTheRangeOntoTheStepsWithinHalfAStep) {
  for (const ValueType type : {ValueType::U8, ValueType::U16}) {
    Quantisation q{type, -3.5, 7.25};
    const double step = (q.hi - q.lo) / q.steps();
    EXPECT_EQ(q.quantise(q.lo), 0);
    EXPECT_EQ(q.quantise(q.hi), q.steps());
    EXPECT_EQ(q.quantise(-100), 0);           // clamped below
    EXPECT_EQ(q.quantise(1e300), q.steps());  // and above
    EXPECT_DOUBLE_EQ(q.dequantise(q.steps()), q.hi);
    double worst = 0;
    for (int i = 0; i <= 100000; ++i) {
      const double v = q.lo + (q.hi - q.lo) * i / 100000.0;
      const double qv = q.quantise(v);
      ASSERT_EQ(qv, std::floor(qv));
      worst = std::max(worst, std::abs(q.dequantise(qv) - v));
    }
    EXPECT_LE(worst, step / 2 * (1 + 1e-9));
    EXPECT_GT(worst, step / 2 * 0.99);  // the bound is tight
    // Windows in input values map onto steps without rounding.
    EXPECT_NEAR(q.toSteps(q.lo + 2.5 * step), 2.5, 1e-9);
  }
}

TEST(Quantisation, RejectsBadTypesAndRanges) {
  EXPECT_THROW(parseQuantiseType("f32"), InputError);
  EXPECT_THROW(parseQuantiseType("i16"), InputError);
  EXPECT_THROW(parseQuantiseType(""), InputError);
  EXPECT_EQ(parseQuantiseType("u16"), ValueType::U16);
  Quantisation q;
  for (const char* bad : {"1,1", "2,1", "0,nan", "inf,1", "0", "0,1,2", "a,b", ",1", "1,"}) {
    SCOPED_TRACE(bad);
    EXPECT_THROW(parseQuantiseRange(bad, q), InputError);
  }
  parseQuantiseRange("-0.5,1e3", q);
  EXPECT_EQ(q.lo, -0.5);
  EXPECT_EQ(q.hi, 1000);
  EXPECT_THROW((Quantisation{ValueType::U8, 1, 1}.validate()), InputError);
  EXPECT_THROW((Quantisation{ValueType::F32, 0, 1}.validate()), InputError);
  EXPECT_THROW((Quantisation{ValueType::U8, 0, std::numeric_limits<double>::infinity()}.validate()), InputError);
}

TEST(QuantisedStore, EveryVoxelIsTheQuantisedInputAndTheRangeReadsBack) {
  ScratchDir dir;
  const Vec3i n{23, 17, 41};
  std::vector<float> v = test::randomVolume<float>(n, -2.0, 6.0, 7);
  for (size_t i = 0; i < v.size(); i += 5) v[i] = 0.0f;  // the background
  v[11] = std::nanf("");                                 // replaced by the background, then quantised
  v[12] = 9.0f;                                          // outside the range below: clamped
  ArraySource<float> src(n, ValueType::F32, v);
  PrepOptions options;
  options.brickSize = 8;
  options.writeVdb = false;
  const Quantisation q{ValueType::U16, -2.0, 6.0};
  options.quantise = q;
  prepStore(src, dir / "s", options);
  auto s = BrickStore::open(dir / "s");
  const StoreMeta& m = s->meta();
  EXPECT_EQ(m.type, ValueType::U16);
  ASSERT_TRUE(m.quantisation.has_value());
  EXPECT_EQ(*m.quantisation, q);
  EXPECT_EQ(m.quantisationClamped, 1);
  EXPECT_EQ(m.nonFiniteReplaced, 1);
  EXPECT_EQ(m.background, q.quantise(0.0));
  EXPECT_EQ(m.bytesRaw, n.volume() * 2);
  EXPECT_DOUBLE_EQ(m.storedValue(6.0), 65535.0);
  const int64_t B = 8, E = B + 2;
  std::vector<uint16_t> brick(size_t(E * E * E));
  double lo = 1e9, hi = -1e9;
  for (uint32_t k = 0; k < s->level(0).bricks.z; ++k)
    for (uint32_t j = 0; j < s->level(0).bricks.y; ++j)
      for (uint32_t i = 0; i < s->level(0).bricks.x; ++i) {
        s->readBrick({0, i, j, k}, brick.data());
        for (int64_t c = 1; c <= B; ++c)
          for (int64_t b = 1; b <= B; ++b)
            for (int64_t a = 1; a <= B; ++a) {
              const int64_t x = i * B + a - 1, y = j * B + b - 1, z = k * B + c - 1;
              if (x >= n.x || y >= n.y || z >= n.z) continue;
              float in = v[size_t(x + n.x * (y + n.y * z))];
              if (std::isnan(in)) in = 0.0f;
              const uint16_t got = brick[size_t(a + E * (b + E * c))];
              ASSERT_EQ(got, q.quantise(in)) << x << "," << y << "," << z;
              lo = std::min(lo, double(got));
              hi = std::max(hi, double(got));
            }
      }
  EXPECT_EQ(m.valueMin, lo);
  EXPECT_EQ(m.valueMax, hi);
  EXPECT_EQ(m.valueMax, 65535);  // the clamped voxel

  // store.json keeps the quantisation; a store whose type disagrees with it is refused.
  const std::vector<char> bytes = test::readFile(dir / "s" / "store.json");
  std::string json(bytes.begin(), bytes.end());
  const StoreMeta back = StoreMeta::fromJson(json, "store.json");
  EXPECT_EQ(back.quantisation, m.quantisation);
  EXPECT_EQ(back.quantisationClamped, 1);
  json.replace(json.find("\"type\": \"u16\"\n"), 13, "\"type\": \"u8\"\n");
  EXPECT_THROW(StoreMeta::fromJson(json, "store.json"), CorruptStoreError);
}

TEST(QuantisedStore, ScanFindsTheRangePrepWouldRecord) {
  // The first pass of `prep --quantise` (no range given) must find exactly the f32 store's value range, so that
  // the quantised store's default window normalises like the f32 store's.
  ScratchDir dir;
  auto first = openSource("synthetic:blobs,n=40", {});
  const Level0Stats stats = scanLevel0(*first, 0.0, NonFinitePolicy::Background, {}, 40 * 40 * 4 * 3);
  auto again = openSource("synthetic:blobs,n=40", {});
  PrepOptions options;
  options.brickSize = 16;
  options.writeVdb = false;
  prepStore(*again, dir / "f", options);
  const StoreMeta f = BrickStore::open(dir / "f")->meta();
  EXPECT_EQ(stats.min, f.valueMin);
  EXPECT_EQ(stats.max, f.valueMax);
  EXPECT_EQ(stats.active, f.activeVoxels);

  auto third = openSource("synthetic:blobs,n=40", {});
  options.quantise = Quantisation{ValueType::U8, stats.min, stats.max};
  prepStore(*third, dir / "q", options);
  const StoreMeta q = BrickStore::open(dir / "q")->meta();
  EXPECT_EQ(q.valueMin, 0);
  EXPECT_EQ(q.valueMax, 255);
  EXPECT_EQ(q.quantisationClamped, 0);
  EXPECT_NE(q.source.find("quantised to u8"), std::string::npos) << q.source;
}

}  // namespace
}  // namespace voxbrick::store
