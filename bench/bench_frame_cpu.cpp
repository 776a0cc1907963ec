// What a warm frame costs on the CPU besides drawing and readback: the ray caster's cell table kept from frame to
// frame (render/gl/volume/KeptCells.h) against the same table filled anew every frame (FrameOptions::keepCellTable
// false: the path it replaced), side by side in one run. Two renderers (each its own atlas, the host cache shared)
// take turns view by view through a drag (--degrees over --views, from --start), each warm from its own view
// before; every view's two frames must be the same image (the run fails otherwise). Writes NAME.csv (one row per
// path and view: the times and what the table did) and NAME.md (medians per path, and the ratio).
//
//   bench_frame_cpu --store DIR [--size 32] [--views 24] [--degrees 24] [--start 30] [--elevation 20]
//                   [--lod 0] [--tf hot] [--window LO,HI] [--gpu-budget 2000] [--host-budget 3000]
//                   [--atlas-format float|half|native] [--out bench/results/render] [--name frame-cpu]
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/read/BrickCache.h"
#include "brickstore/read/OpenAnyStore.h"
#include "image/Image.h"
#include "quality/Statistics.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/VolumeRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;
using voxbrick::quality::median;

namespace {

struct Options {
  std::string storePath, tf = "hot", window, name = "frame-cpu", out = "bench/results/render", atlasFormat = "float";
  int views = 24, size = 32;
  double degrees = 24, start = 30, elevation = 20, lod = 0;
  size_t hostMb = 3000, gpuMb = 2000;
  bool filledFirst = false;

  double azimuth(int v) const { return start + degrees * v / views; }
};

/// The CPU's part of a frame: everything but drawing (which waits for the GPU) and readback.
double outsideMs(const render::FrameStats& s) { return s.msTotal - s.msDrawing - s.msReadback; }

struct Path {
  const char* name;
  bool keep;
  std::unique_ptr<render::VolumeRenderer> renderer;
  std::vector<double> total, outside, drawing, traversal, paging, slicing;
};

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"bench_frame_cpu: a warm frame's CPU cost, the kept cell table against one filled every frame"};
  app.add_option("--store", o.storePath, "the store (or .vdb) to render")->required();
  app.add_option("--size", o.size, "frame side in pixels")->capture_default_str();
  app.add_option("--views", o.views, "views of the drag")->capture_default_str()->check(CLI::Range(1, 100000));
  app.add_option("--degrees", o.degrees, "degrees the drag turns")->capture_default_str();
  app.add_option("--start", o.start, "azimuth of the first view")->capture_default_str();
  app.add_option("--elevation", o.elevation, "elevation in degrees")->capture_default_str();
  app.add_option("--lod", o.lod, "the scene's lod (0: level 0 everywhere)")->capture_default_str();
  app.add_option("--tf", o.tf, "transfer function preset or JSON file")->capture_default_str();
  app.add_option("--window", o.window, "value window LO,HI (default the store's range)");
  app.add_option("--host-budget", o.hostMb, "host cache in MB")->capture_default_str();
  app.add_option("--gpu-budget", o.gpuMb, "GPU budget in MB, each renderer")->capture_default_str();
  app.add_option("--atlas-format", o.atlasFormat, "how the atlases store samples: float, half or native")
      ->capture_default_str();
  app.add_option("--out", o.out, "output directory")->capture_default_str();
  app.add_option("--name", o.name, "output files NAME.csv and NAME.md")->capture_default_str();
  app.add_flag("--filled-first", o.filledFirst, "each view drawn by the filled path first (the kept path by default)");
  CLI11_PARSE(app, argc, argv);

  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  auto cache = std::make_shared<store::BrickCache>(store::openAnyStore(o.storePath), o.hostMb << 20, 2);
  render::Scene scene;
  scene.width = scene.height = o.size;
  scene.transferFunction = render::TransferFunction::load(o.tf);
  scene.transferFunctionName = o.tf;
  if (!o.window.empty()) {
    const size_t comma = o.window.find(',');
    scene.window = {std::stod(o.window.substr(0, comma)), std::stod(o.window.substr(comma + 1))};
  }
  scene.camera.elevation = o.elevation;
  scene.lod = o.lod;
  Path paths[2] = {{"kept", true, nullptr, {}, {}, {}, {}, {}, {}}, {"filled", false, nullptr, {}, {}, {}, {}, {}, {}}};
  for (Path& p : paths) {
    p.renderer = std::make_unique<render::VolumeRenderer>(*context, cache, o.gpuMb << 20,
                                                          render::parseAtlasFormat(o.atlasFormat));
    scene.camera.azimuth = o.azimuth(0);
    render::FrameOptions options;
    options.keepCellTable = p.keep;
    p.renderer->render(scene, nullptr, options);  // compiles the programs, pages the first view
    p.renderer->render(scene, nullptr, options);
  }

  fs::create_directories(o.out);
  const fs::path csvPath = fs::path(o.out) / (o.name + ".csv"), mdPath = fs::path(o.out) / (o.name + ".md");
  std::ofstream csv(csvPath);
  csv << "# " << device << "; " << o.storePath << ", " << o.size << "x" << o.size << ", tf " << o.tf << " window "
      << (o.window.empty() ? "store" : o.window) << ", lod " << o.lod << ", " << o.views << " views over " << o.degrees
      << " degrees from azimuth " << o.start << "; host " << o.hostMb << " MB, gpu " << o.gpuMb << " MB each, atlas "
      << o.atlasFormat << "\n";
  csv << "path,view,azimuth,ms_total,ms_outside,ms_drawing,ms_readback,ms_traversal,ms_paging,ms_slicing,bricks_drawn,"
         "bricks_paged_in,cell_bricks_changed,cells_sent,max_abs_vs_other\n";
  int64_t bricks = 0;
  double worst = 0;
  for (int v = 0; v < o.views; ++v) {
    scene.camera.azimuth = o.azimuth(v);
    image::ImageF images[2];
    render::FrameStats stats[2];
    for (int turn = 0; turn < 2; ++turn) {
      const int i = o.filledFirst ? 1 - turn : turn;
      render::FrameOptions options;
      options.keepCellTable = paths[i].keep;
      images[i] = paths[i].renderer->render(scene, &stats[i], options);
    }
    const double diff = image::compareImages(images[0], images[1]).maxAbs;
    worst = std::max(worst, diff);
    for (int i = 0; i < 2; ++i) {
      const render::FrameStats& s = stats[i];
      Path& p = paths[i];
      p.total.push_back(s.msTotal), p.outside.push_back(outsideMs(s)), p.drawing.push_back(s.msDrawing);
      p.traversal.push_back(s.msTraversal), p.paging.push_back(s.msPaging), p.slicing.push_back(s.msSlicing);
      bricks = s.bricksDrawn;
      csv << p.name << "," << v << "," << o.azimuth(v) << "," << s.msTotal << "," << outsideMs(s) << "," << s.msDrawing
          << "," << s.msReadback << "," << s.msTraversal << "," << s.msPaging << "," << s.msSlicing << ","
          << s.bricksDrawn << "," << s.bricksPagedIn << "," << s.cellBricksChanged << "," << s.cellsSent << "," << diff
          << "\n";
    }
    std::printf("view %d (azimuth %.1f): kept %.1f ms (%.1f outside drawing), filled %.1f ms (%.1f), %lld bricks, %lld "
                "changed, max |diff| %g\n",
                v, o.azimuth(v), stats[0].msTotal, outsideMs(stats[0]), stats[1].msTotal, outsideMs(stats[1]),
                static_cast<long long>(stats[0].bricksDrawn), static_cast<long long>(stats[0].cellBricksChanged), diff);
    std::fflush(stdout);
  }

  std::ofstream md(mdPath);
  md << "Device: " << device << ". Store `" << o.storePath << "`, " << o.size << "x" << o.size
     << ", transfer function `" << o.tf << "`" << (o.window.empty() ? "" : ", window " + o.window) << ", lod " << o.lod
     << ", atlas " << o.atlasFormat << ", " << o.views << " views over " << o.degrees << "° from azimuth " << o.start
     << " (elevation " << o.elevation << "), " << bricks
     << " bricks drawn in the last view; two renderers taking turns, each warm from its own view before. Medians "
        "over the views, ms; outside = total − drawing − readback (the CPU's part). Largest difference between the "
        "two paths' frames: "
     << worst << ".\n\n";
  md << "| path | total | outside drawing | drawing | traversal | paging | slicing (cell table) |\n";
  md << "|---|---:|---:|---:|---:|---:|---:|\n";
  for (const Path& p : paths) {
    char row[256];
    std::snprintf(row, sizeof row, "| %s | %.1f | %.1f | %.1f | %.2f | %.2f | %.2f |\n", p.name, median(p.total),
                  median(p.outside), median(p.drawing), median(p.traversal), median(p.paging), median(p.slicing));
    md << row;
  }
  char ratio[160];
  std::snprintf(ratio, sizeof ratio, "\nOutside drawing, filled / kept: %.1f×; total: %.2f×.\n",
                median(paths[1].outside) / std::max(median(paths[0].outside), 1e-9),
                median(paths[1].total) / std::max(median(paths[0].total), 1e-9));
  md << ratio;
  std::printf("wrote %s and %s\n", csvPath.c_str(), mdPath.c_str());
  if (worst > 0) {
    std::fprintf(stderr, "bench_frame_cpu: the two paths' frames differ (max |diff| %g)\n", worst);
    return 1;
  }
  return 0;
}
