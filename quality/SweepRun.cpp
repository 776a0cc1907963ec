// The sweep in two phases: per dataset the baseline, the slicing alternatives, the slab sizes, the thresholds and
// the ray caster; then, with what that found over every dataset, the best slab size's thresholds and
// pre-integration. Then the Pareto front and the default.
#include "quality/SweepRun.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

#include "quality/DatasetRun.h"
#include "quality/SettingChoice.h"

namespace voxbrick::quality {
namespace fs = std::filesystem;

namespace {

using Log = std::function<void(const std::string&)>;

Setting slabSetting(double step, int slab, double ert = 0, bool preIntegration = false, int subBlock = 0) {
  Setting s{step};
  s.slab = slab;
  s.ert = ert;
  s.preIntegration = preIntegration;
  s.subBlock = subBlock;
  return s;
}

Setting rayCastSetting(double step, double ert = 0, bool preIntegration = false, int subBlock = 0) {
  Setting s = slabSetting(step, 0, ert, preIntegration, subBlock);
  s.raycast = true;
  return s;
}

/// The ray caster's thresholds: off, then each of `erts`.
std::vector<double> rayCastErts(const SweepSpec& spec) {
  std::vector<double> erts{0};
  erts.insert(erts.end(), spec.erts.begin(), spec.erts.end());
  return erts;
}

/// The sub-block size the levels of detail run with: the last of `slabSubBlocks`, 0 if none.
int lodSubBlock(const SweepSpec& spec) { return spec.slabSubBlocks.empty() ? 0 : spec.slabSubBlocks.back(); }

/// Adds each measured point to the result and logs it with the progress so far.
class Recorder {
 public:
  Recorder(SweepResult& result, const Log& log)
      : mResult(result), mLog(log), mPlanned(result.spec.plannedPoints()), mStart(std::chrono::steady_clock::now()) {}

  void operator()(const Point& p) {
    const double minutes = std::chrono::duration<double>(std::chrono::steady_clock::now() - mStart).count() / 60;
    char line[320];
    std::snprintf(line, sizeof line, "[%zu/%zu, %.1f min] %s %s, %s: %.1f ms, worst view %.1f dB",
                  mResult.points.size() + 1, mPlanned, minutes, p.dataset.c_str(), p.variant.label().c_str(),
                  p.setting.label().c_str(), p.msMedian, p.psnrMin);
    mLog(line);
    mResult.points.push_back(p);
  }

 private:
  SweepResult& mResult;
  const Log& mLog;
  size_t mPlanned;
  std::chrono::steady_clock::time_point mStart;
};

/// Every variant at every step with the baseline renderer, then the slicing alternatives on the default variant.
void measureSlicing(const SweepSpec& spec, DatasetRun& run, Recorder& record) {
  for (size_t vi = 0; vi < run.variants().size(); ++vi)
    for (double step : spec.steps) record(run.measure({step}, vi));
  for (double step : spec.steps) {
    for (int b : spec.alternativeBricks) record(run.measure({step, b}, 0));
    if (spec.alternativeNoSkip) record(run.measure({step, 32, false}, 0));
    if (spec.alternativeCpuSlicer) record(run.measure({step, 32, true, render::Slicer::Cpu}, 0));
  }
}

/// At one step: every slab size, then the thresholds at ertSlab, with each sub-block size and level of detail.
void measureSlabStep(const SweepSpec& spec, DatasetRun& run, size_t vi, double step, Recorder& record) {
  const bool ertSlabSwept = std::find(spec.slabs.begin(), spec.slabs.end(), spec.ertSlab) != spec.slabs.end();
  for (int slab : spec.slabs)
    if (slab >= spec.ertSlab || step >= spec.smallSlabMinStep) record(run.measure(slabSetting(step, slab), vi));
  if (!ertSlabSwept && (!spec.erts.empty() || spec.preIntegration))
    record(run.measure(slabSetting(step, spec.ertSlab), vi));
  for (double ert : spec.erts) {
    record(run.measure(slabSetting(step, spec.ertSlab, ert), vi));
    for (int subBlock : spec.slabSubBlocks)
      record(run.measure(slabSetting(step, spec.ertSlab, ert, false, subBlock), vi));
    for (double lod : spec.lods) {
      Setting s = slabSetting(step, spec.ertSlab, ert, false, lodSubBlock(spec));
      s.lod = lod;
      record(run.measure(s, vi));
    }
  }
}

/// At one step: the ray caster with ERT off and each threshold, each with whole-brick cells and each sub-block
/// size, then each level of detail with each threshold.
void measureRayCastStep(const SweepSpec& spec, DatasetRun& run, size_t vi, double step, Recorder& record) {
  for (double ert : rayCastErts(spec)) {
    record(run.measure(rayCastSetting(step, ert), vi));
    for (int subBlock : spec.slabSubBlocks) record(run.measure(rayCastSetting(step, ert, false, subBlock), vi));
  }
  for (double ert : spec.erts)
    for (double lod : spec.lods) {
      Setting s = rayCastSetting(step, ert, false, lodSubBlock(spec));
      s.lod = lod;
      record(run.measure(s, vi));
    }
}

/// Phase 1 of one dataset: slicing, then the slab settings and the ray caster on its slab variants.
void measureFirstPhase(const SweepSpec& spec, const Dataset& d, DatasetRun& run, Recorder& record) {
  measureSlicing(spec, run, record);
  if (!spec.slabs.empty())
    for (const Variant& variant : slabVariants(d, spec.opaqueVariants))
      for (double step : spec.slabStepsOrAll()) measureSlabStep(spec, run, run.variantIndex(variant), step, record);
  if (spec.rayCast)
    for (const Variant& variant : slabVariants(d, spec.opaqueVariants))
      for (double step : spec.slabStepsOrAll()) measureRayCastStep(spec, run, run.variantIndex(variant), step, record);
}

/// What phase 2 runs with, from phase 1's points over every dataset: the best other slab size and the best
/// thresholds for pre-integration (the ray caster's its own, so that its points do not depend on the slab part).
void chooseSecondPhase(const SweepSpec& spec, SweepResult& result, const Log& log) {
  const bool slabs = !spec.slabs.empty();
  if (slabs && spec.ertAtBestSlab && !spec.erts.empty()) result.bestSlab = bestSlabSize(result.points, spec.ertSlab);
  if (slabs && spec.preIntegration)
    result.bestErt = bestErt(result.points, spec.ertSlab, spec.ertToleranceDb, spec.psnrHighThreshold);
  if (spec.rayCast && spec.preIntegration)
    result.bestRayCastErt = bestRayCastErt(result.points, spec.ertToleranceDb, spec.psnrHighThreshold);
  if (result.bestSlab) log("best slab size besides " + slabLabel(spec.ertSlab) + ": " + slabLabel(*result.bestSlab));
  if (result.bestErt) log("best ERT threshold: " + stepText(*result.bestErt));
  if (result.bestRayCastErt) log("best ERT threshold of the ray caster: " + stepText(*result.bestRayCastErt));
}

/// Phase 2 at one step: the thresholds at the best other slab size, and pre-integration with ERT off and with the
/// best threshold, on slabs and on the ray caster.
void measureSecondPhaseStep(const SweepSpec& spec, const SweepResult& result, DatasetRun& run, size_t vi, double step,
                            Recorder& record) {
  if (result.bestSlab && (*result.bestSlab >= spec.ertSlab || step >= spec.smallSlabMinStep))
    for (double ert : spec.erts) record(run.measure(slabSetting(step, *result.bestSlab, ert), vi));
  if (!spec.slabs.empty() && spec.preIntegration) {
    record(run.measure(slabSetting(step, spec.ertSlab, 0, true), vi));
    if (result.bestErt) record(run.measure(slabSetting(step, spec.ertSlab, *result.bestErt, true), vi));
  }
  if (spec.rayCast && spec.preIntegration) {
    record(run.measure(rayCastSetting(step, 0, true), vi));
    if (result.bestRayCastErt) record(run.measure(rayCastSetting(step, *result.bestRayCastErt, true), vi));
  }
}

/// Each dataset's points together, in the order measured.
void groupByDataset(const SweepSpec& spec, std::vector<Point>& points) {
  auto index = [&](const Point& p) {
    return std::find_if(spec.datasets.begin(), spec.datasets.end(),
                        [&](const Dataset& d) { return d.name == p.dataset; }) -
           spec.datasets.begin();
  };
  std::stable_sort(points.begin(), points.end(), [&](const Point& a, const Point& b) { return index(a) < index(b); });
}

}  // namespace

SweepResult runSweep(const SweepSpec& spec, const fs::path& work, render::GlContext& context, const Log& log) {
  SweepResult result;
  result.device = context.describe();
  result.spec = spec;
  fs::create_directories(work);
  Recorder record(result, log);

  std::vector<std::unique_ptr<DatasetRun>> runs;
  for (const Dataset& d : spec.datasets) {
    auto run = std::make_unique<DatasetRun>(spec, d, work, context, result, log);
    measureFirstPhase(spec, d, *run, record);
    run->release();
    runs.push_back(std::move(run));
  }
  if (spec.marches()) {
    chooseSecondPhase(spec, result, log);
    for (size_t i = 0; i < spec.datasets.size(); ++i) {
      for (const Variant& variant : slabVariants(spec.datasets[i], spec.opaqueVariants))
        for (double step : spec.slabStepsOrAll())
          measureSecondPhaseStep(spec, result, *runs[i], runs[i]->variantIndex(variant), step, record);
      runs[i]->release();
    }
  }
  groupByDataset(spec, result.points);
  markPareto(result.points);
  result.chosen = chooseDefault(result.points, spec.datasets, spec.psnrThreshold);
  result.chosenHigh = chooseDefault(result.points, spec.datasets, spec.psnrHighThreshold);
  return result;
}

}  // namespace voxbrick::quality
