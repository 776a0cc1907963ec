// Sparse synthetic .vdb files of balls and spherical shells, for benchmarks of volumes far larger than a dense store
// could be (bench/bench_residency.cpp): only the voxels inside a ball are active, so a box of any size costs what
// its balls do.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace voxbrick::store {

/// The voxels whose centres lie between `inner` and `outer` voxels from (x, y, z), all of value `value`.
struct VdbBall {
  double x = 0, y = 0, z = 0, inner = 0, outer = 0;
  float value = 1;
};

/// One float grid of balls.
struct VdbBallsGrid {
  std::string name;
  std::vector<VdbBall> balls;
};

/// Writes `grids` to `path`, each over a box of n³ voxels (two transparent markers, 0.01, at its first and last
/// voxel give every grid that extent). Throws on a write failure.
void writeBallsVdb(const std::filesystem::path& path, int64_t n, const std::vector<VdbBallsGrid>& grids);

}  // namespace voxbrick::store
