// The one block codec of both stores: values of a fixed size, shuffled into byte planes, in one zstd frame (the brick
// store's bricks, the mesh store's blocks). Each store words its own errors (decodeBlock reports the fault).
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace voxbrick::common {

/// zstd's failure to encode (nothing else fails): its message is zstd's error name.
class CodecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// How a block is encoded; what decodes it is the same elementSize.
struct BlockEncoding {
  /// Bytes of a value. Values of 2 and 4 bytes are first shuffled into planes (byte 0 of every value, then byte 1,
  /// ...): the high bytes of smooth fields, of float exponents and of indices repeat, so the planes compress far better
  /// and decode faster.
  size_t elementSize = 1;
  int level = 1;             ///< zstd's compression level
  bool checksum = false;     ///< zstd's checksum of the content, in the frame
  bool rawLiterals = false;  ///< literals stored as they are rather than Huffman coded (zstd's negative levels do so)
};

/// Encodes `size` bytes at src (a whole number of values) into one zstd frame that states its content size; dst is
/// replaced. Throws CodecError.
void encodeBlock(const void* src, size_t size, const BlockEncoding& encoding, std::vector<char>& dst);

/// What went wrong decoding a frame, if anything.
enum class BlockFault {
  None,
  NotAFrame,    ///< the bytes do not start a zstd frame
  SizeUnknown,  ///< the frame does not state its content size (refused only when the size is required)
  SizeDiffers,  ///< the frame states another content size: `size`
  Corrupt,      ///< zstd could not decode it: `zstdError`
  WrongLength,  ///< it decoded to another number of bytes: `size`
};

struct BlockDecoding {
  BlockFault fault = BlockFault::None;
  uint64_t size = 0;      ///< the size the frame states (SizeDiffers) or decoded to (WrongLength)
  std::string zstdError;  ///< Corrupt: zstd's error name
  explicit operator bool() const { return fault == BlockFault::None; }
};

/// Decodes one frame of `size` bytes at src, encoded with `elementSize`, into exactly `expectedSize` bytes at dst. A
/// frame that states no content size is decoded all the same unless `requireSize`. Never throws for bad bytes: the
/// result says what is wrong with them (dst then holds anything).
[[nodiscard]] BlockDecoding decodeBlock(const void* src, size_t size, size_t elementSize, void* dst,
                                        size_t expectedSize, bool requireSize);

}  // namespace voxbrick::common
