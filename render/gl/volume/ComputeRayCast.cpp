// The compute ray caster's dispatches in bands of workgroups.
#include "render/gl/volume/ComputeRayCast.h"

#include "render/gl/Bands.h"
#include "render/gl/Bindings.h"

namespace voxbrick::render {

void dispatchRayCast(const Gl& gl, const VolumeProgram& program, const Compositor& compositor, int width, int height,
                     Checkpoints& checkpoints, double samplesPerPixel) {
  program.program().use();
  compositor.bindImage(VB_IMAGE_ACCUMULATED);
  dispatchInTiles(gl, width, height, checkpoints, samplesPerPixel,
                  [&](const glm::ivec4& tile) { program.setTile(tile); });
}

}  // namespace voxbrick::render
