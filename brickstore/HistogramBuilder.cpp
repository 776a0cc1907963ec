// Histogram bins: one formula for every store, whichever way its level-0 values are visited.
#include "brickstore/HistogramBuilder.h"

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
      for (int64_t n = 0; n < count; ++n) mHistogram.counts[bin(v[n])] += 1;
    } else {
      constexpr int kOffset = std::is_signed_v<T> ? 32768 : 0;
      for (int64_t n = 0; n < count; ++n) mValueCounts[size_t(int(v[n]) + kOffset)] += 1;
    }
  });
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
