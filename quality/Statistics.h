// What a sweep computes over the views of a setting: medians, and the error of its frames against the reference.
#pragma once

#include <limits>
#include <vector>

#include "image/Image.h"

namespace voxbrick::quality {

/// The median of `v` (the mean of the middle two for an even count); 0 when empty.
double median(std::vector<double> v);

/// A setting's frames against their references, view by view: the worst view's PSNR, the largest difference and the
/// pooled error (the RMSE over all views' pixels, each view the same size).
struct ErrorTally {
  double psnrMin = std::numeric_limits<double>::infinity();
  double maxAbs = 0;
  double sumSquares = 0;
  int views = 0;
  void add(const image::ImageError& e);
  double rmsePooled() const;
  double psnrPooled() const;  ///< infinity for identical frames
};

}  // namespace voxbrick::quality
