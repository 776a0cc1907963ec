// What the ray casters' compute kernels share (raycast.comp.glsl, tet_ray.comp.glsl): one invocation per pixel in
// workgroups of VB_RAYCAST_GROUP_X x VB_RAYCAST_GROUP_Y pixels over the tile [uTile.xy, uTile.zw) of the window (a
// dispatch of dispatchInTiles, render/gl/Bands.h), and the compositor's target as an image, into which each invocation
// composites its own pixel.
#ifdef COMPUTE_STAGE
layout(local_size_x = VB_RAYCAST_GROUP_X, local_size_y = VB_RAYCAST_GROUP_Y) in;

layout(binding = VB_IMAGE_ACCUMULATED, rgba32f) uniform restrict image2D uAccumulated;
uniform ivec4 uTile;  // the pixels [xy, zw) of this dispatch, window coordinates

// This invocation's pixel; false past the tile's edge (a tile need not be whole workgroups wide).
bool tilePixel(out ivec2 pixel) {
  pixel = uTile.xy + ivec2(gl_GlobalInvocationID.xy);
  return all(lessThan(pixel, uTile.zw));
}
#endif
