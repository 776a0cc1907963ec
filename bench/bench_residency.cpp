// bench_residency: ray-driven against octree residency (Scene::residency, render/gl/volume/RayRequests.h) on a sparse
// synthetic volume read live from a .vdb: per frame of a still camera and then a short drag, the bricks the octree
// wanted, the bricks each mode paged, the bricks the rays requested and those they never reached, each mode's frame
// time, and the PSNR of the rays mode's frame against the octree mode's.
//
// The volume (written to --dir, deleted after): a box of N^3 voxels (the default 8192^3), empty but for, at its
// centre, an opaque spherical shell around a few smaller balls inside it ("shell"), or the same balls in the open
// ("balls": nothing is hidden). Bricks of 32: N/32 bricks a side.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/read/BrickCache.h"
#include "brickstore/read/VdbStore.h"
#include "brickstore/vdb/VdbBalls.h"
#include "image/Image.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/VolumeRenderer.h"

namespace {

using namespace voxbrick;

/// The inner balls, about the box's centre c, in voxels; with `shell`, the opaque shell around them.
std::vector<store::VdbBall> balls(double c, bool shell) {
  std::vector<store::VdbBall> out{{c - 150, c, c, 0, 70, 0.5f},
                                  {c + 150, c + 40, c, 0, 60, 0.5f},
                                  {c, c - 160, c + 60, 0, 55, 0.5f},
                                  {c, c + 150, c - 50, 0, 65, 0.5f}};
  if (shell) out.push_back({c, c, c, 280, 286, 1.0f});
  return out;
}

render::Scene scene(int size, render::ResidencyMode mode, double azimuth) {
  render::Scene s;
  s.width = s.height = size;
  s.raycast = true;
  s.raycaster = render::RayCaster::Fragment;
  s.lod = 0;
  s.ert = 0.99;
  s.residency = mode;
  // The balls translucent (0.5), the shell opaque (1.0); the corner markers (0.01) transparent.
  s.transferFunction = render::TransferFunction({{0.0, {0, 0, 0, 0}},
                                                 {0.05, {0, 0, 0, 0}},
                                                 {0.5, {0.2, 0.6, 1.0, 0.08}},
                                                 {0.8, {1.0, 0.6, 0.2, 0.5}},
                                                 {1.0, {1.0, 0.9, 0.8, 1.0}}});
  s.window = std::array<double, 2>{0.0, 1.0};
  s.camera.orbit = false;
  const double a = azimuth * 3.14159265358979 / 180;
  s.camera.eye = {1100 * std::sin(a), -1100 * std::cos(a), 250};
  s.camera.center = {0, 0, 0};
  s.camera.up = {0, 0, 1};
  s.camera.fovY = 40;
  return s;
}

struct Mode {
  Mode(render::GlContext& context, std::shared_ptr<const store::BrickStore> s, size_t gpuBudget)
      : cache(std::make_shared<store::BrickCache>(std::move(s), size_t(2) << 30, 2)),
        renderer(context, cache, gpuBudget) {}
  std::shared_ptr<store::BrickCache> cache;
  render::VolumeRenderer renderer;
  int64_t pagedTotal = 0;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bench_residency: ray-driven against octree residency on a sparse volume read live"};
  std::filesystem::path dir = "/tmp/voxbrick-residency", csvPath, mdPath;
  int n = 8192, size = 256, still = 8, drag = 8, budgetMiB = 1024;
  app.add_option("--dir", dir, "scratch directory for the .vdb (removed after)");
  app.add_option("--n", n, "voxels a side");
  app.add_option("--size", size, "image side in pixels");
  app.add_option("--still", still, "frames of the still camera");
  app.add_option("--drag", drag, "frames of the drag (2 degrees each)");
  app.add_option("--gpu-budget", budgetMiB, "atlas budget in MiB");
  app.add_option("--csv", csvPath, "CSV output")->required();
  app.add_option("--md", mdPath, "Markdown output")->required();
  CLI11_PARSE(app, argc, argv);

  std::filesystem::create_directories(dir);
  const std::filesystem::path vdb = dir / "residency.vdb";
  store::writeBallsVdb(vdb, n, {{"shell", balls(n / 2, true)}, {"balls", balls(n / 2, false)}});
  auto context = render::createContext(render::Backend::Auto);
  std::ofstream csv(csvPath), md(mdPath);
  csv << "case,frame,camera,octree_wanted,octree_paged,octree_ms,rays_paged,rays_requested,rays_untouched,"
         "rays_standin,rays_ms,psnr_db\n";
  md << "| case | frame | camera | octree wanted | octree paged | octree ms | rays paged | rays requested | "
        "never touched | stand-ins | rays ms | PSNR dB |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const char* grid : {"shell", "balls"}) {
    const auto live = store::VdbStore::open(vdb, {grid, 32});
    Mode octree(*context, live, size_t(budgetMiB) << 20), rays(*context, live, size_t(budgetMiB) << 20);
    for (int f = 0; f < still + drag; ++f) {
      const double azimuth = f < still ? 0 : 2.0 * (f - still + 1);
      render::FrameStats o, r;
      const image::ImageF a = octree.renderer.render(scene(size, render::ResidencyMode::Octree, azimuth), &o);
      const image::ImageF b = rays.renderer.render(scene(size, render::ResidencyMode::Rays, azimuth), &r);
      octree.pagedTotal += o.bricksPagedIn, rays.pagedTotal += r.bricksPagedIn;
      const double psnr = image::compareImages(b, a).psnr;
      const std::string camera = f < still ? "still" : "drag " + std::to_string(int(azimuth)) + " deg";
      char line[512];
      std::snprintf(line, sizeof(line), "%s,%d,%s,%lld,%lld,%.1f,%lld,%lld,%lld,%lld,%.1f,%.2f\n", grid, f,
                    camera.c_str(), (long long)o.bricksDrawn, (long long)o.bricksPagedIn, o.msTotal,
                    (long long)r.bricksPagedIn, (long long)r.bricksRequested, (long long)r.bricksUntouched,
                    (long long)r.bricksStandIn, r.msTotal, std::isinf(psnr) ? 999.0 : psnr);
      csv << line;
      std::snprintf(line, sizeof(line),
                    "| %s | %d | %s | %lld | %lld | %.1f | %lld | %lld | %lld | %lld | %.1f | %s |\n", grid, f,
                    camera.c_str(), (long long)o.bricksDrawn, (long long)o.bricksPagedIn, o.msTotal,
                    (long long)r.bricksPagedIn, (long long)r.bricksRequested, (long long)r.bricksUntouched,
                    (long long)r.bricksStandIn, r.msTotal,
                    std::isinf(psnr) ? "identical" : std::to_string(std::round(psnr * 100) / 100).substr(0, 6).c_str());
      md << line;
      std::printf("%s", line);
      std::fflush(stdout);
      if (!o.fallback.empty() || !r.fallback.empty())
        std::printf("  fallback: octree '%s' rays '%s'\n", o.fallback.c_str(), r.fallback.c_str());
    }
    md << "| **" << grid << " total paged** | | | | " << octree.pagedTotal << " | | " << rays.pagedTotal
       << " | | | | | |\n";
  }
  std::filesystem::remove_all(dir);
  return 0;
}
