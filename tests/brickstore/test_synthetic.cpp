// Tests of the analytic test fields and the "synthetic:" source: spec parsing, placement, ranges, exact delivery.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/ingest/Sources.h"
#include "brickstore/ingest/synthetic/SyntheticField.h"

namespace voxbrick::store {
namespace {

/// The message of the InputError that parsing `spec` throws (fails the test if it parses).
std::string parseError(const std::string& spec) {
  try {
    SyntheticField::parse(spec);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "spec '" << spec << "' parsed";
  return {};
}

/// Every sample of a field, x fastest.
std::vector<double> allSamples(const SyntheticField& field) {
  const Vec3i& n = field.dims();
  std::vector<double> out;
  out.reserve(static_cast<size_t>(n.volume()));
  for (int64_t k = 0; k < n.z; ++k)
    for (int64_t j = 0; j < n.y; ++j)
      for (int64_t i = 0; i < n.x; ++i) out.push_back(field.sample(i, j, k));
  return out;
}

TEST(SyntheticField, ParsesNamesAndDimensions) {
  SyntheticField ml = SyntheticField::parse("marschner-lobb");
  EXPECT_EQ(ml.name(), "marschner-lobb");
  EXPECT_EQ(ml.dims(), (Vec3i{64, 64, 64}));
  EXPECT_EQ(ml.spacing(), (Vec3d{1, 1, 1}));
  EXPECT_EQ(ml.type(), ValueType::F32);
  EXPECT_EQ(ml.background(), 0.0);

  EXPECT_EQ(SyntheticField::parse("shells,n=32,count=4").dims(), (Vec3i{32, 32, 32}));
  EXPECT_EQ(SyntheticField::parse("blobs,n=16,ny=8,nz=4").dims(), (Vec3i{16, 8, 4}));
  EXPECT_EQ(SyntheticField::parse("sparse,nx=5,ny=6,nz=7,fill=0.05").dims(), (Vec3i{5, 6, 7}));
  EXPECT_EQ(SyntheticField::parse("hdr,n=16384").dims().x, 16384);

  std::vector<std::string> names = SyntheticField::names();
  for (const char* name : {"marschner-lobb", "shells", "blobs", "sparse", "hdr"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
    EXPECT_EQ(SyntheticField::parse(name).name(), name);
  }
}

TEST(SyntheticField, SpecErrorsNameTheProblem) {
  std::string unknown = parseError("mandelbulb,n=8");
  EXPECT_NE(unknown.find("unknown field 'mandelbulb'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("marschner-lobb, shells, blobs, sparse, hdr"), std::string::npos) << unknown;
  EXPECT_NE(parseError("").find("no field name"), std::string::npos);

  std::string badKey = parseError("shells,n=8,radius=3");
  EXPECT_NE(badKey.find("unknown key 'radius'"), std::string::npos) << badKey;
  EXPECT_NE(badKey.find("count, width"), std::string::npos) << badKey;
  EXPECT_NE(parseError("hdr,fm=3").find("unknown key 'fm'"), std::string::npos);

  EXPECT_NE(parseError("blobs,n=abc").find("bad integer 'abc' for n"), std::string::npos);
  EXPECT_NE(parseError("blobs,n=12x").find("bad integer '12x'"), std::string::npos);
  EXPECT_NE(parseError("blobs,n=").find("bad integer ''"), std::string::npos);
  EXPECT_NE(parseError("marschner-lobb,alpha=0.2.5").find("bad number '0.2.5' for alpha"), std::string::npos);
  EXPECT_NE(parseError("marschner-lobb,fm=nan").find("bad number"), std::string::npos);
  EXPECT_NE(parseError("marschner-lobb,fm=-1").find("fm=-1 must be > 0"), std::string::npos);
  EXPECT_NE(parseError("hdr,n=0").find("n=0 is out of range [1, 16384]"), std::string::npos);
  EXPECT_NE(parseError("hdr,n=-4").find("out of range"), std::string::npos);
  EXPECT_NE(parseError("hdr,n=16385").find("out of range"), std::string::npos);
  EXPECT_NE(parseError("hdr,n=8,nz=100000").find("nz=100000 is out of range"), std::string::npos);
  EXPECT_NE(parseError("sparse,fill=0.5").find("fill=0.5 must be in (0, 0.2]"), std::string::npos);
  EXPECT_NE(parseError("shells,count=0").find("count=0"), std::string::npos);
  EXPECT_NE(parseError("shells,count").find("expected key=value, got 'count'"), std::string::npos);
  EXPECT_NE(parseError("shells,=3").find("expected key=value"), std::string::npos);
  EXPECT_NE(parseError("shells,n=8,n=9").find("key 'n' is given twice"), std::string::npos);
  EXPECT_NE(parseError("shells,n=0").find("synthetic spec 'shells,n=0'"), std::string::npos);
}

TEST(SyntheticField, SamplesSitAtCellCentres) {
  SyntheticField field = SyntheticField::parse("blobs,nx=6,ny=5,nz=4");
  field.setSpacing({0.5, 2.0, 3.0});
  // Sample (i,j,k) is at ((i + 0.5) - n/2) * s, and the box [-n s / 2, n s / 2] is the cube [-1,1]^3.
  EXPECT_EQ(field.sample(0, 0, 0), field.evaluate(-1.25, -4.0, -4.5));
  EXPECT_EQ(field.sample(5, 4, 3), field.evaluate(1.25, 4.0, 4.5));
  EXPECT_DOUBLE_EQ(field.evaluate(1.5, -5.0, 6.0), field.evaluateNormalised(1.0, -1.0, 1.0));
  EXPECT_DOUBLE_EQ(field.evaluate(0.3, 1.0, -1.5), field.evaluateNormalised(0.2, 0.2, -0.25));

  // Spacing stretches the box with the field, so the samples themselves do not change.
  SyntheticField unit = SyntheticField::parse("blobs,nx=6,ny=5,nz=4");
  EXPECT_DOUBLE_EQ(unit.sample(2, 3, 1), field.sample(2, 3, 1));
  EXPECT_THROW(field.setSpacing({0, 1, 1}), InputError);
}

TEST(SyntheticField, MarschnerLobbRangeAndKnownValues) {
  SyntheticField ml = SyntheticField::parse("marschner-lobb");
  // Centre: (1 - sin 0 + α (1 + cos(2π fM))) / (2 (1 + α)) = (1 + 2α) / (2 + 2α) = 0.6 for α = 0.25.
  EXPECT_NEAR(ml.evaluate(0, 0, 0), 0.6, 1e-15);
  // Top face centre: (1 - 1 + 2α) / (2 + 2α) = 0.2; bottom face centre: (2 + 2α) / (2 + 2α) = 1.
  EXPECT_NEAR(ml.evaluateNormalised(0, 0, 1), 0.2, 1e-15);
  EXPECT_NEAR(ml.evaluateNormalised(0, 0, -1), 1.0, 1e-15);
  // At r = 1, cos(πr/2) = 0 so ρr = 1 whatever fM is.
  EXPECT_NEAR(ml.evaluateNormalised(1, 0, 0), 0.6, 1e-12);

  std::vector<double> values = allSamples(ml);
  auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  EXPECT_GE(*lo, 0.0);
  EXPECT_LE(*hi, 1.0);
  EXPECT_LT(*lo, 0.05);  // the signal really spans the range
  EXPECT_GT(*hi, 0.95);

  SyntheticField custom = SyntheticField::parse("marschner-lobb,fm=3,alpha=0.5,n=8");
  EXPECT_NEAR(custom.evaluate(0, 0, 0), 2.0 / 3.0, 1e-15);  // (1 + 2 * 0.5) / 3
}

TEST(SyntheticField, ShellsPeakAtTheirRadiiAndVanishBetween) {
  SyntheticField shells = SyntheticField::parse("shells,count=3");
  for (double r : {0.25, 0.5, 0.75}) EXPECT_NEAR(shells.evaluateNormalised(r, 0, 0), 1.0, 1e-12) << r;
  EXPECT_EQ(shells.evaluateNormalised(0, 0, 0), 0.0);
  EXPECT_EQ(shells.evaluateNormalised(0.95, 0, 0), 0.0);
  EXPECT_EQ(shells.evaluateNormalised(1, 1, 1), 0.0);
  const double mid = shells.evaluateNormalised(0, 0.25 + 0.03125, 0);  // one width out: exp(-1/2), rescaled
  EXPECT_NEAR(mid, (std::exp(-0.5) - std::exp(-8.0)) / (1 - std::exp(-8.0)), 1e-12);

  SyntheticField wide = SyntheticField::parse("shells,count=1,width=0.1");
  EXPECT_NEAR(wide.evaluateNormalised(0, 0, 0.5), 1.0, 1e-12);
  EXPECT_GT(wide.evaluateNormalised(0, 0, 0.85), 0.0);
  EXPECT_EQ(wide.evaluateNormalised(0, 0, 0.95), 0.0);
}

TEST(SyntheticField, BlobsAreSeededAndBounded) {
  std::vector<double> a = allSamples(SyntheticField::parse("blobs,n=24"));
  std::vector<double> b = allSamples(SyntheticField::parse("blobs,n=24,seed=1"));
  std::vector<double> c = allSamples(SyntheticField::parse("blobs,n=24,seed=2"));
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  auto [lo, hi] = std::minmax_element(a.begin(), a.end());
  EXPECT_GE(*lo, 0.0);
  EXPECT_GT(*hi, 0.4);
  EXPECT_LT(*hi, 2.0);
}

TEST(SyntheticField, SparseIsMostlyExactZeros) {
  SyntheticField sparse = SyntheticField::parse("sparse");
  std::vector<double> values = allSamples(sparse);
  const auto zeros = std::count(values.begin(), values.end(), 0.0);
  const double zeroFraction = static_cast<double>(zeros) / static_cast<double>(values.size());
  EXPECT_GT(zeroFraction, 0.9);
  EXPECT_NEAR(1.0 - zeroFraction, 0.03, 0.005);  // the balls fill about `fill` of the box
  EXPECT_LE(*std::max_element(values.begin(), values.end()), 1.0);
  EXPECT_GE(*std::min_element(values.begin(), values.end()), 0.0);

  std::vector<double> dense = allSamples(SyntheticField::parse("sparse,n=48,fill=0.2,count=2,seed=7"));
  const auto denseZeros = std::count(dense.begin(), dense.end(), 0.0);
  EXPECT_NEAR(1.0 - static_cast<double>(denseZeros) / static_cast<double>(dense.size()), 0.2, 0.02);
}

TEST(SyntheticField, HdrCoversElevenDecades) {
  std::vector<double> values = allSamples(SyntheticField::parse("hdr"));
  auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  EXPECT_GT(*lo, 0.0);
  EXPECT_LE(*lo, 1e-5);
  EXPECT_GE(*hi, 1e5);
  EXPECT_LE(*hi, 1e6);
  SyntheticField hdr = SyntheticField::parse("hdr");
  EXPECT_NEAR(hdr.evaluate(0, 0, 0), 1e6, 1e-6);
  EXPECT_NEAR(hdr.evaluateNormalised(1, 1, 1), 1e-6, 1e-18);
}

TEST(SyntheticSource, DeliversExactlyTheFieldSamples) {
  for (const char* spec : {"marschner-lobb,nx=13,ny=7,nz=5", "shells,n=9", "blobs,nx=4,ny=11,nz=6",
                           "sparse,n=12,fill=0.2,count=3", "hdr,nx=3,ny=2,nz=9"}) {
    SCOPED_TRACE(spec);
    std::unique_ptr<VolumeSource> source = openSyntheticSource(spec, SourceOptions{});
    const SyntheticField* field = source->analytic();
    ASSERT_NE(field, nullptr);
    const VolumeInfo& info = source->info();
    EXPECT_EQ(info.dims, field->dims());
    EXPECT_EQ(info.type, ValueType::F32);
    EXPECT_EQ(info.background, 0.0);
    EXPECT_EQ(info.spacing, (Vec3d{1, 1, 1}));

    // Read in uneven batches, including an empty one, to check the z position carries over.
    const Vec3i n = info.dims;
    std::vector<float> volume(static_cast<size_t>(n.volume()));
    int64_t z = 0;
    for (int64_t batch : {int64_t{1}, int64_t{0}, int64_t{2}, n.z}) {
      const int64_t count = std::min(batch, n.z - z);
      source->readSlices(count, volume.data() + z * n.x * n.y);
      z += count;
    }
    ASSERT_EQ(z, n.z);
    for (int64_t k = 0; k < n.z; ++k)
      for (int64_t j = 0; j < n.y; ++j)
        for (int64_t i = 0; i < n.x; ++i)
          ASSERT_EQ(volume[static_cast<size_t>((k * n.y + j) * n.x + i)], static_cast<float>(field->sample(i, j, k)))
              << i << "," << j << "," << k;
    EXPECT_THROW(source->readSlices(1, volume.data()), InputError);
  }
}

TEST(SyntheticField, RowsAreTheSamplesBitForBit) {
  // sampleRow takes shortcuts (coordinates, bump terms and whole balls per row); every float must still be
  // sample()'s, over rows that miss every ball, touch one, and with spacings that change the rounding.
  for (const char* spec : {"marschner-lobb,nx=37,ny=11,nz=5,fm=3", "shells,nx=31,ny=29,nz=7,count=5",
                           "blobs,nx=33,ny=17,nz=9,count=13,seed=4", "sparse,n=40,fill=0.2,count=9,seed=2",
                           "sparse,n=48", "hdr,nx=19,ny=23,nz=3"}) {
    for (const Vec3d spacing : {Vec3d{1, 1, 1}, Vec3d{0.3, 1.7, 0.11}}) {
      SCOPED_TRACE(std::string(spec) + " spacing " + std::to_string(spacing.y));
      SyntheticField field = SyntheticField::parse(spec);
      field.setSpacing(spacing);
      const Vec3i n = field.dims();
      std::vector<float> row(static_cast<size_t>(n.x));
      int64_t nonZero = 0;
      for (int64_t k = 0; k < n.z; ++k)
        for (int64_t j = 0; j < n.y; ++j) {
          field.sampleRow(j, k, row.data());
          for (int64_t i = 0; i < n.x; ++i) {
            ASSERT_EQ(std::bit_cast<uint32_t>(row[size_t(i)]), std::bit_cast<uint32_t>(float(field.sample(i, j, k))))
                << i << "," << j << "," << k;
            nonZero += row[size_t(i)] != 0;
          }
        }
      EXPECT_GT(nonZero, 0);
    }
  }
}

TEST(SyntheticSource, DescriptionAndSpacingOverride) {
  SourceOptions options;
  options.spacing = {0.5, 0.5, 2.0};
  options.spacingGiven = true;
  std::unique_ptr<VolumeSource> source = openSyntheticSource("marschner-lobb,n=8,nz=4", options);
  EXPECT_EQ(source->info().description, "synthetic marschner-lobb 8x8x4");
  EXPECT_EQ(source->info().spacing, options.spacing);
  EXPECT_EQ(source->analytic()->spacing(), options.spacing);

  options.spacing = {1, -1, 1};
  EXPECT_THROW(openSyntheticSource("hdr,n=4", options), InputError);
  EXPECT_THROW(openSyntheticSource("nothing", SourceOptions{}), InputError);
}

TEST(SyntheticSource, LargeVolumeEvaluatesOnlyTheSlicesAskedFor) {
  // A 512^3 field costs only the two slices read: nothing is evaluated ahead.
  std::unique_ptr<VolumeSource> source = openSyntheticSource("sparse,n=512", SourceOptions{});
  std::vector<float> slices(size_t{512} * 512 * 2);
  source->readSlices(2, slices.data());
  EXPECT_EQ(slices[512 * 256 + 256], static_cast<float>(source->analytic()->sample(256, 256, 0)));
}

}  // namespace
}  // namespace voxbrick::store
