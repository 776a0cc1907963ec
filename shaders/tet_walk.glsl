// The adjacency ray caster's walk (render/gl/tets/TetRayCaster.h), shared by its two kernels: the fragment program
// (tet_ray.frag.glsl, one fragment per pixel and pass, blended) and the compute program (tet_ray.comp.glsl, one
// invocation per pixel and pass, compositing its pixel itself). walkPixel walks the pixel's ray from the
// boundary face the entry pass found, tet to tet across the faces it leaves through (the face-adjacency graph), to
// where it leaves the mesh or its opacity reaches the termination threshold. Each tet's segment is classified from
// the pre-integrated table as a projected tet's fragment is (classifySegment of tet.glsl: the same segments, the
// same model), and composited front to back in registers; the result is blended under the passes before it.
//
// The walk decides with Plücker coordinates (Platis & Theoharis 2003): for each edge, the side of the ray it passes
// on, the sign of the permuted inner product of the two lines. A tet's vertices are stored in the order of their
// indices in the mesh (render/gl/tets/TetRayCaster.cpp), and each edge's product is computed from its lower vertex to its
// higher, so every tet sharing an edge gets the same value to the bit: a ray through an edge or a vertex goes on
// into exactly one of the tets around it, never lost between them, whatever the round-off. The ray passes through a
// face where the products of its three edges, taken around it, agree in sign: the sign the entry face has is
// entering, the other leaving. The products are also the barycentric weights of the point where the ray crosses
// the face (each vertex's the product of the edge opposite it), which give the exit's ray parameter and scalar; the
// next tet takes them over as its entry.
//
// With PART_CLIP (a sort-last part, FrameOptions::meshPart), each segment is cut to the part's box (partRange of
// tet.glsl) before it is classified, its ends' scalars interpolated along it (linear in a tet), and a ray stops for
// good once it has passed the box: what lies beyond is other parts'.
#if defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE)
// The marching fragments' counters, as volume_counters.glsl declares them (render/gl/SampleCounters.h reads them).
layout(std430, binding = VB_BINDING_SAMPLE_COUNTERS) buffer SlabCounters { uint uCounters[2 * VB_COUNTERS]; };

// The entry pass's tet and face (coded as uNext's), or 0xffffffff, and its depth: the entry's t as the entry pass
// computed it.
layout(binding = VB_UNIT_TET_ENTRY) uniform usampler2D uEntry;
layout(binding = VB_UNIT_TET_ENTRY_DEPTH) uniform sampler2D uEntryDepth;
uniform float uWindowLo;    // the value window [lo, hi] as lo and 1 / (hi - lo)
uniform float uWindowScale;
uniform float uTermination; // early ray termination: the opacity where a ray stops (above 1: never)
uniform int uMaxSteps;      // tets one pass walks at most (a guard)

// A margin in t between passes: the entry pass computes a face's t its own way, so the next pass must look a little
// before where this one left (or it could miss an entry at that very point) and never at the face this one entered by.
const float kBeyond = 1e-6;
const int kMaxStalled = 256;

void count(int counter, uint n) {
  const uint before = atomicAdd(uCounters[2 * counter], n);
  if (before + n < before) atomicAdd(uCounters[2 * counter + 1], 1u);
}

// The six edge products of a tet with vertices v: low = 0->1, 0->2, 0->3; high = 1->2, 1->3, 2->3.
void edgeProducts(const vec4 v[4], vec3 d, vec3 m, out vec3 low, out vec3 high) {
  low = vec3(edgeProduct(v[0].xyz, v[1].xyz, d, m), edgeProduct(v[0].xyz, v[2].xyz, d, m),
             edgeProduct(v[0].xyz, v[3].xyz, d, m));
  high = vec3(edgeProduct(v[1].xyz, v[2].xyz, d, m), edgeProduct(v[1].xyz, v[3].xyz, d, m),
              edgeProduct(v[2].xyz, v[3].xyz, d, m));
}

// Face k's crossing weights (of vertices 0..3; 0 for vertex k): each vertex's the product of the edge opposite it,
// taken around the face in one direction, the same for every face of the tet (counter-clockwise seen from outside
// if the stored order is positively oriented, clockwise otherwise). Where the ray crosses face k the weights agree in
// sign: all entering, or all leaving.
vec4 faceWeights(int k, vec3 low, vec3 high) {
  // low = (P01, P02, P03), high = (P12, P13, P23).
  if (k == 0) return vec4(0.0, high.z, -high.y, high.x);
  if (k == 1) return vec4(-high.z, 0.0, low.z, -low.y);
  if (k == 2) return vec4(high.y, -low.z, 0.0, low.x);
  return vec4(-high.x, low.y, -low.x, 0.0);
}

// The pixel's walk in this pass (pixelCoord(): its window coordinates): its segments composited front to back into
// `color`, premultiplied, and where it left written to uExits. False where there is nothing to blend (no entry, a
// ray in the entry face's plane, or outside the part), as the fragment program discards.
bool walkPixel(out vec4 color) {
  color = vec4(0.0);
  const uint entry = texelFetch(uEntry, ivec2(pixelCoord()), 0).r;
  if (entry == 0xffffffffu) return false;
  const vec3 origin = rayOrigin();
  const vec3 direction = rayDirection();
  const vec3 moment = cross(origin, direction);
  const float directionSquared = dot(direction, direction);
  const float lengthOverReference = sqrt(directionSquared) * uInvReference;
#ifdef PART_CLIP
  const vec2 part = partRange(origin, direction);
  if (!(part.y > part.x)) {
    // The ray misses the part: no pass has anything to do for it.
    uExits[pixelIndex()] = 2.0;
    return false;
  }
#endif

  uint tet = entry >> 3;
  int face = int(entry & 3u);
  float orientation = (entry & 4u) == 0u ? 1.0 : -1.0;  // of the stored order
  vec4 v[4];
  for (int i = 0; i < 4; ++i) v[i] = uTetVertices[4u * tet + uint(i)];
  vec3 low, high;
  edgeProducts(v, direction, moment, low, high);
  // Where the ray enters, and the sign of its weights there: entering.
  const vec4 entryWeights = faceWeights(face, low, high);
  const float entrySum = entryWeights.x + entryWeights.y + entryWeights.z + entryWeights.w;
  if (entrySum == 0.0) {
    // The ray lies in the face's plane: nothing to walk; the next pass looks beyond this face.
    uExits[pixelIndex()] = texelFetch(uEntryDepth, ivec2(pixelCoord()), 0).r + kBeyond;
    return false;
  }
  // The sign of leaving for a tet whose stored order is positively oriented (the weights of a negatively oriented
  // one go around each face the other way).
  const float leavingPositive = (entrySum > 0.0 ? -1.0 : 1.0) * orientation;
  vec4 point = (entryWeights.x * v[0] + entryWeights.y * v[1] + entryWeights.z * v[2] + entryWeights.w * v[3]) /
               entrySum;  // position and raw scalar
  float t = dot(point.xyz - origin, direction) / directionSquared;
  const float entryT = t;
#ifdef PART_CLIP
  if (t >= part.y) {
    uExits[pixelIndex()] = 2.0;
    return false;
  }
#endif

  vec4 accumulated = vec4(0.0);
  int steps = 0, segments = 0, stalled = 0;  // tets walked; those with a segment of positive length
  bool terminated = false, passed = false;  // passed: beyond the part's box
  for (;;) {
    // Each face's leaving score: the least of its weights, signed so that a face the ray leaves through has them
    // all >= 0. The exit is the best face other than the entry (in exact arithmetic the only one with a score >= 0).
    const float leaving = leavingPositive * orientation;
    const vec3 l = leaving * low, h = leaving * high;
    vec4 score = vec4(min(min(h.z, -h.y), h.x), min(min(-h.z, l.z), -l.y), min(min(h.y, -l.z), l.x),
                      min(min(-h.x, l.y), -l.x));
    score[face] = -3.0e38;
    const float best = max(max(score.x, score.y), max(score.z, score.w));
    const int exitFace = score.x == best ? 0 : score.y == best ? 1 : score.z == best ? 2 : 3;
    const vec4 w = faceWeights(exitFace, low, high);
    const float weightSum = w.x + w.y + w.z + w.w;
    const vec4 exitPoint = weightSum != 0.0 ? (w.x * v[0] + w.y * v[1] + w.z * v[2] + w.w * v[3]) / weightSum : point;
    const float exitT = max(dot(exitPoint.xyz - origin, direction) / directionSquared, t);
#ifdef PART_CLIP
    const float from = max(t, part.x), to = min(exitT, part.y);
    const bool counted = to > from;
    vec4 segment = vec4(0.0);
    if (counted) {
      const float span = exitT - t;  // > 0: the cut stretch has length
      const float front = (mix(point.w, exitPoint.w, (from - t) / span) - uWindowLo) * uWindowScale;
      const float back = (mix(point.w, exitPoint.w, (to - t) / span) - uWindowLo) * uWindowScale;
      segment = classifySegment(front, back, (to - from) * lengthOverReference);
    }
#else
    const bool counted = exitT > t;
    const float front = (point.w - uWindowLo) * uWindowScale;
    const float back = (exitPoint.w - uWindowLo) * uWindowScale;
    vec4 segment = classifySegment(front, back, (exitT - t) * lengthOverReference);
#endif
#ifdef SHADING
    // The scalar's gradient in the tet: the edges from vertex 0 against the scalar's differences along them.
    const mat3 edges = mat3(v[1].xyz - v[0].xyz, v[2].xyz - v[0].xyz, v[3].xyz - v[0].xyz);
    const vec3 gradient = inverse(transpose(edges)) * vec3(v[1].w - v[0].w, v[2].w - v[0].w, v[3].w - v[0].w);
    segment = shadeSegment(segment, gradient, direction);
#endif
    accumulated += (1.0 - accumulated.a) * segment;
    ++steps;
    segments += counted ? 1 : 0;
    // A guard: a ray that went round kMaxStalled tets without moving along is given up.
    stalled = exitT > t ? 0 : stalled + 1;
    t = exitT;
    point = exitPoint;
    if (accumulated.a >= uTermination) {
      terminated = true;
      break;
    }
#ifdef PART_CLIP
    if (t >= part.y) {
      passed = true;
      break;
    }
#endif
    const int next = uNext[tet][exitFace];
    if (next < 0 || steps >= uMaxSteps || stalled >= kMaxStalled) break;
    tet = uint(next) >> 3;
    face = next & 3;
    orientation = (next & 4) == 0 ? 1.0 : -1.0;
    // The face crossed is shared: its three vertices, in the order of their mesh indices in both tets, and their
    // three edge products come along; only the new tet's fourth vertex (opposite the face) is read, and its three
    // edges' products computed.
    const vec4 r0 = exitFace == 0 ? v[1] : v[0], r1 = exitFace <= 1 ? v[2] : v[1], r2 = exitFace <= 2 ? v[3] : v[2];
    const vec3 kept = exitFace == 0 ? high : exitFace == 1 ? vec3(low.yz, high.z)
                      : exitFace == 2 ? vec3(low.xz, high.y) : vec3(low.xy, high.x);  // the shared edges: r0-r1, r0-r2, r1-r2
    const vec4 apex = uTetVertices[4u * tet + uint(face)];
    const vec3 fresh = vec3(face > 0 ? edgeProduct(r0.xyz, apex.xyz, direction, moment)
                                     : edgeProduct(apex.xyz, r0.xyz, direction, moment),
                            face > 1 ? edgeProduct(r1.xyz, apex.xyz, direction, moment)
                                     : edgeProduct(apex.xyz, r1.xyz, direction, moment),
                            face > 2 ? edgeProduct(r2.xyz, apex.xyz, direction, moment)
                                     : edgeProduct(apex.xyz, r2.xyz, direction, moment));  // r0, r1, r2 with apex
    v[0] = face == 0 ? apex : r0;
    v[1] = face == 0 ? r0 : face == 1 ? apex : r1;
    v[2] = face <= 1 ? r1 : face == 2 ? apex : r2;
    v[3] = face == 3 ? apex : r2;
    low = face == 0 ? fresh : face == 1 ? vec3(fresh.x, kept.xy) : face == 2 ? vec3(kept.x, fresh.x, kept.y)
                                                                     : vec3(kept.xy, fresh.x);
    high = face == 0 ? kept : face == 1 ? vec3(fresh.yz, kept.z) : face == 2 ? vec3(fresh.y, kept.z, fresh.z)
                                                                       : vec3(kept.z, fresh.yz);
  }
  // The next pass looks for entries from just before where this one left (a ray leaving through a boundary edge may
  // enter another part of the mesh at that very point), or just beyond where it entered if it went no further; and
  // always beyond this pass's entry as the entry pass computed it (a face met almost edge-on can put its t there a
  // little beyond the walk's), so that no pass finds the same entry again.
  const float entryPassT = texelFetch(uEntryDepth, ivec2(pixelCoord()), 0).r;
  const float exitRule = t - entryT > 2.0 * kBeyond ? t - kBeyond : max(t, entryT) + kBeyond;
  uExits[pixelIndex()] = terminated || passed ? 2.0 : max(exitRule, entryPassT + kBeyond);
  count(VB_COUNTER_FRAGMENTS, 1u);
  count(VB_COUNTER_SAMPLES, uint(segments));
  if (terminated) count(VB_COUNTER_SAMPLES_TERMINATED, 1u);
  color = accumulated;
  return true;
}

#endif
