// Vertex program of the geometry-program slicer (Zellmann & Lang's second variant): one point per box and plane,
// passed on to slice.geom.glsl, which computes the whole polygon. Vertex i of an instance stands for plane i, at
// dot(n, x) = aPlaneDistance + (aFirstPlane + i) * uPlaneIncr (as in slice.vert.glsl, so every box computes plane k's
// distance bit for bit alike). Layout: SliceInstance in render/SliceTables.h.

layout(location = 0) in vec3 aBoxMin;
layout(location = 1) in vec3 aBoxMax;
layout(location = 2) in float aPlaneDistance;
layout(location = 3) in ivec4 aPayload;
layout(location = 4) in int aFirstPlane;
layout(location = 5) in ivec3 aOwnLo;
layout(location = 6) in ivec3 aOwnHi;

uniform float uPlaneIncr;  // distance between consecutive planes

out vec3 gBoxMin;
out vec3 gBoxMax;
out ivec4 gPayload;
out ivec3 gOwnLo;
out ivec3 gOwnHi;
out float gPlaneDistance;

void main() {
  precise float planeDistance = aPlaneDistance + float(aFirstPlane + gl_VertexID) * uPlaneIncr;
  gBoxMin = aBoxMin;
  gBoxMax = aBoxMax;
  gPayload = aPayload;
  gOwnLo = aOwnLo;
  gOwnHi = aOwnHi;
  gPlaneDistance = planeDistance;
}
