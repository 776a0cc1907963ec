// Which box owns a sample, for the grid programs (slice.frag.glsl, slab.frag.glsl, raycast.frag.glsl): a sample is
// kept only where its point lies in the voxels its box owns (half-open: the face towards the eye included), so that
// boxes that meet sample their shared faces once. Where boxes of different sizes meet, two boxes must see exactly the
// same point: it is computed from the pixel's ray and the plane alone, and faces between boxes are tested on a grid
// of 1/256 voxel (ownershipGrid).
#if defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE)

// Whether voxel coordinates `lo` and `hi` (the same point, or two roundings of it) lie in the voxels [ownLo, ownHi):
// half-open, the face towards the eye included.
bool ownedBy(vec3 lo, vec3 hi, vec3 ownLo, vec3 ownHi) {
  bool inside = true;
  for (int a = 0; a < 3; ++a) {
    inside = inside && (uViewDir[a] >= 0.0 ? (lo[a] >= ownLo[a] && hi[a] < ownHi[a])
                                           : (lo[a] > ownLo[a] && hi[a] <= ownHi[a]));
  }
  return inside;
}

// A voxel coordinate on the 1/256-voxel grid where faces between boxes are tested, so that a plane through a face (a
// view along an axis) lands on it despite the round-off of the ray.
vec3 ownershipGrid(vec3 voxel) { return round(voxel * 256.0) * (1.0 / 256.0); }

#endif
