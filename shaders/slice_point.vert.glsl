// Vertex program of the geometry-program slicer (Zellmann & Lang's second variant): one point per box and plane,
// passed on to slice.geom.glsl, which computes the whole polygon. Vertex i of an instance stands for plane i, at
// dot(n, x) = aPlaneDistance + (aFirstPlane + i) * uPlaneIncr (as in slice.vert.glsl, so every box computes plane k's
// distance bit for bit alike). The library slicer.glsl comes first and declares the instance (SliceInstance in
// render/volume/SliceTables.h).

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
