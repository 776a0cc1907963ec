// The stores' shared block codec and output file: what decodes, what is reported for damaged frames, and a failed
// write reported through the caller's own error.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/BlockCodec.h"
#include "common/OutputFile.h"

namespace voxbrick::common {
namespace {

struct WriteError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
[[noreturn]] void throwWriteError(const std::string& message) { throw WriteError(message); }

std::vector<float> smoothField(size_t n) {
  std::vector<float> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = float(std::sin(double(i) * 0.01));
  return v;
}

TEST(BlockCodec, EveryElementSizeRoundTrips) {
  const std::vector<float> values = smoothField(10000);
  const size_t bytes = values.size() * sizeof(float);
  for (size_t elementSize : {1, 2, 4})
    for (bool checksum : {false, true}) {
      std::vector<char> frame;
      encodeBlock(values.data(), bytes, {elementSize, 3, checksum, elementSize == 4}, frame);
      std::vector<float> back(values.size());
      const BlockDecoding d = decodeBlock(frame.data(), frame.size(), elementSize, back.data(), bytes, true);
      ASSERT_TRUE(d) << elementSize;
      EXPECT_EQ(std::memcmp(back.data(), values.data(), bytes), 0) << elementSize;
    }
}

TEST(BlockCodec, ShufflingShrinksSmoothFloats) {
  const std::vector<float> values = smoothField(100000);
  std::vector<char> plain, shuffled;
  encodeBlock(values.data(), values.size() * 4, {1, 1, false, false}, plain);
  encodeBlock(values.data(), values.size() * 4, {4, 1, false, false}, shuffled);
  EXPECT_LT(shuffled.size(), plain.size());
}

TEST(BlockCodec, DamageIsReportedNotThrown) {
  const std::vector<float> values = smoothField(1000);
  const size_t bytes = values.size() * 4;
  std::vector<char> frame;
  encodeBlock(values.data(), bytes, {4, 3, true, false}, frame);
  std::vector<float> out(values.size() * 2);
  EXPECT_EQ(decodeBlock("nonsense", 8, 4, out.data(), bytes, true).fault, BlockFault::NotAFrame);
  const BlockDecoding other = decodeBlock(frame.data(), frame.size(), 4, out.data(), bytes + 4, true);
  EXPECT_EQ(other.fault, BlockFault::SizeDiffers);
  EXPECT_EQ(other.size, bytes);
  std::vector<char> damaged = frame;
  damaged[damaged.size() / 2] ^= 0x55;
  const BlockDecoding corrupt = decodeBlock(damaged.data(), damaged.size(), 4, out.data(), bytes, true);
  EXPECT_EQ(corrupt.fault, BlockFault::Corrupt);
  EXPECT_FALSE(corrupt.zstdError.empty());
}

TEST(OutputFile, AppendsAndReportsFailuresThroughTheCallersError) {
  const auto dir = std::filesystem::temp_directory_path() / ("voxbrick-outputfile-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {
    OutputFile file(dir / "a.bin", throwWriteError);
    EXPECT_EQ(file.append("abc", 3), 0u);
    EXPECT_EQ(file.append("de", 2), 3u);
    EXPECT_EQ(file.size(), 5u);
    file.close();
  }
  std::ifstream in(dir / "a.bin");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), "abcde");
  try {
    OutputFile file(dir / "missing" / "b.bin", throwWriteError);
    FAIL() << "a file in a missing directory cannot be created";
  } catch (const WriteError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot create " + (dir / "missing" / "b.bin").string() + ": "),
              std::string::npos)
        << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace voxbrick::common
