// The level-0 histogram of a store (store.json's "histogram"), built from values as they come.
#pragma once

#include <cstdint>
#include <vector>

#include "brickstore/format/StoreMeta.h"

namespace voxbrick::store {

/// Counts values in StoreMeta's 256 equal bins over [lo, hi] (values outside go to the first or last bin). Integer
/// types count each distinct value (a table of at most 65536 counters, so the pass is one increment per voxel) and
/// are binned at finish(); floats are binned as they come. Not thread-safe: build one per thread and merge().
class HistogramBuilder {
 public:
  static constexpr int kBins = 256;

  HistogramBuilder(ValueType type, double lo, double hi);

  /// Counts `count` values of the builder's type at `values`.
  void add(const void* values, int64_t count);
  /// Counts `value` (of the builder's type) `count` times, as add() would count that many copies.
  void addRepeated(double value, uint64_t count);
  /// Adds the counts of another builder of the same type and range.
  void merge(const HistogramBuilder& other);
  /// The histogram of everything counted.
  Histogram finish() const;

 private:
  size_t bin(double v) const;
  void addFloats(const float* values, int64_t count);

  ValueType mType;
  Histogram mHistogram;
  std::vector<uint64_t> mValueCounts;
};

}  // namespace voxbrick::store
