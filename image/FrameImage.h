// Frame payloads: an 8-bit RGBA image in one of the protocol's encodings (proto::Encoding), and back.
#pragma once

#include <cstdint>
#include <vector>

#include "image/Image.h"
#include "image/ImageFile.h"
#include "proto/Messages.h"

namespace voxbrick::image {

/// The largest frame side a client decodes (the renderer's own limit is 8192).
inline constexpr uint32_t kMaxFrameSide = 1u << 16;

/// The JPEG quality of a jpeg frame whose scene gives no `jpeg_quality`: the lowest whose worst view of the MRI stays
/// at 40 dB or more against the lossless frame at 512² and 1024².
inline constexpr int kDefaultJpegQuality = 85;
/// How a jpeg frame stores colour: 4:2:0 reaches any PSNR on the MRI in fewer bytes than 4:4:4.
inline constexpr JpegChroma kFrameJpegChroma = JpegChroma::Half;

/// The image as a Frame payload in `encoding`: jpeg frames at `jpegQuality` (1..100) with kFrameJpegChroma, alpha
/// dropped; png frames at `pngSpeed`; webp frames lossless (encodeWebp's default level). Throws ImageFailure for an
/// unknown encoding, a video encoding (image/Video.h encodes a stream's frames) or a quality out of range.
std::vector<uint8_t> encodeFrameImage(const Image8& image, proto::Encoding encoding,
                                      int jpegQuality = kDefaultJpegQuality, PngSpeed pngSpeed = PngSpeed::Small);
/// A Frame's payload as an image (a jpeg frame with alpha 255); throws ImageFailure naming the problem if its size is
/// absurd, the payload does not decode to exactly that size, or it is a video frame (image::VideoDecoder decodes a
/// stream).
Image8 decodeFrameImage(const proto::Frame& frame);

}  // namespace voxbrick::image
