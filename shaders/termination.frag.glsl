// Early ray termination (render/gl/volume/SlabPass.h): keeps the pixels whose accumulated opacity reached uTermination, so
// that their depth becomes 0 and the early depth test rejects their fragments in every later slab. It reads the
// accumulated colour through a framebuffer that holds only the depth buffer: no feedback loop.
layout(binding = VB_UNIT_ACCUMULATED) uniform sampler2D uAccumulated;
uniform float uTermination;

void main() {
  if (texelFetch(uAccumulated, ivec2(gl_FragCoord.xy), 0).a < uTermination) discard;
}
