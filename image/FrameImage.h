// Frame payloads: an 8-bit RGBA image in one of the protocol's encodings (proto::Encoding), and back.
#pragma once

#include <cstdint>
#include <vector>

#include "image/Image.h"
#include "proto/Messages.h"

namespace voxbrick::image {

/// The largest frame side a client decodes (the renderer's own limit is 8192).
inline constexpr uint32_t kMaxFrameSide = 1u << 16;

/// The image as a Frame payload in `encoding`; throws ImageFailure for an unknown encoding.
std::vector<uint8_t> encodeFrameImage(const Image8& image, proto::Encoding encoding);
/// A Frame's payload as an image; throws ImageFailure naming the problem if its size is absurd or the payload does
/// not decode to exactly that size.
Image8 decodeFrameImage(const proto::Frame& frame);

}  // namespace voxbrick::image
