// Renderer benchmark: median frame time over an orbit of views for each setting, beside the sampling roofline
// (one trilinear fetch per fragment, no classification, no blending) of the same geometry. Writes CSV and markdown.
//
//   bench_render [--out bench/results/render] [--work bench/work] [--size 512] [--views 36] [--step 0.5]
//                [--datasets NAME,NAME]   (a subset of dense-blobs-256, sparse-256, mri-ch2better)
//                [--configs 'NAME|NAME']  (only these settings, by exact name; the first of them in the built-in
//                                          order is the baseline for max|diff|)
//                [--name render]          (output files NAME.csv and NAME.md)
//                [--tf PRESET]            (every dataset with this transfer function instead of its own)
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
#include "quality/Statistics.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/VolumeRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;
using voxbrick::quality::median;

namespace {

struct Options {
  std::string out = "bench/results/render", work = "bench/work";
  int size = 512, views = 36;
  std::string datasets;  ///< names to run: each dataset whose name is in this text
  std::string configs;   ///< 'NAME|NAME': only these settings; empty: all
  std::string name = "render";
  std::string tf;  ///< every dataset with this transfer function instead of its own
  double step = 0.5;
};

struct Dataset {
  std::string name, input, tf;
};

struct Config {
  std::string name;
  int brick = 32;
  render::Slicer slicer = render::Slicer::Vertex;
  bool skip = true;
  render::RenderMode mode = render::RenderMode::Normal;
  render::AtlasFormat format = render::AtlasFormat::Float;
  int subBlock = 0;
  int slab = 0;                 ///< planes per texture slab (0 slices); named in the setting, not a CSV column
  double ert = 0;               ///< early ray termination threshold (slabs); named in the setting
  bool preIntegration = false;  ///< named in the setting
  bool ess = false;             ///< empty-space silhouette maps; named in the setting
  bool raycast = false;         ///< the frame ray caster (render::Scene::raycast); named in the setting
  /// Its kernel (render::Scene::raycaster): "raycast" settings name the fragment kernel, "raycast compute" the
  /// compute kernel, so that both are measured on every device whatever auto would choose there.
  render::RayCaster raycaster = render::RayCaster::Fragment;
};

struct Result {
  std::string dataset;
  Config config;
  double msMedian = 0, msMin = 0, msMax = 0, fragments = 0, samples = 0, bricksDrawn = 0, maxAbsVsBaseline = 0;
};

/// One setting on one dataset: its renderer, its scene and what each view measured.
struct Run {
  std::unique_ptr<render::VolumeRenderer> renderer;
  render::Scene scene;
  std::vector<double> ms, fragments, samples, drawn;
  double maxAbs = 0;
};

const std::vector<Dataset> kDatasets = {{"dense-blobs-256", "synthetic:blobs,n=256", "hot"},
                                        {"sparse-256", "synthetic:sparse,n=256", "sparse"},
                                        {"mri-ch2better", "/usr/share/mricron/templates/ch2better.nii.gz", "mri"}};

const std::vector<Config> kConfigs = {
    {"vertex slicer, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal},
    {"cpu slicer, skip", 32, render::Slicer::Cpu, true, render::RenderMode::Normal},
    {"vertex slicer, no skip", 32, render::Slicer::Vertex, false, render::RenderMode::Normal},
    {"vertex slicer, skip, B=16", 16, render::Slicer::Vertex, true, render::RenderMode::Normal},
    {"vertex slicer, skip, B=64", 64, render::Slicer::Vertex, true, render::RenderMode::Normal},
    {"roofline, no skip", 32, render::Slicer::Vertex, false, render::RenderMode::Roofline},
    {"vertex slicer, skip, native atlas", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Native},
    {"vertex slicer, skip, half atlas", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Half},
    {"vertex slicer, skip, sub-block 16", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 16},
    {"vertex slicer, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8},
    {"vertex slicer, skip, sub-block 4", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 4},
    {"vertex slicer, skip, B=16, sub-block 8", 16, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8},
    {"vertex slicer, skip, B=16, sub-block 4", 16, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 4},
    {"vertex slicer, skip, B=64, sub-block 8", 64, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8},
    {"slab 4, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float, 0, 4},
    {"slab 16, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float, 0, 16},
    {"slab whole brick, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float,
     0, render::Scene::kMaxSlab},
    {"slab whole brick, skip, B=16", 16, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, render::Scene::kMaxSlab},
    {"slab 64, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float, 0, 64},
    {"slab 16, ert 0.99, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 16, 0.99},
    {"slab 64, ert 0.99, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 64, 0.99},
    {"slab 16, ert 0.99, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 16, 0.99},
    {"slab 64, ert 0.99, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 64, 0.99},
    {"slab 16, ert 1, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float,
     0, 16, 1.0},
    {"slab 64, ert 1, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float,
     0, 64, 1.0},
    {"slab 1, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float, 0, 1},
    {"slab 16, ert 0.999, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 16, 0.999},
    {"slab 8, ert 0.999, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 8, 0.999},
    {"slab 32, ert 0.999, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 32, 0.999},
    {"slab 16, ert 0.999, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 16, 0.999},
    {"slab 16, ert 0.999, skip, sub-block 4", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 4, 16, 0.999},
    {"slab 16, ert 0.999, skip, half atlas", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Half, 0, 16, 0.999},
    {"slab 16, ert 0.999, skip, native atlas", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Native, 0, 16, 0.999},
    {"slab 16, ert 0.999, skip, B=16", 16, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 16, 0.999},
    {"slab 16, ert 0.999, skip, B=64", 64, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 16, 0.999},
    {"slab 32, ert 0.999, skip, ess", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 32, 0.999, false, true},
    {"slab 32, ert 0.999, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 32, 0.999},
    {"slab 32, ert 0.999, skip, sub-block 8, ess", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 32, 0.999, false, true},
    {"slab 32, ert 0.999, skip, sub-block 8, roofline", 32, render::Slicer::Vertex, true, render::RenderMode::Roofline,
     render::AtlasFormat::Float, 8, 32, 0.999},
    {"slab 32, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 32},
    {"slab 32, skip, sub-block 8, roofline", 32, render::Slicer::Vertex, true, render::RenderMode::Roofline,
     render::AtlasFormat::Float, 8, 32},
    {"raycast, ert 0.999, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 0, 0.999, false, false, true},
    {"raycast, ert 0.999, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 0, 0.999, false, false, true},
    {"raycast, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 0, 0, false, false, true},
    {"raycast, skip, sub-block 8, roofline", 32, render::Slicer::Vertex, true, render::RenderMode::Roofline,
     render::AtlasFormat::Float, 8, 0, 0, false, false, true},
    {"raycast compute, ert 0.999, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 0, 0.999, false, false, true, render::RayCaster::Compute},
    {"raycast compute, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 8, 0, 0, false, false, true, render::RayCaster::Compute},
    {"raycast compute, skip, sub-block 8, roofline", 32, render::Slicer::Vertex, true, render::RenderMode::Roofline,
     render::AtlasFormat::Float, 8, 0, 0, false, false, true, render::RayCaster::Compute},
    {"raycast, ert 0.999, skip, sub-block 8, native atlas", 32, render::Slicer::Vertex, true,
     render::RenderMode::Normal, render::AtlasFormat::Native, 8, 0, 0.999, false, false, true},
    {"slab 16, pre-int, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float,
     0, 16, 0, true},
    {"slab 16, ert 0.99, pre-int, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
     render::AtlasFormat::Float, 0, 16, 0.99, true},
};

void addOptions(CLI::App& app, Options& o) {
  app.add_option("--out", o.out, "output directory")->capture_default_str();
  app.add_option("--work", o.work, "directory for the stores (made once, kept)")->capture_default_str();
  app.add_option("--size", o.size, "frame side in pixels")->capture_default_str();
  app.add_option("--views", o.views, "views of the orbit")->capture_default_str();
  app.add_option("--step", o.step, "step in voxels")->capture_default_str();
  app.add_option("--datasets", o.datasets,
                 "a subset of dense-blobs-256, sparse-256, mri-ch2better, comma-separated (default all)");
  app.add_option("--configs", o.configs,
                 "only these settings, by exact name, 'NAME|NAME'; the first of them in the built-in order is the "
                 "baseline for max|diff|");
  app.add_option("--name", o.name, "output files NAME.csv and NAME.md")->capture_default_str();
  app.add_option("--tf", o.tf, "every dataset with this transfer function preset instead of its own");
}

/// The settings of kConfigs named in `names` ('NAME|NAME'), in kConfigs' order; all of them for an empty text.
std::vector<Config> selectConfigs(const std::string& names) {
  std::vector<Config> configs;
  for (const Config& c : kConfigs) {
    bool wanted = names.empty();
    for (size_t start = 0; !wanted && start < names.size();) {
      const size_t bar = std::min(names.find('|', start), names.size());
      wanted = c.name == names.substr(start, bar - start);
      start = bar + 1;
    }
    if (wanted) configs.push_back(c);
  }
  return configs;
}

/// The stores of `d` with bricks of 16, 32 and 64 in `work`, made by prep unless there.
std::map<int, std::shared_ptr<const store::BrickStore>> openStores(const Dataset& d, const fs::path& work) {
  std::map<int, std::shared_ptr<const store::BrickStore>> stores;
  for (int brick : {16, 32, 64}) {
    const fs::path path = work / (d.name + "-b" + std::to_string(brick) + ".vbs");
    if (!fs::exists(path / "store.json")) {
      auto source = store::openSource(d.input, {});
      store::PrepOptions options;
      options.brickSize = brick;
      options.writeVdb = false;
      options.overwrite = true;
      store::prepStore(*source, path, options);
    }
    stores[brick] = store::BrickStore::open(path);
  }
  return stores;
}

/// A renderer for `c` on `store` and its scene, after a warm-up frame that pages every brick and compiles the program.
Run startRun(render::GlContext& context, std::shared_ptr<const store::BrickStore> store, const Config& c,
             const Dataset& d, const Options& o) {
  auto cache = std::make_shared<store::BrickCache>(std::move(store), size_t(4) << 30, 1);
  Run run;
  run.renderer = std::make_unique<render::VolumeRenderer>(context, cache, size_t(2) << 30, c.format);
  render::Scene& scene = run.scene;
  scene.width = scene.height = o.size;
  scene.step = o.step;
  scene.transferFunction = render::TransferFunction::load(o.tf.empty() ? d.tf : o.tf);
  scene.slicer = c.slicer;
  scene.skipEmpty = c.skip;
  scene.subBlock = c.subBlock;
  scene.slab = c.slab;
  scene.ert = c.ert;
  scene.preIntegration = c.preIntegration;
  scene.ess = c.ess;
  scene.raycast = c.raycast;
  scene.raycaster = c.raycaster;
  scene.camera.elevation = 20;
  scene.camera.distance = 2.2;
  run.renderer->render(scene, nullptr, {c.mode});
  return run;
}

/// Views outer, settings inner: on a shared machine every setting then sees the same background load over time, so
/// the ratios between settings stay meaningful even when absolute times drift.
void renderViews(std::vector<Run>& runs, const std::vector<Config>& configs, int views) {
  for (int v = 0; v < views; ++v) {
    image::ImageF baseline;
    for (size_t i = 0; i < configs.size(); ++i) {
      Run& run = runs[i];
      run.scene.camera.azimuth = 360.0 * v / views;
      render::FrameStats stats;
      image::ImageF image = run.renderer->render(run.scene, &stats, {configs[i].mode});
      run.ms.push_back(stats.msTotal);
      run.fragments.push_back(double(stats.fragments));
      run.samples.push_back(double(stats.samples));
      run.drawn.push_back(double(stats.bricksDrawn));
      if (i == 0)
        baseline = std::move(image);
      else if (configs[i].mode == render::RenderMode::Normal)
        run.maxAbs = std::max(run.maxAbs, image::compareImages(image, baseline).maxAbs);
    }
  }
}

/// A run's medians, printed as a progress line.
Result summarise(const Dataset& d, const Config& c, const Run& run) {
  Result r{d.name, c};
  r.msMedian = median(run.ms);
  r.msMin = *std::min_element(run.ms.begin(), run.ms.end());
  r.msMax = *std::max_element(run.ms.begin(), run.ms.end());
  r.fragments = median(run.fragments);
  r.samples = median(run.samples);
  r.bricksDrawn = median(run.drawn);
  r.maxAbsVsBaseline = run.maxAbs;
  std::printf("%-16s %-40s %9.1f ms  %12.0f fragments  %6.0f bricks  max|diff| %.5f\n", d.name.c_str(), c.name.c_str(),
              r.msMedian, r.fragments, r.bricksDrawn, r.maxAbsVsBaseline);
  std::fflush(stdout);
  return r;
}

/// Every setting of `configs` on `d`.
std::vector<Result> benchDataset(render::GlContext& context, const Dataset& d, const std::vector<Config>& configs,
                                 const Options& o) {
  std::map<int, std::shared_ptr<const store::BrickStore>> stores = openStores(d, o.work);
  std::vector<Run> runs;
  for (const Config& c : configs) runs.push_back(startRun(context, stores[c.brick], c, d, o));
  renderViews(runs, configs, o.views);
  std::vector<Result> results;
  for (size_t i = 0; i < configs.size(); ++i) results.push_back(summarise(d, configs[i], runs[i]));
  return results;
}

void writeCsv(const fs::path& path, const std::vector<Result>& results) {
  std::ofstream csv(path);
  csv << "dataset,config,brick,sub_block,slicer,skip,mode,median_ms,min_ms,max_ms,median_fragments,msamples_per_s,"
         "median_bricks_drawn,max_abs_vs_baseline,median_samples\n";
  for (const Result& r : results) {
    const double rate = r.samples / (r.msMedian * 1e3);
    char line[512];
    std::snprintf(line, sizeof line, "%s,%s,%d,%d,%s,%d,%s,%.2f,%.2f,%.2f,%.0f,%.2f,%.0f,%.6f,%.0f\n",
                  r.dataset.c_str(), r.config.name.c_str(), r.config.brick, r.config.subBlock,
                  render::slicerName(r.config.slicer), int(r.config.skip),
                  r.config.mode == render::RenderMode::Roofline ? "roofline" : "normal", r.msMedian, r.msMin, r.msMax,
                  r.fragments, rate, r.bricksDrawn, r.maxAbsVsBaseline, r.samples);
    csv << line;
  }
}

/// The two goals, as ratios measured side by side in this run: a row per dataset that has the four settings.
void writeGoals(std::ofstream& md, const std::vector<Result>& results) {
  md << "\n| dataset | no-skip / skip time | skip / skip + sub-block 8 time | no-skip / skip + sub-block 8 time | "
        "normal / roofline sample rate (no skip) |\n|---|---:|---:|---:|---:|\n";
  for (const Dataset& d : kDatasets) {
    auto find = [&](const std::string& setting) {
      for (const Result& r : results)
        if (r.dataset == d.name && r.config.name == setting) return r;
      return Result{};
    };
    const Result skip = find("vertex slicer, skip"), full = find("vertex slicer, no skip"),
                 roof = find("roofline, no skip"), sub = find("vertex slicer, skip, sub-block 8");
    if (skip.msMedian == 0 || sub.msMedian == 0 || full.msMedian == 0 || roof.msMedian == 0) continue;
    const double rateFull = full.fragments / full.msMedian, rateRoof = roof.fragments / roof.msMedian;
    char line[256];
    std::snprintf(line, sizeof line, "| %s | %.2fx | %.2fx | %.2fx | %.0f%% |\n", d.name.c_str(),
                  full.msMedian / skip.msMedian, skip.msMedian / sub.msMedian, full.msMedian / sub.msMedian,
                  100 * rateFull / rateRoof);
    md << line;
  }
}

void writeMarkdown(const fs::path& path, const std::string& device, const Options& o,
                   const std::vector<Result>& results) {
  std::ofstream md(path);
  md << "Renderer on " << device << ", " << o.size << "x" << o.size << ", " << o.views << " views (azimuth 0..360, "
     << "elevation 20, distance 2.2 R), step " << o.step << " voxels. Median frame time; samples taken "
     << "(slicing: one per fragment shaded; slabs: counted by the fragment program). max|diff| is against the first "
     << "row of the dataset, view by view.\n\n"
     << "| dataset | setting | median ms | min..max ms | M fragments | M samples | Msamples/s | bricks drawn | "
        "max abs diff |\n"
     << "|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Result& r : results) {
    const double rate = r.samples / (r.msMedian * 1e3);
    char line[512];
    std::snprintf(line, sizeof line, "| %s | %s | %.1f | %.1f..%.1f | %.2f | %.2f | %.1f | %.0f | %.4f |\n",
                  r.dataset.c_str(), r.config.name.c_str(), r.msMedian, r.msMin, r.msMax, r.fragments * 1e-6,
                  r.samples * 1e-6, rate, r.bricksDrawn, r.maxAbsVsBaseline);
    md << line;
  }
  writeGoals(md, results);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"bench_render: median frame time over an orbit of views for each renderer setting"};
  addOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  fs::create_directories(o.out);
  fs::create_directories(o.work);
  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  std::printf("bench_render on %s\n%dx%d, %d views, step %.2f voxels\n", device.c_str(), o.size, o.size, o.views,
              o.step);
  const std::vector<Config> configs = selectConfigs(o.configs);
  std::vector<Result> results;
  for (const Dataset& d : kDatasets) {
    if (!o.datasets.empty() && o.datasets.find(d.name) == std::string::npos) continue;
    for (const Result& r : benchDataset(*context, d, configs, o)) results.push_back(r);
  }
  writeCsv(fs::path(o.out) / (o.name + ".csv"), results);
  writeMarkdown(fs::path(o.out) / (o.name + ".md"), device, o, results);
  return 0;
}
