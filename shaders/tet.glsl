// What the tetrahedral meshes' programs share (tet.frag.glsl: projected tets; tet_walk.glsl: the adjacency ray
// caster, in its fragment and compute kernels): a ray segment through one tet, with its scalar linear along it,
// classified from the pre-integrated table (front value, back value, length: render/core/PreIntegration.h, the
// optical model of ARCHITECTURE.md), and with SHADING its headlight. Exact for perspective rays: the segment is the
// pixel's own, in world units. With TET_RAY, the ray caster's buffers, pixel ray and edge product
// (render/gl/tets/TetRayCaster.h). With PART_CLIP, a sort-last part's box, which each ray's integration is clipped to
// (FrameOptions::meshPart).
#if defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE)
uniform float uInvReference;  // 1 / the transfer function's reference length

// The pre-integrated table (render/core/PreIntegration.h), its resolution and length layers.
layout(binding = VB_UNIT_PRE_INTEGRATED) uniform sampler3D uPreIntegrated;
uniform float uTableResolution;
uniform float uRatioMin;
uniform float uLayerScale;
uniform float uLayers;

// The premultiplied colour and opacity of a segment whose normalised scalar runs from `front` to `back` over `ratio`
// reference lengths. (Level 0 explicitly: the ray caster looks the table up in a loop, where implicit derivatives
// are undefined; the table has one level and one filter, so this is what texture() reads.)
vec4 classifySegment(float front, float back, float ratio) {
  // Below the table's shortest segment both colour and opacity are linear in the length to first order (a thin
  // segment): the shortest layer's entry, scaled.
  const float scale = ratio < uRatioMin ? ratio / uRatioMin : 1.0;
  const float layer = (clamp(log(max(ratio, uRatioMin) / uRatioMin) * uLayerScale, 0.0, uLayers - 1.0) + 0.5) / uLayers;
  const vec2 st = (clamp(vec2(front, back), 0.0, 1.0) * (uTableResolution - 1.0) + 0.5) / uTableResolution;
  return textureLod(uPreIntegrated, vec3(st, layer), 0.0) * scale;
}

#ifdef SHADING
// The grids' two-sided Phong headlight (render/reference/Headlight.h, volume_sample.glsl), normal -gradient / |gradient|, for a
// segment along `direction` through a tet whose raw scalar has `gradient` (per world unit). In a tet both the normal
// and the direction to the eye (against the ray's) are constant along the segment, so shading the emission, c x +
// y, shades the pre-integrated segment exactly: C x + y A, premultiplied.
vec4 shadeSegment(vec4 segment, vec3 gradient, vec3 direction) {
  const float magnitude = length(gradient);
  if (magnitude <= 1e-12) return segment;
  const float diffuse = abs(dot(gradient, direction)) / (magnitude * length(direction));
  return vec4(segment.rgb * (0.3 + 0.7 * diffuse) + vec3(0.25 * pow(diffuse, 32.0) * segment.a), segment.a);
}
#endif
#endif

#if defined(PART_CLIP) && (defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE))
// The part's box (FrameOptions::meshPart), centred on the mesh's box as the vertices are.
uniform vec3 uPartLo, uPartHi;

// The range [x, y] of t where the ray origin + t * direction is inside the part's box (x > y: it misses). Two parts
// that share a plane compute its t from the same float with the same expression, so that a segment crossing the
// plane is cut at one t: its stretches on either side add up to it, with neither gap nor overlap.
vec2 partRange(vec3 origin, vec3 direction) {
  float enter = -3.0e38, leave = 3.0e38;
  for (int a = 0; a < 3; ++a) {
    if (direction[a] != 0.0) {
      precise float toLo = (uPartLo[a] - origin[a]) / direction[a];
      precise float toHi = (uPartHi[a] - origin[a]) / direction[a];
      enter = max(enter, min(toLo, toHi));
      leave = min(leave, max(toLo, toHi));
    } else if (origin[a] < uPartLo[a] || origin[a] > uPartHi[a]) {
      return vec2(1.0, 0.0);
    }
  }
  return vec2(enter, leave);
}
#endif

#if defined(TET_RAY) && (defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE))
// The ray caster's tets: four vertices each (position centred on the mesh's box, raw scalar; the projected tets'
// buffer), and across each face the neighbour and its face, coded as tet * 8 + 4 if the tet's stored order is
// negatively oriented + face, or -1 on the boundary.
layout(std430, binding = VB_BINDING_TET_VERTICES) readonly buffer TetVertices { vec4 uTetVertices[]; };
layout(std430, binding = VB_BINDING_TET_NEIGHBOURS) readonly buffer TetNeighbours { ivec4 uNext[]; };
// Per pixel (row-major, bottom row first): the ray parameter where the last pass left the mesh, -1 before the first
// pass, 2 once the ray terminated (beyond every entry: t runs from 0 on the near plane to 1 on the far plane).
layout(std430, binding = VB_BINDING_RAY_EXITS) buffer RayExits { float uExits[]; };
uniform int uWidth;
uniform vec3 uRayOrigin, uRayOriginDx, uRayOriginDy;           // ray origin (near plane) at window (x, y)
uniform vec3 uRayDirection, uRayDirectionDx, uRayDirectionDy;  // near plane to far plane at window (x, y)

// The pixel's window coordinates (its centre): gl_FragCoord's, or in the compute kernel its invocation's, which it sets
// before anything reads them.
#ifdef COMPUTE_STAGE
vec2 gPixelCoord = vec2(0.0);
vec2 pixelCoord() { return gPixelCoord; }
#else
vec2 pixelCoord() { return gl_FragCoord.xy; }
#endif
int pixelIndex() { return int(pixelCoord().y) * uWidth + int(pixelCoord().x); }
vec3 rayOrigin() { return uRayOrigin + pixelCoord().x * uRayOriginDx + pixelCoord().y * uRayOriginDy; }
vec3 rayDirection() { return uRayDirection + pixelCoord().x * uRayDirectionDx + pixelCoord().y * uRayDirectionDy; }

// The Plücker product of edge p -> q (p its lower end in an order fixed for the mesh) with the ray of direction d
// and moment m = cross(origin, d): dot(q, cross(d, p)) + dot(q, m) - dot(p, m), computed the same way wherever the
// edge appears (the ray pass and the entry pass).
// A product of 0 (the ray meets the edge's line, or runs along a face) is replaced by the sign of its change as the
// ray moves by eps * right + eps^2 * up, scaled far below any product that is not 0: a sign the tets around the edge
// again agree on. An edge parallel to the ray stays 0: the moved ray passes no face containing it.
float edgeProduct(vec3 p, vec3 q, vec3 d, vec3 m) {
  precise float product = dot(q, cross(d, p)) + dot(q, m) - dot(p, m);
  if (product != 0.0) return product;
  const vec3 c = cross(d, q - p);
  const float right = dot(uRayOriginDx, c);
  return 1e-30 * sign(right != 0.0 ? right : dot(uRayOriginDy, c));
}
#endif
