// The sweep: stores made once, reference frames cached on disk, GPU frames timed over an orbit and compared view
// by view; then the Pareto front and the default.
#include "bench/Sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "brickstore/StoreWriter.h"
#include "render/ReferenceRenderer.h"
#include "render/RenderErrors.h"
#include "render/VolumeRenderer.h"

namespace voxbrick::bench {
namespace fs = std::filesystem;

namespace {

constexpr size_t kBudget = size_t(2) << 30;  // host cache and GPU atlas: every dataset here fits

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  if (v.empty()) return 0;
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

std::string stepText(double step) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", step);
  return text;
}

/// The store of `d` with brick size `brick` in `work`, made by prep unless one from the same input is there.
std::shared_ptr<const store::BrickStore> datasetStore(const Dataset& d, int brick, const fs::path& work) {
  const fs::path path = work / (d.name + "-b" + std::to_string(brick) + ".vbs");
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
  scene.camera.elevation = 20;
  scene.camera.distance = 2.2;
  scene.transferFunction = render::TransferFunction::load(variant.transferFunction);
  scene.transferFunctionName = variant.transferFunction;
  scene.shading = variant.shading;
  return scene;
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
    const std::string key = "voxbrick-reference 2\n" + mStore->meta().source + "\n" + scene.toJson() +
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
  return variants;
}

}  // namespace

std::string Setting::label() const {
  return "step " + stepText(step) + ", B=" + std::to_string(brick) + (skip ? ", skip" : ", no skip") +
         (slicer == render::Slicer::Cpu ? ", cpu slicer" : ", vertex");
}

SweepSpec SweepSpec::full(const std::string& mriPath) {
  SweepSpec s;
  s.datasets = {{"ml", "synthetic:marschner-lobb,n=128", {"hot", "ct-bone"}},
                {"sparse", "synthetic:sparse,n=256", {"sparse", "hot"}},
                {"mri", mriPath, {"mri", "ct-bone"}}};
  s.steps = {0.25, 0.5, 0.75, 1, 1.5, 2};
  s.alternativeBricks = {16, 64};
  return s;
}

SweepSpec SweepSpec::quick(const std::string& mriPath) {
  SweepSpec s;
  s.datasets = {{"ml", "synthetic:marschner-lobb,n=32", {"hot"}},
                {"sparse", "synthetic:sparse,n=48", {"sparse"}},
                {"mri", mriPath, {"mri"}}};
  s.steps = {0.5, 2};
  s.alternativeBricks = {16};
  s.views = 2;
  s.size = 48;
  s.referenceStep = 0.25;
  return s;
}

SweepResult runSweep(const SweepSpec& spec, const fs::path& work, render::GlContext& context,
                     const std::function<void(const std::string&)>& log) {
  SweepResult result;
  result.device = context.describe();
  result.spec = spec;
  fs::create_directories(work);
  for (const Dataset& d : spec.datasets) {
    std::map<int, std::shared_ptr<const store::BrickStore>> stores;
    stores[32] = datasetStore(d, 32, work);
    for (int b : spec.alternativeBricks) stores[b] = datasetStore(d, b, work);
    const std::vector<Variant> variants = variantsOf(spec, d);

    // Reference frames of every view of every variant, and the self-check of each default-TF variant.
    ReferenceCache references(work / "reference" / d.name, stores[32]);
    std::vector<std::vector<image::ImageF>> truth;
    for (const Variant& variant : variants) {
      std::vector<double> ms;
      truth.emplace_back();
      for (int v = 0; v < spec.views; ++v) {
        double rendered = -1;
        truth.back().push_back(references.get(viewScene(spec, variant, v), spec.referenceStep, &rendered));
        if (rendered >= 0) ms.push_back(rendered);
      }
      ReferenceReport report{d.name, variant, median(ms)};
      if (variant.transferFunction == defaultVariant(d).transferFunction) {
        const image::ImageError e = image::compareImages(
            truth.back()[0], references.get(viewScene(spec, variant, 0), spec.referenceStep / 2, nullptr));
        report.halvingPsnr = e.psnr;
        report.halvingMaxAbs = e.maxAbs;
      }
      result.references.push_back(report);
      log(d.name + " reference, " + variant.label() + ": " + std::to_string(int(report.msPerView)) +
          " ms per view (0: cached)");
    }

    // GPU frames: one renderer per store, so that bricks stay resident across settings as in a server.
    std::map<int, std::unique_ptr<render::VolumeRenderer>> renderers;
    for (const auto& [brick, s] : stores)
      renderers[brick] = std::make_unique<render::VolumeRenderer>(
          context, std::make_shared<store::BrickCache>(s, kBudget, 2), kBudget);
    auto measure = [&](const Setting& setting, size_t variantIndex) {
      const Variant& variant = variants[variantIndex];
      render::VolumeRenderer& renderer = *renderers.at(setting.brick);
      auto sceneOf = [&](int v) {
        render::Scene scene = viewScene(spec, variant, v);
        scene.step = setting.step;
        scene.skipEmpty = setting.skip;
        scene.slicer = setting.slicer;
        return scene;
      };
      renderer.render(sceneOf(0));  // warm-up: pages what this setting draws, builds its program
      Point p{d.name, variant, setting};
      std::vector<double> ms, samples;
      double sumSquares = 0;
      p.psnrMin = std::numeric_limits<double>::infinity();
      for (int v = 0; v < spec.views; ++v) {
        render::FrameStats stats;
        const image::ImageF image = renderer.render(sceneOf(v), &stats);
        ms.push_back(stats.msTotal);
        samples.push_back(double(stats.fragments));
        const image::ImageError e = image::compareImages(image, truth[variantIndex][size_t(v)]);
        p.psnrMin = std::min(p.psnrMin, e.psnr);
        p.maxAbs = std::max(p.maxAbs, e.maxAbs);
        sumSquares += e.rmse * e.rmse;
      }
      p.msMedian = median(ms);
      p.msMin = *std::min_element(ms.begin(), ms.end());
      p.msMax = *std::max_element(ms.begin(), ms.end());
      p.samplesMedian = median(samples);
      p.rmsePooled = std::sqrt(sumSquares / spec.views);
      p.psnrPooled = p.rmsePooled > 0 ? 20 * std::log10(1 / p.rmsePooled) : std::numeric_limits<double>::infinity();
      char line[256];
      std::snprintf(line, sizeof line, "%s %s, %s: %.1f ms, worst view %.1f dB", d.name.c_str(),
                    variant.label().c_str(), setting.label().c_str(), p.msMedian, p.psnrMin);
      log(line);
      result.points.push_back(p);
    };
    for (size_t vi = 0; vi < variants.size(); ++vi)
      for (double step : spec.steps) measure({step}, vi);
    for (double step : spec.steps) {
      for (int b : spec.alternativeBricks) measure({step, b}, 0);
      if (spec.alternativeNoSkip) measure({step, 32, false}, 0);
      if (spec.alternativeCpuSlicer) measure({step, 32, true, render::Slicer::Cpu}, 0);
    }
  }
  markPareto(result.points);
  result.chosen = chooseDefault(result.points, spec.datasets, spec.psnrThreshold);
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
