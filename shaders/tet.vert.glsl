// Projected tetrahedra (seed 002, Carrard & Juliachs), by vertex pulling: one instance per tetrahedron, four vertices
// of a quad covering its projection (so no sprite-size limit), drawn in the visibility order the CPU gave
// (render/TetRenderer.h). The tet's 64 bytes (four vec4: position xyz, scalar w) are read once per quad corner from
// a storage buffer, the same bytes a point sprite would carry.
//
// Per-tet constants for the fragment stage, computed here: the four face planes scaled to be the barycentric
// coordinates (plane i is 1 at vertex i and 0 on the opposite face, so the tet is where all four are >= 0), and the
// scalar as a linear function of position (sum of s_i times plane i), normalised through the value window.
layout(std430, binding = 1) readonly buffer TetVertices { vec4 uTetVertices[]; };
layout(std430, binding = 2) readonly buffer TetOrder { uint uOrder[]; };

uniform mat4 uViewProj;   // world (centred on the mesh) to clip
uniform float uWindowLo;  // the value window [lo, hi] as lo and 1 / (hi - lo)
uniform float uWindowScale;
uniform vec2 uPixel;      // 2 / viewport size: one pixel in normalised device coordinates

flat out vec4 vPlane[4];  // barycentric planes: dot(plane.xyz, x) + plane.w
flat out vec4 vScalar;    // normalised value at x: dot(vScalar.xyz, x) + vScalar.w

void main() {
  const uint tet = uOrder[gl_InstanceID];
  vec4 v[4];
  for (int i = 0; i < 4; ++i) v[i] = uTetVertices[4u * tet + uint(i)];
  // Face i is opposite vertex i; its plane is scaled so that it is 1 at vertex i.
  vec4 scalar = vec4(0.0);
  bool degenerate = false;
  for (int i = 0; i < 4; ++i) {
    const vec3 a = v[(i + 1) & 3].xyz, b = v[(i + 2) & 3].xyz, c = v[(i + 3) & 3].xyz;
    const vec3 n = cross(b - a, c - a);
    const float atVertex = dot(n, v[i].xyz - a);
    degenerate = degenerate || abs(atVertex) <= 1e-30;
    const vec4 plane = vec4(n, -dot(n, a)) / atVertex;
    vPlane[i] = plane;
    scalar += plane * ((v[i].w - uWindowLo) * uWindowScale);
  }
  vScalar = scalar;
  // The quad: the projection's bounding rectangle, a pixel wider each way (conservative for rasterisation); the
  // whole viewport if a vertex lies behind the eye (w <= 0), where the projection has no bounds.
  vec2 lo = vec2(1e30), hi = vec2(-1e30);
  bool behind = false;
  for (int i = 0; i < 4; ++i) {
    const vec4 clip = uViewProj * vec4(v[i].xyz, 1.0);
    behind = behind || clip.w <= 1e-20;
    const vec2 ndc = clip.xy / clip.w;
    lo = min(lo, ndc);
    hi = max(hi, ndc);
  }
  if (behind) {
    lo = vec2(-1.0);
    hi = vec2(1.0);
  }
  lo = max(lo - uPixel, vec2(-1.0));
  hi = min(hi + uPixel, vec2(1.0));
  const vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));
  // A degenerate tet (validation removes them; this guards the division) or one outside the view: an empty quad.
  const bool empty = degenerate || any(greaterThan(lo, hi));
  gl_Position = empty ? vec4(2.0, 2.0, 0.0, 1.0) : vec4(mix(lo, hi, corner), 0.0, 1.0);
}
