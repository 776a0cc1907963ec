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
//               [--out bench/results] [--name orbit-lod] [--frames DIR]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "image/Image.h"
#include "quality/Statistics.h"
#include "render/GlContext.h"
#include "render/VolumeRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;
using voxbrick::quality::median;

namespace {

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

}  // namespace

int main(int argc, char** argv) {
  std::string storePath, lodsText = "1,2,4,8", tf = "hot", name = "orbit-lod", framesDir;
  fs::path out = "bench/results";
  int views = 36, size = 512;
  double degrees = 360, start = 30, elevation = 20, distance = 2.5;
  size_t hostMb = 8192, gpuMb = 1024;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_orbit: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--store") storePath = value();
    else if (a == "--lods") lodsText = value();
    else if (a == "--views") views = std::stoi(value());
    else if (a == "--degrees") degrees = std::stod(value());
    else if (a == "--start") start = std::stod(value());
    else if (a == "--elevation") elevation = std::stod(value());
    else if (a == "--distance") distance = std::stod(value());
    else if (a == "--size") size = std::stoi(value());
    else if (a == "--tf") tf = value();
    else if (a == "--host-budget") hostMb = std::stoul(value());
    else if (a == "--gpu-budget") gpuMb = std::stoul(value());
    else if (a == "--out") out = value();
    else if (a == "--name") name = value();
    else if (a == "--frames") framesDir = value();
    else {
      std::fprintf(stderr, "bench_orbit: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (storePath.empty() || views < 2) {
    std::fprintf(stderr, "bench_orbit: --store DIR is required, and --views at least 2\n");
    return 2;
  }
  std::vector<double> lods{0};
  for (double l : parseList(lodsText))
    if (l > 0) lods.push_back(l);

  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  auto store = store::BrickStore::openAny(storePath);
  auto cache = std::make_shared<store::BrickCache>(store, hostMb << 20, 2);
  std::printf("bench_orbit on %s: %s, %dx%d, %d views over %.1f degrees\n", device.c_str(), storePath.c_str(), size,
              size, views, degrees);
  if (!framesDir.empty()) fs::create_directories(framesDir);

  render::Scene scene;
  scene.width = scene.height = size;
  scene.transferFunction = render::TransferFunction::load(tf);
  scene.transferFunctionName = tf;
  scene.camera.elevation = elevation;
  scene.camera.distance = distance;
  auto azimuth = [&](int v) { return start + degrees * v / views; };

  std::vector<std::vector<Frame>> frames(lods.size());
  for (size_t l = 0; l < lods.size(); ++l) {
    // One renderer per lod, so each keeps its own warm atlas through the orbit; the host cache is shared.
    render::VolumeRenderer renderer(*context, cache, gpuMb << 20);
    scene.lod = lods[l];
    scene.camera.azimuth = azimuth(0);
    renderer.render(scene);  // warm-up: compiles the programs, pages the first view
    for (int v = 0; v < views; ++v) {
      scene.camera.azimuth = azimuth(v);
      Frame f;
      f.image = renderer.render(scene, &f.stats);
      std::printf("lod %g view %d (azimuth %.1f): %.0f ms, bricks per level %s\n", lods[l], v, azimuth(v),
                  f.stats.msTotal, levels(f.stats).c_str());
      std::fflush(stdout);
      if (!framesDir.empty()) {
        char file[64];
        std::snprintf(file, sizeof file, "lod%g-view%02d.png", lods[l], v);
        image::writePng(fs::path(framesDir) / file, image::toImage8(f.image));
      }
      frames[l].push_back(std::move(f));
    }
  }

  fs::create_directories(out);
  std::ofstream csv(out / (name + ".csv"));
  csv << "# " << device << "; " << storePath << ", " << size << "x" << size << ", tf " << tf << ", " << views
      << " views over " << degrees << " degrees from azimuth " << start << ", elevation " << elevation
      << ", distance " << distance << " R; host " << hostMb << " MB, gpu " << gpuMb << " MB\n";
  csv << "lod,view,azimuth,ms_total,bricks_per_level,psnr_vs_level0_db,motion_rms_level0,motion_rms_lod,"
         "popping_rms,popping_over_motion\n";
  std::ofstream md(out / (name + ".md"));
  md << "Device: " << device << ". Store `" << storePath << "`, " << size << "x" << size << ", transfer function `"
     << tf << "`, " << views << " views over " << degrees << "° (azimuth " << start << " + " << degrees / views
     << "° a view, elevation " << elevation << ", distance " << distance << " R), host budget " << hostMb
     << " MB, GPU budget " << gpuMb << " MB; each frame warm from the view before.\n\n";
  md << "| lod | median ms | speed-up | min PSNR vs level 0 (dB) | median motion RMS (level 0) | max lod motion / "
        "level-0 motion | median popping RMS | median popping / motion | max popping / motion |\n";
  md << "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  std::vector<double> ms0;
  for (const Frame& f : frames[0]) ms0.push_back(f.stats.msTotal);
  for (size_t l = 0; l < lods.size(); ++l) {
    std::vector<double> ms, popping, motion, popRatio;
    double minPsnr = std::numeric_limits<double>::infinity(), maxMotionRatio = 0, maxPopRatio = 0;
    for (int v = 0; v < views; ++v) {
      const Frame& f = frames[l][size_t(v)];
      ms.push_back(f.stats.msTotal);
      const double psnr = image::compareImages(f.image, frames[0][size_t(v)].image).psnr;
      minPsnr = std::min(minPsnr, psnr);
      csv << lods[l] << "," << v << "," << azimuth(v) << "," << f.stats.msTotal << "," << levels(f.stats) << ","
          << psnr;
      if (v + 1 < views) {
        const image::ImageF& a0 = frames[0][size_t(v)].image;
        const image::ImageF& b0 = frames[0][size_t(v) + 1].image;
        const image::ImageF& aL = f.image;
        const image::ImageF& bL = frames[l][size_t(v) + 1].image;
        const double m0 = rmsDifference(b0, a0), mL = rmsDifference(bL, aL), pop = rmsDifference(bL, b0, &aL, &a0);
        motion.push_back(m0);
        popping.push_back(pop);
        if (m0 > 0) {
          maxMotionRatio = std::max(maxMotionRatio, mL / m0);
          maxPopRatio = std::max(maxPopRatio, pop / m0);
          popRatio.push_back(pop / m0);
        }
        csv << "," << m0 << "," << mL << "," << pop << "," << (m0 > 0 ? pop / m0 : 0);
      } else {
        csv << ",,,,";
      }
      csv << "\n";
    }
    char row[512];
    std::snprintf(row, sizeof row, "| %g | %.0f | %.2f× | %s | %.5f | %.3f | %.6f | %.4f | %.4f |\n", lods[l], median(ms),
                  median(ms0) / median(ms),
                  std::isinf(minPsnr) ? "—" : std::to_string(std::round(minPsnr * 10) / 10).substr(0, 5).c_str(),
                  median(motion), maxMotionRatio, median(popping), median(popRatio), maxPopRatio);
    md << row;
  }
  std::printf("wrote %s and %s\n", (out / (name + ".csv")).c_str(), (out / (name + ".md")).c_str());
  return 0;
}
