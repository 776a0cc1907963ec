// Slicer vertex program, lean (Zellmann & Lang's first variant): the vertex program of slice.vert.glsl with the
// choice of paths moved to the CPU and one table.
//
// The instance layout, the draw (12 vertices per plane, the fan kFan) and the outputs are slice.vert.glsl's. What
// depends only on the view direction (the front corner, and which box corner plays each Vi) is looked up once per
// frame on the CPU: uPaths (sliceCornerPaths in render/volume/SliceTables.h) holds, for each polygon vertex Pp, the four
// box corners of the path it walks from the front corner to the back one. A vertex reads its row, computes the
// distances of those four corners and tests at most three edges, where slice.vert.glsl computes eight and tests up
// to four through three tables. The odd vertices walk their own paths (the dotted edge second), so where the
// polygon has fewer than six corners they repeat a neighbour on either side; the fan draws the same triangles.
// The library slicer.glsl comes first and declares the instance's attributes.

uniform vec3 uPlaneNormal;  // unit, pointing from the eye into the scene
uniform float uPlaneIncr;   // distance between consecutive planes
uniform mat4 uViewProj;     // world to clip
uniform int uPaths[24];     // the box corners along the path of P0..P5, four per path, front corner first

out vec3 vWorld;
out vec3 vBoxCoord;
flat out ivec4 vPayload;
flat out ivec3 vOwnLo;
flat out ivec3 vOwnHi;
flat out float vPlaneDistance;

const int kFan[12] = int[12](0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5);

void main() {
  const int row = kFan[gl_VertexID % 12] * 4;
  precise float planeDistance = aPlaneDistance + float(aFirstPlane + gl_VertexID / 12) * uPlaneIncr;
  const ivec4 path = ivec4(uPaths[row], uPaths[row + 1], uPaths[row + 2], uPaths[row + 3]);
  precise vec4 distances = vec4(cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, path.x),
                               cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, path.y),
                               cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, path.z),
                               cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, path.w));

  // Every path runs from the front corner to the back one: outside [front, back), the polygon collapses onto the
  // front corner, as in slice.vert.glsl.
  int startCorner = path.x;
  int endCorner = path.x;
  precise float lambda = 0.0;
  if (distances.x <= planeDistance && planeDistance < distances.w) {
    crossPath(path, distances, planeDistance, startCorner, endCorner, lambda);
  }
  precise vec3 world, boxCoord;
  edgePoint(aBoxMin, aBoxMax, startCorner, endCorner, lambda, world, boxCoord);

  vWorld = world;
  vBoxCoord = boxCoord;
  vPayload = aPayload;
  vOwnLo = aOwnLo;
  vOwnHi = aOwnHi;
  vPlaneDistance = planeDistance;
  gl_Position = uViewProj * vec4(world, 1.0);
}
