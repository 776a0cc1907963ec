// Medians and the pooled error of a setting's frames.
#include "quality/Statistics.h"

#include <algorithm>
#include <cmath>

namespace voxbrick::quality {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  if (v.empty()) return 0;
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

void ErrorTally::add(const image::ImageError& e) {
  psnrMin = std::min(psnrMin, e.psnr);
  maxAbs = std::max(maxAbs, e.maxAbs);
  sumSquares += e.rmse * e.rmse;
  ++views;
}

double ErrorTally::rmsePooled() const { return views > 0 ? std::sqrt(sumSquares / views) : 0.0; }

double ErrorTally::psnrPooled() const {
  const double rmse = rmsePooled();
  return rmse > 0 ? 20 * std::log10(1 / rmse) : std::numeric_limits<double>::infinity();
}

}  // namespace voxbrick::quality
