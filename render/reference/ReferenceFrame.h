// What every ray of a reference frame shares: camera basis, box, value window, control points, step, and the bricks
// rays may jump over.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "brickstore/format/StoreMeta.h"
#include "brickstore/read/BrickStore.h"
#include "render/core/Camera.h"
#include "render/core/Scene.h"
#include "render/reference/ReferenceRay.h"
#include "render/reference/ReferenceRenderer.h"

namespace voxbrick::render::reference {

/// Everything a ray needs that is the same for the whole frame.
struct Frame {
  const Scene* scene = nullptr;
  glm::dvec3 spacing{1}, dims{1}, halfDims{0.5}, boxMin{0}, boxMax{0};
  RayBasis basis;
  double lo = 0, inverseWidth = 1;
  double step = 1;  // longest segment, world units
  double referenceLength = 1;
  std::vector<double> kinks;  // the transfer function's control points, distinct and sorted
  // Empty-space skipping: transparent[i] for each level-0 brick; empty when off.
  std::vector<uint8_t> transparent;
  store::Vec3i brickGrid;
  double brickSize = 32;
};

/// Everything of the frame that is the same for every ray: camera basis, box, value window, control points, step.
Frame makeFrame(const Scene& scene, const ReferenceOptions& options, const store::StoreMeta& meta);

/// Marks the level-0 bricks whose [min, max] the transfer function maps to zero opacity, for rays to jump over;
/// never those sampled at a coarser level, whose reconstruction reads beyond them.
void markTransparentBricks(Frame& f, const store::BrickStore& store, const std::vector<uint8_t>& brickLevels);

/// The ray through the centre of pixel (x, y), from the near plane to the box's exit; empty (t0 = t1 = 0) where it
/// misses the box.
Ray pixelRay(const Frame& f, int x, int y, int width, int height);

}  // namespace voxbrick::render::reference
