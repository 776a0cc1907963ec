// Vertex program of the CPU slicer: polygons arrive as world-space triangles computed by render/Slicing.cpp
// (rezkSalamaPolygon, the CPU mirror of slice.vert.glsl), each vertex with its brick's payload.

layout(location = 0) in vec3 aWorld;
layout(location = 3) in ivec4 aPayload;

uniform mat4 uViewProj;

out vec3 vWorld;
flat out ivec4 vPayload;

void main() {
  vWorld = aWorld;
  vPayload = aPayload;
  gl_Position = uViewProj * vec4(aWorld, 1.0);
}
