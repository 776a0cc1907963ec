// Level of detail over an orbit: does a LOD frame pop from one view to the next more than the camera's motion
// explains? Renders every view of an orbit at level 0 and at each --lods value (one renderer per lod, views in
// order, so each frame is warm from the one before, as in a drag), then for each pair of consecutive views:
//   motion      RMS(F0[v+1] - F0[v])                 what the camera motion changes at level 0
//   lod motion  RMS(FL[v+1] - FL[v])                 the same at the level of detail
//   popping     RMS(E[v+1] - E[v]), E = FL - F0      how much the LOD error itself changes between views
// plus each LOD frame's PSNR against the level-0 frame of its view. Error that only follows the camera keeps
// popping a steady small fraction of motion; a level switch that pops shows as a pair whose popping / motion
// stands out from the median (and, at worst, approaches or exceeds 1). RMS on RGB in
// [0, 1], as image::compareImages. Writes NAME.csv (one row per lod and pair) and NAME.md (a summary per lod).
//
//   bench_orbit --store DIR [--lods 1,2,4,8] [--views 36] [--degrees 360] [--start 30] [--elevation 20]
//               [--distance 2.5] [--size 512] [--tf hot] [--host-budget 8192] [--gpu-budget 1024]
//               [--out bench/results/lod] [--name orbit-lod] [--frames DIR]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
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
  std::string storePath, lods = "1,2,4,8", tf = "hot", name = "orbit-lod", framesDir, out = "bench/results/lod";
  int views = 36, size = 512;
  double degrees = 360, start = 30, elevation = 20, distance = 2.5;
  size_t hostMb = 8192, gpuMb = 1024;

  double azimuth(int v) const { return start + degrees * v / views; }
};

/// RMS over RGB of (a - b) - (c - d); pass empty c and d for RMS(a - b).
double rmsDifference(const image::ImageF& a, const image::ImageF& b, const image::ImageF* c = nullptr,
                     const image::ImageF* d = nullptr) {
  double sum = 0;
  const size_t pixels = size_t(a.width) * size_t(a.height);
  for (size_t p = 0; p < pixels; ++p)
    for (size_t k = 0; k < 3; ++k) {
      const size_t i = 4 * p + k;
      double x = double(a.rgba[i]) - double(b.rgba[i]);
      if (c && d) x -= double(c->rgba[i]) - double(d->rgba[i]);
      sum += x * x;
    }
  return pixels ? std::sqrt(sum / double(3 * pixels)) : 0;
}

std::vector<double> parseList(const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(std::stod(item));
  return out;
}

struct Frame {
  image::ImageF image;
  render::FrameStats stats;
};

std::string levels(const render::FrameStats& s) {
  std::string out;
  for (int64_t n : s.bricksPerLevel) out += (out.empty() ? "" : " ") + std::to_string(n);
  return out;
}

void addOptions(CLI::App& app, Options& o) {
  app.add_option("--store", o.storePath, "the store (or .vdb) to turn")->required();
  app.add_option("--lods", o.lods, "levels of detail besides 0, comma-separated")->capture_default_str();
  app.add_option("--views", o.views, "views of the orbit (at least 2)")
      ->capture_default_str()
      ->check(CLI::Range(2, 100000));
  app.add_option("--degrees", o.degrees, "degrees the orbit turns")->capture_default_str();
  app.add_option("--start", o.start, "azimuth of the first view")->capture_default_str();
  app.add_option("--elevation", o.elevation, "elevation in degrees")->capture_default_str();
  app.add_option("--distance", o.distance, "eye distance in bounding radii")->capture_default_str();
  app.add_option("--size", o.size, "frame side in pixels")->capture_default_str();
  app.add_option("--tf", o.tf, "transfer function preset")->capture_default_str();
  app.add_option("--host-budget", o.hostMb, "host cache in MB")->capture_default_str();
  app.add_option("--gpu-budget", o.gpuMb, "GPU budget in MB")->capture_default_str();
  app.add_option("--out", o.out, "output directory")->capture_default_str();
  app.add_option("--name", o.name, "output files NAME.csv and NAME.md")->capture_default_str();
  app.add_option("--frames", o.framesDir, "also write every frame as a PNG into this directory");
}

/// Level 0, then each positive level of `text`.
std::vector<double> lodLevels(const std::string& text) {
  std::vector<double> lods{0};
  for (double l : parseList(text))
    if (l > 0) lods.push_back(l);
  return lods;
}

render::Scene orbitScene(const Options& o) {
  render::Scene scene;
  scene.width = scene.height = o.size;
  scene.transferFunction = render::TransferFunction::load(o.tf);
  scene.transferFunctionName = o.tf;
  scene.camera.elevation = o.elevation;
  scene.camera.distance = o.distance;
  return scene;
}

/// Every view of the orbit at level of detail `lod`, in order, with its own renderer (so it keeps its own warm atlas
/// through the orbit; the host cache is shared) after a warm-up frame.
std::vector<Frame> renderOrbit(render::GlContext& context, const std::shared_ptr<store::BrickCache>& cache,
                               render::Scene scene, double lod, const Options& o) {
  render::VolumeRenderer renderer(context, cache, o.gpuMb << 20);
  scene.lod = lod;
  scene.camera.azimuth = o.azimuth(0);
  renderer.render(scene);  // warm-up: compiles the programs, pages the first view
  std::vector<Frame> frames;
  for (int v = 0; v < o.views; ++v) {
    scene.camera.azimuth = o.azimuth(v);
    Frame f;
    f.image = renderer.render(scene, &f.stats);
    std::printf("lod %g view %d (azimuth %.1f): %.0f ms, bricks per level %s\n", lod, v, o.azimuth(v), f.stats.msTotal,
                levels(f.stats).c_str());
    std::fflush(stdout);
    if (!o.framesDir.empty()) {
      char file[64];
      std::snprintf(file, sizeof file, "lod%g-view%02d.png", lod, v);
      image::writePng(fs::path(o.framesDir) / file, image::toImage8(f.image));
    }
    frames.push_back(std::move(f));
  }
  return frames;
}

void writeHeaders(std::ofstream& csv, std::ofstream& md, const std::string& device, const Options& o) {
  csv << "# " << device << "; " << o.storePath << ", " << o.size << "x" << o.size << ", tf " << o.tf << ", " << o.views
      << " views over " << o.degrees << " degrees from azimuth " << o.start << ", elevation " << o.elevation
      << ", distance " << o.distance << " R; host " << o.hostMb << " MB, gpu " << o.gpuMb << " MB\n";
  csv << "lod,view,azimuth,ms_total,bricks_per_level,psnr_vs_level0_db,motion_rms_level0,motion_rms_lod,"
         "popping_rms,popping_over_motion\n";
  md << "Device: " << device << ". Store `" << o.storePath << "`, " << o.size << "x" << o.size
     << ", transfer function `" << o.tf << "`, " << o.views << " views over " << o.degrees << "° (azimuth " << o.start
     << " + " << o.degrees / o.views << "° a view, elevation " << o.elevation << ", distance " << o.distance
     << " R), host budget " << o.hostMb << " MB, GPU budget " << o.gpuMb
     << " MB; each frame warm from the view before.\n\n";
  md << "| lod | median ms | speed-up | min PSNR vs level 0 (dB) | median motion RMS (level 0) | max lod motion / "
        "level-0 motion | median popping RMS | median popping / motion | max popping / motion |\n";
  md << "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
}

/// One level of detail's views against level 0's: what its summary row needs.
struct LodTally {
  std::vector<double> ms, popping, motion, popRatio;
  double minPsnr = std::numeric_limits<double>::infinity(), maxMotionRatio = 0, maxPopRatio = 0;
};

/// The pair of views v, v + 1: motion at level 0 and at the level of detail, and popping; a CSV row's last columns.
void tallyPair(std::ofstream& csv, const std::vector<Frame>& level0, const std::vector<Frame>& lod, size_t v,
               LodTally& t) {
  const image::ImageF& a0 = level0[v].image;
  const image::ImageF& b0 = level0[v + 1].image;
  const image::ImageF& aL = lod[v].image;
  const image::ImageF& bL = lod[v + 1].image;
  const double m0 = rmsDifference(b0, a0), mL = rmsDifference(bL, aL), pop = rmsDifference(bL, b0, &aL, &a0);
  t.motion.push_back(m0);
  t.popping.push_back(pop);
  if (m0 > 0) {
    t.maxMotionRatio = std::max(t.maxMotionRatio, mL / m0);
    t.maxPopRatio = std::max(t.maxPopRatio, pop / m0);
    t.popRatio.push_back(pop / m0);
  }
  csv << "," << m0 << "," << mL << "," << pop << "," << (m0 > 0 ? pop / m0 : 0);
}

/// Level `l`'s CSV rows, one per view, and its summary row in the markdown.
void writeLod(std::ofstream& csv, std::ofstream& md, const std::vector<std::vector<Frame>>& frames,
              const std::vector<double>& lods, size_t l, const Options& o) {
  std::vector<double> ms0;
  for (const Frame& f : frames[0]) ms0.push_back(f.stats.msTotal);
  LodTally t;
  for (int v = 0; v < o.views; ++v) {
    const Frame& f = frames[l][size_t(v)];
    t.ms.push_back(f.stats.msTotal);
    const double psnr = image::compareImages(f.image, frames[0][size_t(v)].image).psnr;
    t.minPsnr = std::min(t.minPsnr, psnr);
    csv << lods[l] << "," << v << "," << o.azimuth(v) << "," << f.stats.msTotal << "," << levels(f.stats) << ","
        << psnr;
    if (v + 1 < o.views)
      tallyPair(csv, frames[0], frames[l], size_t(v), t);
    else
      csv << ",,,,";
    csv << "\n";
  }
  char row[512];
  std::snprintf(row, sizeof row, "| %g | %.0f | %.2f× | %s | %.5f | %.3f | %.6f | %.4f | %.4f |\n", lods[l],
                median(t.ms), median(ms0) / median(t.ms),
                std::isinf(t.minPsnr) ? "—" : std::to_string(std::round(t.minPsnr * 10) / 10).substr(0, 5).c_str(),
                median(t.motion), t.maxMotionRatio, median(t.popping), median(t.popRatio), t.maxPopRatio);
  md << row;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"bench_orbit: does a level-of-detail frame pop between views more than the camera's motion explains?"};
  addOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  const std::vector<double> lods = lodLevels(o.lods);

  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  auto cache = std::make_shared<store::BrickCache>(store::openAnyStore(o.storePath), o.hostMb << 20, 2);
  std::printf("bench_orbit on %s: %s, %dx%d, %d views over %.1f degrees\n", device.c_str(), o.storePath.c_str(), o.size,
              o.size, o.views, o.degrees);
  if (!o.framesDir.empty()) fs::create_directories(o.framesDir);
  const render::Scene scene = orbitScene(o);
  std::vector<std::vector<Frame>> frames;
  for (double lod : lods) frames.push_back(renderOrbit(*context, cache, scene, lod, o));

  const fs::path out = o.out;
  fs::create_directories(out);
  std::ofstream csv(out / (o.name + ".csv"));
  std::ofstream md(out / (o.name + ".md"));
  writeHeaders(csv, md, device, o);
  for (size_t l = 0; l < lods.size(); ++l) writeLod(csv, md, frames, lods, l, o);
  std::printf("wrote %s and %s\n", (out / (o.name + ".csv")).c_str(), (out / (o.name + ".md")).c_str());
  return 0;
}
