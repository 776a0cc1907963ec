// PNG through render/Image, zstd at level 1 (fast enough not to show beside a frame's render time).
#include "image/FrameImage.h"

#include <stdexcept>
#include <string>

#include <zstd.h>

namespace voxbrick::image {

std::vector<uint8_t> encodeFrameImage(const Image8& image, proto::Encoding encoding) {
  switch (encoding) {
    case proto::Encoding::RawRgba8:
      return image.rgba;
    case proto::Encoding::Png:
      return encodePng(image);
    case proto::Encoding::ZstdRgba8: {
      std::vector<uint8_t> out(ZSTD_compressBound(image.rgba.size()));
      const size_t n = ZSTD_compress(out.data(), out.size(), image.rgba.data(), image.rgba.size(), 1);
      if (ZSTD_isError(n)) throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(n));
      out.resize(n);
      return out;
    }
  }
  throw std::runtime_error("unknown frame encoding");
}

Image8 decodeFrameImage(const proto::Frame& frame) {
  Image8 image{int(frame.width), int(frame.height), {}};
  const size_t bytes = size_t(frame.width) * size_t(frame.height) * 4;
  switch (frame.encoding) {
    case proto::Encoding::Png:
      image = decodePng(frame.payload, "frame");
      break;
    case proto::Encoding::RawRgba8:
      image.rgba = frame.payload;
      break;
    case proto::Encoding::ZstdRgba8: {
      image.rgba.resize(bytes);
      const size_t n = ZSTD_decompress(image.rgba.data(), bytes, frame.payload.data(), frame.payload.size());
      if (ZSTD_isError(n) || n != bytes) throw std::runtime_error("frame: zstd payload does not decode to the frame size");
      break;
    }
  }
  if (image.width != int(frame.width) || image.height != int(frame.height) || image.rgba.size() != bytes)
    throw std::runtime_error("frame: payload does not match its " + std::to_string(frame.width) + "x" +
                             std::to_string(frame.height) + " size");
  return image;
}

}  // namespace voxbrick::image
