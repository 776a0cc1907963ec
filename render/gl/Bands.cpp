// Full-screen passes in bands or tiles sized by their cost.
#include "render/gl/Bands.h"

#include <algorithm>
#include <cmath>

#include "render/gl/Bindings.h"

namespace voxbrick::render {

void forEachTile(int width, int height, Checkpoints& checkpoints, double samplesPerPixel,
                 const std::function<void(int x, int y, int w, int h)>& tile) {
  int rows = kBandRows, columns = width;
  if (const double interval = checkpoints.intervalSamples(); interval > 0 && samplesPerPixel > 0) {
    const double pixels = std::max(1.0, std::floor(interval / samplesPerPixel));
    if (pixels >= width)
      rows = int(std::min<double>(kBandRows, std::floor(pixels / width)));
    else
      rows = 1, columns = std::max(1, int(pixels));
  }
  for (int y = 0; y < height; y += rows)
    for (int x = 0; x < width; x += columns) {
      tile(x, y, std::min(columns, width - x), std::min(rows, height - y));
      checkpoints.pace();
    }
}

void drawTiled(const Gl& gl, int width, int height, Checkpoints& checkpoints, double samplesPerPixel,
               const std::function<void()>& draw) {
  gl.glEnable(GL_SCISSOR_TEST);
  try {
    forEachTile(width, height, checkpoints, samplesPerPixel, [&](int x, int y, int w, int h) {
      gl.glScissor(x, y, w, h);
      draw();
    });
  } catch (...) {
    gl.glDisable(GL_SCISSOR_TEST);  // a cancelled frame leaves the state every pass expects
    throw;
  }
  gl.glDisable(GL_SCISSOR_TEST);
}

void drawInBands(const Gl& gl, int width, int height, Checkpoints& checkpoints, double samplesPerPixel) {
  drawTiled(gl, width, height, checkpoints, samplesPerPixel, [&] { gl.glDrawArrays(GL_TRIANGLES, 0, 3); });
}

void dispatchInTiles(const Gl& gl, int width, int height, Checkpoints& checkpoints, double samplesPerPixel,
                     const std::function<void(const glm::ivec4& tile)>& setTile) {
  constexpr int kGroupX = VB_RAYCAST_GROUP_X, kGroupY = VB_RAYCAST_GROUP_Y;
  // What the stores must be visible to: the next pass's image loads and fetches, the readback (glReadPixels through
  // the framebuffer, or a fetch), the next frame's clear and buffers read with glGetBufferSubData.
  constexpr GLbitfield kBarriers = GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT |
                                   GL_TEXTURE_UPDATE_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT |
                                   GL_PIXEL_BUFFER_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT |
                                   GL_SHADER_STORAGE_BARRIER_BIT;
  const int groupsX = (width + kGroupX - 1) / kGroupX, groupsY = (height + kGroupY - 1) / kGroupY;
  try {
    forEachTile(groupsX, groupsY, checkpoints, samplesPerPixel * kGroupX * kGroupY, [&](int x, int y, int w, int h) {
      setTile(glm::ivec4(x * kGroupX, y * kGroupY, std::min((x + w) * kGroupX, width),
                         std::min((y + h) * kGroupY, height)));
      gl.glDispatchCompute(GLuint(w), GLuint(h), 1);
    });
  } catch (...) {
    gl.glMemoryBarrier(kBarriers);  // the next frame clears and reads the target
    throw;
  }
  gl.glMemoryBarrier(kBarriers);
}

}  // namespace voxbrick::render
