// A fragment of a projected tetrahedron: its pixel's ray meets the tet between the entry and exit faces (where the
// barycentric planes of tet.vert.glsl cross zero), the scalar is linear in between, and the segment's colour and
// opacity come from the pre-integrated table (front value, back value, length; with SHADING, the grids' headlight):
// classifySegment and shadeSegment of the library tet.glsl. Exact for perspective rays, with no sprite size limit.
// Premultiplied output, blended front to back in the visibility order. With PART_CLIP (a sort-last part), the
// segment is cut to the part's box first: the scalar is linear along it, so the cut ends' values are exact.
noperspective in vec4 vAt;     // tet.vert.glsl: the barycentric planes along the ray, at + t * rate
noperspective in vec4 vRate;
noperspective in vec2 vValue;  // the normalised scalar along the ray, vValue.x + t * vValue.y
flat in vec4 vNormSquared;
flat in vec4 vTie;
#ifdef SHADING
flat in vec3 vGradient;
#endif

uniform vec3 uRayDirection, uRayDirectionDx, uRayDirectionDy;  // near plane to far plane at window (x, y)
#ifdef PART_CLIP
uniform vec3 uRayOrigin, uRayOriginDx, uRayOriginDy;  // ray origin (near plane) at window (x, y)
#endif
out vec4 fragColor;

void main() {
#ifdef NULL_FRAGMENT
  // Carrard & Juliachs' null fragment program (their Table 3): no computation, a constant colour, so that what
  // remains is the vertex stage, rasterisation and blending.
  fragColor = vec4(1.0);
  return;
#endif
  const vec3 direction = uRayDirection + gl_FragCoord.x * uRayDirectionDx + gl_FragCoord.y * uRayDirectionDy;
  const float directionSquared = dot(direction, direction);
  // The ray's parameter range inside the tet (t in [0, 1] runs from the near plane to the far plane).
  float enter = 0.0, leave = 1.0;
  for (int i = 0; i < 4; ++i) {
    const float at = vAt[i], rate = vRate[i];
    // Inside where at + t * rate >= 0: rising through the face enters, falling leaves. (Parallel: |cos| <= 1e-6,
    // compared in squares.)
    if (rate * rate > 1e-12 * vNormSquared[i] * directionSquared) {
      if (rate > 0.0)
        enter = max(enter, -at / rate);
      else
        leave = min(leave, -at / rate);
    } else if ((abs(at) <= 1e-5 ? vTie[i] : at) <= 0.0) {
      // A ray parallel to the face (a view along a mesh's own planes) is inside or outside all along; in the face's
      // plane, where the two tets sharing it would each decide by their own rounding (both keeping the ray, or
      // neither: a line across the image), the tie rule of tet.vert.glsl decides, as the reference does.
      discard;
    }
  }
#ifdef PART_CLIP
  const vec2 part =
      partRange(uRayOrigin + gl_FragCoord.x * uRayOriginDx + gl_FragCoord.y * uRayOriginDy, direction);
  enter = max(enter, part.x);
  leave = min(leave, part.y);
#endif
  if (!(leave > enter)) discard;
  const float front = vValue.x + enter * vValue.y;
  const float back = vValue.x + leave * vValue.y;
  const float ratio = (leave - enter) * sqrt(directionSquared) * uInvReference;
  fragColor = classifySegment(front, back, ratio);
#ifdef SHADING
  fragColor = shadeSegment(fragColor, vGradient, direction);
#endif
}
