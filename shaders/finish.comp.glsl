// The frame's last step on the GPU (render/gl/Compositor.h, finish8): the accumulated premultiplied colour C and
// opacity A over the opaque background, out = clamp(C + (1 - clamp(A)) * background), rounded to 8 bits as
// image::toImage8 rounds (floor(x * 255 + 0.5)), alpha 255; one uint a pixel (red in the low byte, so that its bytes
// in memory are R, G, B, A), rows top first. So the readback is the 8-bit image as it is, a quarter of the float
// target's bytes, and no pixel is touched on the CPU. `precise` keeps each operation rounded as the CPU's float
// arithmetic rounds it (no fused multiply-add), so that the bytes are toImage8's of Compositor::finish's floats.
layout(local_size_x = VB_FINISH_GROUP_X, local_size_y = VB_FINISH_GROUP_Y) in;

layout(binding = VB_UNIT_ACCUMULATED) uniform sampler2D uAccumulated;
layout(std430, binding = VB_BINDING_FRAME8) writeonly restrict buffer Frame8 { uint uFrame8[]; };
uniform ivec4 uSize;       // xy: the frame's width and height
uniform vec3 uBackground;  // the scene's background, RGB in [0, 1]

void main() {
  const ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(p, uSize.xy))) return;
  const vec4 src = texelFetch(uAccumulated, p, 0);
  precise float clear = 1.0 - clamp(src.a, 0.0, 1.0);
  uint rgba = 255u << 24;
  for (int c = 0; c < 3; ++c) {
    precise float value = clamp(src[c] + clear * uBackground[c], 0.0, 1.0);
    precise float scaled = value * 255.0 + 0.5;
    rgba |= uint(floor(scaled)) << (8 * c);
  }
  uFrame8[(uSize.y - 1 - p.y) * uSize.x + p.x] = rgba;
}
