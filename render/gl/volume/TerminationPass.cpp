// The termination pass of the silhouette map.
#include "render/gl/volume/TerminationPass.h"

#include "render/gl/Bindings.h"

namespace voxbrick::render {

TerminationPass::TerminationPass(const Gl& gl)
    : mGl(gl),
      mProgram(gl, ProgramSources::fromFiles("termination", {{GL_VERTEX_SHADER, "termination.vert.glsl"},
                                                             {GL_FRAGMENT_SHADER, "termination.frag.glsl"}})),
      mTerminationAt(mProgram.requireUniform("uTermination")),
      mNoAttributes(gl) {}

void TerminationPass::run(double threshold, Compositor& compositor) const {
  compositor.bindSilhouette();
  compositor.accumulated().bind(VB_UNIT_ACCUMULATED);
  mProgram.use();
  mProgram.set(mTerminationAt, float(threshold));
  mNoAttributes.bind();
  mGl.glDepthMask(GL_TRUE);
  mGl.glDrawArrays(GL_TRIANGLES, 0, 3);
  mGl.glDepthMask(GL_FALSE);
  compositor.bindTarget();
}

}  // namespace voxbrick::render
