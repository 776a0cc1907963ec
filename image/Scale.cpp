// Scaling an 8-bit RGBA image: each axis on its own, through taps (a source pixel and its weight) made once per axis.
// Shrinking averages the area each output pixel covers (a box filter with fractional coverage); growing is bilinear;
// both with pixel centres aligned, as a browser draws an image scaled onto a canvas. Not libyuv's ARGBScale: it maps
// a grown image's corners rather than its pixel centres (half a pixel off at 2x), and shrinks by less than 2x, or by
// any ratio that is not a whole number, with two taps instead of a box (aliasing). tests/image's ScaleImage tests hold
// both; bench/results/video/encoder-ladder.md has what a scaled stream of the MRI measures.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "image/Image.h"

namespace voxbrick::image {
namespace {

/// The weights of one output pixel along an axis, in 1/kOne: they sum to kOne.
constexpr uint32_t kOneBits = 14, kOne = 1u << kOneBits;

struct Taps {
  std::vector<int> first;       ///< per output pixel: its first source pixel
  std::vector<int> count;       ///< per output pixel: how many source pixels from `first`
  std::vector<int16_t> weight;  ///< per output pixel: `width` weights (the longest count), unused ones 0
  int width = 0;
};

/// The taps of an axis of `from` pixels scaled to `to`.
Taps tapsFor(int from, int to) {
  const double ratio = double(from) / to;
  std::vector<std::vector<std::pair<int, double>>> all{size_t(to)};
  for (int i = 0; i < to; ++i) {
    auto& taps = all[size_t(i)];
    if (to < from) {
      // The source interval the output pixel covers, each source pixel weighted by the part of it inside.
      const double x0 = i * ratio, x1 = (i + 1) * ratio;
      for (int s = int(std::floor(x0)); s < std::min(from, int(std::ceil(x1))); ++s)
        taps.emplace_back(s, std::min(x1, s + 1.0) - std::max(x0, double(s)));
    } else {
      // The output pixel's centre in source pixels, between the two source centres around it (clamped at the edges).
      const double x = std::clamp((i + 0.5) * ratio - 0.5, 0.0, double(from - 1));
      const int s = std::min(int(x), from - 1);
      const double f = x - s;
      taps.emplace_back(s, 1 - f);
      if (s + 1 < from && f > 0) taps.emplace_back(s + 1, f);
    }
  }
  Taps t;
  for (const auto& taps : all) t.width = std::max(t.width, int(taps.size()));
  t.first.resize(size_t(to));
  t.count.resize(size_t(to));
  t.weight.assign(size_t(to) * size_t(t.width), 0);
  for (int i = 0; i < to; ++i) {
    const auto& taps = all[size_t(i)];
    double sum = 0;
    for (const auto& [s, w] : taps) sum += w;
    t.first[size_t(i)] = taps.front().first;
    t.count[size_t(i)] = int(taps.size());
    // Rounded so that they sum to exactly kOne: a flat image stays flat. (The last takes what the others left, which
    // may be a unit below 0 where it covers next to nothing.)
    int32_t given = 0;
    for (size_t k = 0; k < taps.size(); ++k) {
      const int32_t w = k + 1 == taps.size() ? int32_t(kOne) - given
                                             : int32_t(std::lround(taps[k].second / sum * kOne));
      t.weight[size_t(i) * size_t(t.width) + k] = int16_t(w);
      given += w;
    }
  }
  return t;
}

/// Sums of 16-bit values: 7 bits below the 8-bit value, weights of kOneBits.
constexpr int kRowBits = 7;

/// One output row across `row` (16-bit values, padded with `taps` pixels of 0 past its end): each output pixel the
/// weighted sum of `taps` source pixels from its first (the weights past its count are 0), the four channels
/// together. With the count fixed (N > 0) the compiler unrolls and vectorises it.
template <int N>
[[gnu::always_inline]] inline void acrossRow(const int16_t* row, const Taps& across, int width, uint8_t* out) {
  constexpr int shift = int(kOneBits) + kRowBits, half = 1 << (shift - 1);
  const int taps = N > 0 ? N : across.width;
  // A pixel's four channels as one vector: four 16-bit values widened, times the tap's weight.
  using Channels16 = int16_t __attribute__((vector_size(8)));
  using Channels32 = int32_t __attribute__((vector_size(16)));
  for (int x = 0; x < width; ++x) {
    const int16_t* p = row + size_t(across.first[size_t(x)]) * 4;
    const int16_t* w = across.weight.data() + size_t(x) * size_t(taps);
    Channels32 c = {half, half, half, half};
    for (int k = 0; k < taps; ++k) {
      Channels16 v;
      std::memcpy(&v, p + 4 * k, sizeof v);
      c += __builtin_convertvector(v, Channels32) * int32_t(w[k]);
    }
    c >>= shift;
    for (int j = 0; j < 4; ++j) out[4 * x + j] = uint8_t(c[j]);
  }
}

/// `out` (its size set) from `image` through the taps. Each output row: down the columns first, whole source rows
/// at a time (over contiguous bytes), into 16 bits a channel; then across that row. One row at a time, so that the
/// sums stay in the cache. Compiled twice, for AVX2 and for any x86-64, the one the CPU runs chosen at load (GCC's
/// target_clones).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
void resample(const Image8& image, const Taps& across, const Taps& down, Image8& out) {
  const int width = out.width, height = out.height;
  const size_t inValues = size_t(image.width) * 4;
  std::vector<int32_t> sum(inValues);
  std::vector<int16_t> row(inValues + size_t(across.width) * 4, 0);  // the taps past the end read zeros
  for (int y = 0; y < height; ++y) {
    std::fill(sum.begin(), sum.end(), 0);
    const int16_t* wy = down.weight.data() + size_t(y) * size_t(down.width);
    for (int k = 0; k < down.count[size_t(y)]; ++k) {
      const uint8_t* in = image.rgba.data() + size_t(down.first[size_t(y)] + k) * inValues;
      const int16_t wk = wy[k];
      for (size_t i = 0; i < inValues; ++i) sum[i] += int16_t(in[i]) * wk;
    }
    constexpr int shift = int(kOneBits) - kRowBits, half = 1 << (shift - 1);
    for (size_t i = 0; i < inValues; ++i) row[i] = int16_t((sum[i] + half) >> shift);
    uint8_t* o = out.rgba.data() + size_t(y) * size_t(width) * 4;
    switch (across.width) {
      case 1: acrossRow<1>(row.data(), across, width, o); break;
      case 2: acrossRow<2>(row.data(), across, width, o); break;
      case 3: acrossRow<3>(row.data(), across, width, o); break;
      case 4: acrossRow<4>(row.data(), across, width, o); break;
      case 5: acrossRow<5>(row.data(), across, width, o); break;
      default: acrossRow<0>(row.data(), across, width, o); break;
    }
  }
}

}  // namespace

Image8 scaleImage(const Image8& image, int width, int height) {
  constexpr int kMaxSide = 16383;
  if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide)
    throw ImageFailure("cannot scale an image to " + std::to_string(width) + "x" + std::to_string(height));
  if (image.width < 1 || image.height < 1 || image.rgba.size() != size_t(image.width) * size_t(image.height) * 4)
    throw ImageFailure("cannot scale a " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                       " image of " + std::to_string(image.rgba.size()) + " bytes");
  if (width == image.width && height == image.height) return image;
  const Taps across = tapsFor(image.width, width), down = tapsFor(image.height, height);
  Image8 out{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 4)};
  resample(image, across, down, out);
  return out;
}

}  // namespace voxbrick::image
