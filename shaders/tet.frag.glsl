// A fragment of a projected tetrahedron: its pixel's ray meets the tet between the entry and exit faces (where the
// barycentric planes of tet.vert.glsl cross zero), the scalar is linear in between, and the segment's colour and
// opacity come from the pre-integrated table (front value, back value, length): render/PreIntegration.h, the
// optical model of ARCHITECTURE.md. Exact for perspective rays (the ray is the pixel's own, in world units), with
// no sprite size limit. Premultiplied output, blended front to back in the visibility order.
flat in vec4 vPlane[4];
flat in vec4 vScalar;

uniform vec3 uRayOrigin, uRayOriginDx, uRayOriginDy;           // ray origin (near plane) at window (x, y)
uniform vec3 uRayDirection, uRayDirectionDx, uRayDirectionDy;  // near plane to far plane at window (x, y)
uniform float uInvReference;  // 1 / the transfer function's reference length

// The pre-integrated table (render/PreIntegration.h), its resolution and length layers.
uniform sampler3D uPreIntegrated;
uniform float uTableResolution;
uniform float uRatioMin;
uniform float uLayerScale;
uniform float uLayers;

out vec4 fragColor;

void main() {
#ifdef NULL_FRAGMENT
  // The seed's null fragment program (its Table 3): no computation, a constant colour, so that what remains is the
  // vertex stage, rasterisation and blending.
  fragColor = vec4(1.0);
  return;
#endif
  const vec3 origin = uRayOrigin + gl_FragCoord.x * uRayOriginDx + gl_FragCoord.y * uRayOriginDy;
  const vec3 direction = uRayDirection + gl_FragCoord.x * uRayDirectionDx + gl_FragCoord.y * uRayDirectionDy;
  // The ray's parameter range inside the tet (t in [0, 1] runs from the near plane to the far plane).
  float enter = 0.0, leave = 1.0;
  for (int i = 0; i < 4; ++i) {
    const vec3 n = vPlane[i].xyz;
    const float at = dot(n, origin) + vPlane[i].w;
    const float rate = dot(n, direction);
    // Inside where at + t * rate >= 0: rising through the face enters, falling leaves.
    if (abs(rate) > 1e-6 * length(n) * length(direction)) {
      if (rate > 0.0)
        enter = max(enter, -at / rate);
      else
        leave = min(leave, -at / rate);
      continue;
    }
    // A ray parallel to the face (a view along a mesh's own planes) is inside or outside all along. In the face's
    // plane, where the two tets sharing it would each decide by their own rounding (both keeping the ray, or
    // neither: a line across the image), the ray is taken as moved by eps * (one pixel right) + eps^2 * (one pixel
    // up), as the reference does: the two tets' planes point opposite ways, so exactly one keeps it.
    float side = at;
    if (abs(at) <= 1e-5) {
      side = dot(n, uRayOriginDx);
      if (abs(side) <= 1e-6 * length(n) * length(uRayOriginDx)) side = dot(n, uRayOriginDy);
    }
    if (side <= 0.0) discard;
  }
  if (!(leave > enter)) discard;
  const float front = dot(vScalar.xyz, origin + enter * direction) + vScalar.w;
  const float back = dot(vScalar.xyz, origin + leave * direction) + vScalar.w;
  const float ratio = (leave - enter) * length(direction) * uInvReference;
  // Below the table's shortest segment both colour and opacity are linear in the length to first order (a thin
  // segment): the shortest layer's entry, scaled.
  const float scale = ratio < uRatioMin ? ratio / uRatioMin : 1.0;
  const float layer = (clamp(log(max(ratio, uRatioMin) / uRatioMin) * uLayerScale, 0.0, uLayers - 1.0) + 0.5) / uLayers;
  const vec2 st = (clamp(vec2(front, back), 0.0, 1.0) * (uTableResolution - 1.0) + 0.5) / uTableResolution;
  fragColor = texture(uPreIntegrated, vec3(st, layer)) * scale;
}
