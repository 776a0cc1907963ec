// One slice fragment under the optical model of ARCHITECTURE.md: trilinear sample from the brick atlas, normalise through
// the value window, classify with the 1D transfer function (post-classification), correct the opacity for the
// length of this ray's segment between two planes, and emit premultiplied colour for front-to-back blending.
//
// A fragment is kept only when its sample lies in the voxels its box owns, vOwnLo..vOwnHi (half-open: the face
// towards the eye included). Whole bricks own the whole volume here: between bricks of one size the rasterised
// shared edges are exact, and the test only cuts the volume's outline, which is then the same for every bricking
// (surface bricks are drawn a quarter voxel larger). With EXACT_OWNERSHIP (sub-blocks, whose boxes of different
// sizes meet at T-junctions where rasterised edges leave cracks and double samples) every box owns just its voxels
// and is drawn 1/64 voxel larger, and the sample is computed from the pixel's ray and the plane alone, so that two
// boxes see exactly the same point and exactly one keeps it.
//
// vPayload.xyz = slot origin + 1 - brick start (voxels of the brick's level): adding it to the sample's voxel
// coordinate in that level gives the atlas texel coordinate; the one-voxel border keeps every fetch inside the slot.
// With MULTI_ORIENTED the brick lies in its slot with rotated axes, and both the start and the coordinate are
// rotated (orient). vPayload.w = the brick's pyramid level m (and the rotation: levelOf, orient): a level-m voxel is
// 2^m level-0 voxels across, so the level's voxel
// coordinate is the level-0 one times 2^-m (exactly the same number at level 0). Positions, ownership and planes stay
// in level-0 voxels. Voxel coordinates are clamped to [0, n] before a fetch: within half a voxel of the surface the
// value is the edge voxel's (clamp-to-edge) either way, and the fetch stays in the slot.

#ifdef RAYCAST
// The frame ray caster has no box: each sample's brick comes from the cell table (render/gl/volume/CellTable.h), and its
// payload is set here before the sample is read.
ivec4 gPayload = ivec4(0);
#define PAYLOAD gPayload
#else
in vec3 vWorld;
flat in ivec4 vPayload;
flat in ivec3 vOwnLo;
flat in ivec3 vOwnHi;
flat in float vPlaneDistance;
#define PAYLOAD vPayload
#endif
#if defined(SLAB) || defined(RAYCAST)
#ifdef SLAB
flat in int vFirstPlane;  // the slab's planes: [vFirstPlane, vFirstPlane + vPlaneCount)
flat in int vPlaneCount;
#endif
uniform float uPlaneIncr;    // distance between consecutive global planes
uniform float uTermination;  // early ray termination: stop once the fragment's own opacity reaches it (> 1: never)
// What the marching fragments did, as 64-bit counters (low word, high word): fragments started, samples taken,
// samples left untaken when the fragment's own opacity reached uTermination (render/Marching.h reads them).
layout(std430, binding = 0) buffer SlabCounters { uint uCounters[6]; };
#ifndef EMPTY_TEST
// The depth test (the silhouette map) before the program runs: a program with atomics would otherwise be run and
// then tested. Marching fragments neither discard nor write depth, so the result is the same. (The empty-space pass
// discards, and must write depth only where it keeps a fragment: it is tested late.)
layout(early_fragment_tests) in;
#endif
void count(int counter, uint n) {
  const uint before = atomicAdd(uCounters[2 * counter], n);
  if (before + n < before) atomicAdd(uCounters[2 * counter + 1], 1u);
}
#endif

uniform sampler3D uAtlas;
uniform sampler1D uTransfer;
uniform vec3 uInvAtlasSize;
uniform vec3 uInvSpacing;        // 1 / voxel spacing
uniform vec3 uHalfDims;          // n / 2: voxel coordinate of the world origin
uniform vec3 uDims;              // n
uniform float uWindowLo;         // the value window [lo, hi] as lo and 1 / (hi - lo)
uniform float uWindowScale;
uniform float uStepOverReference;  // plane spacing / reference length
uniform vec3 uEye;
uniform vec3 uViewDir;
uniform int uOrthographic;
uniform vec3 uRayOrigin, uRayOriginDx, uRayOriginDy;           // ray origin (on the near plane) at window (x, y)
uniform vec3 uRayDirection, uRayDirectionDx, uRayDirectionDy;  // near plane to far plane at window (x, y)

out vec4 fragColor;

// ln(1 - a) for a in [0, 1). Below 2^-6 a series: there 1 - a loses a's low bits to rounding, and a GPU's log is
// accurate only in absolute terms near 1 (alpha 1e-7 at step / L_ref = 1000 came out 3 % off on llvmpipe).
float logOneMinus(float a) {
  return a < 0.015625 ? -a * (1.0 + a * (0.5 + a * (1.0 / 3.0 + a * 0.25))) : log(1.0 - a);
}

// 1 - e^y for y <= 0, by a series where 1 - exp(y) would cancel.
float oneMinusExp(float y) {
  return y > -0.015625 ? -y * (1.0 + y * (0.5 + y * (1.0 / 6.0 + y * (1.0 / 24.0)))) : 1.0 - exp(y);
}

// A payload's w holds the brick's level and, with MULTI_ORIENTED, the rotation of its axes in the slot (AtlasFormat.h:
// payloadLevel, orientVoxel): level w & 63, rotation w >> 6; negative w (the cell table's markers) pass unchanged.
#ifdef MULTI_ORIENTED
int levelOf(int w) { return w < 0 ? w : (w & 63); }
vec3 orient(vec3 v, int w) {
  const int r = w >> 6;
  return r == 1 ? v.yzx : r == 2 ? v.zxy : v;
}
#else
int levelOf(int w) { return w; }
vec3 orient(vec3 v, int w) { return v; }
#endif

// 2^-m for the brick's level m.
float levelScale() { return 1.0 / float(1 << levelOf(PAYLOAD.w)); }

float sampleAt(vec3 voxel) {
  return texture(uAtlas, (orient(clamp(voxel, vec3(0.0), uDims) * levelScale(), PAYLOAD.w) + vec3(PAYLOAD.xyz)) *
                             uInvAtlasSize).r;
}

// The length of this ray's segment between two planes, in reference lengths. Planes are uPlaneIncr apart along the
// view axis; a perspective ray crosses them obliquely, so its segment is longer by 1 / cos(angle to the axis). The
// same for every sample of a ray (world - eye runs along the ray).
float segmentRatio(vec3 world) {
  const float cosine = uOrthographic != 0 ? 1.0 : max(dot(normalize(world - uEye), uViewDir), 1e-3);
  return uStepOverReference / cosine;
}

// The value window: raw atlas value to the transfer function's [0, 1].
float normalised(float value) { return clamp((value - uWindowLo) * uWindowScale, 0.0, 1.0); }

// The transfer function at normalised x: its table holds tf(k / (n - 1)), k = 0 .. n - 1 (TransferFunction::table),
// so x maps to texel coordinate x (n - 1) + 0.5, exact at both ends.
vec4 classify(float x) {
  const float n = float(textureSize(uTransfer, 0));
  return texture(uTransfer, (x * (n - 1.0) + 0.5) / n);
}

// The Phong headlight (render/reference/Headlight.h) at `world` (voxel coordinate `voxel`) as (diffuse factor, specular term):
// a colour c becomes c * x + y. (1, 0) without SHADING or where the gradient vanishes.
vec2 headlight(vec3 world, vec3 voxel) {
#ifdef SHADING
  // Central differences half a voxel each way: the samples stay inside the slot (whose border is one voxel).
  const vec3 gradient = vec3(sampleAt(voxel + vec3(0.5, 0, 0)) - sampleAt(voxel - vec3(0.5, 0, 0)),
                             sampleAt(voxel + vec3(0, 0.5, 0)) - sampleAt(voxel - vec3(0, 0.5, 0)),
                             sampleAt(voxel + vec3(0, 0, 0.5)) - sampleAt(voxel - vec3(0, 0, 0.5))) * uInvSpacing;
  const float magnitude = length(gradient);
  if (magnitude > 1e-12) {
    const vec3 normal = -gradient / magnitude;
    const vec3 toEye = uOrthographic != 0 ? -uViewDir : normalize(uEye - world);
    const float diffuse = abs(dot(normal, toEye));  // two-sided headlight
    const float specular = pow(diffuse, 32.0);
    return vec2(0.3 + 0.7 * diffuse, 0.25 * specular);
  }
#endif
  return vec2(1.0, 0.0);
}

// The classified, opacity-corrected (for a segment of `ratio` reference lengths), optionally shaded sample at
// `world` (voxel coordinate `voxel`), premultiplied.
vec4 shadeSample(vec3 world, vec3 voxel, float value, float ratio) {
  const vec4 classified = classify(normalised(value));
  const float alpha = classified.a >= 1.0 ? 1.0 : oneMinusExp(ratio * logOneMinus(classified.a));
  vec3 color = classified.rgb;
#ifdef SHADING
  const vec2 light = headlight(world, voxel);
  color = color * light.x + vec3(light.y);
#endif
  return vec4(color * alpha, alpha);
}

// Premultiplied `rgba` (a pre-integrated segment) shaded at `world`: the straight colour's c * x + y, premultiplied.
vec4 shade(vec4 rgba, vec3 world, vec3 voxel) {
#ifdef SHADING
  const vec2 light = headlight(world, voxel);
  rgba.rgb = rgba.rgb * light.x + vec3(light.y) * rgba.a;
#endif
  return rgba;
}

#ifdef PRE_INTEGRATION
// The pre-integrated segment table (render/core/PreIntegration.h): premultiplied colour and opacity of a segment whose
// normalised value runs linearly from front (s) to back (t), at layer r for its length.
uniform sampler3D uPreIntegrated;
uniform float uTableResolution;  // R
uniform float uRatioMin;         // the first layer's segment length, in reference lengths
uniform float uLayerScale;       // layers per unit of ln(ratio)
uniform float uLayers;

float layerCoordinate(float ratio) {
  return (clamp(log(ratio / uRatioMin) * uLayerScale, 0.0, uLayers - 1.0) + 0.5) / uLayers;
}

vec4 preIntegrated(float front, float back, float layer) {
  const vec2 st = (vec2(normalised(front), normalised(back)) * (uTableResolution - 1.0) + 0.5) / uTableResolution;
  return texture(uPreIntegrated, vec3(st, layer));
}
#endif

// Whether voxel coordinates `lo` and `hi` (the same point, or two roundings of it) lie in the voxels the box owns:
// half-open, the face towards the eye included.
bool ownedBy(vec3 lo, vec3 hi, vec3 ownLo, vec3 ownHi) {
  bool inside = true;
  for (int a = 0; a < 3; ++a) {
    inside = inside && (uViewDir[a] >= 0.0 ? (lo[a] >= ownLo[a] && hi[a] < ownHi[a])
                                           : (lo[a] > ownLo[a] && hi[a] <= ownHi[a]));
  }
  return inside;
}

#ifndef RAYCAST
bool owned(vec3 lo, vec3 hi) { return ownedBy(lo, hi, vec3(vOwnLo), vec3(vOwnHi)); }
#endif

#if defined(SLAB) || defined(RAYCAST)
// This pixel's ray, origin (on the near plane) + t·direction in world units (both affine in window coordinates),
// their components along the view axis (start, along), and the same ray in voxel coordinates, o + t·dv, with inv the
// reciprocal of dv (components below 1e-20 replaced, so that it stays finite).
struct PixelRay {
  vec3 origin, direction;
  float along, start;
  vec3 o, inv;
};

PixelRay pixelRay() {
  PixelRay r;
  r.origin = uRayOrigin + gl_FragCoord.x * uRayOriginDx + gl_FragCoord.y * uRayOriginDy;
  r.direction = uRayDirection + gl_FragCoord.x * uRayDirectionDx + gl_FragCoord.y * uRayDirectionDy;
  r.along = dot(uViewDir, r.direction);
  r.start = dot(uViewDir, r.origin);
  r.o = r.origin * uInvSpacing + uHalfDims;
  const vec3 dv = r.direction * uInvSpacing;
  r.inv = 1.0 / mix(dv, vec3(1e-20), lessThan(abs(dv), vec3(1e-20)));
  return r;
}

// The parameter range (in, out) of the ray o + t·d (voxel coordinates, inv = 1 / d) inside the box [lo, hi], from
// t = 0 on: empty when in > out.
vec2 rayBoxRange(vec3 o, vec3 inv, vec3 lo, vec3 hi) {
  const vec3 a = (lo - o) * inv, b = (hi - o) * inv;
  return vec2(max(max(min(a.x, b.x), min(a.y, b.y)), max(min(a.z, b.z), 0.0)),
              min(min(max(a.x, b.x), max(a.y, b.y)), max(a.z, b.z)));
}

// The voxel coordinate of the ray origin + t·direction where it meets the plane at `distance` along the view axis
// (start and along: the origin's and the direction's components along it).
vec3 voxelOnPlane(vec3 origin, vec3 direction, float start, float along, float distance) {
  return (origin + direction * ((distance - start) / along)) * uInvSpacing + uHalfDims;
}
#endif

#ifdef SLAB
// A slab: the samples of this pixel's ray on the global planes [vFirstPlane, vFirstPlane + vPlaneCount) that lie in
// the voxels the box owns, composited front to back in registers and emitted once (premultiplied). A box of level m
// takes every 2^m-th plane (those whose index is a multiple of 2^m, the same for every box of that level), each
// sample standing for a segment 2^m planes long.
void main() {
  const PixelRay ray = pixelRay();
  const vec3 origin = ray.origin, direction = ray.direction, o = ray.o, inv = ray.inv;
  const float along = ray.along, start = ray.start;
  // The planes the ray can have inside the box: its parameter range in the owned voxels (widened by 1/128 voxel,
  // beyond the ownership test's 1/256 grid) and one plane more each side. The ownership test alone decides.
  const vec2 range = rayBoxRange(o, inv, vec3(vOwnLo) - 1.0 / 128.0, vec3(vOwnHi) + 1.0 / 128.0);
  const int level = levelOf(vPayload.w), stride = 1 << level;
  // The first plane of the level's subset at or after the first plane the ray can have (>> floors negatives too).
  const int first = ((max(vFirstPlane, int(floor((start + along * range.x) / uPlaneIncr)) - 1) + stride - 1) >> level)
                    << level;
  const int last = min(vFirstPlane + vPlaneCount, int(ceil((start + along * range.y) / uPlaneIncr)) + 2);
  // Planes whose point lies at least 1/64 voxel inside every owned face, one plane in from either end for round-off,
  // are owned without a test (the ray's point is off by far less than 1/64 voxel).
  const vec2 inside = rayBoxRange(o, inv, vec3(vOwnLo) + 1.0 / 64.0, vec3(vOwnHi) - 1.0 / 64.0);
  const int insideFirst = int(ceil((start + along * inside.x) / uPlaneIncr)) + 1;
  const int insideLast = int(floor((start + along * inside.y) / uPlaneIncr)) - 1;
  // Faces between boxes are tested on the 1/256-voxel grid, as EXACT_OWNERSHIP; the volume's own faces on the
  // unrounded point, as slicing tests them, so that rays grazing the surface keep the same samples - except faces the
  // planes are parallel to (a view along an axis): a plane through such a face lands on it only on the grid, where
  // the half-open rule keeps exactly one of the samples on the near and far faces, as slicing does.
  const bvec3 parallel = greaterThan(abs(uViewDir), vec3(0.9999));
  const bvec3 unroundedLo = bvec3(ivec3(equal(vOwnLo, ivec3(0))) * ivec3(not(parallel)));
  const bvec3 unroundedHi = bvec3(ivec3(equal(vec3(vOwnHi), uDims)) * ivec3(not(parallel)));
  vec4 sum = vec4(0.0);
  uint taken = 0u, untaken = 0u;
  const float ratio = segmentRatio(origin + direction) * float(stride);
#ifdef PRE_INTEGRATION
  const float layer = layerCoordinate(ratio);
  // The segment from plane k to plane k + 1 belongs to the box owning sample k. Its back sample may lie beyond the
  // box; it is read within half a voxel of the box's faces, where the slot's one-voxel border still holds the
  // neighbours' values (further out, clamped to that shell: an approximation only near faces, for steps above half a
  // voxel).
  const vec3 backLo = vec3(vOwnLo) - 0.5, backHi = vec3(vOwnHi) + 0.5;
  float back = 0.0;
  int backPlane = first - 1;  // the plane `back` was read on
#endif
  for (int k = first; k < last; k += stride) {
    if (sum.a >= uTermination) {
      untaken = uint((last - k + stride - 1) >> level);  // planes, an upper bound of the owned samples left
      break;
    }
    // The ray's point on plane k, as EXACT_OWNERSHIP computes it, so that neighbouring boxes agree on its owner.
    const float planeDistance = float(k) * uPlaneIncr;
    const float t = (planeDistance - start) / along;
    const vec3 world = origin + direction * t;
    const vec3 voxel = world * uInvSpacing + uHalfDims;
    if (k < insideFirst || k > insideLast) {
      if (t < 0.0) continue;  // before the near plane, where slicing's polygons are clipped
      const vec3 snapped = round(voxel * 256.0) * (1.0 / 256.0);
      if (!owned(mix(snapped, voxel, unroundedLo), mix(snapped, voxel, unroundedHi))) continue;
    }
#ifdef EMPTY_TEST
    // The empty-space silhouette pass: keep the fragment (its depth marks the pixel) at the first sample, or with
    // pre-integration the first segment, the march would give any opacity; discard it if there is none.
#ifdef PRE_INTEGRATION
    const vec3 after = voxelOnPlane(origin, direction, start, along, planeDistance + uPlaneIncr * float(stride));
    if (preIntegrated(sampleAt(voxel), sampleAt(clamp(after, backLo, backHi)), layer).a > 0.0) return;
#else
    if (classify(normalised(sampleAt(voxel))).a > 0.0) return;
#endif
    continue;
#endif
#ifdef PRE_INTEGRATION
    const float value = backPlane == k ? back : sampleAt(voxel);
    const vec3 next = voxelOnPlane(origin, direction, start, along, planeDistance + uPlaneIncr * float(stride));
    back = sampleAt(clamp(next, backLo, backHi));
    backPlane = k + stride;
#else
    const float value = sampleAt(voxel);
#endif
    ++taken;
#ifdef ROOFLINE
    sum = vec4(value * 1e-9);  // below any termination threshold: every sample taken
#elif defined(PRE_INTEGRATION)
    sum += (1.0 - sum.a) * shade(preIntegrated(value, back, layer), world, voxel);
#else
    sum += (1.0 - sum.a) * shadeSample(world, voxel, value, ratio);
#endif
  }
#ifdef EMPTY_TEST
  discard;
#else
  count(0, 1u);
  if (taken > 0u) count(1, taken);
  if (untaken > 0u) count(2, untaken);
  fragColor = sum;
#endif
}
#elif defined(RAYCAST)
uniform isampler3D uCells;  // per cell: its brick's atlas payload (xyz) and level (w); w = -1: nothing to draw there
                            // (x: log2 of the block to leap), -2: a brick of another batch (render/gl/volume/CellTable.h)
uniform int uCellShift;     // a cell is 2^uCellShift level-0 voxels across
uniform vec3 uCellCount;   // cells along x, y, z

// The frame ray caster (render/gl/volume/RayCastPass.h): this pixel's samples on the global planes, through every cell of the
// batch, composited front to back in registers and emitted once (premultiplied). A sample belongs to the cell that
// owns its point as EXACT_OWNERSHIP decides between boxes (on the 1/256-voxel grid, half-open with the face towards
// the eye included) and to the volume as slabs decide at its outline, so that it takes the samples slabs take. A
// cell of level m takes the planes whose index is a multiple of 2^m, each standing for a segment 2^m planes long.
// Cells with nothing to draw, and planes a coarse cell does not take, are stepped over to the cell's exit.
void main() {
  const PixelRay ray = pixelRay();
  const vec3 origin = ray.origin, direction = ray.direction, o = ray.o, inv = ray.inv;
  const float along = ray.along, start = ray.start;
  const vec2 range = rayBoxRange(o, inv, vec3(-1.0 / 128.0), uDims + 1.0 / 128.0);
  if (range.x > range.y) {
    fragColor = vec4(0.0);
    return;
  }
  int k = int(floor((start + along * range.x) / uPlaneIncr)) - 1;
  const int last = int(ceil((start + along * range.y) / uPlaneIncr)) + 2;
  // Planes at least 1/64 voxel inside the volume, one plane in from either end, need no outline test.
  const vec2 inside = rayBoxRange(o, inv, vec3(1.0 / 64.0), uDims - 1.0 / 64.0);
  const int insideFirst = int(ceil((start + along * inside.x) / uPlaneIncr)) + 1;
  const int insideLast = int(floor((start + along * inside.y) / uPlaneIncr)) - 1;
  // The outline is tested on the unrounded point, except faces the planes are parallel to (as slabs test it).
  const bvec3 parallel = greaterThan(abs(uViewDir), vec3(0.9999));
  const bvec3 eyeAtHi = lessThan(uViewDir, vec3(0.0));  // the cell face at hi faces the eye: owned, lo is not
  const float cellScale = 1.0 / float(1 << uCellShift);
  const float ratio = segmentRatio(origin + direction);
#ifdef PRE_INTEGRATION
  float back = 0.0;
  int backPlane = k - 1;  // the plane `back` was read on
  ivec3 backCell = ivec3(-1);
#endif
  vec4 sum = vec4(0.0);
  uint taken = 0u, untaken = 0u;
  while (k < last) {
    if (sum.a >= uTermination) {
      untaken = uint(last - k);  // planes, an upper bound of the samples left
      break;
    }
    const float planeDistance = float(k) * uPlaneIncr;
    const float t = (planeDistance - start) / along;
    const vec3 world = origin + direction * t;
    const vec3 voxel = world * uInvSpacing + uHalfDims;
    const vec3 snapped = round(voxel * 256.0) * (1.0 / 256.0);
    if (k < insideFirst || k > insideLast) {
      const vec3 outline = mix(voxel, snapped, parallel);
      if (t < 0.0 || !ownedBy(outline, outline, vec3(0.0), uDims)) {
        ++k;
        continue;
      }
    }
    const vec3 scaled = snapped * cellScale;
    const ivec3 cell = clamp(ivec3(mix(floor(scaled), ceil(scaled) - 1.0, eyeAtHi)), ivec3(0), ivec3(uCellCount) - 1);
    const ivec4 entry = texelFetch(uCells, cell, 0);
    const int level = levelOf(entry.w);
    const int stride = 1 << max(level, 0);
    if (level < 0 || (k & (stride - 1)) != 0) {
      // Nothing to draw in this cell, or a plane its level does not take. A cell with nothing to draw at all adds
      // nothing even on its faces (render/gl/volume/CellTable.h): on to the first plane at its exit. Otherwise on to the
      // plane one before the last the ray has in the cell, or the next plane the level takes if that comes first,
      // so that points near the faces are owned plane by plane. At least the next plane.
      // A cell with nothing to draw leaps out of its block of 2^entry.x cells with nothing to draw.
      const int leap = level == -1 ? entry.x : 0;
      const ivec3 blockLo = (cell >> leap) << (leap + uCellShift);
      const float exitT = rayBoxRange(o, inv, vec3(blockLo), vec3(blockLo + (1 << (leap + uCellShift)))).y;
      const float exitPlane = (start + along * exitT) / uPlaneIncr;
      const int next = level == -1 ? int(ceil(exitPlane - 0.01))
                       : level < 0 ? int(floor(exitPlane)) - 1
                                   : min(int(floor(exitPlane)) - 1, (k + stride - 1) & ~(stride - 1));
      k = max(k + 1, next);
      continue;
    }
    gPayload = entry;
#ifdef PRE_INTEGRATION
    // As slabs: the back sample from this cell's brick, within half a voxel of the cell.
    const float value = backPlane == k && backCell == cell ? back : sampleAt(voxel);
    const vec3 next = voxelOnPlane(origin, direction, start, along, planeDistance + uPlaneIncr * float(stride));
    back = sampleAt(clamp(next, vec3(cell << uCellShift) - 0.5, vec3((cell + 1) << uCellShift) + 0.5));
    backPlane = k + stride;
    backCell = cell;
#else
    const float value = sampleAt(voxel);
#endif
    ++taken;
#ifdef ROOFLINE
    sum = vec4(value * 1e-9);  // below any termination threshold: every sample taken
#elif defined(PRE_INTEGRATION)
    sum += (1.0 - sum.a) * shade(preIntegrated(value, back, layerCoordinate(ratio * float(stride))), world, voxel);
#else
    sum += (1.0 - sum.a) * shadeSample(world, voxel, value, ratio * float(stride));
#endif
    ++k;
  }
  count(0, 1u);
  if (taken > 0u) count(1, taken);
  if (untaken > 0u) count(2, untaken);
  fragColor = sum;
}
#else
void main() {
#ifdef EXACT_OWNERSHIP
  // The pixel's ray (origin and direction are affine in window coordinates) meets this fragment's plane.
  const vec3 origin = uRayOrigin + gl_FragCoord.x * uRayOriginDx + gl_FragCoord.y * uRayOriginDy;
  const vec3 direction = uRayDirection + gl_FragCoord.x * uRayDirectionDx + gl_FragCoord.y * uRayDirectionDy;
  const vec3 world = origin + direction * ((vPlaneDistance - dot(uViewDir, origin)) / dot(uViewDir, direction));
  const vec3 voxel = world * uInvSpacing + uHalfDims;
  // Faces between boxes are tested on a grid of 1/256 voxel, so that a plane through a face (a view along an axis)
  // lands on it despite the round-off of the ray. Faces on the volume's surface are tested exactly as for whole
  // bricks, on the interpolated position: a ray grazing the surface then keeps the same samples either way.
  const vec3 snapped = round(voxel * 256.0) * (1.0 / 256.0);
  const vec3 interpolated = vWorld * uInvSpacing + uHalfDims;
  const vec3 ownedLo = mix(snapped, interpolated, equal(vOwnLo, ivec3(0)));
  const vec3 ownedHi = mix(snapped, interpolated, equal(vec3(vOwnHi), uDims));
#else
  const vec3 world = vWorld;
  const vec3 voxel = world * uInvSpacing + uHalfDims;
  const vec3 ownedLo = voxel, ownedHi = voxel;
#endif
  if (!owned(ownedLo, ownedHi)) discard;
  const float value = sampleAt(voxel);
#ifdef ROOFLINE
  fragColor = vec4(value);
  return;
#endif
  fragColor = shadeSample(world, voxel, value, segmentRatio(world));
}
#endif
