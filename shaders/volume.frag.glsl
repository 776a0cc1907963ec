// One slice fragment under the optical model of DESIGN.md: trilinear sample from the brick atlas, normalise through
// the value window, classify with the 1D transfer function (post-classification), correct the opacity for the
// length of this ray's segment between two planes, and emit premultiplied colour for front-to-back blending.
//
// vPayload.xyz = slot origin + 1 - brick start (voxels): adding it to the fragment's voxel coordinate gives the
// atlas texel coordinate; the one-voxel border keeps every fetch inside the slot.

in vec3 vWorld;
flat in ivec4 vPayload;

uniform sampler3D uAtlas;
uniform sampler1D uTransfer;
uniform vec3 uInvAtlasSize;
uniform vec3 uInvSpacing;        // 1 / voxel spacing
uniform vec3 uHalfDims;          // n / 2: voxel coordinate of the world origin
uniform float uWindowLo;         // the value window [lo, hi] as lo and 1 / (hi - lo)
uniform float uWindowScale;
uniform float uStepOverReference;  // plane spacing / reference length
uniform vec3 uEye;
uniform vec3 uViewDir;
uniform int uOrthographic;

out vec4 fragColor;

float sampleAt(vec3 texel) { return texture(uAtlas, texel * uInvAtlasSize).r; }

void main() {
  const vec3 texel = vWorld * uInvSpacing + uHalfDims + vec3(vPayload.xyz);
  const float value = sampleAt(texel);
#ifdef ROOFLINE
  fragColor = vec4(value);
  return;
#endif
  const float t = clamp((value - uWindowLo) * uWindowScale, 0.0, 1.0);
  const vec4 classified = texture(uTransfer, t);

  // Planes are uPlaneIncr apart along the view axis; a perspective ray crosses them obliquely, so its segment is
  // longer by 1 / cos(angle to the axis).
  const float cosine = uOrthographic != 0 ? 1.0 : max(dot(normalize(vWorld - uEye), uViewDir), 1e-3);
  const float ratio = uStepOverReference / cosine;
  const float alpha = classified.a >= 1.0 ? 1.0 : 1.0 - exp(ratio * log(1.0 - classified.a));

  vec3 color = classified.rgb;
#ifdef SHADING
  // Central differences half a voxel each way: the samples stay inside the slot (whose border is one voxel).
  const vec3 gradient = vec3(sampleAt(texel + vec3(0.5, 0, 0)) - sampleAt(texel - vec3(0.5, 0, 0)),
                             sampleAt(texel + vec3(0, 0.5, 0)) - sampleAt(texel - vec3(0, 0.5, 0)),
                             sampleAt(texel + vec3(0, 0, 0.5)) - sampleAt(texel - vec3(0, 0, 0.5))) * uInvSpacing;
  const float magnitude = length(gradient);
  if (magnitude > 1e-12) {
    const vec3 normal = -gradient / magnitude;
    const vec3 toEye = uOrthographic != 0 ? -uViewDir : normalize(uEye - vWorld);
    const float diffuse = abs(dot(normal, toEye));  // two-sided headlight
    const float specular = pow(diffuse, 32.0);
    color = color * (0.3 + 0.7 * diffuse) + vec3(0.25 * specular);
  }
#endif
  fragColor = vec4(color * alpha, alpha);
}
