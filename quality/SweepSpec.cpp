// The sweep's settings and their labels, the committed, quick and calibration specs, and what a spec plans.
#include "quality/SweepSpec.h"

#include <algorithm>
#include <cstdio>

namespace voxbrick::quality {
namespace fs = std::filesystem;

std::string stepText(double step) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", step);
  return text;
}

fs::path datasetStorePath(const Dataset& d, int brick, const fs::path& work) {
  if (!d.store.empty()) return d.store;
  return work / (d.name + "-b" + std::to_string(brick) + ".vbs");
}

std::string slabLabel(int slab) {
  if (slab <= 0) return "slicing";
  return slab >= render::Scene::kMaxSlab ? "slab whole brick" : "slab " + std::to_string(slab);
}

namespace {

/// The settings after the renderer in a label: ", ert 0.99, pre-int, sub-block 8, lod 2", each only where not default.
std::string marchingOptions(const Setting& s) {
  std::string text;
  if (s.ert > 0) text += ", ert " + stepText(s.ert);
  if (s.preIntegration) text += ", pre-int";
  if (s.subBlock > 0) text += ", sub-block " + std::to_string(s.subBlock);
  if (s.lod > 0) text += ", lod " + stepText(s.lod);
  return text;
}

}  // namespace

std::string marchingLabel(const Setting& s) {
  return (s.raycast ? std::string("raycast") : slabLabel(s.slab)) + marchingOptions(s);
}

std::string Setting::label() const {
  std::string text = "step " + stepText(step) + ", B=" + std::to_string(brick) + (skip ? ", skip" : ", no skip") +
                     (slicer == render::Slicer::Cpu ? ", cpu slicer" : ", vertex");
  if (raycast)
    text += ", raycast";
  else if (slab > 0)
    text += ", " + slabLabel(slab);
  return text + marchingOptions(*this);
}

SweepSpec SweepSpec::full(const std::string& mriPath) {
  SweepSpec s;
  s.datasets = {{"ml", "synthetic:marschner-lobb,n=128", {"hot", "ct-bone"}, "ct-bone"},
                {"sparse", "synthetic:sparse,n=256", {"sparse", "hot"}},
                {"mri", mriPath, {"mri", "ct-bone"}, "ct-bone"}};
  s.steps = {0.25, 0.5, 0.75, 1, 1.5, 2};
  s.alternativeBricks = {16, 64};
  s.slabs = {1, 4, 16, 32, render::Scene::kMaxSlab};
  s.ertSlab = 32;
  s.erts = {0.99, 0.999, 1};
  s.slabSubBlocks = {8};
  s.smallSlabMinStep = 0.5;  // slabs of 1 and 4 planes at step 0.25 would add about 15 minutes
  s.rayCast = true;
  return s;
}

SweepSpec SweepSpec::quick(const std::string& mriPath) {
  SweepSpec s;
  s.datasets = {{"ml", "synthetic:marschner-lobb,n=32", {"hot"}, "ct-bone"},
                {"sparse", "synthetic:sparse,n=48", {"sparse"}},
                {"mri", mriPath, {"mri"}}};
  s.steps = {0.5, 2};
  s.alternativeBricks = {16};
  // Every kind of slab and ray-caster setting once, at the coarse step: whole bricks (the best other size), slab 16
  // and the ray caster with and without ERT and pre-integration, on the default variants and Marschner–Lobb's
  // opaque one.
  s.slabs = {16, render::Scene::kMaxSlab};
  s.erts = {0.99};
  s.slabSubBlocks = {8};
  s.rayCast = true;
  s.slabSteps = {2};
  s.slabTableStep = 2;
  s.views = 2;
  s.size = 48;
  s.referenceStep = 0.25;
  return s;
}

SweepSpec SweepSpec::calibrate(const std::string& store, const std::vector<std::string>& transferFunctions) {
  SweepSpec s;
  const std::string name = fs::path(store).filename().string();
  for (const std::string& tf : transferFunctions) s.datasets.push_back({name + "-" + tf, "", {tf}, "", store});
  s.steps = {0.35, 0.5, 0.75, 1, 1.5, 2, 3};
  s.alternativeNoSkip = s.alternativeCpuSlicer = false;
  s.shadingVariants = false;
  s.erts = {0.999};
  s.slabSubBlocks = {8};
  s.lods = {1, 2};
  s.opaqueVariants = false;
  s.rayCast = true;
  s.views = 6;
  s.elevations = {20, -30, 55};
  return s;
}

std::vector<Variant> slabVariants(const Dataset& d, bool opaque) {
  std::vector<Variant> variants{defaultVariant(d)};
  if (opaque && !d.opaque.empty() && !(Variant{d.opaque} == variants[0])) variants.push_back({d.opaque});
  return variants;
}

std::vector<Variant> sweptVariants(const SweepSpec& spec, const Dataset& d) {
  std::vector<Variant> variants;
  for (const std::string& tf : d.transferFunctions) {
    variants.push_back({tf, false});
    if (spec.shadingVariants) variants.push_back({tf, true});
  }
  if (spec.marches())
    for (const Variant& v : slabVariants(d, spec.opaqueVariants))
      if (std::find(variants.begin(), variants.end(), v) == variants.end()) variants.push_back(v);
  return variants;
}

size_t SweepSpec::plannedPoints() const {
  size_t n = 0;
  for (const Dataset& d : datasets) {
    n += sweptVariants(*this, d).size() * steps.size();
    n += steps.size() * (alternativeBricks.size() + size_t(alternativeNoSkip) + size_t(alternativeCpuSlicer));
    if (!marches()) continue;
    const bool ertSlabSwept = std::find(slabs.begin(), slabs.end(), ertSlab) != slabs.end();
    const bool otherSlab = std::any_of(slabs.begin(), slabs.end(), [&](int b) { return b != ertSlab; });
    const size_t preIntegrated = preIntegration ? (erts.empty() ? 1 : 2) : 0;
    size_t perVariant = 0;
    for (double step : slabStepsOrAll()) {
      if (!slabs.empty()) {
        for (int slab : slabs) perVariant += slab >= ertSlab || step >= smallSlabMinStep;
        perVariant += erts.size() * (1 + slabSubBlocks.size() + lods.size()) +
                      (!ertSlabSwept && (!erts.empty() || preIntegration));
        if (ertAtBestSlab && otherSlab) perVariant += erts.size();
        perVariant += preIntegrated;
      }
      if (rayCast)
        perVariant += (1 + erts.size()) * (1 + slabSubBlocks.size()) + erts.size() * lods.size() + preIntegrated;
    }
    n += slabVariants(d, opaqueVariants).size() * perVariant;
  }
  return n;
}

}  // namespace voxbrick::quality
