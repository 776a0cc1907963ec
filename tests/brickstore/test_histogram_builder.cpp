// The float histogram against its definition: bin = clamp(int((v - lo) * (256 / (hi - lo))), 0, 255), counted one
// value at a time, for values in range, on bin edges, out of range and with an empty range.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "brickstore/format/HistogramBuilder.h"

namespace voxbrick::store {
namespace {

std::vector<uint64_t> definition(const std::vector<float>& v, double lo, double hi) {
  std::vector<uint64_t> counts(HistogramBuilder::kBins, 0);
  const double span = hi - lo;
  for (const float x : v) {
    const int b = span > 0 ? static_cast<int>((double(x) - lo) * (HistogramBuilder::kBins / span)) : 0;
    counts[size_t(std::clamp(b, 0, HistogramBuilder::kBins - 1))] += 1;
  }
  return counts;
}

void expectDefinition(const std::vector<float>& v, double lo, double hi) {
  HistogramBuilder builder(ValueType::F32, lo, hi);
  builder.add(v.data(), 37);  // two calls, neither a multiple of the batch
  builder.add(v.data() + 37, int64_t(v.size()) - 37);
  const Histogram h = builder.finish();
  EXPECT_EQ(h.counts, definition(v, lo, hi));
}

TEST(HistogramBuilder, FloatBinsAsDefined) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> value(-1.5f, 3.25f);
  std::vector<float> v(10007);
  for (float& x : v) x = value(rng);
  const double lo = -1.0, hi = 3.0;
  for (int b = 0; b <= HistogramBuilder::kBins; ++b) {  // every bin edge, and its neighbours
    const float edge = float(lo + (hi - lo) * b / HistogramBuilder::kBins);
    v[size_t(b * 3)] = edge;
    v[size_t(b * 3 + 1)] = std::nextafter(edge, -10.0f);
    v[size_t(b * 3 + 2)] = std::nextafter(edge, 10.0f);
  }
  v[9000] = 1e5f;  // far out of range (bins beyond int are not defined: prep bins within [lo, hi])
  v[9001] = -1e5f;
  expectDefinition(v, lo, hi);
  expectDefinition(v, 0.5, 0.5);  // an empty range: everything in the first bin
  expectDefinition(v, -1.5, 3.25);
}

}  // namespace
}  // namespace voxbrick::store
