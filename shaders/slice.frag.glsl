// Slicing: one fragment of a box's slice polygon is one sample (volume_sample.glsl), emitted premultiplied for
// front-to-back blending.
//
// A fragment is kept only when its sample lies in the voxels its box owns, vOwnLo..vOwnHi (volume_ownership.glsl).
// Whole bricks own the whole volume here: between bricks of one size the rasterised shared edges are exact, and the
// test only cuts the volume's outline, which is then the same for every bricking (surface bricks are drawn a quarter
// voxel larger). With EXACT_OWNERSHIP (sub-blocks, whose boxes of different sizes meet at T-junctions where
// rasterised edges leave cracks and double samples) every box owns just its voxels and is drawn 1/64 voxel larger,
// and the sample is computed from the pixel's ray and the plane alone, so that two boxes see exactly the same point
// and exactly one keeps it.
in vec3 vWorld;
flat in ivec4 vPayload;  // the box's brick (volume_sample.glsl)
flat in ivec3 vOwnLo;
flat in ivec3 vOwnHi;
flat in float vPlaneDistance;

out vec4 fragColor;

ivec4 brickPayload() { return vPayload; }

void main() {
#ifdef EXACT_OWNERSHIP
  // The pixel's ray meets this fragment's plane.
  const PixelRay ray = pixelRay();
  const vec3 world = ray.origin + ray.direction * ((vPlaneDistance - ray.start) / ray.along);
  const vec3 voxel = world * uInvSpacing + uHalfDims;
  // Faces between boxes are tested on the grid. Faces on the volume's surface are tested exactly as for whole
  // bricks, on the interpolated position: a ray grazing the surface then keeps the same samples either way.
  const vec3 snapped = ownershipGrid(voxel);
  const vec3 interpolated = vWorld * uInvSpacing + uHalfDims;
  const vec3 ownedLo = mix(snapped, interpolated, equal(vOwnLo, ivec3(0)));
  const vec3 ownedHi = mix(snapped, interpolated, equal(vec3(vOwnHi), uDims));
#else
  const vec3 world = vWorld;
  const vec3 voxel = world * uInvSpacing + uHalfDims;
  const vec3 ownedLo = voxel, ownedHi = voxel;
#endif
  if (!ownedBy(ownedLo, ownedHi, vec3(vOwnLo), vec3(vOwnHi))) discard;
  const float value = sampleAt(voxel);
#ifdef ROOFLINE
  fragColor = vec4(value);
  return;
#endif
  fragColor = shadeSample(world, voxel, value, segmentRatio(world));
}
