// Run-length encoded pixel ranges and their kernels (PixelRuns.h).
#include "distributed/PixelRuns.h"

#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <variant>

#include "common/Half.h"

namespace voxbrick::distributed {
namespace {

// A pixel is empty when every channel is +0 or -0 (as activeRect's comparison with 0); NaN counts as active.
inline bool emptyPixel(const float* p) {
  uint64_t a, b;
  std::memcpy(&a, p, 8);
  std::memcpy(&b, p + 2, 8);
  return ((a | b) & 0x7fffffff7fffffffull) == 0;
}

// Four empty pixels in a row (one test of 64 bytes), to cross empty space quickly.
inline bool emptyQuad(const float* p) {
  uint64_t w[8];
  std::memcpy(w, p, 64);
  return ((w[0] | w[1] | w[2] | w[3] | w[4] | w[5] | w[6] | w[7]) & 0x7fffffff7fffffffull) == 0;
}

// Pixels to read: 4 floats, or 4 halves (a received message's), each.
struct Pixels {
  const void* data;
  bool half;
  Pixels at(size_t pixel) const { return {static_cast<const uint8_t*>(data) + pixel * (half ? 8 : 16), half}; }
};

inline void loadScalar(const Pixels& p, size_t pixel, float out[4]) {
  if (!p.half) {
    std::memcpy(out, static_cast<const float*>(p.data) + pixel * 4, 16);
    return;
  }
  const uint16_t* h = static_cast<const uint16_t*>(p.data) + pixel * 4;
  for (int c = 0; c < 4; ++c) out[c] = common::halfToFloat(h[c]);
}

// front over back for `count` pixels: out = f + (1 − f.a)·b per channel. The SIMD path uses the same two
// operations per channel (no fused multiply-add), and F16C converts halves exactly, so both give the same bits.
void blendScalar(Pixels f, Pixels b, float* out, size_t count) {
  for (size_t i = 0; i < count; ++i) {
    float front[4], back[4];
    loadScalar(f, i, front);
    loadScalar(b, i, back);
    const float keep = 1.0f - front[3];
    for (int c = 0; c < 4; ++c) out[4 * i + c] = front[c] + keep * back[c];
  }
}

template <bool Half>
__attribute__((target("avx2,f16c"))) inline __m256 loadTwo(const void* data, size_t pixel) {
  if constexpr (Half) {
    return _mm256_cvtph_ps(
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(static_cast<const uint16_t*>(data) + pixel * 4)));
  } else {
    return _mm256_loadu_ps(static_cast<const float*>(data) + pixel * 4);
  }
}

template <bool FrontHalf, bool BackHalf>
__attribute__((target("avx2,f16c"))) void blendSimd(Pixels f, Pixels b, float* out, size_t count) {
  const __m256 one = _mm256_set1_ps(1.0f);
  size_t i = 0;
  for (; i + 2 <= count; i += 2) {  // two pixels a register: alpha broadcast within each 128-bit lane
    const __m256 front = loadTwo<FrontHalf>(f.data, i);
    const __m256 keep = _mm256_sub_ps(one, _mm256_permute_ps(front, 0xff));
    _mm256_storeu_ps(out + 4 * i, _mm256_add_ps(front, _mm256_mul_ps(keep, loadTwo<BackHalf>(b.data, i))));
  }
  if (i < count) blendScalar(f.at(i), b.at(i), out + 4 * i, count - i);
}

const bool kSimd = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("f16c");

bool useSimd(Kernels kernels) { return kernels == Kernels::Best && kSimd; }

void blend(Pixels f, Pixels b, float* out, size_t count, Kernels kernels) {
  if (!useSimd(kernels)) return blendScalar(f, b, out, count);
  if (f.half) return b.half ? blendSimd<true, true>(f, b, out, count) : blendSimd<true, false>(f, b, out, count);
  b.half ? blendSimd<false, true>(f, b, out, count) : blendSimd<false, false>(f, b, out, count);
}

void toHalves(const float* in, uint16_t* out, size_t count, Kernels kernels) {
  if (useSimd(kernels)) return common::floatsToHalves(in, out, count);  // F16C: the same rounding
  for (size_t i = 0; i < count; ++i) out[i] = common::floatToHalf(in[i]);
}

void toFloats(const uint16_t* in, float* out, size_t count, Kernels kernels) {
  if (useSimd(kernels)) return common::halvesToFloats(in, out, count);
  for (size_t i = 0; i < count; ++i) out[i] = common::halfToFloat(in[i]);
}

void copyPixels(Pixels from, float* out, size_t count, Kernels kernels) {
  if (from.half) return toFloats(static_cast<const uint16_t*>(from.data), out, count * 4, kernels);
  std::memcpy(out, from.data, count * 16);
}

size_t channelBytes(PixelEncoding encoding) { return encoding == PixelEncoding::Half ? 2 : 4; }

// Builds runs in order: each active stretch is appended after the last, joined to it when they touch.
class RunWriter {
 public:
  explicit RunWriter(PixelRuns& out) : mOut(out), mLast(out.begin) {}
  // Room for the `count` active pixels at [start, start + count), start >= the end of the last stretch.
  float* append(uint32_t start, uint32_t count) {
    if (start == mLast && mOut.runs.size() > 0) {
      mOut.runs.data()[mOut.runs.size() - 1] += count;
    } else {
      mOut.runs.push(start - mLast);
      mOut.runs.push(count);
    }
    mLast = start + count;
    return mOut.pixels.extend(size_t(count) * 4);
  }

 private:
  PixelRuns& mOut;
  uint32_t mLast;
};

// The active stretches of runs, in order, with their pixels: [start, end) and where its pixels are.
class RunReader {
 public:
  explicit RunReader(const PixelRuns& in) : mIn(in), mPosition(in.begin) { next(); }
  bool done() const { return mDone; }
  uint32_t start() const { return mStart; }
  uint32_t end() const { return mEnd; }
  const float* pixels() const { return mPixels; }
  Pixels source() const { return {mPixels, false}; }
  // Drops the stretch's pixels before `to` (start < to <= end), moving to the next stretch when none are left.
  void advance(uint32_t to) {
    mPixels += size_t(to - mStart) * 4;
    mStart = to;
    if (mStart == mEnd) next();
  }

 private:
  void next() {
    for (;;) {
      if (mRun >= mIn.runCount()) {
        mDone = true;
        return;
      }
      const uint32_t* pair = mIn.runs.data() + 2 * mRun++;
      mStart = mPosition + pair[0];
      mEnd = mStart + pair[1];
      mPosition = mEnd;
      if (mEnd > mStart) return;
    }
  }
  const PixelRuns& mIn;
  size_t mRun = 0;
  uint32_t mPosition, mStart = 0, mEnd = 0;
  const float* mPixels = mIn.pixels.data();
  bool mDone = false;
};

// The active stretches of pixels [begin, end) of a dense frame within its footprint, found as they are read
// (RunReader's interface). Rows of the footprint that span the frame's width are read as one range, so that a
// stretch crossing a row's end stays one.
class DenseReader {
 public:
  DenseReader(const DenseFrame& dense, uint32_t begin, uint32_t end)
      : mRgba(dense.frame->rgba.data()),
        mWidth(uint32_t(dense.frame->width)),
        mX0(uint32_t(dense.footprint.x0)),
        mX1(uint32_t(dense.footprint.x1)),
        mY0(uint32_t(dense.footprint.y0)),
        mY1(uint32_t(dense.footprint.y1)),
        mLimit(end),
        mStart(begin) {
    if (dense.footprint.empty()) mLimit = begin;
    find(begin);
  }
  bool done() const { return mDone; }
  uint32_t start() const { return mStart; }
  uint32_t end() const { return mEnd; }
  const float* pixels() const { return mRgba + size_t(mStart) * 4; }
  Pixels source() const { return {pixels(), false}; }
  void advance(uint32_t to) {
    mStart = to;
    if (mStart == mEnd) find(mEnd);
  }

 private:
  void find(uint32_t i) {
    for (;;) {
      if (i >= mLimit) break;
      // Into the footprint: the pixels read from i on end at `stop` (the row's footprint, or the footprint's last
      // row when its rows span the frame).
      const uint32_t y = i / mWidth, x = i - y * mWidth;
      if (y >= mY1) break;
      if (y < mY0 || x < mX0 || x >= mX1) {
        const uint64_t row = y < mY0 ? mY0 : x < mX0 ? y : y + 1;
        i = uint32_t(std::min<uint64_t>(row * mWidth + mX0, mLimit));
        continue;
      }
      const bool rows = mX0 == 0 && mX1 == mWidth;
      const uint32_t stop = std::min(rows ? mY1 * mWidth : y * mWidth + mX1, mLimit);
      if (!rows && y + 1 < mY1 && y != mPrefetched) {
        // The next row's start, so that the reads go on streaming past the jump over the pixels outside.
        mPrefetched = y;
        const float* next = mRgba + (size_t(y + 1) * mWidth + mX0) * 4;
        for (int line = 0; line < 16; ++line) __builtin_prefetch(next + line * 16);
      }
      while (i + 4 <= stop && emptyQuad(mRgba + size_t(i) * 4)) i += 4;
      while (i < stop && emptyPixel(mRgba + size_t(i) * 4)) ++i;
      if (i < stop) {
        mStart = i;
        while (i < stop && !emptyPixel(mRgba + size_t(i) * 4)) ++i;
        mEnd = i;
        return;
      }
    }
    mDone = true;
  }
  const float* mRgba;
  uint32_t mWidth, mX0, mX1, mY0, mY1;
  uint32_t mLimit, mStart, mEnd = 0;
  uint32_t mPrefetched = UINT32_MAX;  // the row whose next row's start was prefetched
  bool mDone = false;
};

void checkFrame(const DenseFrame& dense, uint32_t begin, uint32_t end, const char* what) {
  const image::ImageF& frame = *dense.frame;
  const size_t pixels = size_t(frame.width) * size_t(frame.height);
  if (begin > end || end > pixels || frame.rgba.size() != pixels * 4) {
    throw std::invalid_argument(std::string(what) + ": pixels [" + std::to_string(begin) + ", " + std::to_string(end) +
                                ") do not lie in a frame of " + std::to_string(pixels) + " pixels");
  }
}

void checkWithin(const PixelRuns& in, uint32_t begin, uint32_t end, const char* what) {
  if (begin > end || begin < in.begin || end > in.end) {
    throw std::invalid_argument(std::string(what) + ": [" + std::to_string(begin) + ", " + std::to_string(end) +
                                ") is not within the runs' range [" + std::to_string(in.begin) + ", " +
                                std::to_string(in.end) + ")");
  }
}

// The stretches of `reader` within [begin, end), clipped, each given to `visit(start, end, pixels)`.
template <typename Reader, typename Visit>
void eachStretch(Reader reader, uint32_t begin, uint32_t end, Visit visit) {
  for (; !reader.done() && reader.start() < end; reader.advance(reader.end())) {
    const uint32_t s = std::max(reader.start(), begin), e = std::min(reader.end(), end);
    if (s < e) visit(s, e, reader.pixels() + size_t(s - reader.start()) * 4);
  }
}

// One pass: the header's room, the pixels as they are found (the runs aside), then the runs and the header.
template <typename Reader>
void packFrom(Reader reader, uint32_t begin, uint32_t end, PixelEncoding encoding, GrowingBuffer<uint8_t>& out,
              Kernels kernels) {
  thread_local GrowingBuffer<uint32_t> runs;
  runs.clear();
  runs.reserve((size_t(end - begin) / 2 + 1) * 2);
  out.clear();
  out.reserve(runsMessageBytes(size_t(end - begin) / 2 + 1, end - begin, encoding));
  out.extend(kRunsHeaderBytes);
  uint32_t last = begin, active = 0;
  const size_t pixelBytes = 4 * channelBytes(encoding);
  eachStretch(reader, begin, end, [&](uint32_t s, uint32_t e, const float* from) {
    runs.push(s - last);
    runs.push(e - s);
    last = e;
    active += e - s;
    uint8_t* to = out.extend(size_t(e - s) * pixelBytes);
    if (encoding == PixelEncoding::Float) {
      std::memcpy(to, from, size_t(e - s) * 16);
    } else {
      toHalves(from, reinterpret_cast<uint16_t*>(to), size_t(e - s) * 4, kernels);
    }
  });
  std::memcpy(out.extend(runs.size() * 4), runs.data(), runs.size() * 4);
  const uint32_t header[4] = {begin, end, uint32_t(runs.size() / 2), active};
  std::memcpy(out.data(), header, kRunsHeaderBytes);
}

template <typename Reader>
void sliceFrom(Reader reader, uint32_t begin, uint32_t end, PixelRuns& out) {
  out.reset(begin, end);
  RunWriter writer(out);
  eachStretch(reader, begin, end, [&writer](uint32_t s, uint32_t e, const float* from) {
    std::memcpy(writer.append(s, e - s), from, size_t(e - s) * 16);
  });
}

// A pixel's finished 8-bit value: render::outputPixel (Scene.cpp) on the premultiplied colour, then image::toImage8's
// rounding (floor of x·255 + 0.5 on values in [0.5, 255.5] is their truncation). The same operations in the same
// order, in double and then float as there, so the bytes are the same (the kernels test holds them to
// toImage8(finishPartial)); only the sign of a zero may differ, which no byte shows.
struct FinishParameters {
  double background[3];
  bool transparent;
};

void finishScalar(const FinishParameters& f, const float* p, uint8_t* to, size_t count) {
  for (size_t i = 0; i < count; ++i, p += 4, to += 4) {
    const double a = std::clamp(double(p[3]), 0.0, 1.0);
    double o[4] = {0, 0, 0, 0};
    if (!f.transparent) {
      for (int c = 0; c < 3; ++c) o[c] = std::clamp(double(p[c]) + (1 - a) * f.background[c], 0.0, 1.0);
      o[3] = 1.0;
    } else if (a > 0) {
      for (int c = 0; c < 3; ++c) o[c] = std::clamp(double(p[c]) / a, 0.0, 1.0);
      o[3] = a;
    }
    for (int c = 0; c < 4; ++c) to[c] = uint8_t(int(std::clamp(float(o[c]), 0.0f, 1.0f) * 255.0f + 0.5f));
  }
}

// One pixel a step, its four channels in one register of doubles (no fused multiply-add: the same rounding).
__attribute__((target("avx2,f16c"))) void finishSimd(const FinishParameters& f, const float* p, uint8_t* to,
                                                     size_t count) {
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  const __m256d background = _mm256_setr_pd(f.background[0], f.background[1], f.background[2], 0.0);
  const __m128 zeroF = _mm_setzero_ps(), oneF = _mm_set1_ps(1.0f), scale = _mm_set1_ps(255.0f),
               half = _mm_set1_ps(0.5f);
  for (size_t i = 0; i < count; ++i, p += 4, to += 4) {
    const __m256d pixel = _mm256_cvtps_pd(_mm_loadu_ps(p));
    const __m256d a = _mm256_min_pd(_mm256_max_pd(_mm256_permute4x64_pd(pixel, 0xff), zero), one);
    __m256d o;
    if (!f.transparent) {
      o = _mm256_add_pd(pixel, _mm256_mul_pd(_mm256_sub_pd(one, a), background));
      o = _mm256_blend_pd(_mm256_min_pd(_mm256_max_pd(o, zero), one), one, 0x8);
    } else {
      o = _mm256_min_pd(_mm256_max_pd(_mm256_div_pd(pixel, a), zero), one);
      o = _mm256_and_pd(_mm256_blend_pd(o, a, 0x8), _mm256_cmp_pd(a, zero, _CMP_GT_OQ));
    }
    const __m128 v = _mm_min_ps(_mm_max_ps(_mm256_cvtpd_ps(o), zeroF), oneF);
    const __m128i bytes = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(v, scale), half));
    const __m128i packed = _mm_packus_epi16(_mm_packus_epi32(bytes, bytes), bytes);
    const int word = _mm_cvtsi128_si32(packed);
    std::memcpy(to, &word, 4);
  }
}

// Two pixels a step in floats, which agree with the doubles above to a few float steps: a channel whose value·255 +
// 0.5 lies within 1/1000 of a whole number (where those steps could round it the other way) sends its pair of pixels
// through finishSimd. So the bytes are still the scalar path's.
__attribute__((target("avx2,f16c"))) void finishFloats(const FinishParameters& f, const float* p, uint8_t* to,
                                                       size_t count) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), scale = _mm256_set1_ps(255.0f),
               half = _mm256_set1_ps(0.5f), near = _mm256_set1_ps(1e-3f), far = _mm256_set1_ps(1 - 1e-3f);
  const float b0 = float(f.background[0]), b1 = float(f.background[1]), b2 = float(f.background[2]);
  const __m256 background = _mm256_setr_ps(b0, b1, b2, 0, b0, b1, b2, 0);
  size_t i = 0;
  for (; i + 2 <= count; i += 2) {
    const __m256 pixels = _mm256_loadu_ps(p + 4 * i);
    const __m256 a = _mm256_min_ps(_mm256_max_ps(_mm256_permute_ps(pixels, 0xff), zero), one);
    __m256 o;
    if (!f.transparent) {
      o = _mm256_add_ps(pixels, _mm256_mul_ps(_mm256_sub_ps(one, a), background));
      o = _mm256_blend_ps(_mm256_min_ps(_mm256_max_ps(o, zero), one), one, 0x88);
    } else {
      o = _mm256_min_ps(_mm256_max_ps(_mm256_div_ps(pixels, a), zero), one);
      o = _mm256_and_ps(_mm256_blend_ps(o, a, 0x88), _mm256_cmp_ps(a, zero, _CMP_GT_OQ));
    }
    const __m256 v = _mm256_add_ps(_mm256_mul_ps(o, scale), half);
    const __m256 fraction = _mm256_sub_ps(v, _mm256_floor_ps(v));
    const __m256 doubtful =
        _mm256_or_ps(_mm256_cmp_ps(fraction, near, _CMP_LT_OQ), _mm256_cmp_ps(fraction, far, _CMP_GT_OQ));
    if (_mm256_movemask_ps(doubtful) != 0 || _mm256_movemask_ps(_mm256_cmp_ps(v, v, _CMP_UNORD_Q)) != 0) {
      finishSimd(f, p + 4 * i, to + 4 * i, 2);
      continue;
    }
    const __m256i words = _mm256_cvttps_epi32(v);
    const __m128i packed16 = _mm_packus_epi32(_mm256_castsi256_si128(words), _mm256_extracti128_si256(words, 1));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(to + 4 * i), _mm_packus_epi16(packed16, packed16));
  }
  if (i < count) finishSimd(f, p + 4 * i, to + 4 * i, count - i);
}

class Finisher {
 public:
  Finisher(const render::SceneView& view, Kernels kernels)
      : mParameters{{view.background.x, view.background.y, view.background.z}, view.transparent},
        mSimd(useSimd(kernels)) {
    const float nothing[4] = {0, 0, 0, 0};
    pixels(nothing, mEmpty, 1);
  }
  void pixels(const float* p, uint8_t* to, size_t count) const {
    if (mSimd) return finishFloats(mParameters, p, to, count);
    finishScalar(mParameters, p, to, count);
  }
  void empty(uint8_t* to, size_t count) const {
    for (size_t i = 0; i < count; ++i) std::memcpy(to + i * 4, mEmpty, 4);
  }

 private:
  FinishParameters mParameters;
  bool mSimd;
  uint8_t mEmpty[4];
};

template <typename Reader>
void finishFrom(Reader reader, uint32_t begin, uint32_t end, const render::SceneView& view, uint8_t* out,
                Kernels kernels) {
  const Finisher finisher(view, kernels);
  uint32_t position = begin;
  eachStretch(reader, begin, end, [&](uint32_t s, uint32_t e, const float* p) {
    finisher.empty(out + size_t(position - begin) * 4, s - position);
    finisher.pixels(p, out + size_t(s - begin) * 4, e - s);
    position = e;
  });
  finisher.empty(out + size_t(position - begin) * 4, end - position);
}

// The active stretches of a checked message (checkRunsMessage), its pixels read where they lie, in their encoding.
class MessageReader {
 public:
  MessageReader(std::span<const uint8_t> message, PixelEncoding encoding) {
    uint32_t header[4];
    std::memcpy(header, message.data(), sizeof header);
    mPosition = header[0];
    mRunsLeft = header[2];
    mHalf = encoding == PixelEncoding::Half;
    mPixels = message.data() + kRunsHeaderBytes;
    mRuns = mPixels + size_t(header[3]) * (mHalf ? 8 : 16);
    next();
  }
  bool done() const { return mDone; }
  uint32_t start() const { return mStart; }
  uint32_t end() const { return mEnd; }
  Pixels source() const { return {mPixels, mHalf}; }
  void advance(uint32_t to) {
    mPixels += size_t(to - mStart) * (mHalf ? 8 : 16);
    mStart = to;
    if (mStart == mEnd) next();
  }

 private:
  void next() {
    for (;;) {
      if (mRunsLeft == 0) {
        mDone = true;
        return;
      }
      uint32_t pair[2];
      std::memcpy(pair, mRuns, 8);
      mRuns += 8;
      --mRunsLeft;
      mStart = mPosition + pair[0];
      mEnd = mStart + pair[1];
      mPosition = mEnd;
      if (mEnd > mStart) return;
    }
  }
  const uint8_t* mPixels = nullptr;
  const uint8_t* mRuns = nullptr;
  uint32_t mRunsLeft = 0, mPosition = 0, mStart = 0, mEnd = 0;
  bool mHalf = true, mDone = false;
};

// A reader's stretches within [begin, end), clipped.
template <typename Reader>
class Clipped {
 public:
  Clipped(Reader reader, uint32_t begin, uint32_t end) : mReader(reader), mEnd(end) {
    while (!mReader.done() && mReader.end() <= begin) mReader.advance(mReader.end());
    if (!mReader.done() && mReader.start() < begin) mReader.advance(begin);
  }
  bool done() const { return mReader.done() || mReader.start() >= mEnd; }
  uint32_t start() const { return mReader.start(); }
  uint32_t end() const { return std::min(mReader.end(), mEnd); }
  Pixels source() const { return mReader.source(); }
  void advance(uint32_t to) { mReader.advance(to); }

 private:
  Reader mReader;
  uint32_t mEnd;
};

template <typename FrontReader, typename BackReader>
void overFrom(FrontReader f, BackReader b, uint32_t begin, uint32_t end, PixelRuns& out, Kernels kernels) {
  out.reset(begin, end);
  RunWriter writer(out);
  // Copies the stretch of `r` before `to` (or all of it).
  auto copy = [&writer, kernels](auto& r, uint32_t to) {
    const uint32_t e = std::min(r.end(), to);
    copyPixels(r.source(), writer.append(r.start(), e - r.start()), e - r.start(), kernels);
    r.advance(e);
  };
  while (!f.done() || !b.done()) {
    if (f.done() || (!b.done() && b.start() < f.start())) {
      copy(b, f.done() ? b.end() : f.start());
    } else if (b.done() || f.start() < b.start()) {
      copy(f, b.done() ? f.end() : b.start());
    } else {  // both active from the same pixel on
      const uint32_t e = std::min(f.end(), b.end());
      blend(f.source(), b.source(), writer.append(f.start(), e - f.start()), e - f.start(), kernels);
      f.advance(e);
      b.advance(e);
    }
  }
}

struct MessageHeader {
  uint32_t begin, end, runCount, activeCount;
};
static_assert(sizeof(MessageHeader) == kRunsHeaderBytes);

MessageHeader readHeader(std::span<const uint8_t> message) {
  if (message.size() < kRunsHeaderBytes) {
    throw std::runtime_error("a pixel message of " + std::to_string(message.size()) + " bytes has no header");
  }
  MessageHeader header;
  std::memcpy(&header, message.data(), kRunsHeaderBytes);
  return header;
}

}  // namespace

bool simdKernelsAvailable() { return kSimd; }

DenseFrame::DenseFrame(const image::ImageF& partial, const render::PixelRect& within) : frame(&partial) {
  footprint = {std::clamp(within.x0, 0, partial.width), std::clamp(within.y0, 0, partial.height),
               std::clamp(within.x1, 0, partial.width), std::clamp(within.y1, 0, partial.height)};
  if (footprint.empty()) footprint = {};
  // A footprint two fifths of the frame wide or more is read as whole rows: streaming on past its sides costs less
  // than restarting the stream on every row (measured packing 2048² frames: row by row 20–35 % slower than whole rows
  // at 45–75 % of the width, as fast at 41 %, 10–40 % faster at 29–39 %).
  if (!footprint.empty() && (footprint.x1 - footprint.x0) * 5 >= partial.width * 2)
    footprint.x0 = 0, footprint.x1 = partial.width;
}

uint64_t DenseFrame::pixelsWithin(uint32_t begin, uint32_t end) const {
  if (footprint.empty() || begin >= end) return 0;
  // Per row of the footprint, the part of [x0, x1) whose pixel indices lie in [begin, end).
  const uint64_t width = uint64_t(frame->width);
  uint64_t total = 0;
  const uint64_t firstRow = std::max<uint64_t>(uint64_t(footprint.y0), begin / width);
  const uint64_t lastRow = std::min<uint64_t>(uint64_t(footprint.y1), (uint64_t(end) + width - 1) / width);
  for (uint64_t y = firstRow; y < lastRow; ++y) {
    const uint64_t lo = std::max<uint64_t>(y * width + uint64_t(footprint.x0), begin);
    const uint64_t hi = std::min<uint64_t>(y * width + uint64_t(footprint.x1), end);
    if (hi > lo) total += hi - lo;
  }
  return total;
}

void encodeRuns(const DenseFrame& frame, uint32_t begin, uint32_t end, PixelRuns& out) {
  checkFrame(frame, begin, end, "encodeRuns");
  sliceFrom(DenseReader(frame, begin, end), begin, end, out);
}

size_t runsMessageBytes(size_t runCount, size_t activePixels, PixelEncoding encoding) {
  return kRunsHeaderBytes + runCount * 8 + activePixels * 4 * channelBytes(encoding);
}

void packRuns(const PixelRuns& in, uint32_t begin, uint32_t end, PixelEncoding encoding, GrowingBuffer<uint8_t>& out,
              Kernels kernels) {
  checkWithin(in, begin, end, "packRuns");
  packFrom(RunReader(in), begin, end, encoding, out, kernels);
}

void packRuns(const DenseFrame& frame, uint32_t begin, uint32_t end, PixelEncoding encoding,
              GrowingBuffer<uint8_t>& out, Kernels kernels) {
  checkFrame(frame, begin, end, "packRuns");
  packFrom(DenseReader(frame, begin, end), begin, end, encoding, out, kernels);
}

void sliceRuns(const PixelRuns& in, uint32_t begin, uint32_t end, PixelRuns& out) {
  checkWithin(in, begin, end, "sliceRuns");
  sliceFrom(RunReader(in), begin, end, out);
}

void checkRunsMessage(std::span<const uint8_t> message, uint32_t begin, uint32_t end, PixelEncoding encoding) {
  const MessageHeader header = readHeader(message);
  if (header.begin != begin || header.end != end) {
    throw std::runtime_error("a pixel message holds pixels [" + std::to_string(header.begin) + ", " +
                             std::to_string(header.end) + ") where [" + std::to_string(begin) + ", " +
                             std::to_string(end) + ") was due");
  }
  const uint64_t length = uint64_t(end) - begin;
  if (header.runCount > length || header.activeCount > length ||
      message.size() != runsMessageBytes(header.runCount, header.activeCount, encoding)) {
    throw std::runtime_error("a pixel message of " + std::to_string(message.size()) + " bytes does not hold the " +
                             std::to_string(header.runCount) + " runs and " + std::to_string(header.activeCount) +
                             " pixels its header declares");
  }
  uint64_t covered = 0, active = 0;
  const uint8_t* runs = message.data() + kRunsHeaderBytes + size_t(header.activeCount) * 4 * channelBytes(encoding);
  for (uint32_t r = 0; r < header.runCount; ++r) {
    uint32_t pair[2];
    std::memcpy(pair, runs + size_t(r) * 8, 8);
    covered += uint64_t(pair[0]) + pair[1];
    active += pair[1];
  }
  if (covered > length || active != header.activeCount) {
    throw std::runtime_error("a pixel message's runs cover " + std::to_string(covered) + " pixels with " +
                             std::to_string(active) + " active, in a range of " + std::to_string(length) +
                             " pixels declaring " + std::to_string(header.activeCount) + " active");
  }
}

void unpackRuns(std::span<const uint8_t> message, PixelEncoding encoding, PixelRuns& out, Kernels kernels) {
  const MessageHeader header = readHeader(message);
  out.reset(header.begin, header.end);
  const uint8_t* pixels = message.data() + kRunsHeaderBytes;
  const size_t channels = size_t(header.activeCount) * 4;
  std::memcpy(out.runs.extend(size_t(header.runCount) * 2), pixels + channels * channelBytes(encoding),
              size_t(header.runCount) * 8);
  if (channels == 0) return;
  float* to = out.pixels.extend(channels);
  if (encoding == PixelEncoding::Float) {
    std::memcpy(to, pixels, channels * 4);
  } else {
    toFloats(reinterpret_cast<const uint16_t*>(pixels), to, channels, kernels);
  }
}

void overRuns(const PixelRuns& front, const PixelRuns& back, PixelRuns& out, Kernels kernels) {
  if (front.begin != back.begin || front.end != back.end) {
    throw std::invalid_argument("overRuns: ranges [" + std::to_string(front.begin) + ", " + std::to_string(front.end) +
                                ") and [" + std::to_string(back.begin) + ", " + std::to_string(back.end) + ") differ");
  }
  overFrom(RunReader(front), RunReader(back), front.begin, front.end, out, kernels);
}

void overRuns(PixelSource front, PixelSource back, uint32_t begin, uint32_t end, PixelRuns& out, Kernels kernels) {
  auto reader = [begin,
                 end](PixelSource source) -> std::variant<Clipped<RunReader>, DenseReader, Clipped<MessageReader>> {
    if (const auto* const* runs = std::get_if<const PixelRuns*>(&source)) {
      checkWithin(**runs, begin, end, "overRuns");
      return Clipped<RunReader>(RunReader(**runs), begin, end);
    }
    if (const auto* message = std::get_if<PixelMessage>(&source)) {
      checkRunsMessage(message->bytes, begin, end, message->encoding);
      return Clipped<MessageReader>(MessageReader(message->bytes, message->encoding), begin, end);
    }
    const DenseFrame& frame = std::get<DenseFrame>(source);
    checkFrame(frame, begin, end, "overRuns");
    return DenseReader(frame, begin, end);
  };
  std::visit([&](auto f, auto b) { overFrom(f, b, begin, end, out, kernels); }, reader(front), reader(back));
}

void scatterRuns(const PixelRuns& in, image::ImageF& frame) {
  if (size_t(in.end) * 4 > frame.rgba.size()) throw std::invalid_argument("scatterRuns: the runs pass the frame");
  for (RunReader reader(in); !reader.done(); reader.advance(reader.end())) {
    std::memcpy(frame.rgba.data() + size_t(reader.start()) * 4, reader.pixels(),
                size_t(reader.end() - reader.start()) * 16);
  }
}

void finishRuns(const PixelRuns& in, const render::SceneView& view, uint8_t* out, Kernels kernels) {
  finishFrom(RunReader(in), in.begin, in.end, view, out, kernels);
}

void finishRuns(const DenseFrame& frame, uint32_t begin, uint32_t end, const render::SceneView& view, uint8_t* out,
                Kernels kernels) {
  checkFrame(frame, begin, end, "finishRuns");
  finishFrom(DenseReader(frame, begin, end), begin, end, view, out, kernels);
}

}  // namespace voxbrick::distributed
