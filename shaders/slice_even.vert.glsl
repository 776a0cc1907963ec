// Vertex program of the vertex-geometry slicer (Zellmann & Lang's third variant): the polygon vertices that always
// exist, P0, P2 and P4, as one triangle per box and plane; slice_odd.geom.glsl adds P1, P3 and P5 where the plane
// crosses their dotted edges.
//
// Vertex 3 * i + k of an instance is P(2k) on plane i, found as slice_lean.vert.glsl finds it (the path of row 2k of
// uPaths, sliceCornerPaths in render/volume/SliceTables.h in polygon order). Each also hands on the distances of its path's
// two middle corners, which between them hold the ends of every dotted edge, so that the geometry program computes
// no distance, and whether the plane cuts the half-open box [front, back) at all. Layout: SliceInstance in
// render/volume/SliceTables.h. The library slicer.glsl comes first and declares the instance's
// attributes.

uniform vec3 uPlaneNormal;  // unit, pointing from the eye into the scene
uniform float uPlaneIncr;   // distance between consecutive planes
uniform int uPaths[24];     // the box corners along the path of P0..P5, four per path, front corner first

out vec3 gWorld;           // P(2k)
out vec3 gBoxCoord;
out vec2 gMiddleDistance;  // dot(n, x) of the second and third corners of P(2k)'s path
out int gCut;              // 1 when the plane cuts the half-open box, 0 when the polygon is empty
out vec3 gBoxMin;
out vec3 gBoxMax;
out ivec4 gPayload;
out ivec3 gOwnLo;
out ivec3 gOwnHi;
out float gPlaneDistance;

void main() {
  const int row = (gl_VertexID % 3) * 8;
  precise float planeDistance = aPlaneDistance + float(aFirstPlane + gl_VertexID / 3) * uPlaneIncr;
  const ivec4 path = ivec4(uPaths[row], uPaths[row + 1], uPaths[row + 2], uPaths[row + 3]);
  precise vec4 distances = vec4(cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, path.x),
                               cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, path.y),
                               cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, path.z),
                               cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, path.w));

  const bool cut = distances.x <= planeDistance && planeDistance < distances.w;
  int startCorner = path.x;
  int endCorner = path.x;
  precise float lambda = 0.0;
  if (cut) crossPath(path, distances, planeDistance, startCorner, endCorner, lambda);
  precise vec3 world, boxCoord;
  edgePoint(aBoxMin, aBoxMax, startCorner, endCorner, lambda, world, boxCoord);

  gWorld = world;
  gBoxCoord = boxCoord;
  gMiddleDistance = distances.yz;
  gCut = cut ? 1 : 0;
  gBoxMin = aBoxMin;
  gBoxMax = aBoxMax;
  gPayload = aPayload;
  gOwnLo = aOwnLo;
  gOwnHi = aOwnHi;
  gPlaneDistance = planeDistance;
}
