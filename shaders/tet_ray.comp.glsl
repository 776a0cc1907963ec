// The adjacency ray caster's compute kernel (render/gl/tets/TetRayCaster.h): the fragment kernel's walk (walkPixel,
// tet_walk.glsl), one invocation per pixel in workgroups of VB_RAYCAST_GROUP_X x VB_RAYCAST_GROUP_Y pixels, over the
// tile [uTile.xy, uTile.zw) of the window. Each invocation owns its pixel of the compositor's target and composites
// its ray under what earlier passes left, as the blending does: C += (1 - A) c, A += (1 - A) a.
layout(local_size_x = VB_RAYCAST_GROUP_X, local_size_y = VB_RAYCAST_GROUP_Y) in;

layout(binding = VB_IMAGE_ACCUMULATED, rgba32f) uniform restrict image2D uAccumulated;
uniform ivec4 uTile;  // the pixels [xy, zw) of this dispatch, window coordinates

void main() {
  const ivec2 pixel = uTile.xy + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, uTile.zw))) return;
  gPixelCoord = vec2(pixel) + 0.5;  // gl_FragCoord's numbers: the pixel's centre
  vec4 color;
  if (!walkPixel(color)) return;
  const vec4 under = imageLoad(uAccumulated, pixel);
  imageStore(uAccumulated, pixel, under + (1.0 - under.a) * color);
}
