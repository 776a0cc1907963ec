// Geometry program of the geometry-program slicer (Zellmann & Lang's second variant): the polygon where one plane cuts
// one box, from one point (slice_point.vert.glsl), as a triangle strip of four triangles.
//
// The polygon is the vertex-lean slicer's (slice_lean.vert.glsl): the vertices walk the paths of uPaths
// (sliceCornerPaths in render/volume/SliceTables.h), here with the rows in strip order (kSliceStrip: P0, P1, P5, P2, P4,
// P3), so that the strip zigzags across the polygon and its triangles run counter-clockwise as the fan's do. A
// polygon of fewer than six corners repeats vertices, as in the paper: the triangles they empty rasterise nothing.
// A plane outside the half-open box [front, back) emits nothing. The library slicer.glsl comes first.

layout(points) in;
layout(triangle_strip, max_vertices = 6) out;

in vec3 gBoxMin[];
in vec3 gBoxMax[];
in ivec4 gPayload[];
in ivec3 gOwnLo[];
in ivec3 gOwnHi[];
in float gPlaneDistance[];

uniform vec3 uPlaneNormal;  // unit, pointing from the eye into the scene
uniform mat4 uViewProj;     // world to clip
uniform int uPaths[24];     // the box corners along the path of each strip vertex, four per path, front corner first

out vec3 vWorld;
out vec3 vBoxCoord;
flat out ivec4 vPayload;
flat out ivec3 vOwnLo;
flat out ivec3 vOwnHi;
flat out float vPlaneDistance;

void main() {
  const vec3 boxMin = gBoxMin[0];
  const vec3 boxMax = gBoxMax[0];
  const float planeDistance = gPlaneDistance[0];
  precise float distances[8];
  for (int corner = 0; corner < 8; ++corner) distances[corner] = cornerDistance(uPlaneNormal, boxMin, boxMax, corner);
  if (!(distances[uPaths[0]] <= planeDistance && planeDistance < distances[uPaths[3]])) return;

  for (int row = 0; row < 24; row += 4) {
    const ivec4 path = ivec4(uPaths[row], uPaths[row + 1], uPaths[row + 2], uPaths[row + 3]);
    int startCorner, endCorner;
    precise float lambda;
    crossPath(path, vec4(distances[path.x], distances[path.y], distances[path.z], distances[path.w]), planeDistance,
              startCorner, endCorner, lambda);
    precise vec3 world, boxCoord;
    edgePoint(boxMin, boxMax, startCorner, endCorner, lambda, world, boxCoord);
    // Outputs are undefined after each EmitVertex: all of them are written for every vertex.
    vWorld = world;
    vBoxCoord = boxCoord;
    vPayload = gPayload[0];
    vOwnLo = gOwnLo[0];
    vOwnHi = gOwnHi[0];
    vPlaneDistance = planeDistance;
    gl_Position = uViewProj * vec4(world, 1.0);
    EmitVertex();
  }
  EndPrimitive();
}
