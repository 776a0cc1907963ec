// The order of degradation of interactive frames (render/core/Interactive.h): for each way of drawing a frame more
// cheaply (a smaller drawing scaled up bilinearly, a longer step, a coarser level of detail), alone and at several
// strengths, the time a frame takes and its PSNR against the exact frame of the same view, over a few views of an
// orbit. The way that loses the fewest dB per ms saved goes first on the ladder (interactiveLadder).
//
//   bench_interactive --store DIR [--size 512] [--views 4] [--tf grayscale] [--out bench/results/interactive]
//                     [--name interactive-order] [--rungs S:STEP:LOD,...] [--step 0.75] [--orbit-elevation 20]
//
// --rungs: these rungs (scale, step factor, level-of-detail factor, as interactiveScene draws them; family "rung")
// in place of each way alone, with the estimated samples of each (the planner's cost model): the bottom of the ladder
// at a size, against the rungs that could take its place.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "image/Image.h"
#include "render/core/Interactive.h"
#include "render/core/TransferFunction.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"

using namespace voxbrick;

namespace {

struct Options {
  std::string storePath, tf = "grayscale", out = "bench/results/interactive", name = "interactive-order";
  int size = 512, views = 4, repeats = 3;
  std::vector<std::string> rungs;
  double step = 0.75, elevation = 20;
};

struct Way {
  std::string family;
  render::InteractiveRung rung;
};

std::vector<Way> ways(const std::vector<std::string>& rungs) {
  std::vector<Way> out{{"exact", {}}};
  if (!rungs.empty()) {
    for (const std::string& r : rungs) {
      render::InteractiveRung rung;
      if (std::sscanf(r.c_str(), "%lf:%lf:%lf", &rung.scale, &rung.stepFactor, &rung.lodFactor) != 3 ||
          !(rung.scale > 0 && rung.scale <= 1 && rung.stepFactor >= 1 && rung.lodFactor >= 1))
        throw std::invalid_argument("--rungs: " + r + " is not SCALE:STEP:LOD (scale in (0, 1], factors >= 1)");
      out.push_back({"rung", rung});
    }
    return out;
  }
  for (double s : {0.75, 0.5, 0.35, 0.25}) out.push_back({"scale", {s, 1, 1}});
  for (double f : {1.5, 2.0, 3.0, 4.0, 6.0}) out.push_back({"step", {1, f, 1}});
  for (double f : {2.0, 4.0, 8.0, 16.0}) out.push_back({"lod", {1, 1, f}});
  return out;
}

std::string date() {
  const std::time_t now = std::time(nullptr);
  char text[16];
  std::strftime(text, sizeof text, "%Y-%m-%d", std::localtime(&now));
  return text;
}

std::string joined(const std::vector<std::string>& parts) {
  std::string out;
  for (const std::string& p : parts) out += (out.empty() ? "" : ",") + p;
  return out;
}

double msOf(render::RenderEngine& engine, const std::shared_ptr<const render::Dataset>& dataset,
            const render::Scene& scene, const render::Scene& drawn, image::ImageF& image, int repeats) {
  std::vector<double> ms;
  for (int r = 0; r < repeats; ++r) {
    const auto t = std::chrono::steady_clock::now();
    image = render::scaleBilinear(engine.render(dataset, drawn), scene.width, scene.height);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count());
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Time and PSNR of each way of drawing an interactive frame more cheaply");
  Options o;
  app.add_option("--store", o.storePath, "the store to draw")->required();
  app.add_option("--size", o.size, "frame side in pixels")->capture_default_str();
  app.add_option("--views", o.views, "views of the orbit")->capture_default_str()->check(CLI::Range(1, 360));
  app.add_option("--repeats", o.repeats, "frames timed per setting (the median)")->capture_default_str();
  app.add_option("--tf", o.tf, "transfer function preset")->capture_default_str();
  app.add_option("--out", o.out, "output directory")->capture_default_str();
  app.add_option("--name", o.name, "output files NAME.csv and NAME.md")->capture_default_str();
  app.add_option("--rungs", o.rungs, "rungs SCALE:STEP:LOD to measure in place of each way alone")->delimiter(',');
  app.add_option("--step", o.step, "the scene's step, voxels")->capture_default_str();
  app.add_option("--orbit-elevation", o.elevation, "the views' elevation, degrees")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  std::vector<Way> all;
  try {
    all = ways(o.rungs);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "bench_interactive: %s\n", e.what());
    return 2;
  }

  const auto dataset = render::openDataset(o.storePath, o.storePath, size_t(4096) << 20);
  render::RenderEngine engine(render::RenderEngineOptions{});
  render::Scene scene;
  scene.width = scene.height = o.size;
  scene.transferFunction = render::TransferFunction::load(o.tf);
  scene.transferFunctionName = o.tf;
  scene.step = o.step;
  scene.camera.elevation = o.elevation;
  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / (o.name + ".csv"));
  csv << "family,scale,step_factor,lod_factor,view,ms,psnr_db,samples_estimated\n";
  struct Sum {
    double ms = 0, psnr = 0, samples = 0;
  };
  std::vector<Sum> sums(all.size());
  for (int v = 0; v < o.views; ++v) {
    scene.camera.azimuth = 30 + 360.0 * v / o.views;
    image::ImageF exact, image;
    engine.render(dataset, scene);  // warm: every brick resident
    const double exactMs = msOf(engine, dataset, scene, scene, exact, o.repeats);
    for (size_t w = 0; w < all.size(); ++w) {
      const double ms =
          w == 0 ? exactMs
                 : msOf(engine, dataset, scene, render::interactiveScene(scene, all[w].rung), image, o.repeats);
      const double psnr = w == 0 ? 99 : std::min(99.0, image::compareImages(image, exact).psnr);
      render::FrameStats stats;
      engine.render(dataset, w == 0 ? scene : render::interactiveScene(scene, all[w].rung), &stats);
      sums[w].ms += ms / o.views, sums[w].psnr += psnr / o.views, sums[w].samples += stats.samplesEstimated / o.views;
      csv << all[w].family << ',' << all[w].rung.scale << ',' << all[w].rung.stepFactor << ',' << all[w].rung.lodFactor
          << ',' << v << ',' << ms << ',' << psnr << ',' << stats.samplesEstimated << '\n';
    }
  }
  std::ofstream md(std::filesystem::path(o.out) / (o.name + ".md"));
  md << "# Ways of drawing an interactive frame more cheaply\n\n`bench_interactive --store " << o.storePath
     << " --size " << o.size << " --views " << o.views << " --tf " << o.tf << " --step " << o.step
     << (o.rungs.empty() ? std::string() : " --rungs " + joined(o.rungs)) << "`: "
     << (o.rungs.empty() ? "each way alone" : "each rung as interactiveScene draws it")
     << ", mean over the views of the median of " << o.repeats
     << " warm frames (drawing and scaling up); PSNR against the exact frame of the view (99: exact); the planner's "
        "estimated samples. "
     << date() << "; " << engine.describe() << " (a shared machine: times are indicative; compare rows).\n\n"
     << "| way | scale | step x | lod x | ms | fraction of the exact frame's time | PSNR dB | samples estimated |\n"
     << "| --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (size_t w = 0; w < all.size(); ++w) {
    char line[256];
    std::snprintf(line, sizeof line, "| %s | %g | %g | %g | %.1f | %.2f | %.1f | %.3g |\n", all[w].family.c_str(),
                  all[w].rung.scale, all[w].rung.stepFactor, all[w].rung.lodFactor, sums[w].ms, sums[w].ms / sums[0].ms,
                  sums[w].psnr, sums[w].samples);
    md << line;
    std::printf("%s", line);
  }
  return 0;
}
