// A reference frame's shared state, and each pixel's ray.
#include "render/reference/ReferenceFrame.h"

#include <algorithm>

#include "render/volume/FramePlan.h"

namespace voxbrick::render::reference {

Frame makeFrame(const Scene& scene, const ReferenceOptions& options, const store::StoreMeta& meta) {
  Frame f;
  f.scene = &scene;
  const Box box = volumeBox(meta.dims, meta.spacing);
  f.boxMin = box.min;
  f.boxMax = box.max;
  for (int a = 0; a < 3; ++a) {
    f.spacing[a] = meta.spacing[a];
    f.dims[a] = double(meta.dims[a]);
  }
  f.halfDims = 0.5 * f.dims;

  const double aspect = double(scene.width) / double(scene.height);
  const Camera camera = gridCamera(scene, meta);
  double nearPlane = 0, farPlane = 0;
  camera.clipRange(box, nearPlane, farPlane);
  f.basis = RayBasis::of(camera, aspect, nearPlane);

  // The value window exactly as the GPU renderer takes it.
  const ValueWindow window = valueWindow(scene, meta);
  f.lo = window.lo;
  f.inverseWidth = window.inverseWidth;

  for (const TransferFunction::Point& p : scene.transferFunction.points())
    if (f.kinks.empty() || p.x > f.kinks.back()) f.kinks.push_back(p.x);

  const double minSpacing = std::min({meta.spacing.x, meta.spacing.y, meta.spacing.z});
  f.step = options.step * minSpacing;
  f.referenceLength = scene.transferFunction.referenceLength().value_or(minSpacing);
  return f;
}

void markTransparentBricks(Frame& f, const store::BrickStore& store, const std::vector<uint8_t>& brickLevels) {
  const store::StoreMeta& meta = store.meta();
  const store::LevelMeta& level = meta.levels.at(0);
  f.brickGrid = level.bricks;
  f.brickSize = double(meta.brickSize);
  f.transparent.resize(size_t(level.bricksTotal()));
  for (int64_t k = 0; k < level.bricks.z; ++k)
    for (int64_t j = 0; j < level.bricks.y; ++j)
      for (int64_t i = 0; i < level.bricks.x; ++i) {
        const store::BrickRecord& r = store.record({0, uint32_t(i), uint32_t(j), uint32_t(k)});
        const size_t index = size_t(i + level.bricks.x * (j + level.bricks.y * k));
        f.transparent[index] = (brickLevels.empty() || brickLevels[index] == 0) &&
                               !f.scene->transferFunction.contributes((double(r.min) - f.lo) * f.inverseWidth,
                                                                      (double(r.max) - f.lo) * f.inverseWidth);
      }
}

Ray pixelRay(const Frame& f, int x, int y, int width, int height) {
  Ray ray;
  double tNear = 0;
  f.basis.pixelRay(x, y, width, height, ray.origin, ray.dir, tNear);
  if (!clipToBox(ray.origin, ray.dir, f.boxMin, f.boxMax, ray.t0, ray.t1)) {
    ray.t0 = ray.t1 = 0;
    return ray;
  }
  ray.t0 = std::max(ray.t0, tNear);
  return ray;
}

}  // namespace voxbrick::render::reference
