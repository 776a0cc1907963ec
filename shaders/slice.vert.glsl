// Slicer vertex program (Rezk-Salama & Kolb, VMV 2005): one box-plane intersection polygon per instance, in view order.
//
// Each instance is one axis-aligned world-space box and a run of planes; vertex 12 * i + k of the instance is vertex
// kFan[k] of the polygon cut by plane i, dot(uPlaneNormal, x) = aPlaneDistance + (aFirstPlane + i) * uPlaneIncr.
// With aPlaneDistance = 0 and aFirstPlane the global index k of the first plane, every box computes plane k's
// distance bit for bit alike, so neighbours agree on which of them owns a plane through a shared face.
// render/volume/SliceTables.h holds the tables (uploaded into uSequence, uEdgeStart, uEdgeEnd), the corner numbering and the
// instance layout; render/volume/Slicing.cpp mirrors this program on the CPU, line for line. The library slicer.glsl comes
// first and declares the instance's attributes.
//
// Where it departs from the paper's listing, it does so for robustness in float: the distances of the eight corners
// are computed once, up front, instead of once per edge, so along every path they grow monotonically and a plane
// inside the box always finds its edge on each path (per-edge sums can, by rounding, miss a plane through a corner);
// a plane outside the box gives a defined, empty polygon (the paper leaves it undefined); and vertices are computed
// from world-space corners alone, exact at the corners, so two boxes sharing a face produce bit-identical vertices
// on it and slices of neighbouring bricks meet without cracks (slicer.glsl's edgePoint).

uniform vec3 uPlaneNormal;  // unit, pointing from the eye into the scene
uniform float uPlaneIncr;   // distance between consecutive planes
uniform mat4 uViewProj;     // world to clip
uniform int uSequence[64];
uniform int uEdgeStart[24];
uniform int uEdgeEnd[24];

out vec3 vWorld;     // the vertex in world coordinates
out vec3 vBoxCoord;  // the vertex in box coordinates, [0, 1]^3 over the box
flat out ivec4 vPayload;
flat out ivec3 vOwnLo;         // the voxels [lo, hi) the box owns: the fragment stage keeps only samples in them
flat out ivec3 vOwnHi;
flat out float vPlaneDistance;  // dot(n, x) of this polygon's plane

const int kFan[12] = int[12](0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5);

void main() {
  const int polygonVertex = kFan[gl_VertexID % 12];
  precise float planeDistance = aPlaneDistance + float(aFirstPlane + gl_VertexID / 12) * uPlaneIncr;
  // The front corner is computed here from the sign of the normal (the paper passes it in as a uniform) so that
  // it can never disagree with uPlaneNormal; the CPU mirror uses the same rule (sliceFrontIndex).
  const int front = (uPlaneNormal.x < 0.0 ? 1 : 0) | (uPlaneNormal.y < 0.0 ? 2 : 0) | (uPlaneNormal.z < 0.0 ? 4 : 0);

  precise float distances[8];
  for (int corner = 0; corner < 8; ++corner) {
    distances[corner] = cornerDistance(uPlaneNormal, aBoxMin, aBoxMax, corner);
  }

  // A plane outside [front, back) collapses the whole polygon onto the front corner: zero area, nothing drawn.
  // Half-open like planeIndexRange, so that a plane through a face shared by two boxes is drawn by the box behind
  // the face only. This float test alone decides, so an instance may carry more planes than its box has
  // (slicerPlaneRange) and neighbours, computing the same distances, never both draw or both drop a plane.
  int startCorner = front;
  int endCorner = front;
  precise float lambda = 0.0;
  if (distances[front] <= planeDistance && planeDistance < distances[front ^ 7]) {
    for (int e = 0; e < 4; ++e) {
      const int i = uSequence[front * 8 + uEdgeStart[polygonVertex * 4 + e]];
      const int j = uSequence[front * 8 + uEdgeEnd[polygonVertex * 4 + e]];
      float t;
      if (crossEdge(distances[i], distances[j], planeDistance, t)) {
        startCorner = i;
        endCorner = j;
        lambda = t;
        break;
      }
    }
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
