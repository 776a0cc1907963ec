// Texture slabs: one fragment of a box's back faces (slab.vert.glsl) per slab marches its pixel's ray through the
// slab's global planes [vFirstPlane, vFirstPlane + vPlaneCount), samples (volume_sample.glsl) where the point lies in
// the voxels the box owns (volume_ownership.glsl), composites them front to back in registers and emits the sum once
// (premultiplied), stopping at the termination threshold; what it did is counted (volume_counters.glsl). A box of
// level m takes every 2^m-th plane (those whose index is a multiple of 2^m, the same for every box of that level),
// each sample standing for a segment 2^m planes long. With PRE_INTEGRATION each segment between two samples is
// classified from the pre-integrated table. With EMPTY_TEST, the empty-space silhouette pass: the fragment is kept
// where the slab has any opacity, and writes no colour.
flat in ivec4 vPayload;  // the box's brick (volume_sample.glsl)
flat in ivec3 vOwnLo;
flat in ivec3 vOwnHi;
flat in int vFirstPlane;
flat in int vPlaneCount;

uniform float uPlaneIncr;    // distance between consecutive global planes
uniform float uTermination;  // early ray termination: stop once the fragment's own opacity reaches it (> 1: never)

#ifndef EMPTY_TEST
// The depth test (the silhouette map) before the program runs: a program with atomics would otherwise be run and
// then tested. Marching fragments neither discard nor write depth, so the result is the same. (The empty-space pass
// discards, and must write depth only where it keeps a fragment: it is tested late.)
layout(early_fragment_tests) in;
#endif

out vec4 fragColor;

ivec4 brickPayload() { return vPayload; }

void main() {
  const PixelRay ray = pixelRay();
  const vec3 origin = ray.origin, direction = ray.direction, o = ray.o, inv = ray.inv;
  const float along = ray.along, start = ray.start;
  // The planes the ray can have inside the box: its parameter range in the owned voxels (widened by 1/128 voxel,
  // beyond the ownership test's 1/256 grid) and one plane more each side. The ownership test alone decides.
  const vec2 range = rayBoxRange(o, inv, vec3(vOwnLo) - 1.0 / 128.0, vec3(vOwnHi) + 1.0 / 128.0);
  const int level = levelOf(vPayload.w), stride = 1 << level;
  // The first plane of the level's subset at or after the first plane the ray can have (>> floors negatives too).
  const int first = ((max(vFirstPlane, int(floor((start + along * range.x) / uPlaneIncr)) - 1) + stride - 1) >> level)
                    << level;
  const int last = min(vFirstPlane + vPlaneCount, int(ceil((start + along * range.y) / uPlaneIncr)) + 2);
  // Planes whose point lies at least 1/64 voxel inside every owned face, one plane in from either end for round-off,
  // are owned without a test (the ray's point is off by far less than 1/64 voxel).
  const vec2 inside = rayBoxRange(o, inv, vec3(vOwnLo) + 1.0 / 64.0, vec3(vOwnHi) - 1.0 / 64.0);
  const int insideFirst = int(ceil((start + along * inside.x) / uPlaneIncr)) + 1;
  const int insideLast = int(floor((start + along * inside.y) / uPlaneIncr)) - 1;
  // Faces between boxes are tested on the 1/256-voxel grid, as slices with EXACT_OWNERSHIP; the volume's own faces
  // on the unrounded point, as slicing tests them, so that rays grazing the surface keep the same samples - except
  // faces the planes are parallel to (a view along an axis): a plane through such a face lands on it only on the grid,
  // where the half-open rule keeps exactly one of the samples on the near and far faces, as slicing does.
  const bvec3 parallel = greaterThan(abs(uViewDir), vec3(0.9999));
  const bvec3 unroundedLo = bvec3(ivec3(equal(vOwnLo, ivec3(0))) * ivec3(not(parallel)));
  const bvec3 unroundedHi = bvec3(ivec3(equal(vec3(vOwnHi), uDims)) * ivec3(not(parallel)));
  vec4 sum = vec4(0.0);
  uint taken = 0u, untaken = 0u;
  const float ratio = segmentRatio(origin + direction) * float(stride);
#ifdef PRE_INTEGRATION
  const float layer = layerCoordinate(ratio);
  // The segment from plane k to plane k + 1 belongs to the box owning sample k. Its back sample may lie beyond the
  // box; it is read within half a voxel of the box's faces, where the slot's one-voxel border still holds the
  // neighbours' values (further out, clamped to that shell: an approximation only near faces, for steps above half a
  // voxel).
  const vec3 backLo = vec3(vOwnLo) - 0.5, backHi = vec3(vOwnHi) + 0.5;
  float back = 0.0;
  int backPlane = first - 1;  // the plane `back` was read on
#endif
  for (int k = first; k < last; k += stride) {
    if (sum.a >= uTermination) {
      untaken = uint((last - k + stride - 1) >> level);  // planes, an upper bound of the owned samples left
      break;
    }
    // The ray's point on plane k, as slices with EXACT_OWNERSHIP compute it, so that neighbouring boxes agree on its
    // owner.
    const float planeDistance = float(k) * uPlaneIncr;
    const float t = (planeDistance - start) / along;
    const vec3 world = origin + direction * t;
    const vec3 voxel = world * uInvSpacing + uHalfDims;
    if (k < insideFirst || k > insideLast) {
      if (t < 0.0) continue;  // before the near plane, where slicing's polygons are clipped
      const vec3 snapped = ownershipGrid(voxel);
      if (!ownedBy(mix(snapped, voxel, unroundedLo), mix(snapped, voxel, unroundedHi), vec3(vOwnLo), vec3(vOwnHi)))
        continue;
    }
#ifdef EMPTY_TEST
    // The empty-space silhouette pass: keep the fragment (its depth marks the pixel) at the first sample, or with
    // pre-integration the first segment, the march would give any opacity; discard it if there is none.
#ifdef PRE_INTEGRATION
    const vec3 after = voxelOnPlane(origin, direction, start, along, planeDistance + uPlaneIncr * float(stride));
    if (preIntegrated(sampleAt(voxel), sampleAt(clamp(after, backLo, backHi)), layer).a > 0.0) return;
#else
    if (classify(normalised(sampleAt(voxel))).a > 0.0) return;
#endif
    continue;
#endif
#ifdef PRE_INTEGRATION
    const float value = backPlane == k ? back : sampleAt(voxel);
    const vec3 next = voxelOnPlane(origin, direction, start, along, planeDistance + uPlaneIncr * float(stride));
    back = sampleAt(clamp(next, backLo, backHi));
    backPlane = k + stride;
#else
    const float value = sampleAt(voxel);
#endif
    ++taken;
#ifdef ROOFLINE
    sum = vec4(value * 1e-9);  // below any termination threshold: every sample taken
#elif defined(PRE_INTEGRATION)
    sum += (1.0 - sum.a) * shade(preIntegrated(value, back, layer), world, voxel);
#else
    sum += (1.0 - sum.a) * shadeSample(world, voxel, value, ratio);
#endif
  }
#ifdef EMPTY_TEST
  discard;
#else
  count(VB_COUNTER_FRAGMENTS, 1u);
  if (taken > 0u) count(VB_COUNTER_SAMPLES, taken);
  if (untaken > 0u) count(VB_COUNTER_SAMPLES_TERMINATED, untaken);
  fragColor = sum;
#endif
}
