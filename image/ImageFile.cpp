// Image files: JPEG through libjpeg(-turbo), the choice of format by extension, and atomic writes.
#include "image/ImageFile.h"

#include <jpeglib.h>
#include <webp/decode.h>
#include <webp/encode.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>

#include "common/AtomicReplace.h"

namespace voxbrick::image {
namespace {

/// libjpeg reports errors through a callback that must not return: it jumps back to the call with the message.
struct JpegErrors {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = "";
};

[[noreturn]] void jpegError(j_common_ptr info) {
  auto* errors = reinterpret_cast<JpegErrors*>(info->err);
  (*info->err->format_message)(info, errors->message);
  std::longjmp(errors->jump, 1);
}

void jpegSilence(j_common_ptr, int) {}

std::string lowerExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

}  // namespace

ImageFormat imageFormatFor(const std::filesystem::path& path) {
  const std::string ext = lowerExtension(path);
  if (ext == ".png") return ImageFormat::Png;
  if (ext == ".jpg" || ext == ".jpeg") return ImageFormat::Jpeg;
  throw ImageFailure(path.string() + ": cannot write images of extension '" + ext + "' (use .png, .jpg or .jpeg)");
}

std::vector<uint8_t> encodeJpeg(const Image8& image, int quality, JpegChroma chroma) {
  if (quality < 1 || quality > 100)
    throw ImageFailure("encodeJpeg: quality " + std::to_string(quality) + " is outside [1, 100]");
  if (image.width <= 0 || image.height <= 0) throw ImageFailure("encodeJpeg: empty image");
  jpeg_compress_struct info{};
  JpegErrors errors;
  info.err = jpeg_std_error(&errors.mgr);
  errors.mgr.error_exit = jpegError;
  errors.mgr.emit_message = jpegSilence;
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  std::vector<uint8_t> row(size_t(image.width) * 3);
  if (setjmp(errors.jump)) {
    jpeg_destroy_compress(&info);
    std::free(buffer);
    throw ImageFailure(std::string("encodeJpeg: ") + errors.message);
  }
  jpeg_create_compress(&info);
  jpeg_mem_dest(&info, &buffer, &size);
  info.image_width = JDIMENSION(image.width);
  info.image_height = JDIMENSION(image.height);
  info.input_components = 3;
  info.in_color_space = JCS_RGB;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, quality, TRUE);
  // Full-resolution chroma at high quality: thin coloured features of a transfer function survive.
  if (chroma == JpegChroma::Full || (chroma == JpegChroma::Auto && quality >= 90))
    for (int c = 0; c < info.num_components; ++c) info.comp_info[c].h_samp_factor = info.comp_info[c].v_samp_factor = 1;
  jpeg_start_compress(&info, TRUE);
  while (info.next_scanline < info.image_height) {
    const uint8_t* src = image.rgba.data() + size_t(info.next_scanline) * size_t(image.width) * 4;
    for (int x = 0; x < image.width; ++x) std::memcpy(&row[size_t(x) * 3], src + size_t(x) * 4, 3);
    JSAMPROW rows[1] = {row.data()};
    jpeg_write_scanlines(&info, rows, 1);
  }
  jpeg_finish_compress(&info);
  std::vector<uint8_t> bytes(buffer, buffer + size);
  jpeg_destroy_compress(&info);
  std::free(buffer);
  return bytes;
}

Image8 decodeJpeg(std::span<const uint8_t> bytes, const std::string& what,
                  std::optional<std::array<int, 2>> expectedSize) {
  jpeg_decompress_struct info{};
  JpegErrors errors;
  info.err = jpeg_std_error(&errors.mgr);
  errors.mgr.error_exit = jpegError;
  errors.mgr.emit_message = jpegSilence;
  Image8 image;
  std::vector<uint8_t> row;
  if (setjmp(errors.jump)) {
    jpeg_destroy_decompress(&info);
    throw ImageFailure(what + ": not a readable JPEG: " + errors.message);
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, bytes.data(), static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(&info, TRUE);
  if (expectedSize &&
      (int64_t(info.image_width) != (*expectedSize)[0] || int64_t(info.image_height) != (*expectedSize)[1])) {
    const std::string size = std::to_string(info.image_width) + "x" + std::to_string(info.image_height);
    jpeg_destroy_decompress(&info);
    throw ImageFailure(what + ": the JPEG is " + size + ", not the expected " + std::to_string((*expectedSize)[0]) +
                       "x" + std::to_string((*expectedSize)[1]));
  }
  info.out_color_space = JCS_RGB;
  jpeg_start_decompress(&info);
  image.width = int(info.output_width);
  image.height = int(info.output_height);
  image.rgba.assign(size_t(image.width) * size_t(image.height) * 4, 255);
  row.resize(size_t(image.width) * 3);
  while (info.output_scanline < info.output_height) {
    uint8_t* dst = image.rgba.data() + size_t(info.output_scanline) * size_t(image.width) * 4;
    JSAMPROW rows[1] = {row.data()};
    jpeg_read_scanlines(&info, rows, 1);
    for (int x = 0; x < image.width; ++x) std::memcpy(dst + size_t(x) * 4, &row[size_t(x) * 3], 3);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return image;
}

void writeFileAtomically(const std::filesystem::path& path, std::span<const uint8_t> bytes) {
  try {
    common::replaceFile(path, bytes);
  } catch (const common::ReplaceError& e) {
    throw ImageFailure(e.what());
  }
}

std::vector<uint8_t> encodeWebp(const Image8& image, int level) {
  if (image.width <= 0 || image.height <= 0 || image.rgba.size() != size_t(image.width) * size_t(image.height) * 4)
    throw ImageFailure("encodeWebp: an empty or inconsistent image");
  if (image.width > WEBP_MAX_DIMENSION || image.height > WEBP_MAX_DIMENSION)
    throw ImageFailure("encodeWebp: " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                       " exceeds WebP's " + std::to_string(WEBP_MAX_DIMENSION) + " pixels a side");
  WebPConfig config;
  if (!WebPConfigInit(&config) || !WebPConfigLosslessPreset(&config, std::clamp(level, 0, 9)))
    throw ImageFailure("encodeWebp: libwebp refused its configuration");
  config.exact = 1;  // keep the colour under alpha 0: lossless means every byte
  WebPPicture picture;
  if (!WebPPictureInit(&picture)) throw ImageFailure("encodeWebp: libwebp version mismatch");
  picture.width = image.width;
  picture.height = image.height;
  picture.use_argb = 1;
  WebPMemoryWriter writer;
  WebPMemoryWriterInit(&writer);
  picture.writer = WebPMemoryWrite;
  picture.custom_ptr = &writer;
  const bool ok = WebPPictureImportRGBA(&picture, image.rgba.data(), image.width * 4) && WebPEncode(&config, &picture);
  const int error = picture.error_code;
  std::vector<uint8_t> bytes(writer.mem, writer.mem + (ok ? writer.size : 0));
  WebPPictureFree(&picture);
  WebPMemoryWriterClear(&writer);
  if (!ok) throw ImageFailure("encodeWebp: libwebp failed (error " + std::to_string(error) + ")");
  return bytes;
}

Image8 decodeWebp(std::span<const uint8_t> bytes, const std::string& what,
                  std::optional<std::array<int, 2>> expectedSize) {
  int width = 0, height = 0;
  if (!WebPGetInfo(bytes.data(), bytes.size(), &width, &height))
    throw ImageFailure(what + ": not a WebP image (its header does not read)");
  if (expectedSize && (width != (*expectedSize)[0] || height != (*expectedSize)[1]))
    throw ImageFailure(what + ": the WebP is " + std::to_string(width) + "x" + std::to_string(height) + ", not " +
                       std::to_string((*expectedSize)[0]) + "x" + std::to_string((*expectedSize)[1]));
  Image8 image{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 4)};
  if (!WebPDecodeRGBAInto(bytes.data(), bytes.size(), image.rgba.data(), image.rgba.size(), width * 4))
    throw ImageFailure(what + ": the WebP does not decode (truncated or damaged)");
  return image;
}

void writeImage(const std::filesystem::path& path, const Image8& image, const ImageWriteOptions& options) {
  const std::vector<uint8_t> bytes =
      imageFormatFor(path) == ImageFormat::Jpeg ? encodeJpeg(image, options.jpegQuality) : encodePng(image);
  writeFileAtomically(path, bytes);
}

Image8 readImage(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ImageFailure("cannot read " + path.string() + ": " + std::strerror(errno));
  const std::vector<uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (bytes.size() >= 2 && bytes[0] == 0xFF && bytes[1] == 0xD8) return decodeJpeg(bytes, path.string());
  return decodePng(bytes, path.string());
}

}  // namespace voxbrick::image
