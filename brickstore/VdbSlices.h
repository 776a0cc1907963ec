// Slices of a dense volume into an OpenVDB float tree, leaf by leaf: the tree tools::copyFromDense builds (tolerance
// 0), with whole leaves filled straight from the slices. Internal to brickstore/ (it includes OpenVDB).
#pragma once

#include <cstdint>

#include <openvdb/openvdb.h>

#include "brickstore/Types.h"

namespace voxbrick::store {

/// Adds `count` slices of a dims.x x dims.y volume of T (x fastest, then y), the first at z = z0, to `tree`: index
/// (x, y, z) takes the value converted to float, active unless it equals the tree's background (then it holds the
/// background, inactive). The resulting tree (leaves, tiles, values, active states) is the one
/// tools::copyFromDense(dense, tree, 0.0f) gives for the same box, also when the slices start or end inside a leaf
/// that an earlier call began; a leaf whose 8^3 voxels all lie in the slices is filled without a first fill,
/// probe or per-voxel bounds, which makes this about twice as fast.
template <typename T>
void addSlicesToTree(openvdb::FloatTree& tree, const T* values, const Vec3i& dims, int64_t z0, int64_t count);

}  // namespace voxbrick::store
