// The frame-image codec on its own: every encoding round-trips, encodes deterministically, and refuses payloads that
// do not decode to the frame's size, with no socket, server or GL involved.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include <zlib.h>

#include "image/FrameImage.h"

namespace voxbrick::image {
namespace {

/// A w x h image whose every byte differs from its neighbours' (so a shifted or swapped decode cannot pass).
Image8 pattern(int width, int height) {
  Image8 image{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 4)};
  for (size_t i = 0; i < image.rgba.size(); ++i) image.rgba[i] = uint8_t((i * 37 + i / 7) & 0xff);
  return image;
}

proto::Frame frameOf(const Image8& image, proto::Encoding encoding) {
  proto::Frame frame;
  frame.width = uint32_t(image.width);
  frame.height = uint32_t(image.height);
  frame.encoding = encoding;
  frame.payload = encodeFrameImage(image, encoding);
  return frame;
}

const proto::Encoding kEncodings[] = {proto::Encoding::RawRgba8, proto::Encoding::Png, proto::Encoding::ZstdRgba8,
                                      proto::Encoding::Webp};

TEST(FrameImage, EveryEncodingRoundTripsExactly) {
  const Image8 image = pattern(37, 21);
  for (proto::Encoding encoding : kEncodings) {
    const Image8 back = decodeFrameImage(frameOf(image, encoding));
    EXPECT_EQ(back.width, 37);
    EXPECT_EQ(back.height, 21);
    EXPECT_EQ(back.rgba, image.rgba) << "encoding " << int(encoding);
  }
}

TEST(FrameImage, EncodingTwiceGivesTheSameBytes) {
  const Image8 image = pattern(64, 48);
  for (proto::Encoding encoding : kEncodings)
    EXPECT_EQ(encodeFrameImage(image, encoding), encodeFrameImage(image, encoding)) << "encoding " << int(encoding);
}

TEST(FrameImage, CompressedEncodingsAreSmallerOnAFlatImage) {
  Image8 flat{256, 256, std::vector<uint8_t>(256 * 256 * 4, 90)};
  EXPECT_LT(encodeFrameImage(flat, proto::Encoding::Png).size(), flat.rgba.size() / 50);
  EXPECT_LT(encodeFrameImage(flat, proto::Encoding::ZstdRgba8).size(), flat.rgba.size() / 50);
  EXPECT_LT(encodeFrameImage(flat, proto::Encoding::Webp).size(), flat.rgba.size() / 50);
}

// A webp frame is lossless to the byte: the colour of a pixel whose alpha is 0 comes back too (libwebp would
// otherwise flatten it, which a transparent frame composited by a client would show).
TEST(FrameImage, AWebpFrameKeepsEveryByteEvenUnderAlphaZero) {
  Image8 image{40, 30, std::vector<uint8_t>(40 * 30 * 4)};
  for (size_t i = 0; i < image.rgba.size(); i += 4) {
    image.rgba[i] = uint8_t(i * 7), image.rgba[i + 1] = uint8_t(i / 4), image.rgba[i + 2] = uint8_t(255 - i % 251);
    image.rgba[i + 3] = (i / 4) % 3 == 0 ? 0 : uint8_t(i % 256);
  }
  const proto::Frame frame = frameOf(image, proto::Encoding::Webp);
  ASSERT_GE(frame.payload.size(), 12u);
  EXPECT_EQ(std::string(frame.payload.begin() + 8, frame.payload.begin() + 12), "WEBP");
  EXPECT_EQ(decodeFrameImage(frame).rgba, image.rgba);
  EXPECT_EQ(decodeWebp(encodeWebp(image, 0), "level 0").rgba, image.rgba) << "every level is lossless";
}

/// The filter byte of each row of an 8-bit RGBA PNG (its IDAT chunks' data inflated).
std::vector<int> rowFilters(const std::vector<uint8_t>& png, int width, int height) {
  std::vector<uint8_t> deflated;
  for (size_t at = 8; at + 12 <= png.size();) {
    const size_t length = size_t(png[at]) << 24 | size_t(png[at + 1]) << 16 | size_t(png[at + 2]) << 8 | png[at + 3];
    if (std::string(png.begin() + long(at) + 4, png.begin() + long(at) + 8) == "IDAT")
      deflated.insert(deflated.end(), png.begin() + long(at) + 8, png.begin() + long(at + 8 + length));
    at += 12 + length;
  }
  const size_t stride = 1 + size_t(width) * 4;
  std::vector<uint8_t> rows(stride * size_t(height));
  uLongf size = uLongf(rows.size());
  EXPECT_EQ(uncompress(rows.data(), &size, deflated.data(), uLong(deflated.size())), Z_OK);
  EXPECT_EQ(size, rows.size());
  std::vector<int> filters;
  for (size_t y = 0; y < size_t(height); ++y) filters.push_back(rows[y * stride]);
  return filters;
}

TEST(FrameImage, AFastPngIsTheSamePictureWithEveryRowFilteredUp) {
  // A picture whose rows suit different filters: a smooth ramp across (Sub) over detail that repeats down (Up).
  Image8 image{96, 64, std::vector<uint8_t>(96 * 64 * 4)};
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 96; ++x)
      for (int c = 0; c < 4; ++c)
        image.rgba[(size_t(y) * 96 + size_t(x)) * 4 + size_t(c)] =
            uint8_t(y < 32 ? x * 2 + c : (x * 37 + c * 11) & 0xff);
  const std::vector<uint8_t> fast = encodeFrameImage(image, proto::Encoding::Png, kDefaultJpegQuality, PngSpeed::Fast);
  const std::vector<uint8_t> small = encodeFrameImage(image, proto::Encoding::Png);
  for (const auto* png : {&fast, &small}) {
    proto::Frame frame{96, 64, proto::Encoding::Png, "{}", *png};
    EXPECT_EQ(decodeFrameImage(frame).rgba, image.rgba);
  }
  EXPECT_EQ(rowFilters(fast, 96, 64), std::vector<int>(64, 2)) << "PNG's Up filter is 2";
  const std::vector<int> chosen = rowFilters(small, 96, 64);
  EXPECT_NE(std::count(chosen.begin(), chosen.end(), 2), 64) << "libpng's adaptive choice";
  EXPECT_EQ(encodePng(image), small) << "Small is encodePng's default";
}

TEST(FrameImage, PayloadsOfTheWrongSizeAreRefused) {
  const Image8 image = pattern(16, 8);
  for (proto::Encoding encoding : kEncodings) {
    proto::Frame frame = frameOf(image, encoding);
    frame.height = 9;  // the payload holds 16 x 8
    EXPECT_THROW(decodeFrameImage(frame), ImageFailure) << "encoding " << int(encoding);
  }
  proto::Frame raw = frameOf(image, proto::Encoding::RawRgba8);
  raw.payload.pop_back();
  EXPECT_THROW(decodeFrameImage(raw), ImageFailure);
}

TEST(FrameImage, TruncatedAndCorruptPayloadsAreRefusedForEveryCut) {
  const Image8 image = pattern(20, 12);
  for (proto::Encoding encoding : {proto::Encoding::Png, proto::Encoding::ZstdRgba8, proto::Encoding::Webp}) {
    const proto::Frame whole = frameOf(image, encoding);
    // libpng reads all pixels before the closing IEND chunk (12 bytes) and does not insist on it: a cut there may
    // decode, but only to the very same pixels. Every other cut is refused.
    const size_t trailer = encoding == proto::Encoding::Png ? 12 : 0;
    for (size_t keep = 0; keep < whole.payload.size(); ++keep) {
      proto::Frame cut = whole;
      cut.payload.resize(keep);
      if (keep >= whole.payload.size() - trailer) {
        try {
          EXPECT_EQ(decodeFrameImage(cut).rgba, image.rgba) << keep << " bytes";
        } catch (const ImageFailure&) {
        }
        continue;
      }
      EXPECT_THROW(decodeFrameImage(cut), ImageFailure) << "encoding " << int(encoding) << ", " << keep << " bytes";
    }
  }
  proto::Frame garbage = frameOf(image, proto::Encoding::ZstdRgba8);
  for (uint8_t& b : garbage.payload) b ^= 0x5a;
  EXPECT_THROW(decodeFrameImage(garbage), ImageFailure);
}

TEST(FrameImage, AbsurdSizesAreRefusedBeforeAnythingIsAllocated) {
  proto::Frame frame = frameOf(pattern(4, 4), proto::Encoding::ZstdRgba8);
  frame.width = 0xffffffffu;
  frame.height = 0xffffffffu;
  EXPECT_THROW(decodeFrameImage(frame), ImageFailure);
  frame.width = 0;
  frame.height = 4;
  EXPECT_THROW(decodeFrameImage(frame), ImageFailure);
  // A PNG whose header claims a size other than the frame's is refused before libpng allocates for it.
  proto::Frame png = frameOf(pattern(4, 4), proto::Encoding::Png);
  png.payload[16] = 0x7f;  // IHDR width's top byte
  EXPECT_THROW(decodeFrameImage(png), ImageFailure);
  // So is a WebP of another size than the frame says.
  proto::Frame webp = frameOf(pattern(4, 4), proto::Encoding::Webp);
  webp.width = 5;
  EXPECT_THROW(decodeFrameImage(webp), ImageFailure);
}

}  // namespace
}  // namespace voxbrick::image

namespace voxbrick::image {
namespace {

/// A smooth w x h image with opaque alpha, as rendered frames are (a JPEG of noise would say little).
Image8 gradient(int width, int height) {
  Image8 image{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 4, 255)};
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      uint8_t* p = &image.rgba[(size_t(y) * size_t(width) + size_t(x)) * 4];
      p[0] = uint8_t(255 * x / width), p[1] = uint8_t(255 * y / height), p[2] = uint8_t((x + y) % 256);
    }
  return image;
}

TEST(FrameImage, JpegRoundTripsWithinItsLossAndDropsAlpha) {
  Image8 image = gradient(96, 80);
  image.rgba[3] = 7;  // an alpha that is not kept
  const proto::Frame frame = frameOf(image, proto::Encoding::Jpeg);
  EXPECT_EQ(frame.payload.at(0), 0xFF);
  EXPECT_EQ(frame.payload.at(1), 0xD8);
  const Image8 back = decodeFrameImage(frame);
  ASSERT_EQ(back.width, 96);
  ASSERT_EQ(back.height, 80);
  EXPECT_EQ(back.rgba[3], 255);
  EXPECT_GE(compareImages(toImageF(image), toImageF(back)).psnr, 30.0);
  // Quality trades bytes for error.
  const auto low = encodeFrameImage(image, proto::Encoding::Jpeg, 10);
  const auto high = encodeFrameImage(image, proto::Encoding::Jpeg, 95);
  EXPECT_LT(low.size(), high.size());
  EXPECT_THROW(encodeFrameImage(image, proto::Encoding::Jpeg, 0), ImageFailure);
  EXPECT_THROW(encodeFrameImage(image, proto::Encoding::Jpeg, 101), ImageFailure);
}

TEST(FrameImage, AJpegOfAnotherSizeOrCorruptIsRefused) {
  proto::Frame frame = frameOf(gradient(40, 30), proto::Encoding::Jpeg);
  frame.width = 41;  // the JPEG's header says 40x30
  EXPECT_THROW(decodeFrameImage(frame), ImageFailure);
  frame.width = 40;
  frame.payload[1] = 0;  // no start-of-image marker: not a JPEG
  EXPECT_THROW(decodeFrameImage(frame), ImageFailure);
}

}  // namespace
}  // namespace voxbrick::image
