// What a sweep measured: a point per dataset, variant and setting, the reference's report, and the choices made
// from the points.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "quality/SweepSpec.h"

namespace voxbrick::quality {

/// One measured point: a dataset, a variant and a setting over every view.
struct Point {
  std::string dataset;
  Variant variant;
  Setting setting;
  double msMedian = 0, msMin = 0, msMax = 0;  ///< frame time over the views
  double samplesMedian = 0;                   ///< volume samples taken per frame (FrameStats::samples)
  double fragmentsMedian = 0;                 ///< fragments started per frame (slicing: = samples)
  double samplesTerminatedMedian = 0;         ///< samples left by early ray termination inside a fragment
  double slabPassesMedian = 0;                ///< draws of one slab each (0 when slicing)
  double psnrMin = 0;                         ///< the worst view's PSNR against the reference (dB)
  double psnrPooled = 0;                      ///< PSNR of the RMSE over all views' pixels
  double rmsePooled = 0;
  double maxAbs = 0;    ///< over all views
  bool pareto = false;  ///< on the Pareto front (time, worst PSNR) of its dataset and variant
};

/// How the reference was made for a dataset, and its self-check: view 0 of each default-transfer-function variant at
/// the reference step against half that step.
struct ReferenceReport {
  std::string dataset;
  Variant variant;
  double msPerView = 0;    ///< median over the views that were not cached (0 if all were)
  double halvingPsnr = 0;  ///< step vs step/2
  double halvingMaxAbs = 0;
};

struct SweepResult {
  std::string device;
  SweepSpec spec;
  std::vector<Point> points;
  std::vector<ReferenceReport> references;
  std::optional<Setting> chosen;         ///< chooseDefault's answer at spec.psnrThreshold
  std::optional<Setting> chosenHigh;     ///< chooseDefault's answer at spec.psnrHighThreshold
  std::optional<int> bestSlab;           ///< bestSlabSize: the other slab size the thresholds also ran at
  std::optional<double> bestErt;         ///< bestErt: the threshold pre-integration also ran with
  std::optional<double> bestRayCastErt;  ///< bestRayCastErt: the threshold the ray caster's pre-integration ran with
};

}  // namespace voxbrick::quality
