// The pixel's ray of the grid programs that compute their samples from it (slabs, the frame ray caster, and slices
// with EXACT_OWNERSHIP): its origin and direction are affine in window coordinates. A fragment's window coordinates
// are gl_FragCoord's; the compute ray caster gives its pixel's centre, the same numbers.
#if defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE)

uniform vec3 uRayOrigin, uRayOriginDx, uRayOriginDy;           // ray origin (on the near plane) at window (x, y)
uniform vec3 uRayDirection, uRayDirectionDx, uRayDirectionDy;  // near plane to far plane at window (x, y)

// This pixel's ray, origin (on the near plane) + t·direction in world units (both affine in window coordinates),
// their components along the view axis (start, along), and the same ray in voxel coordinates, o + t·dv, with inv the
// reciprocal of dv (components below 1e-20 replaced, so that it stays finite).
struct PixelRay {
  vec3 origin, direction;
  float along, start;
  vec3 o, inv;
};

PixelRay pixelRayAt(vec2 window) {
  PixelRay r;
  r.origin = uRayOrigin + window.x * uRayOriginDx + window.y * uRayOriginDy;
  r.direction = uRayDirection + window.x * uRayDirectionDx + window.y * uRayDirectionDy;
  r.along = dot(uViewDir, r.direction);
  r.start = dot(uViewDir, r.origin);
  r.o = r.origin * uInvSpacing + uHalfDims;
  const vec3 dv = r.direction * uInvSpacing;
  r.inv = 1.0 / mix(dv, vec3(1e-20), lessThan(abs(dv), vec3(1e-20)));
  return r;
}

#ifdef FRAGMENT_STAGE
// This fragment's ray: at its pixel's centre.
PixelRay pixelRay() { return pixelRayAt(gl_FragCoord.xy); }
#endif

// The parameter range (in, out) of the ray o + t·d (voxel coordinates, inv = 1 / d) inside the box [lo, hi], from
// t = 0 on: empty when in > out.
vec2 rayBoxRange(vec3 o, vec3 inv, vec3 lo, vec3 hi) {
  const vec3 a = (lo - o) * inv, b = (hi - o) * inv;
  return vec2(max(max(min(a.x, b.x), min(a.y, b.y)), max(min(a.z, b.z), 0.0)),
              min(min(max(a.x, b.x), max(a.y, b.y)), max(a.z, b.z)));
}

// The voxel coordinate of the ray origin + t·direction where it meets the plane at `distance` along the view axis
// (start and along: the origin's and the direction's components along it).
vec3 voxelOnPlane(vec3 origin, vec3 direction, float start, float along, float distance) {
  return (origin + direction * ((distance - start) / along)) * uInvSpacing + uHalfDims;
}

#endif
