// The adjacency ray caster's fragment kernel (render/gl/tets/TetRayCaster.h): one fragment per pixel and pass walks
// the pixel's ray (walkPixel, tet_walk.glsl), blended under the passes before it.
out vec4 fragColor;

void main() {
  vec4 color;
  if (!walkPixel(color)) discard;
  fragColor = color;
}
