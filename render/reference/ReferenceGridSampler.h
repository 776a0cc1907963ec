// The reference renderer's reconstruction of a brick store: trilinear over bricks, of level 0 or per-brick levels.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "brickstore/format/StoreMeta.h"
#include "render/reference/ReferenceBricks.h"

namespace voxbrick::render::reference {

/// Trilinear reconstruction at a level-0 voxel coordinate (voxel i's centre at i + ½), clamp-to-edge, of level 0 or,
/// with per-brick levels, of the level chosen for the level-0 brick the point lies in (at the coordinate clamped to
/// the volume times 2^-m). The cell's lower corner picks the brick of that level, whose one-voxel border holds the
/// upper corner, as on the GPU.
template <typename T>
class GridSampler {
 public:
  GridSampler(ReferenceBricks& bricks, const store::StoreMeta& meta, const std::vector<uint8_t>& brickLevels)
      : mBricks(bricks),
        mMeta(meta),
        mDims(meta.dims),
        mBrick(meta.brickSize),
        mEdge(meta.brickSize + 2),
        mBrickGrid(meta.levels.at(0).bricks),
        mBrickLevels(brickLevels) {}

  double operator()(const glm::dvec3& p) const {
    int level = 0;
    glm::dvec3 q = p;
    if (!mBrickLevels.empty()) {
      int64_t b[3];
      for (int a = 0; a < 3; ++a) {
        q[a] = std::clamp(p[a], 0.0, double(mDims[a]));
        b[a] = std::min(int64_t(q[a]), mDims[a] - 1) / mBrick;
      }
      level = mBrickLevels[size_t(b[0] + mBrickGrid.x * (b[1] + mBrickGrid.y * b[2]))];
      q = std::ldexp(1.0, -level) * q;
    }
    const store::LevelMeta& lm = mMeta.levels[size_t(level)];
    int64_t brick[3], local[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
      const double u = std::clamp(q[a] - 0.5, 0.0, double(lm.dims[a] - 1));
      const int64_t i = std::min(int64_t(u), lm.dims[a] - 1);
      f[a] = u - double(i);
      brick[a] = i / mBrick;
      local[a] = i - brick[a] * mBrick + 1;
    }
    const store::BrickKey key{uint32_t(level), uint32_t(brick[0]), uint32_t(brick[1]), uint32_t(brick[2])};
    const size_t index = mBricks.index(key, size_t(brick[0] + lm.bricks.x * (brick[1] + lm.bricks.y * brick[2])));
    const T* v = static_cast<const T*>(mBricks.data(key, index)) + (local[0] + mEdge * (local[1] + mEdge * local[2]));
    const int64_t dy = mEdge, dz = mEdge * mEdge;
    auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
    const double x00 = lerp(double(v[0]), double(v[1]), f[0]);
    const double x10 = lerp(double(v[dy]), double(v[dy + 1]), f[0]);
    const double x01 = lerp(double(v[dz]), double(v[dz + 1]), f[0]);
    const double x11 = lerp(double(v[dz + dy]), double(v[dz + dy + 1]), f[0]);
    return lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2]);
  }

 private:
  ReferenceBricks& mBricks;
  const store::StoreMeta& mMeta;
  store::Vec3i mDims;
  int64_t mBrick, mEdge;
  store::Vec3i mBrickGrid;
  const std::vector<uint8_t>& mBrickLevels;
};

}  // namespace voxbrick::render::reference
