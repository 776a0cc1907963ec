// Renderer benchmark: median frame time over an orbit of views for each setting, beside the sampling roofline
// (one trilinear fetch per fragment, no classification, no blending) of the same geometry. Writes CSV and markdown.
//
//   bench_render [--out bench/results] [--work bench/work] [--size 512] [--views 36] [--step 0.5]
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

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "brickstore/StoreWriter.h"
#include "quality/Statistics.h"
#include "render/GlContext.h"
#include "render/VolumeRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;
using voxbrick::quality::median;

namespace {

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
  int slab = 0;  ///< planes per texture slab (0 slices); named in the setting, not a CSV column
  double ert = 0;              ///< early ray termination threshold (slabs); named in the setting
  bool preIntegration = false;  ///< named in the setting
  bool ess = false;             ///< empty-space silhouette maps; named in the setting
  bool raycast = false;         ///< the frame ray caster (render::Scene::raycast); named in the setting
};

struct Result {
  std::string dataset;
  Config config;
  double msMedian = 0, msMin = 0, msMax = 0, fragments = 0, samples = 0, bricksDrawn = 0, maxAbsVsBaseline = 0;
};

}  // namespace

int main(int argc, char** argv) {
  fs::path out = "bench/results", work = "bench/work";
  int size = 512, views = 36;
  std::string only, onlyConfigs, name = "render", tfOverride;
  double step = 0.5;
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string a = argv[i];
    if (a == "--out") out = argv[i + 1];
    else if (a == "--work") work = argv[i + 1];
    else if (a == "--size") size = std::stoi(argv[i + 1]);
    else if (a == "--views") views = std::stoi(argv[i + 1]);
    else if (a == "--step") step = std::stod(argv[i + 1]);
    else if (a == "--datasets") only = argv[i + 1];
    else if (a == "--configs") onlyConfigs = argv[i + 1];
    else if (a == "--name") name = argv[i + 1];
    else if (a == "--tf") tfOverride = argv[i + 1];
    else {
      std::fprintf(stderr, "bench_render: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  fs::create_directories(out);
  fs::create_directories(work);
  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  std::printf("bench_render on %s\n%dx%d, %d views, step %.2f voxels\n", device.c_str(), size, size, views, step);

  const std::vector<Dataset> datasets = {{"dense-blobs-256", "synthetic:blobs,n=256", "hot"},
                                         {"sparse-256", "synthetic:sparse,n=256", "sparse"},
                                         {"mri-ch2better", "/usr/share/mricron/templates/ch2better.nii.gz", "mri"}};
  const std::vector<Config> allConfigs = {
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
      {"slab 16, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float, 0,
       16},
      {"slab whole brick, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 0, render::Scene::kMaxSlab},
      {"slab whole brick, skip, B=16", 16, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 0, render::Scene::kMaxSlab},
      {"slab 64, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float, 0,
       64},
      {"slab 16, ert 0.99, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 0, 16, 0.99},
      {"slab 64, ert 0.99, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 0, 64, 0.99},
      {"slab 16, ert 0.99, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 8, 16, 0.99},
      {"slab 64, ert 0.99, skip, sub-block 8", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 8, 64, 0.99},
      {"slab 16, ert 1, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 0, 16, 1.0},
      {"slab 64, ert 1, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 0, 64, 1.0},
      {"slab 1, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal, render::AtlasFormat::Float, 0,
       1},
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
      {"slab 32, ert 0.999, skip, sub-block 8, roofline", 32, render::Slicer::Vertex, true,
       render::RenderMode::Roofline, render::AtlasFormat::Float, 8, 32, 0.999},
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
      {"raycast, ert 0.999, skip, sub-block 8, native atlas", 32, render::Slicer::Vertex, true,
       render::RenderMode::Normal, render::AtlasFormat::Native, 8, 0, 0.999, false, false, true},
      {"slab 16, pre-int, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 0, 16, 0, true},
      {"slab 16, ert 0.99, pre-int, skip", 32, render::Slicer::Vertex, true, render::RenderMode::Normal,
       render::AtlasFormat::Float, 0, 16, 0.99, true},
  };

  std::vector<Config> configs;
  for (const Config& c : allConfigs) {
    bool wanted = onlyConfigs.empty();
    for (size_t start = 0; !wanted && start < onlyConfigs.size();) {
      const size_t bar = std::min(onlyConfigs.find('|', start), onlyConfigs.size());
      wanted = c.name == onlyConfigs.substr(start, bar - start);
      start = bar + 1;
    }
    if (wanted) configs.push_back(c);
  }
  std::vector<Result> results;
  for (const Dataset& d : datasets) {
    if (!only.empty() && only.find(d.name) == std::string::npos) continue;
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
    // Views outer, settings inner: on a shared machine every setting then sees the same background load over time,
    // so the ratios between settings stay meaningful even when absolute times drift.
    struct Run {
      std::unique_ptr<render::VolumeRenderer> renderer;
      render::Scene scene;
      std::vector<double> ms, fragments, samples, drawn;
      double maxAbs = 0;
    };
    std::vector<Run> runs;
    for (const Config& c : configs) {
      auto cache = std::make_shared<store::BrickCache>(stores[c.brick], size_t(4) << 30, 1);
      Run run;
      run.renderer = std::make_unique<render::VolumeRenderer>(*context, cache, size_t(2) << 30, c.format);
      render::Scene& scene = run.scene;
      scene.width = scene.height = size;
      scene.step = step;
      scene.transferFunction = render::TransferFunction::load(tfOverride.empty() ? d.tf : tfOverride);
      scene.slicer = c.slicer;
      scene.skipEmpty = c.skip;
      scene.subBlock = c.subBlock;
      scene.slab = c.slab;
      scene.ert = c.ert;
      scene.preIntegration = c.preIntegration;
      scene.ess = c.ess;
      scene.raycast = c.raycast;
      scene.camera.elevation = 20;
      scene.camera.distance = 2.2;
      run.renderer->render(scene, nullptr, {c.mode});  // warm-up: pages every brick, compiles the program
      runs.push_back(std::move(run));
    }
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
    for (size_t i = 0; i < configs.size(); ++i) {
      const Run& run = runs[i];
      Result r{d.name, configs[i]};
      r.msMedian = median(run.ms);
      r.msMin = *std::min_element(run.ms.begin(), run.ms.end());
      r.msMax = *std::max_element(run.ms.begin(), run.ms.end());
      r.fragments = median(run.fragments);
      r.samples = median(run.samples);
      r.bricksDrawn = median(run.drawn);
      r.maxAbsVsBaseline = run.maxAbs;
      std::printf("%-16s %-40s %9.1f ms  %12.0f fragments  %6.0f bricks  max|diff| %.5f\n", d.name.c_str(),
                  configs[i].name.c_str(), r.msMedian, r.fragments, r.bricksDrawn, r.maxAbsVsBaseline);
      std::fflush(stdout);
      results.push_back(r);
    }
  }

  std::ofstream csv(out / (name + ".csv"));
  csv << "dataset,config,brick,sub_block,slicer,skip,mode,median_ms,min_ms,max_ms,median_fragments,msamples_per_s,"
         "median_bricks_drawn,max_abs_vs_baseline,median_samples\n";
  std::ofstream md(out / (name + ".md"));
  md << "Renderer on " << device << ", " << size << "x" << size << ", " << views << " views (azimuth 0..360, "
     << "elevation 20, distance 2.2 R), step " << step << " voxels. Median frame time; samples taken "
     << "(slicing: one per fragment shaded; slabs: counted by the fragment program). max|diff| is against the first "
     << "row of the dataset, view by view.\n\n"
     << "| dataset | setting | median ms | min..max ms | M fragments | M samples | Msamples/s | bricks drawn | "
        "max abs diff |\n"
     << "|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Result& r : results) {
    const double rate = r.samples / (r.msMedian * 1e3);
    char line[512];
    std::snprintf(line, sizeof line, "%s,%s,%d,%d,%s,%d,%s,%.2f,%.2f,%.2f,%.0f,%.2f,%.0f,%.6f,%.0f\n", r.dataset.c_str(),
                  r.config.name.c_str(), r.config.brick, r.config.subBlock, render::slicerName(r.config.slicer),
                  int(r.config.skip), r.config.mode == render::RenderMode::Roofline ? "roofline" : "normal",
                  r.msMedian, r.msMin, r.msMax, r.fragments, rate, r.bricksDrawn, r.maxAbsVsBaseline, r.samples);
    csv << line;
    std::snprintf(line, sizeof line, "| %s | %s | %.1f | %.1f..%.1f | %.2f | %.2f | %.1f | %.0f | %.4f |\n",
                  r.dataset.c_str(), r.config.name.c_str(), r.msMedian, r.msMin, r.msMax, r.fragments * 1e-6,
                  r.samples * 1e-6, rate, r.bricksDrawn, r.maxAbsVsBaseline);
    md << line;
  }
  // The two goals, as ratios measured side by side in this run.
  md << "\n| dataset | no-skip / skip time | skip / skip + sub-block 8 time | no-skip / skip + sub-block 8 time | "
        "normal / roofline sample rate (no skip) |\n|---|---:|---:|---:|---:|\n";
  for (const Dataset& d : datasets) {
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
  return 0;
}
