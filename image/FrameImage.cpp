// Frame payloads: PNG through image/Image, zstd at level 1 (fast enough not to show beside a frame's render time),
// JPEG and lossless WebP through image/ImageFile.
#include "image/FrameImage.h"

#include <stdexcept>
#include <string>
#include <utility>

#include <zstd.h>

namespace voxbrick::image {
namespace {

/// Width and height from a PNG's IHDR chunk (big-endian at bytes 16 and 20), read before libpng allocates for
/// them; (0, 0) when the bytes are too short to hold one.
std::pair<uint32_t, uint32_t> pngSize(const std::vector<uint8_t>& png) {
  if (png.size() < 24) return {0, 0};
  auto be32 = [&](size_t at) {
    return uint32_t(png[at]) << 24 | uint32_t(png[at + 1]) << 16 | uint32_t(png[at + 2]) << 8 | uint32_t(png[at + 3]);
  };
  return {be32(16), be32(20)};
}

}  // namespace

std::vector<uint8_t> encodeFrameImage(const Image8& image, proto::Encoding encoding, int jpegQuality,
                                      PngSpeed pngSpeed) {
  switch (encoding) {
    case proto::Encoding::RawRgba8: return image.rgba;
    case proto::Encoding::Png: return encodePng(image, pngSpeed);
    case proto::Encoding::ZstdRgba8: {
      std::vector<uint8_t> out(ZSTD_compressBound(image.rgba.size()));
      const size_t n = ZSTD_compress(out.data(), out.size(), image.rgba.data(), image.rgba.size(), 1);
      if (ZSTD_isError(n)) throw ImageFailure(std::string("encodeFrameImage: zstd: ") + ZSTD_getErrorName(n));
      out.resize(n);
      return out;
    }
    case proto::Encoding::Jpeg: return encodeJpeg(image, jpegQuality, kFrameJpegChroma);
    case proto::Encoding::Webp: return encodeWebp(image);
    case proto::Encoding::Vp8:
    case proto::Encoding::Vp9:
      throw ImageFailure(std::string("encodeFrameImage: a ") + proto::encodingName(encoding) +
                         " frame belongs to a stream: encode it with image::VideoEncoder");
  }
  throw ImageFailure("encodeFrameImage: unknown encoding " + std::to_string(int(encoding)));
}

Image8 decodeFrameImage(const proto::Frame& frame) {
  // Checked before any size is computed from them: a hostile or broken server must not make a client allocate.
  if (frame.width == 0 || frame.height == 0 || frame.width > kMaxFrameSide || frame.height > kMaxFrameSide)
    throw ImageFailure("frame: size " + std::to_string(frame.width) + "x" + std::to_string(frame.height) +
                       " is outside 1.." + std::to_string(kMaxFrameSide) + " per side");
  Image8 image{int(frame.width), int(frame.height), {}};
  const size_t bytes = size_t(frame.width) * size_t(frame.height) * 4;
  switch (frame.encoding) {
    case proto::Encoding::Png:
      if (pngSize(frame.payload) != std::pair{frame.width, frame.height})
        throw ImageFailure("frame: the PNG's header does not name the frame's " + std::to_string(frame.width) + "x" +
                           std::to_string(frame.height) + " size");
      image = decodePng(frame.payload, "frame");
      break;
    case proto::Encoding::RawRgba8: image.rgba = frame.payload; break;
    case proto::Encoding::Jpeg:
      image = decodeJpeg(frame.payload, "frame", std::array{int(frame.width), int(frame.height)});
      break;
    case proto::Encoding::Webp:
      image = decodeWebp(frame.payload, "frame", std::array{int(frame.width), int(frame.height)});
      break;
    case proto::Encoding::Vp8:
    case proto::Encoding::Vp9:
      throw ImageFailure(std::string("frame: a ") + proto::encodingName(frame.encoding) +
                         " frame decodes only in its stream, with the frames before it (image::VideoDecoder)");
    case proto::Encoding::ZstdRgba8: {
      image.rgba.resize(bytes);
      const size_t n = ZSTD_decompress(image.rgba.data(), bytes, frame.payload.data(), frame.payload.size());
      if (ZSTD_isError(n) || n != bytes) throw ImageFailure("frame: zstd payload does not decode to the frame size");
      break;
    }
  }
  if (image.width != int(frame.width) || image.height != int(frame.height) || image.rgba.size() != bytes)
    throw ImageFailure("frame: payload does not match its " + std::to_string(frame.width) + "x" +
                       std::to_string(frame.height) + " size");
  return image;
}

}  // namespace voxbrick::image
