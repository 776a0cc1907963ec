// zstd compression of brick payloads, with errors that name the brick.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace voxbrick::store {

/// Compresses `size` bytes at src into one zstd frame (with content checksum) appended to nothing: dst is replaced.
void compressFrame(const void* src, size_t size, int level, std::vector<char>& dst);

/// Decompresses one zstd frame into exactly `expectedSize` bytes at dst. Throws CorruptStoreError mentioning
/// `what` when the frame is corrupt, fails its checksum, or decodes to a different size.
void decompressFrame(const void* src, size_t size, void* dst, size_t expectedSize, const std::string& what);

}  // namespace voxbrick::store
