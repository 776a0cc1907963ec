// Histogram bins: one formula for every store, whichever way its level-0 values are visited.
#include "brickstore/format/HistogramBuilder.h"

#include <algorithm>
#include <type_traits>

namespace voxbrick::store {

HistogramBuilder::HistogramBuilder(ValueType type, double lo, double hi) : mType(type) {
  mHistogram.lo = lo;
  mHistogram.hi = hi;
  mHistogram.counts.assign(kBins, 0);
  if (type != ValueType::F32) mValueCounts.assign(type == ValueType::U8 ? 256 : 65536, 0);
}

void HistogramBuilder::add(const void* values, int64_t count) {
  dispatchType(mType, [&](auto tag) {
    using T = decltype(tag);
    const T* v = static_cast<const T*>(values);
    if constexpr (std::is_same_v<T, float>) {
      addFloats(v, count);
    } else {
      constexpr int kOffset = std::is_signed_v<T> ? 32768 : 0;
      for (int64_t n = 0; n < count; ++n) mValueCounts[size_t(int(v[n]) + kOffset)] += 1;
    }
  });
}

void HistogramBuilder::addFloats(const float* v, int64_t count) {
  // bin()'s arithmetic, clamped before the conversion (the same bin for every finite value, and for values far out
  // of range): bins of 64 values at a time in a loop the compiler vectorises, then counted in four tables so that
  // runs of one bin do not wait on each other's increments.
  const double lo = mHistogram.lo, span = mHistogram.hi - mHistogram.lo, scale = span > 0 ? kBins / span : 0.0;
  constexpr int64_t kBatch = 64;
  int32_t bins[kBatch];
  uint64_t tables[4][kBins] = {};
  for (int64_t n0 = 0; n0 < count; n0 += kBatch) {
    const int64_t m = std::min(kBatch, count - n0);
    for (int64_t i = 0; i < m; ++i)
      bins[i] = static_cast<int32_t>(std::clamp((double(v[n0 + i]) - lo) * scale, 0.0, double(kBins - 1)));
    int64_t i = 0;
    for (; i + 4 <= m; i += 4)
      for (int t = 0; t < 4; ++t) tables[t][bins[i + t]] += 1;
    for (; i < m; ++i) tables[0][bins[i]] += 1;
  }
  for (int b = 0; b < kBins; ++b)
    mHistogram.counts[size_t(b)] += tables[0][b] + tables[1][b] + tables[2][b] + tables[3][b];
}

void HistogramBuilder::addRepeated(double value, uint64_t count) {
  if (mType == ValueType::F32)
    mHistogram.counts[bin(double(static_cast<float>(value)))] += count;
  else
    mValueCounts[size_t(int(value) + (mType == ValueType::I16 ? 32768 : 0))] += count;
}

void HistogramBuilder::merge(const HistogramBuilder& other) {
  for (size_t b = 0; b < mHistogram.counts.size(); ++b) mHistogram.counts[b] += other.mHistogram.counts[b];
  for (size_t v = 0; v < mValueCounts.size(); ++v) mValueCounts[v] += other.mValueCounts[v];
}

Histogram HistogramBuilder::finish() const {
  Histogram out = mHistogram;
  const int offset = mType == ValueType::I16 ? 32768 : 0;
  for (size_t value = 0; value < mValueCounts.size(); ++value)
    if (mValueCounts[value] != 0) out.counts[bin(double(int(value) - offset))] += mValueCounts[value];
  return out;
}

size_t HistogramBuilder::bin(double v) const {
  const double span = mHistogram.hi - mHistogram.lo;
  const int b = span > 0 ? static_cast<int>((v - mHistogram.lo) * (kBins / span)) : 0;
  return static_cast<size_t>(std::clamp(b, 0, kBins - 1));
}

}  // namespace voxbrick::store
