// One slice fragment under the optical model of DESIGN.md: trilinear sample from the brick atlas, normalise through
// the value window, classify with the 1D transfer function (post-classification), correct the opacity for the
// length of this ray's segment between two planes, and emit premultiplied colour for front-to-back blending.
//
// Where a sample is, and which box it belongs to, does not depend on the polygon that produced the fragment: the
// sample is the point where the ray through the pixel centre meets the polygon's plane, computed from the pixel and
// the plane alone, and a box keeps it only when it lies in the voxels the box owns (half-open, the face towards the
// eye included). Boxes are drawn a little larger than what they own, so the fragment test, not the rasterised
// polygon edges, decides coverage: neighbouring boxes of any sizes (bricks, sub-blocks) then take every sample
// exactly once, and the volume's outline does not depend on the bricking.
//
// vPayload.xyz = slot origin + 1 - brick start (voxels): adding it to the sample's voxel coordinate gives the atlas
// texel coordinate; the one-voxel border keeps every fetch inside the slot. Voxel coordinates are clamped to
// [0, n] before a fetch: within half a voxel of the surface the value is the edge voxel's (clamp-to-edge) either
// way, and the fetch stays in the slot.

flat in ivec4 vPayload;
flat in ivec3 vOwnLo;
flat in ivec3 vOwnHi;
flat in float vPlaneDistance;

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
uniform mat4 uInvViewProj;       // clip to world
uniform vec2 uPixelToNdc;        // 2 / viewport size

out vec4 fragColor;

float sampleAt(vec3 voxel) {
  return texture(uAtlas, (clamp(voxel, vec3(0.0), uDims) + vec3(vPayload.xyz)) * uInvAtlasSize).r;
}

void main() {
  // The pixel's ray as the points at clip depth -1 and +1, then its intersection with this fragment's plane.
  const vec2 ndc = gl_FragCoord.xy * uPixelToNdc - 1.0;
  const vec4 onRay = uInvViewProj[0] * ndc.x + uInvViewProj[1] * ndc.y + uInvViewProj[3];
  const vec4 nearPoint = onRay - uInvViewProj[2];
  const vec4 farPoint = onRay + uInvViewProj[2];
  const vec3 origin = nearPoint.xyz / nearPoint.w;
  const vec3 direction = farPoint.xyz / farPoint.w - origin;
  const vec3 world = origin + direction * ((vPlaneDistance - dot(uViewDir, origin)) / dot(uViewDir, direction));
  const vec3 voxel = world * uInvSpacing + uHalfDims;
  // The ownership test sees the point on a grid of 1/256 voxel, so that a plane through a box face (a view along an
  // axis) lands exactly on the face despite the round-off of the ray, and the half-open rule decides.
  const vec3 snapped = round(voxel * 256.0) * (1.0 / 256.0);
  bool inside = true;
  for (int a = 0; a < 3; ++a) {
    inside = inside && (uViewDir[a] >= 0.0 ? (snapped[a] >= float(vOwnLo[a]) && snapped[a] < float(vOwnHi[a]))
                                           : (snapped[a] > float(vOwnLo[a]) && snapped[a] <= float(vOwnHi[a])));
  }
  if (!inside) discard;
  const float value = sampleAt(voxel);
#ifdef ROOFLINE
  fragColor = vec4(value);
  return;
#endif
  const float t = clamp((value - uWindowLo) * uWindowScale, 0.0, 1.0);
  const vec4 classified = texture(uTransfer, t);

  // Planes are uPlaneIncr apart along the view axis; a perspective ray crosses them obliquely, so its segment is
  // longer by 1 / cos(angle to the axis).
  const float cosine = uOrthographic != 0 ? 1.0 : max(dot(normalize(world - uEye), uViewDir), 1e-3);
  const float ratio = uStepOverReference / cosine;
  const float alpha = classified.a >= 1.0 ? 1.0 : 1.0 - exp(ratio * log(1.0 - classified.a));

  vec3 color = classified.rgb;
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
    color = color * (0.3 + 0.7 * diffuse) + vec3(0.25 * specular);
  }
#endif
  fragColor = vec4(color * alpha, alpha);
}
