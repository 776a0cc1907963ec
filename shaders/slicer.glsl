// Helpers of the GPU slicers (slice.vert.glsl, slice_lean.vert.glsl, slice.geom.glsl, slice_even.vert.glsl,
// slice_odd.geom.glsl): box corners by selection, their distances along the plane normal, the crossing of a plane
// with an edge or a path of edges, and the point there. Every slicer computes its vertices through these, in the
// same order of operations, so the variants give the same vertices bit for bit, as neighbouring boxes do on a
// shared face. render/volume/Slicing.cpp mirrors them in double precision.

#ifdef VERTEX_STAGE
// The instance every GPU slicer's vertex program reads: one world-space box and a run of planes (SliceInstance, its
// attribute locations and SliceGeometry's layout in render/volume/SliceTables.h).
layout(location = 0) in vec3 aBoxMin;
layout(location = 1) in vec3 aBoxMax;
layout(location = 2) in float aPlaneDistance;
layout(location = 3) in ivec4 aPayload;
layout(location = 4) in int aFirstPlane;
layout(location = 5) in ivec3 aOwnLo;
layout(location = 6) in ivec3 aOwnHi;
#endif

// The corner of the unit cube with bit 0 = x, bit 1 = y, bit 2 = z (render/volume/SliceTables.h numbers box corners so).
vec3 unitCorner(int corner) {
  return vec3(float(corner & 1), float((corner >> 1) & 1), float((corner >> 2) & 1));
}

// Box corner by a boolean select, never by arithmetic: min + 1 * (max - min) need not round to max.
vec3 boxCorner(vec3 boxMin, vec3 boxMax, int corner) {
  return mix(boxMin, boxMax, bvec3((corner & 1) != 0, (corner & 2) != 0, (corner & 4) != 0));
}

// dot(n, x) of a box corner. Each corner's distance is computed once and only compared or subtracted afterwards, so
// along every path of edges the distances grow monotonically and a plane inside the box always finds its edge on
// each path (per-edge sums can, by rounding, miss a plane through a corner).
float cornerDistance(vec3 n, vec3 boxMin, vec3 boxMax, int corner) {
  precise float d = dot(n, boxCorner(boxMin, boxMax, corner));
  return d;
}

// True when the edge whose ends lie at distances di and dj holds the plane at distance d, with `lambda` where along
// it. di < dj skips edges parallel to the plane, as the paper's non-zero denominator does.
bool crossEdge(float di, float dj, float d, out float lambda) {
  lambda = 0.0;
  if (!(di < dj && di <= d && d <= dj)) return false;
  // A plane through the edge's far corner meets it at t = 1 exactly: (dj - di) / (dj - di) is 1 under IEEE division,
  // but GLSL's division need not be correctly rounded (NVIDIA's gave 0.99999994, and the corner came out twice, one
  // ulp apart), so that case is not left to it. (d - di) is 0 at the near corner, and 0 / x is 0 either way.
  precise float t = d == dj ? 1.0 : clamp((d - di) / (dj - di), 0.0, 1.0);
  lambda = t;
  return true;
}

// The first edge of the path of box corners path.x -> path.y -> path.z -> path.w (at distances `distances`) that
// holds the plane at d: its corners and where along it. A path from the front corner to the back one crosses every
// plane between them, so for such a plane the walk always ends on an edge; otherwise it stays on path.x.
void crossPath(ivec4 path, vec4 distances, float d, out int startCorner, out int endCorner, out float lambda) {
  startCorner = path.x;
  endCorner = path.x;
  lambda = 0.0;
  float t;
  if (crossEdge(distances.x, distances.y, d, t)) {
    startCorner = path.x, endCorner = path.y, lambda = t;
  } else if (crossEdge(distances.y, distances.z, d, t)) {
    startCorner = path.y, endCorner = path.z, lambda = t;
  } else if (crossEdge(distances.z, distances.w, d, t)) {
    startCorner = path.z, endCorner = path.w, lambda = t;
  }
}

// The point at `lambda` on the box edge from corner startCorner to corner endCorner, in world and in box
// coordinates ([0, 1]^3 over the box). a * (1 - t) + b * t rather than a + t * (b - a), so that t = 0 and t = 1 give
// the corners exactly; and only the one coordinate that varies along the edge is interpolated, so that the other two
// are exactly the corner's, boxCoord is exactly 0 or 1 there, and two boxes sharing a face compute the same point.
void edgePoint(vec3 boxMin, vec3 boxMax, int startCorner, int endCorner, float lambda, out vec3 world,
               out vec3 boxCoord) {
  const vec3 start = boxCorner(boxMin, boxMax, startCorner);
  const vec3 end = boxCorner(boxMin, boxMax, endCorner);
  const vec3 startCoord = unitCorner(startCorner);
  const vec3 endCoord = unitCorner(endCorner);
  const bvec3 along = notEqual(startCoord, endCoord);
  precise vec3 w = mix(start, start * (1.0 - lambda) + end * lambda, along);
  precise vec3 b = mix(startCoord, startCoord * (1.0 - lambda) + endCoord * lambda, along);
  world = w;
  boxCoord = b;
}
