// Fixtures shared by the rendering suites: small stores made in-process, scenes and cameras, frames from the
// reference, image checks. GL-free; the GL suites add render/gl/GlFixtures.h.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
#include "image/Image.h"
#include "render/core/TransferFunction.h"
#include "render/reference/Compositing.h"
#include "render/reference/ReferenceRenderer.h"
#include "render/volume/Traversal.h"
#include "support/ArraySource.h"

namespace voxbrick::test {

/// The transfer-function presets of config/tf.
inline const std::vector<std::string> kPresets = {"ct-bone", "grayscale", "hot", "mri", "sparse"};

/// A preset of config/tf: by name where VOXBRICK_CONFIG_DIR is set (as ctest sets it), else from the source tree, so
/// that the test binary also runs on its own from any directory.
inline render::TransferFunction preset(const std::string& name) {
  if (const char* dir = std::getenv("VOXBRICK_CONFIG_DIR"); dir && *dir) return render::TransferFunction::load(name);
  return render::TransferFunction::load(
      (std::filesystem::path(VOXBRICK_SOURCE_DIR) / "config" / "tf" / (name + ".json")).string());
}

/// The largest difference of two premultiplied RGBA values.
inline double maxDifference(const glm::dvec4& a, const glm::dvec4& b) {
  const glm::dvec4 d = glm::abs(a - b);
  return std::max({d.r, d.g, d.b, d.a});
}

/// The composite midpoint rule over a segment whose normalised value runs linearly from sf to sb, r reference lengths
/// long: cut where the value crosses a control point (each piece then has a smooth integrand, so the error falls as
/// n^-2), each piece in max(minSteps, ceil(n * its share)) * refine substeps, each classified with
/// TransferFunction::evaluate (the window's clamp included) and opacity-corrected for its length, front to back.
/// refine = 2 halves every substep of refine = 1, as Richardson's extrapolation needs. Premultiplied RGBA.
inline glm::dvec4 midpointSegment(const render::TransferFunction& tf, double sf, double sb, double r, int n,
                                  int minSteps, int refine = 1) {
  std::vector<double> cuts{0.0, 1.0};
  for (const render::TransferFunction::Point& p : tf.points())
    if (sf != sb && (p.x - sf) / (sb - sf) > 0 && (p.x - sf) / (sb - sf) < 1) cuts.push_back((p.x - sf) / (sb - sf));
  std::sort(cuts.begin(), cuts.end());
  render::FrontToBack<double> acc;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    const double u0 = cuts[i], length = cuts[i + 1] - cuts[i];
    const int steps = std::max(minSteps, int(std::ceil(n * length))) * refine;
    for (int j = 0; j < steps; ++j) {
      const glm::dvec4 c = tf.evaluate(sf + (u0 + (j + 0.5) / steps * length) * (sb - sf));
      acc.add(c.r, c.g, c.b, render::TransferFunction::correctOpacity(c.a, r * length / steps));
    }
  }
  return {acc.r, acc.g, acc.b, acc.a};
}

/// A store of an input prep understands ("synthetic:...", a file), without the VDB grid.
inline std::shared_ptr<const store::BrickStore> prep(const std::string& spec, const std::filesystem::path& out,
                                                     int brick, const store::SourceOptions& sourceOptions = {}) {
  auto source = store::openSource(spec, sourceOptions);
  store::PrepOptions options;
  options.brickSize = brick;
  options.writeVdb = false;
  store::prepStore(*source, out, options);
  return store::BrickStore::open(out);
}

/// A store of a known array (no VDB grid).
template <typename T>
std::shared_ptr<const store::BrickStore> prepArray(const store::Vec3i& n, store::ValueType type, std::vector<T> values,
                                                   const std::filesystem::path& out, int brick,
                                                   const store::Vec3d& spacing = {}) {
  ArraySource<T> source(n, type, std::move(values));
  source.setSpacing(spacing);
  store::PrepOptions options;
  options.brickSize = brick;
  options.writeVdb = false;
  store::prepStore(source, out, options);
  return store::BrickStore::open(out);
}

/// A small frame (96x80, orbit 35°/25° at 2.2 radii, the "hot" preset, step 0.5) at level of detail `lod`.
inline render::Scene lodScene(double lod) {
  render::Scene scene;
  scene.width = 96;
  scene.height = 80;
  scene.camera.azimuth = 35;
  scene.camera.elevation = 25;
  scene.camera.distance = 2.2;
  scene.transferFunction = render::TransferFunction::load("hot");
  scene.step = 0.5;
  scene.lod = lod;
  return scene;
}

/// Slicing (no slabs, no ray caster, no termination, whole bricks) of lodScene's frame at the default level of detail
/// with transfer function `tf`: the baseline that slabs and the ray caster are held to.
inline render::Scene slicingScene(const std::string& tf) {
  render::Scene scene = lodScene(render::Scene{}.lod);
  scene.transferFunction = render::TransferFunction::load(tf);
  scene.slab = 0;
  scene.raycast = false;
  scene.ert = 0;
  scene.subBlock = 0;
  return scene;
}

/// Cameras that stress a ray march: oblique perspective, a view along an axis (planes through brick and cell
/// faces), orthographic from below, and the eye inside the volume (the near plane cuts bricks, rays start inside);
/// with `fromBehind`, the axis view from the far side too (the faces towards the eye flip).
inline std::vector<std::pair<std::string, render::CameraSpec>> marchCameras(bool fromBehind) {
  std::vector<std::pair<std::string, render::CameraSpec>> out;
  render::CameraSpec c;
  c.azimuth = 35, c.elevation = 25, c.distance = 2.2;
  out.push_back({"oblique", c});
  render::CameraSpec axis;
  axis.orbit = false;
  axis.eye = {0, 0, 300};
  out.push_back({"axis", axis});
  if (fromBehind) {
    render::CameraSpec back = axis;
    back.eye = {0, 0, -300};
    out.push_back({"axis-back", back});
  }
  render::CameraSpec ortho = c;
  ortho.orthographic = true;
  ortho.azimuth = 200, ortho.elevation = -40;
  out.push_back({"ortho", ortho});
  render::CameraSpec inside = c;
  inside.distance = 0.25, inside.fovY = 75;
  out.push_back({"inside", inside});
  return out;
}

/// A reference frame with a fresh renderer and cache.
inline image::ImageF renderReference(std::shared_ptr<const store::BrickStore> s, const render::Scene& scene,
                                     const render::ReferenceOptions& options = {},
                                     render::ReferenceStats* stats = nullptr) {
  auto cache = std::make_shared<store::BrickCache>(std::move(s), size_t(256) << 20, 0);
  render::ReferenceRenderer renderer(cache);
  return renderer.render(scene, options, stats);
}

/// Mean of R, G and B over the image: a frame that is (nearly) black proves nothing.
inline double meanBrightness(const image::ImageF& image) {
  double sum = 0;
  for (size_t i = 0; i < image.rgba.size(); i += 4) sum += image.rgba[i] + image.rgba[i + 1] + image.rgba[i + 2];
  return sum / double(image.rgba.size() / 4 * 3);
}

/// Expects max |diff| <= maxAbs; otherwise writes both images and their difference heat map to the temp directory.
inline void expectClose(const image::ImageF& a, const image::ImageF& b, double maxAbs, const std::string& what) {
  const image::ImageError e = image::compareImages(a, b);
  EXPECT_LE(e.maxAbs, maxAbs) << what << ": rmse " << e.rmse << ", psnr " << e.psnr;
  if (e.maxAbs > maxAbs) {
    const auto dir = std::filesystem::temp_directory_path();
    image::writePng(dir / (what + "-a.png"), image::toImage8(a));
    image::writePng(dir / (what + "-b.png"), image::toImage8(b));
    image::writePng(dir / (what + "-diff.png"), image::toImage8(image::differenceHeatmap(a, b, e.maxAbs)));
    std::cerr << "images written to " << (dir / (what + "-{a,b,diff}.png")).string() << "\n";
  }
}

/// True if every channel of every pixel is finite.
inline bool allFinite(const image::ImageF& image) {
  for (float v : image.rgba)
    if (!std::isfinite(v)) return false;
  return true;
}

/// How many of `bricks` cover each level-0 brick of a `grid` of them (x fastest): a level-m brick covers the 2^m
/// bricks per axis under its octree node, cut at the grid.
inline std::vector<int> levelZeroCoverage(const std::vector<render::BrickDraw>& bricks, const store::Vec3i& grid) {
  std::vector<int> cover(size_t(grid.volume()), 0);
  for (const render::BrickDraw& d : bricks) {
    const int m = int(d.key.level);
    for (int64_t k = int64_t(d.key.k) << m; k < std::min((int64_t(d.key.k) + 1) << m, grid.z); ++k)
      for (int64_t j = int64_t(d.key.j) << m; j < std::min((int64_t(d.key.j) + 1) << m, grid.y); ++j)
        for (int64_t i = int64_t(d.key.i) << m; i < std::min((int64_t(d.key.i) + 1) << m, grid.x); ++i)
          ++cover[size_t(i + grid.x * (j + grid.y * k))];
  }
  return cover;
}

}  // namespace voxbrick::test
