// Early ray termination between the marching passes of texture slabs and the frame ray caster.
#pragma once

#include "render/gl/Compositor.h"
#include "render/gl/GlObjects.h"

namespace voxbrick::render {

/// Early ray termination between passes: a pass over the accumulated colour writes depth 0 where its opacity reached
/// the threshold, so that the early depth test (the target's silhouette map, Compositor::begin) rejects those pixels'
/// fragments in every later pass. Marching fragments lie at depth 1/2 and are tested GL_LESS.
class TerminationPass {
 public:
  explicit TerminationPass(const Gl& gl);
  /// Marks the pixels of `compositor`'s target whose opacity reached `threshold`; leaves the target bound.
  void run(double threshold, Compositor& compositor) const;

 private:
  const Gl& mGl;
  Program mProgram;
  GLint mTerminationAt = -1;
  VertexArray mNoAttributes;
};

}  // namespace voxbrick::render
