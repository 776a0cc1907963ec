// The entry pass of the adjacency ray caster (render/gl/tets/TetRayCaster.h): of the boundary faces where the pixel's ray
// enters the mesh beyond where the last pass left it, the nearest (depth = the ray parameter, tested GL_LESS) writes
// its tet and face. Whether the ray crosses the face is decided exactly, with the Plücker products of its edges (the
// ray passes through a triangle where they agree in sign), each edge's computed from its ends in one order fixed for
// the mesh (lexicographic), so that faces sharing an edge agree on it: a ray is never let through between two faces.
// A face the ray leaves through, or meets edge-on, is no entry. Each kept fragment counts, so that a pass finding
// none ends the frame.
layout(std430, binding = VB_BINDING_ENTRY_COUNT) buffer EntryCount { uint uEntries; };

flat in uint vFace;
flat in vec3 vCorner0, vCorner1, vCorner2;

layout(location = 0) out uint entry;

vec3 gDirection, gMoment;

bool lexLess(vec3 p, vec3 q) { return p.x < q.x || (p.x == q.x && (p.y < q.y || (p.y == q.y && p.z < q.z))); }

// The product of the directed edge a -> b (edgeProduct of tet.glsl, from its lexicographically lower end), so that
// b -> a is the same value negated to the bit.
float side(vec3 a, vec3 b) {
  return lexLess(b, a) ? -edgeProduct(b, a, gDirection, gMoment) : edgeProduct(a, b, gDirection, gMoment);
}

void main() {
  const vec3 origin = rayOrigin();
  gDirection = rayDirection();
  gMoment = cross(origin, gDirection);
  // The face's outward normal: a ray entering runs against it.
  const vec3 normal = cross(vCorner1 - vCorner0, vCorner2 - vCorner0);
  const float rate = dot(normal, gDirection);
  if (!(rate < 0.0)) discard;
  const vec3 s = vec3(side(vCorner0, vCorner1), side(vCorner1, vCorner2), side(vCorner2, vCorner0));
  if (!(all(greaterThanEqual(s, vec3(0.0))) || all(lessThanEqual(s, vec3(0.0))))) discard;
  const float t = dot(normal, vCorner0 - origin) / rate;
  if (!(t > uExits[pixelIndex()])) discard;
  gl_FragDepth = clamp(t, 0.0, 1.0);
  entry = vFace;
  atomicAdd(uEntries, 1u);
}
