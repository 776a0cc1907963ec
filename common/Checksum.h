// The checksum of the stores' on-disk formats: the brick store's and the mesh store's indices and the mesh store's
// blocks all carry zlib's CRC-32 (the polynomial of gzip and PNG).
#pragma once

#include <cstddef>
#include <cstdint>

namespace voxbrick::common {

/// CRC-32 (zlib's) of `size` bytes at `data`, of any size, continuing from `crc` (0 to start).
uint32_t crc32Of(const void* data, size_t size, uint32_t crc = 0);

}  // namespace voxbrick::common
