// Projected tetrahedra (Carrard & Juliachs), by vertex pulling: one instance per tetrahedron, a strip of
// four vertices covering its projection exactly (so no sprite-size limit), drawn in the visibility order the CPU gave
// (render/gl/tets/TetRenderer.h). The tet's 64 bytes (four vec4: position xyz, scalar w) are read once per quad corner from
// a storage buffer, the same bytes a point sprite would carry.
//
// What the fragment stage needs, computed here. The four face planes scaled to be the barycentric coordinates (plane
// i is 1 at vertex i and 0 on the opposite face, so the tet is where all four are >= 0) and the scalar as a linear
// function of position (the sum of s_i times plane i, normalised through the value window). Along the pixel ray
// origin + t * direction (both affine in window coordinates), plane i is at_i + t * rate_i and the scalar
// s0 + t * s1, and at_i, rate_i, s0, s1 are themselves affine in window coordinates: computed at the strip's
// corners, they are interpolated exactly (noperspective) to every fragment, which then needs only four divisions
// to find where its ray enters and leaves the tet.
layout(std430, binding = VB_BINDING_TET_VERTICES) readonly buffer TetVertices { vec4 uTetVertices[]; };
layout(std430, binding = VB_BINDING_TET_ORDER) readonly buffer TetOrder { uint uOrder[]; };

uniform int uOrderOffset;  // the first of this draw's tets in the order (a frame is drawn in several draws)
uniform mat4 uViewProj;   // world (centred on the mesh) to clip
uniform float uWindowLo;  // the value window [lo, hi] as lo and 1 / (hi - lo)
uniform float uWindowScale;
uniform vec2 uViewport;   // width, height in pixels
uniform vec3 uRayOrigin, uRayOriginDx, uRayOriginDy;           // ray origin (near plane) at window (x, y)
uniform vec3 uRayDirection, uRayDirectionDx, uRayDirectionDy;  // near plane to far plane at window (x, y)

noperspective out vec4 vAt;    // the planes at the ray's origin
noperspective out vec4 vRate;  // the planes' change along the ray (per unit of t)
noperspective out vec2 vValue; // the normalised scalar at the origin and its change along the ray
flat out vec4 vNormSquared;    // |n_i|^2 of each plane, for the test of a ray parallel to a face
flat out vec4 vTie;            // each plane's side of a ray lying in it (tet.frag.glsl)
#ifdef SHADING
flat out vec3 vGradient;       // the raw scalar's gradient (per world unit): constant in a tet, its shading normal
#endif

// Twice the signed area of triangle (a, b, c).
float orient(vec2 a, vec2 b, vec2 c) { return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x); }

// Whether segments ab and cd cross (properly: touching ends do not count).
bool cross2(vec2 a, vec2 b, vec2 c, vec2 d) {
  return orient(a, b, c) * orient(a, b, d) < 0.0 && orient(c, d, a) * orient(c, d, b) < 0.0;
}

// A triangle strip of four of the points (indices) covering their convex hull. If two of the three ways of pairing
// the points gives crossing segments, those are the quadrilateral's diagonals a-b and c-d, its boundary runs
// a, c, b, d, and the strip a, c, d, b cuts it along c-d. Otherwise one point lies inside the triangle of the other
// three: the strip is that triangle, its last vertex repeated.
ivec4 hullStrip(vec2 p[4]) {
  if (cross2(p[0], p[1], p[2], p[3])) return ivec4(0, 2, 3, 1);
  if (cross2(p[0], p[2], p[1], p[3])) return ivec4(0, 1, 3, 2);
  if (cross2(p[0], p[3], p[1], p[2])) return ivec4(0, 1, 2, 3);
  for (int k = 0; k < 4; ++k) {
    const int a = (k + 1) & 3, b = (k + 2) & 3, c = (k + 3) & 3;
    const float s0 = orient(p[a], p[b], p[k]), s1 = orient(p[b], p[c], p[k]), s2 = orient(p[c], p[a], p[k]);
    if ((s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0)) return ivec4(a, b, c, c);
  }
  return ivec4(0, 1, 2, 3);  // not reached for four points in a plane; a strip of them all otherwise
}

void main() {
  const uint tet = uOrder[uOrderOffset + gl_InstanceID];
  vec4 v[4];
  for (int i = 0; i < 4; ++i) v[i] = uTetVertices[4u * tet + uint(i)];
  // Face i is opposite vertex i; its plane is scaled so that it is 1 at vertex i.
  vec4 plane[4];
  vec4 scalar = vec4(0.0);
  bool degenerate = false;
  for (int i = 0; i < 4; ++i) {
    const vec3 a = v[(i + 1) & 3].xyz, b = v[(i + 2) & 3].xyz, c = v[(i + 3) & 3].xyz;
    const vec3 n = cross(b - a, c - a);
    const float atVertex = dot(n, v[i].xyz - a);
    degenerate = degenerate || abs(atVertex) <= 1e-30;
    plane[i] = vec4(n, -dot(n, a)) / atVertex;
    scalar += plane[i] * ((v[i].w - uWindowLo) * uWindowScale);
  }
  // The tet's projection, a triangle or a convex quadrilateral (the convex hull of its four projected vertices),
  // drawn as a strip of four vertices: only pixels whose rays meet the tet start a fragment (a bounding rectangle
  // would start about twice as many). A vertex behind the eye (w <= 0) leaves the projection unbounded: then the
  // whole viewport.
  vec2 p[4];
  bool behind = false;
  for (int i = 0; i < 4; ++i) {
    const vec4 clip = uViewProj * vec4(v[i].xyz, 1.0);
    behind = behind || clip.w <= 1e-20;
    p[i] = clip.xy / clip.w;
  }
  ivec4 strip;
  if (behind) {
    p[0] = vec2(-1.0, -1.0);
    p[1] = vec2(1.0, -1.0);
    p[2] = vec2(-1.0, 1.0);
    p[3] = vec2(1.0, 1.0);
    strip = ivec4(0, 1, 2, 3);
  } else {
    strip = hullStrip(p);
  }
  const vec2 corner = p[strip[gl_VertexID]];
  // A degenerate tet (validation removes them; this guards the division): an empty strip.
  gl_Position = degenerate ? vec4(2.0, 2.0, 0.0, 1.0) : vec4(corner, 0.0, 1.0);
  // The ray through this corner, and the affine quantities there.
  const vec2 window = (corner * 0.5 + 0.5) * uViewport;
  const vec3 origin = uRayOrigin + window.x * uRayOriginDx + window.y * uRayOriginDy;
  const vec3 direction = uRayDirection + window.x * uRayDirectionDx + window.y * uRayDirectionDy;
  for (int i = 0; i < 4; ++i) {
    const vec3 n = plane[i].xyz;
    vAt[i] = dot(n, origin) + plane[i].w;
    vRate[i] = dot(n, direction);
    vNormSquared[i] = dot(n, n);
    // A ray in the face's plane is taken as moved by eps * (one pixel right) + eps^2 * (one pixel up): the two tets
    // sharing the face have planes pointing opposite ways, so exactly one keeps it.
    const float right = dot(n, uRayOriginDx);
    vTie[i] = right * right > 1e-12 * dot(n, n) * dot(uRayOriginDx, uRayOriginDx) ? right : dot(n, uRayOriginDy);
  }
  vValue = vec2(dot(scalar.xyz, origin) + scalar.w, dot(scalar.xyz, direction));
#ifdef SHADING
  vGradient = scalar.xyz / uWindowScale;
#endif
}
