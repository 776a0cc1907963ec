// Full-screen passes in bands or tiles sized by their cost.
#include "render/gl/Bands.h"

#include <algorithm>
#include <cmath>

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

}  // namespace voxbrick::render
