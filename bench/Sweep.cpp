// The sweep: stores made once, reference frames cached on disk, GPU frames timed over an orbit and compared view
// by view; then the Pareto front and the default.
#include "bench/Sweep.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "brickstore/StoreWriter.h"
#include "render/reference/ReferenceRenderer.h"
#include "render/core/RenderErrors.h"
#include "render/gl/volume/VolumeRenderer.h"

namespace voxbrick::bench {
namespace fs = std::filesystem;

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

namespace {

constexpr size_t kBudget = size_t(2) << 30;  // host cache and GPU atlas: every dataset here fits

std::string stepText(double step) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", step);
  return text;
}

/// The store of `d` with brick size `brick` in `work`, made by prep unless one from the same input is there; or the
/// one `d.store` names, as it is.
std::shared_ptr<const store::BrickStore> datasetStore(const Dataset& d, int brick, const fs::path& work) {
  const fs::path path = datasetStorePath(d, brick, work);
  if (!d.store.empty()) return store::BrickStore::openAny(path);
  auto source = store::openSource(d.input, {});
  if (fs::exists(path / "store.json")) {
    auto existing = store::BrickStore::open(path);
    if (existing->meta().source == source->info().description && existing->brickSize() == brick) return existing;
  }
  store::PrepOptions options;
  options.brickSize = brick;
  options.writeVdb = false;
  options.overwrite = true;
  store::prepStore(*source, path, options);
  return store::BrickStore::open(path);
}

render::Scene viewScene(const SweepSpec& spec, const Variant& variant, int view) {
  render::Scene scene;
  scene.width = scene.height = spec.size;
  scene.camera.azimuth = 360.0 * view / spec.views;
  scene.camera.elevation = spec.elevations.empty() ? 20 : spec.elevations[size_t(view) % spec.elevations.size()];
  scene.camera.distance = 2.2;
  scene.transferFunction = render::TransferFunction::load(variant.transferFunction);
  scene.transferFunctionName = variant.transferFunction;
  scene.shading = variant.shading;
  return scene;
}

/// The scene as the reference renderer sees it: without the GPU renderer's drawing settings (which it ignores), so
/// that a cache made before they existed stays valid.
std::string referenceJson(const render::Scene& scene) {
  nlohmann::json j = nlohmann::json::parse(scene.toJson());
  // How the GPU draws does not change the reference's frame.
  for (const char* key : {"slab", "raycast", "ert", "pre_integration", "sub_block", "slicer"}) j.erase(key);
  return j.dump(2);
}

/// Reference frames on disk: a text header naming everything the frame depends on, then RGBA floats.
class ReferenceCache {
 public:
  ReferenceCache(fs::path dir, std::shared_ptr<const store::BrickStore> s)
      : mDir(std::move(dir)), mStore(std::move(s)),
        mRenderer(std::make_shared<store::BrickCache>(mStore, kBudget, 2)) {
    fs::create_directories(mDir);
  }

  /// The frame of `scene` at `step`; `msRendered` gets the time if it had to be rendered, else stays.
  image::ImageF get(const render::Scene& scene, double step, double* msRendered) {
    const std::string key = "voxbrick-reference 2\n" + mStore->meta().source + "\n" + referenceJson(scene) +
                            "\nstep " + stepText(step) + "\n";
    char name[64];
    std::snprintf(name, sizeof name, "%016zx.ref", std::hash<std::string>{}(key));
    const fs::path path = mDir / name;
    image::ImageF image{scene.width, scene.height, std::vector<float>(size_t(scene.width) * size_t(scene.height) * 4)};
    const size_t bytes = image.rgba.size() * sizeof(float);
    if (std::ifstream in{path, std::ios::binary}) {
      std::string header(key.size(), '\0');
      in.read(header.data(), std::streamsize(header.size()));
      in.read(reinterpret_cast<char*>(image.rgba.data()), std::streamsize(bytes));
      if (in && header == key && in.peek() == std::char_traits<char>::eof()) return image;
    }
    render::ReferenceOptions options;
    options.step = step;
    render::ReferenceStats stats;
    image = mRenderer.render(scene, options, &stats);
    if (msRendered) *msRendered = stats.ms;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(key.data(), std::streamsize(key.size()));
    out.write(reinterpret_cast<const char*>(image.rgba.data()), std::streamsize(bytes));
    if (!out) throw std::runtime_error("cannot write " + path.string());
    return image;
  }

 private:
  fs::path mDir;
  std::shared_ptr<const store::BrickStore> mStore;
  render::ReferenceRenderer mRenderer;
};

std::vector<Variant> variantsOf(const SweepSpec& spec, const Dataset& d) {
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

}  // namespace

fs::path datasetStorePath(const Dataset& d, int brick, const fs::path& work) {
  if (!d.store.empty()) return d.store;
  return work / (d.name + "-b" + std::to_string(brick) + ".vbs");
}

render::QualityTable qualityTable(const SweepResult& result, const fs::path& work, const fs::path& store) {
  render::QualityTable table;
  table.device = result.device;
  table.width = table.height = result.spec.size;
  table.views = result.spec.views;
  for (const Point& p : result.points) {
    const auto d = std::find_if(result.spec.datasets.begin(), result.spec.datasets.end(),
                                [&](const Dataset& x) { return x.name == p.dataset; });
    const Setting& s = p.setting;
    if (d == result.spec.datasets.end() || datasetStorePath(*d, 32, work) != store || s.brick != 32 || !s.skip ||
        s.slicer != render::Slicer::Vertex)
      continue;
    render::QualityEntry e;
    e.transferFunction = p.variant.transferFunction;
    e.shading = p.variant.shading;
    e.setting = {s.step, s.raycast, s.slab, s.ert, s.preIntegration, s.subBlock, s.lod};
    e.msMedian = p.msMedian;
    // An image equal to the reference has an infinite PSNR, which JSON cannot hold: 999 dB stands for it.
    e.psnrMin = std::min(p.psnrMin, 999.0);
    table.entries.push_back(e);
  }
  return table;
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
  if (raycast) text += ", raycast";
  else if (slab > 0) text += ", " + slabLabel(slab);
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

namespace {

/// One dataset's part of the sweep: its stores, variants and reference frames, and (made when first needed, released
/// between the sweep's phases) one GPU renderer per store, so that bricks stay resident across settings as in a
/// server.
class DatasetRun {
 public:
  DatasetRun(const SweepSpec& spec, const Dataset& d, const fs::path& work, render::GlContext& context,
             SweepResult& result, const std::function<void(const std::string&)>& log)
      : mSpec(spec), mDataset(d), mContext(context) {
    mStores[32] = datasetStore(d, 32, work);
    for (int b : spec.alternativeBricks) mStores[b] = datasetStore(d, b, work);
    mVariants = variantsOf(spec, d);

    // Reference frames of every view of every variant, and the self-check of each default-TF variant.
    ReferenceCache references(work / "reference" / d.name, mStores[32]);
    for (const Variant& variant : mVariants) {
      std::vector<double> ms;
      mTruth.emplace_back();
      for (int v = 0; v < spec.views; ++v) {
        double rendered = -1;
        mTruth.back().push_back(references.get(viewScene(spec, variant, v), spec.referenceStep, &rendered));
        if (rendered >= 0) ms.push_back(rendered);
      }
      ReferenceReport report{d.name, variant, median(ms)};
      if (variant.transferFunction == defaultVariant(d).transferFunction) {
        const image::ImageError e = image::compareImages(
            mTruth.back()[0], references.get(viewScene(spec, variant, 0), spec.referenceStep / 2, nullptr));
        report.halvingPsnr = e.psnr;
        report.halvingMaxAbs = e.maxAbs;
      }
      result.references.push_back(report);
      log(d.name + " reference, " + variant.label() + ": " + std::to_string(int(report.msPerView)) +
          " ms per view (0: cached)");
    }
  }

  const std::vector<Variant>& variants() const { return mVariants; }
  size_t variantIndex(const Variant& v) const {
    return size_t(std::find(mVariants.begin(), mVariants.end(), v) - mVariants.begin());
  }

  /// Frees the GPU renderers (and their atlases) until the next measure().
  void release() { mRenderers.clear(); }

  Point measure(const Setting& setting, size_t variantIndex) {
    const Variant& variant = mVariants[variantIndex];
    std::unique_ptr<render::VolumeRenderer>& slot = mRenderers[setting.brick];
    if (!slot)
      slot = std::make_unique<render::VolumeRenderer>(
          mContext, std::make_shared<store::BrickCache>(mStores.at(setting.brick), kBudget, 2), kBudget);
    render::VolumeRenderer& renderer = *slot;
    auto sceneOf = [&](int v) {
      render::Scene scene = viewScene(mSpec, variant, v);
      scene.step = setting.step;
      scene.skipEmpty = setting.skip;
      scene.slicer = setting.slicer;
      scene.slab = setting.slab;
      scene.raycast = setting.raycast;
      scene.ert = setting.ert;
      scene.preIntegration = setting.preIntegration;
      scene.subBlock = setting.subBlock;
      scene.lod = setting.lod;
      return scene;
    };
    renderer.render(sceneOf(0));  // warm-up: pages what this setting draws, builds its program
    Point p{mDataset.name, variant, setting};
    std::vector<double> ms, samples, fragments, terminated, passes;
    ErrorTally errors;
    for (int v = 0; v < mSpec.views; ++v) {
      render::FrameStats stats;
      const image::ImageF image = renderer.render(sceneOf(v), &stats);
      ms.push_back(stats.msTotal);
      samples.push_back(double(stats.samples));
      fragments.push_back(double(stats.fragments));
      terminated.push_back(double(stats.samplesTerminated));
      passes.push_back(double(stats.slabPasses));
      errors.add(image::compareImages(image, mTruth[variantIndex][size_t(v)]));
    }
    p.psnrMin = errors.psnrMin;
    p.maxAbs = errors.maxAbs;
    p.msMedian = median(ms);
    p.msMin = *std::min_element(ms.begin(), ms.end());
    p.msMax = *std::max_element(ms.begin(), ms.end());
    p.samplesMedian = median(samples);
    p.fragmentsMedian = median(fragments);
    p.samplesTerminatedMedian = median(terminated);
    p.slabPassesMedian = median(passes);
    p.rmsePooled = errors.rmsePooled();
    p.psnrPooled = errors.psnrPooled();
    return p;
  }

 private:
  const SweepSpec& mSpec;
  const Dataset& mDataset;
  render::GlContext& mContext;
  std::map<int, std::shared_ptr<const store::BrickStore>> mStores;
  std::vector<Variant> mVariants;
  std::vector<std::vector<image::ImageF>> mTruth;
  std::map<int, std::unique_ptr<render::VolumeRenderer>> mRenderers;
};

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

}  // namespace

size_t SweepSpec::plannedPoints() const {
  size_t n = 0;
  for (const Dataset& d : datasets) {
    n += variantsOf(*this, d).size() * steps.size();
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

std::vector<Variant> slabVariants(const Dataset& d, bool opaque) {
  std::vector<Variant> variants{defaultVariant(d)};
  if (opaque && !d.opaque.empty() && !(Variant{d.opaque} == variants[0])) variants.push_back({d.opaque});
  return variants;
}

SweepResult runSweep(const SweepSpec& spec, const fs::path& work, render::GlContext& context,
                     const std::function<void(const std::string&)>& log) {
  SweepResult result;
  result.device = context.describe();
  result.spec = spec;
  fs::create_directories(work);
  const auto start = std::chrono::steady_clock::now();
  const size_t planned = spec.plannedPoints();
  auto record = [&](const Point& p) {
    const double minutes = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / 60;
    char line[320];
    std::snprintf(line, sizeof line, "[%zu/%zu, %.1f min] %s %s, %s: %.1f ms, worst view %.1f dB",
                  result.points.size() + 1, planned, minutes, p.dataset.c_str(), p.variant.label().c_str(),
                  p.setting.label().c_str(), p.msMedian, p.psnrMin);
    log(line);
    result.points.push_back(p);
  };
  const std::vector<double> slabSteps = spec.slabStepsOrAll();
  const bool ertSlabSwept = std::find(spec.slabs.begin(), spec.slabs.end(), spec.ertSlab) != spec.slabs.end();

  // Phase 1, dataset by dataset: the baseline, the slicing alternatives, the slab sizes and the thresholds at ertSlab.
  std::vector<std::unique_ptr<DatasetRun>> runs;
  for (const Dataset& d : spec.datasets) {
    auto run = std::make_unique<DatasetRun>(spec, d, work, context, result, log);
    for (size_t vi = 0; vi < run->variants().size(); ++vi)
      for (double step : spec.steps) record(run->measure({step}, vi));
    for (double step : spec.steps) {
      for (int b : spec.alternativeBricks) record(run->measure({step, b}, 0));
      if (spec.alternativeNoSkip) record(run->measure({step, 32, false}, 0));
      if (spec.alternativeCpuSlicer) record(run->measure({step, 32, true, render::Slicer::Cpu}, 0));
    }
    if (!spec.slabs.empty())
      for (const Variant& variant : slabVariants(d, spec.opaqueVariants)) {
        const size_t vi = run->variantIndex(variant);
        for (double step : slabSteps) {
          for (int slab : spec.slabs)
            if (slab >= spec.ertSlab || step >= spec.smallSlabMinStep)
              record(run->measure(slabSetting(step, slab), vi));
          if (!ertSlabSwept && (!spec.erts.empty() || spec.preIntegration))
            record(run->measure(slabSetting(step, spec.ertSlab), vi));
          for (double ert : spec.erts) {
            record(run->measure(slabSetting(step, spec.ertSlab, ert), vi));
            for (int subBlock : spec.slabSubBlocks)
              record(run->measure(slabSetting(step, spec.ertSlab, ert, false, subBlock), vi));
            for (double lod : spec.lods) {
              Setting s = slabSetting(step, spec.ertSlab, ert, false,
                                      spec.slabSubBlocks.empty() ? 0 : spec.slabSubBlocks.back());
              s.lod = lod;
              record(run->measure(s, vi));
            }
          }
        }
      }
    if (spec.rayCast)
      for (const Variant& variant : slabVariants(d, spec.opaqueVariants)) {
        const size_t vi = run->variantIndex(variant);
        for (double step : slabSteps) {
          for (double ert : rayCastErts(spec)) {
            record(run->measure(rayCastSetting(step, ert), vi));
            for (int subBlock : spec.slabSubBlocks)
              record(run->measure(rayCastSetting(step, ert, false, subBlock), vi));
          }
          for (double ert : spec.erts)
            for (double lod : spec.lods) {
              Setting s = rayCastSetting(step, ert, false, spec.slabSubBlocks.empty() ? 0 : spec.slabSubBlocks.back());
              s.lod = lod;
              record(run->measure(s, vi));
            }
        }
      }
    run->release();
    runs.push_back(std::move(run));
  }

  // Phase 2, with what phase 1 found over every dataset: the thresholds at the best other slab size, and
  // pre-integration with ERT off and with the best threshold, on slabs and on the ray caster. The ray caster's best
  // threshold is its own, so that its points do not depend on the slab part being swept.
  if (spec.marches()) {
    const bool slabs = !spec.slabs.empty();
    if (slabs && spec.ertAtBestSlab && !spec.erts.empty()) result.bestSlab = bestSlabSize(result.points, spec.ertSlab);
    if (slabs && spec.preIntegration)
      result.bestErt = bestErt(result.points, spec.ertSlab, spec.ertToleranceDb, spec.psnrHighThreshold);
    if (spec.rayCast && spec.preIntegration)
      result.bestRayCastErt = bestRayCastErt(result.points, spec.ertToleranceDb, spec.psnrHighThreshold);
    if (result.bestSlab) log("best slab size besides " + slabLabel(spec.ertSlab) + ": " + slabLabel(*result.bestSlab));
    if (result.bestErt) log("best ERT threshold: " + stepText(*result.bestErt));
    if (result.bestRayCastErt) log("best ERT threshold of the ray caster: " + stepText(*result.bestRayCastErt));
    for (size_t i = 0; i < spec.datasets.size(); ++i) {
      DatasetRun& run = *runs[i];
      for (const Variant& variant : slabVariants(spec.datasets[i], spec.opaqueVariants)) {
        const size_t vi = run.variantIndex(variant);
        for (double step : slabSteps) {
          if (result.bestSlab && (*result.bestSlab >= spec.ertSlab || step >= spec.smallSlabMinStep))
            for (double ert : spec.erts) record(run.measure(slabSetting(step, *result.bestSlab, ert), vi));
          if (slabs && spec.preIntegration) {
            record(run.measure(slabSetting(step, spec.ertSlab, 0, true), vi));
            if (result.bestErt) record(run.measure(slabSetting(step, spec.ertSlab, *result.bestErt, true), vi));
          }
          if (spec.rayCast && spec.preIntegration) {
            record(run.measure(rayCastSetting(step, 0, true), vi));
            if (result.bestRayCastErt) record(run.measure(rayCastSetting(step, *result.bestRayCastErt, true), vi));
          }
        }
      }
      run.release();
    }
  }
  // Each dataset's points together, in the order measured.
  std::stable_sort(result.points.begin(), result.points.end(), [&](const Point& a, const Point& b) {
    auto index = [&](const Point& p) {
      return std::find_if(spec.datasets.begin(), spec.datasets.end(),
                          [&](const Dataset& d) { return d.name == p.dataset; }) -
             spec.datasets.begin();
    };
    return index(a) < index(b);
  });

  markPareto(result.points);
  result.chosen = chooseDefault(result.points, spec.datasets, spec.psnrThreshold);
  result.chosenHigh = chooseDefault(result.points, spec.datasets, spec.psnrHighThreshold);
  return result;
}

void markPareto(std::vector<Point>& points) {
  for (Point& p : points) {
    p.pareto = std::none_of(points.begin(), points.end(), [&](const Point& q) {
      return q.dataset == p.dataset && q.variant == p.variant && q.msMedian <= p.msMedian &&
             q.psnrMin >= p.psnrMin && (q.msMedian < p.msMedian || q.psnrMin > p.psnrMin);
    });
  }
}

std::optional<Setting> chooseDefault(const std::vector<Point>& points, const std::vector<Dataset>& datasets,
                                     double psnrThreshold) {
  std::optional<Setting> best;
  double bestCost = std::numeric_limits<double>::infinity();
  for (const Point& candidate : points) {
    double cost = 0;
    for (const Dataset& d : datasets) {
      const auto p = std::find_if(points.begin(), points.end(), [&](const Point& q) {
        return q.dataset == d.name && q.setting == candidate.setting && q.variant == defaultVariant(d);
      });
      cost += p != points.end() && p->psnrMin >= psnrThreshold ? p->msMedian : std::numeric_limits<double>::infinity();
    }
    if (cost < bestCost) {
      best = candidate.setting;
      bestCost = cost;
    }
  }
  return best;
}

std::optional<int> bestSlabSize(const std::vector<Point>& points, int exclude) {
  // Per slab size, the (dataset, variant, step) it was measured at and its median time there.
  std::map<int, std::map<std::string, double>> times;
  for (const Point& p : points) {
    const Setting& s = p.setting;
    if (s.slab <= 0 || s.raycast || s.slab == exclude || s.ert > 0 || s.preIntegration || s.brick != 32 || !s.skip ||
        s.slicer != render::Slicer::Vertex)
      continue;
    times[s.slab][p.dataset + "\n" + p.variant.label() + "\n" + stepText(s.step)] = p.msMedian;
  }
  std::map<std::string, size_t> sizesAt;  // how many sizes were measured at each (dataset, variant, step)
  for (const auto& [slab, where] : times)
    for (const auto& [key, ms] : where) ++sizesAt[key];
  if (std::none_of(sizesAt.begin(), sizesAt.end(), [&](const auto& at) { return at.second == times.size(); }))
    return std::nullopt;
  std::optional<int> best;
  double bestTotal = std::numeric_limits<double>::infinity();
  for (const auto& [slab, where] : times) {
    double total = 0;
    for (const auto& [key, ms] : where)
      if (sizesAt[key] == times.size()) total += ms;
    if (total < bestTotal) best = slab, bestTotal = total;
  }
  return best;
}

namespace {

/// bestErt's rule over the points whose setting is `plain` (one renderer, without pre-integration).
std::optional<double> lowestKeepingErt(const std::vector<Point>& points,
                                       const std::function<bool(const Setting&)>& plain, double toleranceDb,
                                       double highThreshold) {
  std::map<double, bool> keeps;  // threshold -> keeps the accuracy everywhere
  for (const Point& p : points) {
    if (!plain(p.setting) || p.setting.ert <= 0) continue;
    bool& ok = keeps.try_emplace(p.setting.ert, true).first->second;
    const auto off = std::find_if(points.begin(), points.end(), [&](const Point& q) {
      return q.dataset == p.dataset && q.variant == p.variant && plain(q.setting) && q.setting.ert == 0 &&
             q.setting.step == p.setting.step;
    });
    if (off != points.end() && p.psnrMin < std::min(off->psnrMin - toleranceDb, highThreshold)) ok = false;
  }
  for (const auto& [ert, ok] : keeps)
    if (ok) return ert;
  if (keeps.empty()) return std::nullopt;
  return keeps.rbegin()->first;
}

}  // namespace

std::optional<double> bestErt(const std::vector<Point>& points, int slab, double toleranceDb, double highThreshold) {
  return lowestKeepingErt(
      points,
      [&](const Setting& s) {
        return s.slab == slab && !s.raycast && !s.preIntegration && s.brick == 32 && s.skip &&
               s.slicer == render::Slicer::Vertex;
      },
      toleranceDb, highThreshold);
}

std::optional<double> bestRayCastErt(const std::vector<Point>& points, double toleranceDb, double highThreshold) {
  return lowestKeepingErt(
      points,
      [](const Setting& s) {
        return s.raycast && !s.preIntegration && s.brick == 32 && s.skip && s.slicer == render::Slicer::Vertex;
      },
      toleranceDb, highThreshold);
}

std::optional<Point> fastestPoint(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                  double psnrThreshold) {
  std::optional<Point> best;
  for (const Point& p : points)
    if (p.dataset == dataset && p.variant == variant && p.psnrMin >= psnrThreshold &&
        (!best || p.msMedian < best->msMedian))
      best = p;
  return best;
}

std::optional<double> coarsestStep(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                   double psnrThreshold) {
  std::optional<double> step;
  for (const Point& p : points)
    if (p.dataset == dataset && p.variant == variant && p.setting == Setting{p.setting.step} &&
        p.psnrMin >= psnrThreshold && (!step || p.setting.step > *step))
      step = p.setting.step;
  return step;
}

}  // namespace voxbrick::bench
