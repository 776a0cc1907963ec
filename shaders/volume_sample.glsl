// The grid programs' sample (slice.frag.glsl, slab.frag.glsl, raycast.frag.glsl), under the optical model of
// ARCHITECTURE.md: a trilinear fetch from the brick atlas, normalised through the value window, classified with the 1D
// transfer function (post-classification), its opacity corrected for the length of the ray's segment it stands for,
// optionally shaded (SHADING), premultiplied for front-to-back blending; with PRE_INTEGRATION, a segment classified
// from the pre-integrated table instead.
//
// The brick a sample is read from is the technique's (brickPayload: the box's for slices and slabs, the cell
// table's for the ray caster). Its payload.xyz = slot origin + 1 - brick start (voxels of the brick's level): adding
// it to the sample's voxel coordinate in that level gives the atlas texel coordinate; the one-voxel border keeps every
// fetch inside the slot. With MULTI_ORIENTED the brick lies in its slot with rotated axes, and both the start and the
// coordinate are rotated (orient). payload.w = the brick's pyramid level m (and the rotation: levelOf, orient): a
// level-m voxel is 2^m level-0 voxels across, so the level's voxel coordinate is the level-0 one times 2^-m (exactly
// the same number at level 0). Positions, ownership and planes stay in level-0 voxels. Voxel coordinates are clamped
// to [0, n] before a fetch: within half a voxel of the surface the value is the edge voxel's (clamp-to-edge) either
// way, and the fetch stays in the slot.
#if defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE)

layout(binding = VB_UNIT_ATLAS) uniform sampler3D uAtlas;
layout(binding = VB_UNIT_TRANSFER) uniform sampler1D uTransfer;
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

// The atlas payload of the brick being sampled: defined by each technique's file.
ivec4 brickPayload();

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
float levelScale() { return 1.0 / float(1 << levelOf(brickPayload().w)); }

float sampleAt(vec3 voxel) {
  const ivec4 payload = brickPayload();
  return texture(uAtlas, (orient(clamp(voxel, vec3(0.0), uDims) * levelScale(), payload.w) + vec3(payload.xyz)) *
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
layout(binding = VB_UNIT_PRE_INTEGRATED) uniform sampler3D uPreIntegrated;
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

#endif
