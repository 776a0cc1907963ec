// Projected tetrahedra (seed 002, Carrard & Juliachs), by vertex pulling: one instance per tetrahedron, a strip of
// four vertices covering its projection exactly (so no sprite-size limit), drawn in the visibility order the CPU gave
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

flat out vec4 vPlane[4];  // barycentric planes: dot(plane.xyz, x) + plane.w
flat out vec4 vScalar;    // normalised value at x: dot(vScalar.xyz, x) + vScalar.w

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
  // A degenerate tet (validation removes them; this guards the division): an empty strip.
  gl_Position = degenerate ? vec4(2.0, 2.0, 0.0, 1.0) : vec4(p[strip[gl_VertexID]], 0.0, 1.0);
}
