// The compute ray caster's dispatches in bands of workgroups, and the choice of kernel by device.
#include "render/gl/volume/ComputeRayCast.h"

#include <algorithm>

#include "render/gl/Bands.h"
#include "render/gl/Bindings.h"

namespace voxbrick::render {
namespace {

constexpr int kGroupX = VB_RAYCAST_GROUP_X, kGroupY = VB_RAYCAST_GROUP_Y;

/// What a batch's stores must be visible to: the next batch's image loads, and after the last, the readback
/// (glReadPixels through the framebuffer, or a fetch), the next frame's clear and the counters read with
/// glGetBufferSubData.
constexpr GLbitfield kBarriers = GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT |
                                 GL_TEXTURE_UPDATE_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT |
                                 GL_PIXEL_BUFFER_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT;

}  // namespace

bool computeRayCasterByDefault(const GlContext& context) {
  return !context.software() && context.renderer().find("NVIDIA") != std::string::npos;
}

void dispatchRayCast(const Gl& gl, const VolumeProgram& program, const Compositor& compositor, int width, int height,
                     Checkpoints& checkpoints, double samplesPerPixel) {
  program.program().use();
  compositor.bindImage(VB_IMAGE_ACCUMULATED);
  // Tiles of whole workgroups: the bands of drawInBands over a grid of groups, each group a pixel of
  // kGroupX * kGroupY times the cost, so that a band of one row of pixels does not leave most of each group idle.
  const int groupsX = (width + kGroupX - 1) / kGroupX, groupsY = (height + kGroupY - 1) / kGroupY;
  try {
    forEachTile(groupsX, groupsY, checkpoints, samplesPerPixel * kGroupX * kGroupY, [&](int x, int y, int w, int h) {
      const glm::ivec4 tile(x * kGroupX, y * kGroupY, std::min((x + w) * kGroupX, width),
                            std::min((y + h) * kGroupY, height));
      program.setTile(tile);
      gl.glDispatchCompute(GLuint(w), GLuint(h), 1);
    });
  } catch (...) {
    gl.glMemoryBarrier(kBarriers);  // the next frame clears and reads the target
    throw;
  }
  gl.glMemoryBarrier(kBarriers);
}

}  // namespace voxbrick::render
