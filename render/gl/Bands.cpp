// Full-screen passes in bands.
#include "render/gl/Bands.h"

#include <algorithm>

namespace voxbrick::render {

void drawInBands(const Gl& gl, int width, int height, Checkpoints& checkpoints) {
  gl.glEnable(GL_SCISSOR_TEST);
  try {
    for (int y = 0; y < height; y += kBandRows) {
      gl.glScissor(0, y, width, std::min(kBandRows, height - y));
      gl.glDrawArrays(GL_TRIANGLES, 0, 3);
      checkpoints.pace();
    }
  } catch (...) {
    gl.glDisable(GL_SCISSOR_TEST);  // a cancelled frame leaves the state every pass expects
    throw;
  }
  gl.glDisable(GL_SCISSOR_TEST);
}

}  // namespace voxbrick::render
