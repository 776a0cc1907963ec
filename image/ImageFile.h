// Image files as commands write them: the format chosen by the file's extension (PNG, JPEG), and every file written
// atomically (a temporary beside it, then a rename), so that a failed write leaves the old file or none.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "image/Image.h"

namespace voxbrick::image {

enum class ImageFormat { Png, Jpeg };

/// The format an output path asks for: `.png` PNG, `.jpg`/`.jpeg` JPEG (any case); throws ImageFailure naming the
/// extension and the file otherwise.
ImageFormat imageFormatFor(const std::filesystem::path& path);

/// How an image file is written.
struct ImageWriteOptions {
  int jpegQuality = 90;  ///< libjpeg quality in [1, 100]
};

/// How a JPEG stores colour: Auto is 4:2:0 below quality 90, else 4:4:4; Full is 4:4:4 (full-resolution chroma);
/// Half is 4:2:0 (chroma at half resolution both ways).
enum class JpegChroma { Auto, Full, Half };

/// A baseline JPEG of the RGB channels; alpha is dropped. Throws ImageFailure if `quality` is outside [1, 100] or the
/// image is empty.
std::vector<uint8_t> encodeJpeg(const Image8& image, int quality, JpegChroma chroma = JpegChroma::Auto);
/// Decodes a JPEG (grey or colour) as 8-bit RGBA with alpha 255; throws ImageFailure naming `what`. With
/// `expectedSize` ({width, height}), a JPEG whose header names another size is refused before its pixels are
/// allocated.
Image8 decodeJpeg(std::span<const uint8_t> bytes, const std::string& what,
                  std::optional<std::array<int, 2>> expectedSize = std::nullopt);

/// A lossless WebP (libwebp's VP8L) of the RGBA image, alpha included, every pixel's colour kept (also under alpha 0):
/// it decodes to exactly `image`. libwebp's lossless preset `level` (0..9: more time for fewer bytes); the default, 1,
/// took fewer bytes than 0 and half the time of 2 for the same bytes on the MRI's frames
/// (bench/results/image/png-speed.md). Throws ImageFailure if the image is empty or libwebp fails.
std::vector<uint8_t> encodeWebp(const Image8& image, int level = 1);
/// Decodes a WebP as 8-bit RGBA; throws ImageFailure naming `what`. With `expectedSize`, a WebP whose header names
/// another size is refused before its pixels are allocated.
Image8 decodeWebp(std::span<const uint8_t> bytes, const std::string& what,
                  std::optional<std::array<int, 2>> expectedSize = std::nullopt);

/// Writes `bytes` to `path` through a temporary file in the same directory, renamed over `path` once complete and
/// flushed: on any failure (a full disk, a file-size limit) the temporary is removed, an existing file at `path` is
/// untouched, and ImageFailure names `path` and the reason.
void writeFileAtomically(const std::filesystem::path& path, std::span<const uint8_t> bytes);

/// Writes `image` in the format `path`'s extension asks for (imageFormatFor), atomically.
void writeImage(const std::filesystem::path& path, const Image8& image, const ImageWriteOptions& options = {});
/// Reads a PNG or a JPEG (by its first bytes) as 8-bit RGBA; throws ImageFailure naming the file.
Image8 readImage(const std::filesystem::path& path);

}  // namespace voxbrick::image
