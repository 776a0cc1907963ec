// The stores' checksum: zlib's CRC-32, checked against the standard's known values.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "common/Checksum.h"

namespace voxbrick::common {
namespace {

uint32_t crcOf(const std::string& text, uint32_t crc = 0) { return crc32Of(text.data(), text.size(), crc); }

TEST(Checksum, KnownValues) {
  EXPECT_EQ(crcOf(""), 0u);
  EXPECT_EQ(crcOf("a"), 0xE8B7BE43u);
  EXPECT_EQ(crcOf("123456789"), 0xCBF43926u);  // the CRC-32 check value
  EXPECT_EQ(crcOf("The quick brown fox jumps over the lazy dog"), 0x414FA339u);
  const std::vector<unsigned char> zeros(32, 0);
  EXPECT_EQ(crc32Of(zeros.data(), zeros.size()), 0x190A55ADu);
}

TEST(Checksum, ContinuesFromAPreviousValue) {
  EXPECT_EQ(crcOf("6789", crcOf("12345")), 0xCBF43926u);
  EXPECT_EQ(crcOf("", crcOf("123456789")), 0xCBF43926u);
}

TEST(Checksum, ABufferInPiecesEqualsTheWhole) {
  std::vector<unsigned char> bytes(1 << 20);
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<unsigned char>(i * 2654435761u >> 24);
  const uint32_t whole = crc32Of(bytes.data(), bytes.size());
  uint32_t pieces = 0;
  for (size_t at = 0; at < bytes.size(); at += 4097)
    pieces = crc32Of(bytes.data() + at, std::min<size_t>(4097, bytes.size() - at), pieces);
  EXPECT_EQ(pieces, whole);
  EXPECT_NE(whole, 0u);
}

}  // namespace
}  // namespace voxbrick::common
