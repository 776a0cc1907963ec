// Level 1 and the histogram made during level 0's pass (so level 0 is not read back) give the store that reading
// level 0 back gives: Level1Spill against DownsampleSource, and whole stores from a raw file (which can be read again,
// so prep counts its histogram from it) against the same values from a source that cannot.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/LevelSources.h"
#include "brickstore/prep/StoreWriter.h"
#include "support/ArraySource.h"
#include "support/TestSupport.h"

namespace voxbrick::store {
namespace {

using test::ArraySource;
using test::ScratchDir;

/// Every slice of `source`, read in batches of `batch`.
std::vector<char> readAll(VolumeSource& source, int64_t batch) {
  const VolumeInfo& info = source.info();
  const size_t slice = static_cast<size_t>(info.dims.x * info.dims.y) * valueSize(info.type);
  std::vector<char> all(slice * static_cast<size_t>(info.dims.z));
  for (int64_t z = 0; z < info.dims.z; z += batch)
    source.readSlices(std::min(batch, info.dims.z - z), all.data() + slice * size_t(z));
  return all;
}

template <typename T>
void expectSpillMatchesDownsample(Vec3i dims, ValueType type, int64_t batch) {
  ScratchDir dir;
  const std::vector<T> values = test::randomVolume<T>(dims, 0, 1000, 5);
  ArraySource<T> fine(dims, type, values);
  DownsampleSource expected(fine);
  const std::vector<char> want = readAll(expected, 1);

  Level1Spill spill(fine.info(), dir / "level1.scratch");
  const size_t slice = static_cast<size_t>(dims.x * dims.y);
  for (int64_t z = 0; z < dims.z; z += batch)
    spill.addSlices(z, std::min(batch, dims.z - z), values.data() + slice * size_t(z));
  std::unique_ptr<VolumeSource> level1 = spill.spilled();
  EXPECT_EQ(level1->info().dims.x, expected.info().dims.x);
  EXPECT_EQ(level1->info().dims.y, expected.info().dims.y);
  ASSERT_EQ(level1->info().dims.z, expected.info().dims.z);
  EXPECT_EQ(readAll(*level1, 3), want);
}

TEST(FirstPass, SpillIsTheDownsample) {
  expectSpillMatchesDownsample<float>({13, 11, 9}, ValueType::F32, 4);  // odd dims: the last plane, row, column
  expectSpillMatchesDownsample<float>({16, 8, 32}, ValueType::F32, 8);
  expectSpillMatchesDownsample<uint16_t>({7, 12, 10}, ValueType::U16, 2);  // integers round half up
}

TEST(FirstPass, SpillRefusesSlicesOutOfOrder) {
  ScratchDir dir;
  ArraySource<float> fine({4, 4, 8}, ValueType::F32, std::vector<float>(128, 1.0f));
  Level1Spill spill(fine.info(), dir / "level1.scratch");
  std::vector<float> slices(64, 1.0f);
  EXPECT_THROW(spill.addSlices(2, 2, slices.data()), StoreError);
  EXPECT_THROW(spill.addSlices(0, 3, slices.data()), StoreError);
  EXPECT_THROW(spill.spilled(), StoreError);
}

TEST(FirstPass, RawSourceReopensAtTheStart) {
  ScratchDir dir;
  const Vec3i dims{6, 5, 4};
  const std::vector<float> values = test::randomVolume<float>(dims, -1, 1, 3);
  test::writeFile(dir / "v.raw", values.data(), values.size() * sizeof(float));
  SourceOptions options;
  options.dims = dims;
  options.type = "f32";
  std::unique_ptr<VolumeSource> source = openSource((dir / "v.raw").string(), options);
  std::vector<float> first(30);
  source->readSlices(1, first.data());
  std::unique_ptr<VolumeSource> again = source->reopen();
  ASSERT_NE(again, nullptr);
  std::vector<float> all(values.size());
  again->readSlices(dims.z, all.data());
  EXPECT_EQ(all, values);
  ArraySource<float> array(dims, ValueType::F32, values);
  EXPECT_EQ(array.reopen(), nullptr);
}

void expectSameStore(Vec3i dims, int brick, int threads, bool nonFinite) {
  ScratchDir dir;
  std::vector<float> values = test::randomVolume<float>(dims, -3, 7, 11);
  for (size_t n = 0; n < values.size(); n += 97) values[n] = 0;  // background voxels
  if (nonFinite) {
    values[5] = std::numeric_limits<float>::quiet_NaN();
    values[values.size() - 3] = std::numeric_limits<float>::infinity();
  }
  test::writeFile(dir / "v.raw", values.data(), values.size() * sizeof(float));
  PrepOptions options;
  options.brickSize = brick;
  options.threads = threads;
  options.memoryBudgetMB = 256;
  SourceOptions raw;
  raw.dims = dims;
  raw.type = "f32";
  std::unique_ptr<VolumeSource> file = openSource((dir / "v.raw").string(), raw);
  ASSERT_NE(file->reopen(), nullptr);
  const PrepSummary a = prepStore(*file, dir / "a", options);
  ArraySource<float> array(dims, ValueType::F32, values);
  array.setSpacing(file->info().spacing);
  const PrepSummary b = prepStore(array, dir / "b", options);
  // The raw file's pass made level 1 and its histogram came from the file read again; the array's read level 0 back.
  auto hasPhase = [](const PrepSummary& s, const std::string& name) {
    return std::any_of(s.phases.begin(), s.phases.end(), [&](const PhaseTime& p) { return p.name == name; });
  };
  EXPECT_TRUE(hasPhase(a, "histogram (input read again)"));
  EXPECT_TRUE(hasPhase(a, "levels 1+ (level 1 from level 0's pass)"));
  EXPECT_TRUE(hasPhase(b, "levels 1+ (level 0 read back) and histogram"));
  EXPECT_FALSE(std::filesystem::exists(dir / "a" / "level1.scratch"));
  EXPECT_EQ(test::readFile(dir / "a" / "bricks.bin"), test::readFile(dir / "b" / "bricks.bin"));
  EXPECT_EQ(test::readFile(dir / "a" / "index.bin"), test::readFile(dir / "b" / "index.bin"));
  EXPECT_EQ(a.meta.histogram.counts, b.meta.histogram.counts);
  EXPECT_EQ(a.meta.valueMin, b.meta.valueMin);
  EXPECT_EQ(a.meta.valueMax, b.meta.valueMax);
  EXPECT_EQ(a.meta.nonFiniteReplaced, b.meta.nonFiniteReplaced);
  EXPECT_EQ(a.meta.bytesVdb, b.meta.bytesVdb);
}

TEST(FirstPass, StoreIsTheReadBackStore) {
  expectSameStore({40, 36, 50}, 8, 2, false);
  expectSameStore({33, 17, 21}, 8, 1, true);    // odd dims, non-finite values replaced
  expectSameStore({20, 20, 12}, 32, 2, false);  // one level: the histogram alone
}

}  // namespace
}  // namespace voxbrick::store
