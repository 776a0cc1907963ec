// Front-to-back octree traversal over level-0 bricks with empty-space skipping, frustum culling and level of detail.
#include "render/volume/Traversal.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

struct OctreeTraversal::Walk {
  const Camera& camera;
  const Frustum& frustum;
  const RangePredicate& contributes;
  TraversalOptions options;
  const DrawWhole& drawWhole;
  glm::dvec3 eye;
  glm::dvec3 direction;
  bool orthographic;
  TraversalResult result;
};

OctreeTraversal::OctreeTraversal(const store::MinMaxOctree& octree, const store::Vec3i& dims, int brickSize,
                                 const store::Vec3d& spacing)
    : mOctree(&octree), mDims(dims), mBrickSize(brickSize), mSpacing(spacing) {
  if (brickSize <= 0) throw RenderInputError("OctreeTraversal: brick size " + std::to_string(brickSize) + " <= 0");
  mVolume = volumeBox(dims, spacing);  // checks dims and spacing
  store::Vec3i expected{store::divUp(dims.x, mBrickSize), store::divUp(dims.y, mBrickSize),
                        store::divUp(dims.z, mBrickSize)};
  const store::Vec3i& bricks = octree.bricks();
  if (!(bricks == expected))
    throw RenderInputError("OctreeTraversal: octree has " + std::to_string(bricks.x) + "x" + std::to_string(bricks.y) +
                           "x" + std::to_string(bricks.z) + " bricks, but dims " + std::to_string(dims.x) + "x" +
                           std::to_string(dims.y) + "x" + std::to_string(dims.z) + " with brick size " +
                           std::to_string(brickSize) + " need " + std::to_string(expected.x) + "x" +
                           std::to_string(expected.y) + "x" + std::to_string(expected.z));
}

Box voxelSpanBox(const store::Vec3i& lo, const store::Vec3i& hi, const store::Vec3i& dims,
                 const store::Vec3d& spacing) {
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.min[a] = voxelFace(lo[a], dims[a], spacing[a]);
    box.max[a] = voxelFace(hi[a], dims[a], spacing[a]);
  }
  return box;
}

Box OctreeTraversal::nodeBox(int d, int64_t i, int64_t j, int64_t k) const {
  store::Vec3i lo, hi;
  mOctree->brickSpan(d, i, j, k, lo, hi);
  for (int a = 0; a < 3; ++a) {
    lo[a] *= mBrickSize;
    hi[a] = std::min(hi[a] * mBrickSize, mDims[a]);
  }
  return voxelSpanBox(lo, hi, mDims, mSpacing);
}

bool OctreeTraversal::coarseEnough(const Camera& camera, const LevelOfDetail& lod, int level, const Box& box) const {
  return voxelPixels(camera, lod.imageHeight, level, box) <= lod.pixels;
}

double OctreeTraversal::voxelPixels(const Camera& camera, int imageHeight, int level, const Box& box) const {
  const double voxel = std::ldexp(std::max({mSpacing.x, mSpacing.y, mSpacing.z}), level);
  const double tanHalf = std::tan(0.5 * camera.fovYDegrees * 3.14159265358979323846 / 180.0);
  double depth = camera.distance();  // orthographic: the view's height is taken in the plane through the centre
  if (!camera.orthographic) {
    const glm::dvec3 direction = camera.viewDirection();
    depth = std::numeric_limits<double>::infinity();
    for (int corner = 0; corner < 8; ++corner) {
      const glm::dvec3 p((corner & 1) ? box.max.x : box.min.x, (corner & 2) ? box.max.y : box.min.y,
                         (corner & 4) ? box.max.z : box.min.z);
      depth = std::min(depth, glm::dot(p - camera.eye, direction));
    }
    if (!(depth > 0)) return std::numeric_limits<double>::infinity();
  }
  return voxel * double(imageHeight) / (2.0 * depth * tanHalf);
}

Box OctreeTraversal::brickBox(int64_t i, int64_t j, int64_t k) const { return nodeBox(mOctree->depth(), i, j, k); }

TraversalResult OctreeTraversal::run(const Camera& camera, const Frustum& frustum, const RangePredicate& contributes,
                                     const TraversalOptions& options, const DrawWhole& drawWhole) const {
  if (options.skipEmpty && !contributes)
    throw RenderInputError("OctreeTraversal::run: skipEmpty is set but the range predicate is empty");
  if (options.lod.pixels < 0 || !std::isfinite(options.lod.pixels) || options.lod.imageHeight <= 0)
    throw RenderInputError("OctreeTraversal::run: level of detail needs pixels >= 0 and an image height > 0");
  Walk walk{camera, frustum, contributes, options, drawWhole, camera.eye, camera.viewDirection(), camera.orthographic,
            {}};
  visit(walk, 0, 0, 0, 0);
  return std::move(walk.result);
}

void OctreeTraversal::visit(Walk& walk, int d, int64_t i, int64_t j, int64_t k) const {
  TraversalStats& stats = walk.result.stats;
  ++stats.nodesVisited;
  store::Vec3i lo, hi;
  mOctree->brickSpan(d, i, j, k, lo, hi);
  int64_t bricks = (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z);
  if (const auto& part = walk.options.partBricks) {
    const store::Vec3i& partLo = (*part)[0];
    const store::Vec3i& partHi = (*part)[1];
    if (lo.x >= partHi.x || hi.x <= partLo.x || lo.y >= partHi.y || hi.y <= partLo.y || lo.z >= partHi.z ||
        hi.z <= partLo.z) {
      stats.bricksOutsidePart += bricks;
      return;
    }
  }
  if (walk.options.skipEmpty) {
    store::MinMaxOctree::Range range = mOctree->range(d, i, j, k);
    if (!walk.contributes(range.min, range.max)) {
      stats.bricksSkippedEmpty += bricks;
      return;
    }
  }
  Box box = nodeBox(d, i, j, k);
  if (walk.options.cullFrustum && !walk.frustum.intersects(box)) {
    stats.bricksCulled += bricks;
    return;
  }
  const int level = mOctree->depth() - d;
  const store::BrickKey key{static_cast<uint32_t>(level), static_cast<uint32_t>(i), static_cast<uint32_t>(j),
                            static_cast<uint32_t>(k)};
  if (level == 0 || (walk.drawWhole && walk.drawWhole(key)) ||
      (walk.options.lod.pixels > 0 && level <= walk.options.lod.coarsest &&
       coarseEnough(walk.camera, walk.options.lod, level, box))) {
    walk.result.bricks.push_back({key, box});
    ++stats.bricksDrawn;
    if (level > 0) {
      ++stats.bricksCoarse;
      stats.bricksCoarsened += bricks;
    }
    if (stats.bricksPerLevel.size() <= size_t(level)) stats.bricksPerLevel.resize(size_t(level) + 1, 0);
    ++stats.bricksPerLevel[size_t(level)];
    return;
  }
  // q = child bits XOR highNear has bit a clear when the child is on the eye's side of the split plane along a.
  // Visiting q = 0..7 puts each child after every child that is nearer on all the axes where the two differ; two
  // children nearer on one axis and further on another cannot occlude each other, so their order is free.
  int64_t index[3] = {i, j, k};
  int64_t childBricks = int64_t{1} << (mOctree->depth() - d - 1);
  int highNear = 0;
  for (int a = 0; a < 3; ++a) {
    bool highFirst;
    if (walk.orthographic) {
      highFirst = walk.direction[a] < 0;
    } else {
      // The same expression as the boxes, so an eye on a brick face compares equal to that face.
      double split = voxelFace((2 * index[a] + 1) * childBricks * mBrickSize, mDims[a], mSpacing[a]);
      highFirst = walk.eye[a] >= split;
    }
    if (highFirst) highNear |= 1 << a;
  }
  for (int q = 0; q < 8; ++q) {
    int c = q ^ highNear;
    int64_t ci = 2 * i + (c & 1), cj = 2 * j + ((c >> 1) & 1), ck = 2 * k + ((c >> 2) & 1);
    if (mOctree->exists(d + 1, ci, cj, ck)) visit(walk, d + 1, ci, cj, ck);
  }
}

}  // namespace voxbrick::render
