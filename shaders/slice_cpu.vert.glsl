// Vertex program of the CPU slicer: polygons arrive as world-space triangles computed by render/volume/Slicing.cpp
// (rezkSalamaPolygon, the CPU mirror of slice.vert.glsl), each vertex with its box's payload, the global index of
// its plane and the voxels the box owns (the outputs of slice.vert.glsl).

layout(location = 0) in vec3 aWorld;
layout(location = 3) in ivec4 aPayload;
layout(location = 4) in int aPlane;
layout(location = 5) in ivec3 aOwnLo;
layout(location = 6) in ivec3 aOwnHi;

uniform mat4 uViewProj;
uniform float uPlaneIncr;

out vec3 vWorld;
flat out ivec4 vPayload;
flat out ivec3 vOwnLo;
flat out ivec3 vOwnHi;
flat out float vPlaneDistance;

void main() {
  vWorld = aWorld;
  vPayload = aPayload;
  vOwnLo = aOwnLo;
  vOwnHi = aOwnHi;
  vPlaneDistance = float(aPlane) * uPlaneIncr;
  gl_Position = uViewProj * vec4(aWorld, 1.0);
}
