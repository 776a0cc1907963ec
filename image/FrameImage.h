// Frame payloads: an 8-bit RGBA image in one of the protocol's encodings (proto::Encoding), and back.
#pragma once

#include <cstdint>
#include <vector>

#include "proto/Messages.h"
#include "image/Image.h"

namespace voxbrick::image {

/// The image as a Frame payload in `encoding`.
std::vector<uint8_t> encodeFrameImage(const Image8& image, proto::Encoding encoding);
/// A Frame's payload as an image; throws std::runtime_error if it does not decode to the frame's size.
Image8 decodeFrameImage(const proto::Frame& frame);

}  // namespace voxbrick::image
