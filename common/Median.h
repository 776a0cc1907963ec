#pragma once
// The median of a few values, as the server's measures of a session take it (a drag's intervals between Renders, a
// link's recent deliveries and their bytes): of an even count, the upper of the middle two, so that it is always one
// of the values measured.
#include <algorithm>
#include <vector>

namespace voxbrick {

/// The median of `values` (not empty; of an even count, the upper of the middle two).
inline double upperMedian(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace voxbrick
