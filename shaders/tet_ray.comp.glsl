// The adjacency ray caster's compute kernel (render/gl/tets/TetRayCaster.h): the fragment kernel's walk (walkPixel,
// tet_walk.glsl) at each invocation's pixel (compute_tile.glsl), composited under what earlier passes left, as the
// blending does: C += (1 - A) c, A += (1 - A) a.
void main() {
  ivec2 pixel;
  if (!tilePixel(pixel)) return;
  gPixelCoord = vec2(pixel) + 0.5;  // gl_FragCoord's numbers: the pixel's centre
  vec4 color;
  if (!walkPixel(color)) return;
  const vec4 under = imageLoad(uAccumulated, pixel);
  imageStore(uAccumulated, pixel, under + (1.0 - under.a) * color);
}
