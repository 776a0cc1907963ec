// The frame ray caster's compute kernel (render/gl/volume/ComputeRayCast.h): the same march as the fragment kernel
// (marchPixel, volume_march.glsl), one invocation per pixel in workgroups of VB_RAYCAST_GROUP_X x VB_RAYCAST_GROUP_Y
// pixels, over the tile [uTile.xy, uTile.zw) of the window. Each invocation owns its pixel of the compositor's
// target: it reads what earlier batches accumulated, leaves a pixel whose opacity reached the termination threshold
// (what the silhouette map does for the fragment kernel) and composites its batch's ray under the rest as the
// blending does, C += (1 - A) c, A += (1 - A) a. With ROOFLINE, the march's result is stored as it is, as the
// fragment kernel's is without blending.
void main() {
  ivec2 pixel;
  if (!tilePixel(pixel)) return;  // compute_tile.glsl
  // gl_FragCoord's numbers: the pixel's centre.
  const vec2 window = vec2(pixel) + 0.5;
#ifdef ROOFLINE
  imageStore(uAccumulated, pixel, marchPixel(window));
#else
  const vec4 under = imageLoad(uAccumulated, pixel);
  if (under.a >= uTermination) return;
  const vec4 ray = marchPixel(window);
  imageStore(uAccumulated, pixel, under + (1.0 - under.a) * ray);
#endif
}
