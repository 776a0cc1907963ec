// Choices drawn from a sweep's points: the Pareto front, the default at a PSNR threshold, the fastest setting per
// dataset, and the slab size and early-ray-termination thresholds the sweep's second phase runs with.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "quality/SweepResult.h"

namespace voxbrick::quality {

/// Sets Point::pareto: per dataset and variant, the points no other point beats in both time and worst PSNR.
void markPareto(std::vector<Point>& points);

/// Of the slab sizes measured without ERT or pre-integration other than `exclude`, the one with the least total
/// median time over the datasets, variants and steps at which every such size was measured; none if there is none.
std::optional<int> bestSlabSize(const std::vector<Point>& points, int exclude);

/// The lowest threshold (the most termination) of those measured at slab `slab` without pre-integration whose worst
/// view, at every dataset, variant and step, stays at or above min(the same without ERT − toleranceDb,
/// highThreshold): ERT may cost accuracy only where the frame stays above the higher threshold. If none does, the
/// highest threshold measured; none if no threshold was measured.
std::optional<double> bestErt(const std::vector<Point>& points, int slab, double toleranceDb, double highThreshold);

/// The same rule over the ray caster's points: thresholds measured with it without pre-integration, each against the
/// ray caster without ERT.
std::optional<double> bestRayCastErt(const std::vector<Point>& points, double toleranceDb, double highThreshold);

/// The fastest point of `dataset` and `variant` whose worst view reaches `psnrThreshold`; none if no point does.
std::optional<Point> fastestPoint(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                  double psnrThreshold);

/// The fastest setting (sum of the median times over the datasets) whose worst view reaches `psnrThreshold` on every
/// dataset's default variant; none if no setting does.
std::optional<Setting> chooseDefault(const std::vector<Point>& points, const std::vector<Dataset>& datasets,
                                     double psnrThreshold);

/// The coarsest step at which the baseline renderer (B=32, skipping, vertex slicer) keeps the worst view of
/// `variant` on `dataset` at or above `psnrThreshold`; none if no swept step does.
std::optional<double> coarsestStep(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                   double psnrThreshold);

}  // namespace voxbrick::quality
