// zstd compression of brick payloads, with errors that name the brick.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace voxbrick::store {

/// Compresses `size` bytes at src into one zstd frame (with content checksum); dst is replaced. With
/// elementSize > 1 the bytes are first shuffled into planes (byte 0 of every value, then byte 1, ...): the high
/// bytes of smooth 16- and 32-bit fields repeat, so the planes compress far better and decode faster.
void compressFrame(const void* src, size_t size, size_t elementSize, int level, std::vector<char>& dst);

/// Decompresses one frame written by compressFrame with the same elementSize into exactly `expectedSize` bytes at
/// dst. Throws CorruptStoreError mentioning `what` when the frame is corrupt, fails its checksum, or decodes to a
/// different size.
void decompressFrame(const void* src, size_t size, size_t elementSize, void* dst, size_t expectedSize,
                     const std::string& what);

}  // namespace voxbrick::store
