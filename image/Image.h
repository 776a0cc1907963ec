// Images: linear float RGBA as renderers produce them, 8-bit RGBA for output, PNG files, error metrics. No GL: the
// server, the clients and the benchmarks use it as the renderers do.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace voxbrick::image {

/// A PNG that cannot be read or written, or images that cannot be compared; the message names the file or the sizes.
class ImageFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An RGBA image, row 0 at the top, 4 floats per pixel in [0, 1] (colour already composited over the background).
struct ImageF {
  int width = 0, height = 0;
  std::vector<float> rgba;
  float* pixel(int x, int y) { return rgba.data() + 4 * (size_t(y) * size_t(width) + size_t(x)); }
  const float* pixel(int x, int y) const { return rgba.data() + 4 * (size_t(y) * size_t(width) + size_t(x)); }
};

/// An 8-bit RGBA image, row 0 at the top.
struct Image8 {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;
};

/// Rounds to 8 bits per channel (round half up, clamped to [0, 1]).
Image8 toImage8(const ImageF& image);
/// `image` scaled to `width` x `height` (each from 1 to 16383), each axis on its own: where it shrinks, each pixel
/// is the mean of the area of the image it covers; where it grows, bilinear; pixel centres aligned, as a browser
/// draws an image scaled onto a canvas (image/Scale.cpp). The same image when the size is its own. Throws
/// ImageFailure for such a size, or an image whose bytes are not 4 a pixel.
Image8 scaleImage(const Image8& image, int width, int height);
/// Scales 8-bit channels to [0, 1].
ImageF toImageF(const Image8& image);

/// How hard encodePng works. Small: libpng's adaptive choice of filter for each row and zlib's default level, the
/// smaller file. Fast: the Up filter on every row and zlib's level 1, in a fifth to a quarter of the time, for 0-4 %
/// more bytes on shaded renderings of the MRI, 14-21 % on others and 44 % on a flat picture
/// (bench/results/image/png-speed.md).
enum class PngSpeed { Small, Fast };

/// An 8-bit RGBA PNG in memory.
std::vector<uint8_t> encodePng(const Image8& image, PngSpeed speed = PngSpeed::Small);
/// Decodes a PNG of any bit depth and colour type as 8-bit RGBA; throws ImageFailure naming `what`.
Image8 decodePng(std::span<const uint8_t> bytes, const std::string& what);
/// Writes an 8-bit RGBA PNG atomically (image/ImageFile.h); throws ImageFailure naming the file.
void writePng(const std::filesystem::path& path, const Image8& image);
/// Reads a PNG of any bit depth and colour type as 8-bit RGBA; throws ImageFailure naming the file.
Image8 readPng(const std::filesystem::path& path);

/// Image differences on RGB in [0, 1] (alpha ignored), as the optical model measures error.
struct ImageError {
  double rmse = 0;
  double psnr = 0;  ///< 20 log10(1 / rmse) dB; infinity for identical images
  double maxAbs = 0;
};
/// Compares two images of the same size; throws ImageFailure if the sizes differ.
ImageError compareImages(const ImageF& a, const ImageF& b);

/// Where two images differ: each pixel's largest absolute RGB difference d, shown as black (0) through purple, red
/// and yellow to white (d >= scale). `scale` must be finite and positive; throws ImageFailure as compareImages does.
ImageF differenceHeatmap(const ImageF& a, const ImageF& b, double scale);

}  // namespace voxbrick::image
