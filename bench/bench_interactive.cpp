// The order of degradation of interactive frames (render/core/Interactive.h): for each way of drawing a frame more
// cheaply (a smaller drawing scaled up bilinearly, a longer step, a coarser level of detail), alone and at several
// strengths, the time a frame takes and its PSNR against the exact frame of the same view, over a few views of an
// orbit. The way that loses the fewest dB per ms saved goes first on the ladder (interactiveLadder).
//
//   bench_interactive --store DIR [--size 512] [--views 4] [--tf grayscale] [--out bench/results/interactive]
//                     [--name interactive-order]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
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
};

struct Way {
  std::string family;
  render::InteractiveRung rung;
};

std::vector<Way> ways() {
  std::vector<Way> out{{"exact", {}}};
  for (double s : {0.75, 0.5, 0.35, 0.25}) out.push_back({"scale", {s, 1, 1}});
  for (double f : {1.5, 2.0, 3.0, 4.0, 6.0}) out.push_back({"step", {1, f, 1}});
  for (double f : {2.0, 4.0, 8.0, 16.0}) out.push_back({"lod", {1, 1, f}});
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
  CLI11_PARSE(app, argc, argv);

  const auto dataset = render::openDataset(o.storePath, o.storePath, size_t(4096) << 20);
  render::RenderEngine engine(render::RenderEngineOptions{});
  render::Scene scene;
  scene.width = scene.height = o.size;
  scene.transferFunction = render::TransferFunction::load(o.tf);
  scene.transferFunctionName = o.tf;
  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / (o.name + ".csv"));
  csv << "family,scale,step_factor,lod_factor,view,ms,psnr_db\n";
  struct Sum {
    double ms = 0, psnr = 0;
  };
  const std::vector<Way> all = ways();
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
      sums[w].ms += ms / o.views, sums[w].psnr += psnr / o.views;
      csv << all[w].family << ',' << all[w].rung.scale << ',' << all[w].rung.stepFactor << ',' << all[w].rung.lodFactor
          << ',' << v << ',' << ms << ',' << psnr << '\n';
    }
  }
  std::ofstream md(std::filesystem::path(o.out) / (o.name + ".md"));
  md << "# Ways of drawing an interactive frame more cheaply\n\n`bench_interactive --store " << o.storePath
     << " --size " << o.size << " --views " << o.views << "`: each way alone, mean over the views of the median of "
     << o.repeats << " warm frames; PSNR against the exact frame of the view (99: exact).\n\n"
     << "| way | scale | step x | lod x | ms | fraction of the exact frame's time | PSNR dB |\n"
     << "| --- | --- | --- | --- | --- | --- | --- |\n";
  for (size_t w = 0; w < all.size(); ++w) {
    char line[256];
    std::snprintf(line, sizeof line, "| %s | %g | %g | %g | %.1f | %.2f | %.1f |\n", all[w].family.c_str(),
                  all[w].rung.scale, all[w].rung.stepFactor, all[w].rung.lodFactor, sums[w].ms, sums[w].ms / sums[0].ms,
                  sums[w].psnr);
    md << line;
    std::printf("%s", line);
  }
  return 0;
}
