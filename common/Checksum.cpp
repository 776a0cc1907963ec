// CRC-32 through zlib, which takes a uInt length: larger buffers are fed in pieces.
#include "common/Checksum.h"

#include <zlib.h>

#include <algorithm>
#include <limits>

namespace voxbrick::common {

uint32_t crc32Of(const void* data, size_t size, uint32_t crc) {
  const auto* p = static_cast<const Bytef*>(data);
  uLong c = crc;
  while (size > 0) {
    const auto n = static_cast<uInt>(std::min<size_t>(size, std::numeric_limits<uInt>::max()));
    c = ::crc32(c, p, n);
    p += n;
    size -= n;
  }
  return static_cast<uint32_t>(c);
}

}  // namespace voxbrick::common
