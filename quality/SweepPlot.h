// The sweep's plot: median frame time against the worst view's PSNR, one panel per dataset, the Pareto fronts drawn.
#pragma once

#include <string>

#include "quality/SweepResult.h"

namespace voxbrick::quality {

/// A self-contained SVG document: per dataset a panel with log-scaled time (x) and PSNR (y), points coloured by
/// variant and shaped by renderer alternative, filled where on the Pareto front, each variant's front as a line,
/// the PSNR threshold dashed and the chosen default ringed.
std::string sweepSvg(const SweepResult& result);

}  // namespace voxbrick::quality
