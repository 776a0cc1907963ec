// Planning a frame: everything about it that needs no GL.
#include "render/volume/FramePlan.h"

#include <algorithm>
#include <limits>
#include <string>

#include "render/core/RenderErrors.h"
#include "render/core/WorldFrame.h"

namespace voxbrick::render {

ValueWindow valueWindow(const Scene& scene, const store::StoreMeta& meta) {
  ValueWindow w;
  // A window is given in the input's values; a quantised store holds steps, so it is mapped onto them (the default,
  // the store's range, is in stored units already).
  w.lo = scene.window ? meta.storedValue((*scene.window)[0]) : meta.valueMin;
  w.hi = scene.window ? meta.storedValue((*scene.window)[1]) : meta.valueMax;
  if (!(w.hi > w.lo)) w.hi = w.lo + 1;  // a constant volume: everything maps to 0
  w.inverseWidth = 1.0 / (w.hi - w.lo);
  return w;
}

Camera gridCamera(const Scene& scene, const store::StoreMeta& meta) {
  return scene.camera.resolve(volumeBox(meta.dims, meta.spacing),
                              WorldFrame::of(meta.orientation, meta.dims, meta.spacing),
                              double(scene.width) / double(scene.height));
}

Box FramePlan::drawBox(const Box& b, const store::Vec3d& spacing) const {
  const double interiorMargin = exactOwnership() ? kInteriorMargin : 0.0;
  Box out = b;
  for (int a = 0; a < 3; ++a) {
    out.min[a] -= (out.min[a] <= volume.min[a] ? kSurfaceMargin : interiorMargin) * spacing[a];
    out.max[a] += (out.max[a] >= volume.max[a] ? kSurfaceMargin : interiorMargin) * spacing[a];
  }
  return out;
}

namespace {

/// Keeps the bricks of `visible` that own level-0 voxels inside `part`, and recounts the bricks drawn. The counts per
/// level keep their length, so that the frame's coarsest level is the whole frame's (the pre-integration table's
/// range follows it). Returns the box of the bricks kept (min above max when none is).
Box keepPart(TraversalResult& visible, const PartBox& part, int brickSize) {
  std::erase_if(visible.bricks, [&](const BrickDraw& d) {
    const int64_t side = int64_t(brickSize) << d.key.level;
    const int64_t lo[3] = {int64_t(d.key.i) * side, int64_t(d.key.j) * side, int64_t(d.key.k) * side};
    for (size_t a = 0; a < 3; ++a)
      if (lo[a] >= part.hi[a] || lo[a] + side <= part.lo[a]) return true;
    return false;
  });
  TraversalStats& stats = visible.stats;
  std::fill(stats.bricksPerLevel.begin(), stats.bricksPerLevel.end(), 0);
  Box kept{glm::dvec3(1.0), glm::dvec3(-1.0)};
  for (const BrickDraw& d : visible.bricks) {
    stats.bricksPerLevel.at(d.key.level) += 1;
    const bool first = &d == &visible.bricks.front();
    kept.min = first ? d.box.min : glm::min(kept.min, d.box.min);
    kept.max = first ? d.box.max : glm::max(kept.max, d.box.max);
  }
  stats.bricksDrawn = int64_t(visible.bricks.size());
  stats.bricksCoarse = stats.bricksDrawn - (stats.bricksPerLevel.empty() ? 0 : stats.bricksPerLevel[0]);
  return kept;
}

void checkPart(const PartBox& part, const store::Vec3i& dims) {
  for (size_t a = 0; a < 3; ++a)
    if (part.lo[a] < 0 || part.lo[a] >= part.hi[a] || part.hi[a] > dims[int(a)])
      throw RenderInputError("part [" + std::to_string(part.lo[0]) + " " + std::to_string(part.lo[1]) + " " +
                             std::to_string(part.lo[2]) + ", " + std::to_string(part.hi[0]) + " " +
                             std::to_string(part.hi[1]) + " " + std::to_string(part.hi[2]) +
                             ") is not a non-empty box of voxels inside the volume of " + std::to_string(dims.x) +
                             " x " + std::to_string(dims.y) + " x " + std::to_string(dims.z));
}

/// The traversal's bricks, coarsened to fit `budget` when level of detail is on and they need more.
void traverse(FramePlan& plan, const Scene& scene, const store::BrickStore& store, const BrickBudget& budget) {
  const store::StoreMeta& meta = store.meta();
  const Frustum frustum = Frustum::fromMatrix(plan.viewProj);
  const OctreeTraversal traversal(store.octree(), meta.dims, store.brickSize(), meta.spacing);
  TraversalOptions options{scene.skipEmpty, scene.cullFrustum, {scene.lod, store.levelCount() - 1, scene.height}, {}};
  if (plan.part) {  // the bricks meeting the part: its voxels [lo, hi) over the brick size, rounded out
    const int64_t B = store.brickSize();
    const PartBox& part = *plan.part;
    options.partBricks = std::array<store::Vec3i, 2>{
        store::Vec3i{part.lo[0] / B, part.lo[1] / B, part.lo[2] / B},
        store::Vec3i{(part.hi[0] + B - 1) / B, (part.hi[1] + B - 1) / B, (part.hi[2] + B - 1) / B}};
  }
  plan.visible = traversal.run(plan.camera, frustum, plan.contributes, options);
  if (plan.part) plan.partDrawn = keepPart(plan.visible, *plan.part, store.brickSize());
  plan.bricksWanted = int64_t(plan.visible.bricks.size());
  if (scene.lod <= 0 || budget.limit() <= 0) return;
  plan.budget = budget;
  const CoarseningCost cost{
      traversal, plan.camera, scene.height, [tf = scene.transferFunction, w = plan.window](float mn, float mx) {
        return tf.maxAlpha((double(mn) - w.lo) * w.inverseWidth, (double(mx) - w.lo) * w.inverseWidth);
      }};
  const std::vector<store::BrickKey> whole =
      coarsenToFit(plan.visible.bricks, store.octree(), store.levelCount() - 1, cost, budget.limit());
  if (whole.empty()) return;
  plan.visible = traversal.run(plan.camera, frustum, plan.contributes, options, drawWholeTest(whole));
  if (plan.part) plan.partDrawn = keepPart(plan.visible, *plan.part, store.brickSize());
}

}  // namespace

FramePlan planFrame(const Scene& scene, const store::BrickStore& store, int transferTableTexels,
                    const BrickBudget& budget, const std::optional<PartBox>& part) {
  scene.validate();
  const store::StoreMeta& meta = store.meta();
  const int B = store.brickSize();
  FramePlan plan;
  if (part) checkPart(*part, meta.dims);
  plan.part = part;
  plan.volume = volumeBox(meta.dims, meta.spacing);
  plan.camera = gridCamera(scene, meta);
  plan.camera.clipRange(plan.volume, plan.nearPlane, plan.farPlane);
  plan.viewProj = plan.camera.projection(double(scene.width) / double(scene.height), plan.nearPlane, plan.farPlane) *
                  plan.camera.view();

  plan.window = valueWindow(scene, meta);
  plan.contributes = [tf = scene.transferFunction, w = plan.window, transferTableTexels](float mn, float mx) {
    return tf.tableContributes((double(mn) - w.lo) * w.inverseWidth, (double(mx) - w.lo) * w.inverseWidth,
                               transferTableTexels);
  };
  plan.classification = {plan.window.lo, plan.window.hi, transferTableTexels, {}};
  for (const TransferFunction::Point& p : scene.transferFunction.points())
    plan.classification.opacity.emplace_back(p.x, p.rgba.a);
  traverse(plan, scene, store, budget);
  plan.coarsestLevel = int(plan.visible.stats.bricksPerLevel.size()) - 1;
  if (plan.coarsestLevel < 0) plan.coarsestLevel = 0;

  plan.planeNormal = plan.camera.viewDirection();
  const double minSpacing = std::min({meta.spacing.x, meta.spacing.y, meta.spacing.z});
  plan.step = scene.step * minSpacing;
  plan.referenceLength = scene.transferFunction.referenceLength().value_or(minSpacing);
  // A sub-block as large as the brick is the brick itself (whole bricks, as 0); a larger one cannot be cut from it.
  // The scene's default (8) meets bricks of 8, so equality is not an error here; `voxbrick render` refuses it when
  // it is typed.
  if (scene.subBlock > B)
    throw RenderInputError("sub-block " + std::to_string(scene.subBlock) +
                           " must be 0 (whole bricks) or a power of two below the brick size " + std::to_string(B));
  plan.subBlock = scene.subBlock > 0 && scene.subBlock < B ? scene.subBlock : 0;
  plan.raycast = scene.raycast;
  if (plan.raycast) {
    plan.cellSize = rayCastCellSize(meta.dims, plan.subBlock, B);
    plan.raycast = plan.cellSize > 0;  // else texture slabs, of the scene's size or the default
    plan.pagedCells = plan.raycast && rayCastCells(meta.dims, plan.cellSize) > kMaxDenseCells;
    if (!plan.raycast)
      plan.fallback = "drawn with texture slabs, not the ray caster: its cell table would exceed " +
                      std::to_string(kMaxRayCastBlocks * 512) + " cells of a brick or a side of 32767 voxels (" +
                      std::to_string(meta.dims.x) + "x" + std::to_string(meta.dims.y) + "x" +
                      std::to_string(meta.dims.z) + " voxels in bricks of " + std::to_string(B) + ")";
  }
  plan.rayResidency = plan.raycast && scene.residency == ResidencyMode::Rays && !part;
  plan.slab = plan.raycast ? 0 : scene.slab > 0 || !scene.raycast ? scene.slab : Scene{}.slab;
  plan.ert = plan.marches() ? scene.ert : 0;
  plan.preIntegration = plan.marches() && scene.preIntegration;
  plan.ess = plan.slab > 0 && scene.ess;
  plan.width = scene.width;
  plan.height = scene.height;
  plan.rays = pixelRays(plan.viewProj, scene.width, scene.height);
  return plan;
}

int64_t rayCastCells(const store::Vec3i& dims, int64_t cellSize) {
  const int64_t c = cellSize;
  return ((dims.x + c - 1) / c) * ((dims.y + c - 1) / c) * ((dims.z + c - 1) / c);
}

int rayCastCellSize(const store::Vec3i& dims, int subBlock, int brickSize) {
  int size = subBlock > 0 ? subBlock : brickSize;
  // Blocks of the directory: 8^3 cells each, so cells of 8c voxels.
  auto blocks = [&](int64_t c) { return rayCastCells(dims, 8 * c); };
  while (blocks(size) > kMaxRayCastBlocks && size < brickSize) size *= 2;
  if (blocks(size) > kMaxRayCastBlocks || std::max({dims.x, dims.y, dims.z}) > 32767) return 0;
  return size;
}

std::vector<uint8_t> brickLevels(const TraversalResult& visible, const store::StoreMeta& meta) {
  const store::Vec3i& grid = meta.levels.at(0).bricks;
  std::vector<uint8_t> levels(size_t(grid.volume()), 0);
  for (const BrickDraw& d : visible.bricks) {
    const int m = int(d.key.level), level = m + int(d.standIn);
    if (level == 0) continue;
    const int64_t lo[3] = {int64_t(d.key.i) << m, int64_t(d.key.j) << m, int64_t(d.key.k) << m};
    for (int64_t k = lo[2]; k < std::min(lo[2] + (int64_t{1} << m), grid.z); ++k)
      for (int64_t j = lo[1]; j < std::min(lo[1] + (int64_t{1} << m), grid.y); ++j)
        for (int64_t i = lo[0]; i < std::min(lo[0] + (int64_t{1} << m), grid.x); ++i)
          levels[size_t(i + grid.x * (j + grid.y * k))] = uint8_t(level);
  }
  return levels;
}

double FramePlan::estimatedSamples() const {
  double samples = 0;
  for (const BrickDraw& brick : visible.bricks) {
    const Box& b = brick.box;
    glm::dvec2 lo(1e300), hi(-1e300);
    double nearest = 1e300, farthest = -1e300;
    bool behind = false;
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 p{c & 1 ? b.max.x : b.min.x, c & 2 ? b.max.y : b.min.y, c & 4 ? b.max.z : b.min.z};
      const glm::dvec4 clip = viewProj * glm::dvec4(p, 1.0);
      if (clip.w <= 1e-12)
        behind = true;
      else
        lo = glm::min(lo, glm::dvec2(clip) / clip.w), hi = glm::max(hi, glm::dvec2(clip) / clip.w);
      const double d = glm::dot(p, planeNormal);
      nearest = std::min(nearest, d), farthest = std::max(farthest, d);
    }
    // A box reaching behind the eye may cover the whole screen.
    if (behind) lo = glm::dvec2(-1), hi = glm::dvec2(1);
    lo = glm::clamp(lo, -1.0, 1.0), hi = glm::clamp(hi, -1.0, 1.0);
    const double pixels = (hi.x - lo.x) * 0.5 * width * (hi.y - lo.y) * 0.5 * height;
    const double planes = (farthest - nearest) / (step * planeStride(int(brick.key.level + brick.standIn))) + 1;
    samples += std::max(pixels, 0.0) * planes;
  }
  return samples;
}

std::pair<double, double> FramePlan::segmentRatios() const {
  const double ratio = step / referenceLength;
  const double coarse = double(planeStride(coarsestLevel));
  if (camera.orthographic) return {ratio, ratio * coarse};
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  const double xs[] = {0.5, 0.5 * width, width - 0.5}, ys[] = {0.5, 0.5 * height, height - 0.5};
  for (double x : xs)
    for (double y : ys) {
      const glm::dvec3 d = rays.direction + x * rays.directionDx + y * rays.directionDy;
      const double cosine = std::max(glm::dot(glm::normalize(d), planeNormal), 1e-3);
      lo = std::min(lo, ratio / cosine), hi = std::max(hi, ratio / cosine);
    }
  return {lo, hi * coarse};
}

}  // namespace voxbrick::render
