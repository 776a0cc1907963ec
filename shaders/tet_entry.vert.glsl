// The adjacency ray caster's entry pass (render/gl/tets/TetRayCaster.h): per boundary face, a rectangle covering its
// projection with a pixel to spare (two triangles), pulled from storage buffers (three corners a face, centred on the
// mesh's box, counter-clockwise seen from outside; and the tet and face, coded as the ray caster's neighbours are). The rasteriser's own coverage of
// the face could miss a pixel whose ray does cross it (it snaps corners to its sub-pixel grid); the fragment stage
// decides exactly instead, from its triangle's corners.
layout(std430, binding = VB_BINDING_BOUNDARY_CORNERS) readonly buffer BoundaryCorners { vec4 uCorners[]; };
layout(std430, binding = VB_BINDING_BOUNDARY_FACES) readonly buffer BoundaryFaces { uint uFaces[]; };

uniform mat4 uViewProj;  // world (centred on the mesh) to clip
uniform vec2 uViewport;  // width, height in pixels

flat out uint vFace;
flat out vec3 vCorner0, vCorner1, vCorner2;

void main() {
  const int face = gl_VertexID / 6, corner = gl_VertexID % 6;
  vCorner0 = uCorners[3 * face].xyz;
  vCorner1 = uCorners[3 * face + 1].xyz;
  vCorner2 = uCorners[3 * face + 2].xyz;
  vFace = uFaces[face];
  // The mesh's box lies beyond the near plane (TetRenderer::rayCastable), so every w is positive.
  const vec4 c0 = uViewProj * vec4(vCorner0, 1.0), c1 = uViewProj * vec4(vCorner1, 1.0),
             c2 = uViewProj * vec4(vCorner2, 1.0);
  const vec2 p0 = c0.xy / c0.w, p1 = c1.xy / c1.w, p2 = c2.xy / c2.w;
  const vec2 margin = 2.0 / uViewport;  // a pixel, in normalised device coordinates
  const vec2 lo = min(min(p0, p1), p2) - margin, hi = max(max(p0, p1), p2) + margin;
  // Corners 0, 1, 2 and 2, 1, 3 of the rectangle: (lo, lo), (hi, lo), (lo, hi), (hi, hi).
  const int c = corner == 3 ? 2 : corner == 4 ? 1 : corner == 5 ? 3 : corner;
  gl_Position = vec4((c & 1) == 0 ? lo.x : hi.x, (c & 2) == 0 ? lo.y : hi.y, 0.0, 1.0);
}
