// Image conversion, PNG I/O through libpng, and error metrics.
#include "image/Image.h"
#include "image/ImageFile.h"

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>

namespace voxbrick::image {
namespace {

struct FileCloser {
  void operator()(FILE* f) const { std::fclose(f); }
};

[[noreturn]] void pngError(png_structp png, png_const_charp message) {
  auto* what = static_cast<std::string*>(png_get_error_ptr(png));
  *what = message;
  png_longjmp(png, 1);
}

}  // namespace

Image8 toImage8(const ImageF& image) {
  Image8 out{image.width, image.height, std::vector<uint8_t>(image.rgba.size())};
  // Truncating a value of at least 0.5 is its floor: a loop the compiler vectorizes (std::floor kept it scalar, about
  // 7 ms of a 1024² frame). A NaN, which std::clamp passes through, is taken as 0.
  const float* in = image.rgba.data();
  uint8_t* bytes = out.rgba.data();
  for (size_t i = 0; i < image.rgba.size(); ++i) {
    const float v = in[i];
    bytes[i] = static_cast<uint8_t>((v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f) * 255.0f + 0.5f);
  }
  return out;
}

ImageF toImageF(const Image8& image) {
  ImageF out{image.width, image.height, std::vector<float>(image.rgba.size())};
  for (size_t i = 0; i < image.rgba.size(); ++i) out.rgba[i] = float(image.rgba[i]) / 255.0f;
  return out;
}

std::vector<uint8_t> encodePng(const Image8& image, PngSpeed speed) {
  std::vector<uint8_t> out;
  std::string message;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &message, pngError, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) throw ImageFailure("encodePng: libpng could not start");
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw ImageFailure("encodePng: " + message);
  }
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t length) {
        auto* bytes = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(p));
        bytes->insert(bytes->end(), data, data + length);
      },
      nullptr);
  png_set_IHDR(png, info, png_uint_32(image.width), png_uint_32(image.height), 8, PNG_COLOR_TYPE_RGBA,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (speed == PngSpeed::Fast) {
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
    png_set_compression_level(png, 1);
  }
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) png_write_row(png, image.rgba.data() + size_t(y) * size_t(image.width) * 4);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

Image8 decodePng(std::span<const uint8_t> bytes, const std::string& what) {
  struct Reader {
    std::span<const uint8_t> bytes;
    size_t offset = 0;
  } reader{bytes};
  std::string message;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &message, pngError, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) throw ImageFailure("decodePng: libpng could not start");
  Image8 out;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw ImageFailure(what + ": not a readable PNG (" + message + ")");
  }
  png_set_read_fn(png, &reader, [](png_structp p, png_bytep data, png_size_t length) {
    auto* r = static_cast<Reader*>(png_get_io_ptr(p));
    if (length > r->bytes.size() - r->offset) png_error(p, "truncated");
    std::memcpy(data, r->bytes.data() + r->offset, length);
    r->offset += length;
  });
  png_read_info(png, info);
  png_set_expand(png);
  png_set_strip_16(png);
  png_set_gray_to_rgb(png);
  png_set_add_alpha(png, 0xFF, PNG_FILLER_AFTER);
  png_read_update_info(png, info);
  out.width = int(png_get_image_width(png, info));
  out.height = int(png_get_image_height(png, info));
  if (out.width <= 0 || out.height <= 0 || out.width > 65536 || out.height > 65536)
    png_error(png, "image size out of range");
  out.rgba.resize(size_t(out.width) * size_t(out.height) * 4);
  std::vector<png_bytep> rows(size_t(out.height));
  for (int y = 0; y < out.height; ++y) rows[size_t(y)] = out.rgba.data() + size_t(y) * size_t(out.width) * 4;
  png_read_image(png, rows.data());
  png_destroy_read_struct(&png, &info, nullptr);
  return out;
}

void writePng(const std::filesystem::path& path, const Image8& image) { writeFileAtomically(path, encodePng(image)); }

Image8 readPng(const std::filesystem::path& path) {
  std::unique_ptr<FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file) throw ImageFailure("cannot read " + path.string() + ": " + std::strerror(errno));
  std::vector<uint8_t> bytes;
  uint8_t buffer[1 << 16];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, file.get())) > 0) bytes.insert(bytes.end(), buffer, buffer + n);
  if (std::ferror(file.get())) throw ImageFailure("cannot read " + path.string() + ": " + std::strerror(errno));
  return decodePng(bytes, path.string());
}

ImageError compareImages(const ImageF& a, const ImageF& b) {
  if (a.width != b.width || a.height != b.height)
    throw ImageFailure("compareImages: sizes differ (" + std::to_string(a.width) + "x" + std::to_string(a.height) +
                       " vs " + std::to_string(b.width) + "x" + std::to_string(b.height) + ")");
  double sum = 0, maxAbs = 0;
  const size_t pixels = size_t(a.width) * size_t(a.height);
  for (size_t p = 0; p < pixels; ++p)
    for (int c = 0; c < 3; ++c) {
      const double d = double(a.rgba[4 * p + size_t(c)]) - double(b.rgba[4 * p + size_t(c)]);
      sum += d * d;
      maxAbs = std::max(maxAbs, std::abs(d));
    }
  ImageError e;
  e.rmse = pixels ? std::sqrt(sum / double(3 * pixels)) : 0;
  e.maxAbs = maxAbs;
  e.psnr = e.rmse > 0 ? 20 * std::log10(1 / e.rmse) : std::numeric_limits<double>::infinity();
  return e;
}

ImageF differenceHeatmap(const ImageF& a, const ImageF& b, double scale) {
  compareImages(a, b);  // the size check, with its message
  if (!(scale > 0) || !std::isfinite(scale))
    throw ImageFailure("differenceHeatmap: scale " + std::to_string(scale) + " is not finite and positive");
  // A ramp whose lightness rises monotonically, so that it also reads in grey.
  constexpr float kRamp[5][3] = {{0, 0, 0}, {0.35f, 0.05f, 0.55f}, {0.85f, 0.15f, 0.2f}, {1, 0.8f, 0.1f}, {1, 1, 1}};
  ImageF out{a.width, a.height, std::vector<float>(a.rgba.size())};
  for (size_t p = 0; p < a.rgba.size(); p += 4) {
    double d = 0;
    for (size_t c = 0; c < 3; ++c) d = std::max(d, std::abs(double(a.rgba[p + c]) - double(b.rgba[p + c])));
    const double x = std::clamp(d / scale, 0.0, 1.0) * 4;
    const int i = std::min(int(x), 3);
    const float t = float(x - i);
    for (size_t c = 0; c < 3; ++c) out.rgba[p + c] = kRamp[i][c] + t * (kRamp[i + 1][c] - kRamp[i][c]);
    out.rgba[p + 3] = 1;
  }
  return out;
}

}  // namespace voxbrick::image
