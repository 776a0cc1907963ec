// What the marching passes share (texture slabs, render/SlabPass.h, the frame ray caster, render/RayCastPass.h, and
// the mesh ray caster, render/TetRayCaster.h): the termination pass of the silhouette map, the fragment program's
// counters, and full-screen passes drawn in bands.
#pragma once

#include "render/Checkpoints.h"
#include "render/Compositor.h"
#include "render/FrameStats.h"
#include "render/GlObjects.h"

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
  GLint mTerminationAt = -1, mAccumulatedAt = -1;
  VertexArray mNoAttributes;
};

/// The marching fragments' counters (SlabCounters of volume.frag.glsl, shader storage binding 0): fragments started,
/// samples taken, samples left when a fragment's opacity reached the termination threshold, as 64-bit counts.
class SampleCounters {
 public:
  explicit SampleCounters(const Gl& gl) : mGl(gl), mBuffer(gl) {}
  /// Zeroes the counters and binds them for the frame's passes.
  void reset();
  /// After the compositor's finish: the counts into stats.fragments, samples and samplesTerminated.
  void read(FrameStats& stats) const;

 private:
  const Gl& mGl;
  Buffer mBuffer;
};

/// Rows of a band of drawInBands.
inline constexpr int kBandRows = 64;

/// Draws the bound program's full-screen triangle (three vertices, no attributes) over a width x height target in
/// bands of kBandRows rows, scissored, pacing `checkpoints` after each band, so that a frame given up stops within
/// a band's work. The scissor test is off afterwards, also when FrameCancelled is thrown.
void drawInBands(const Gl& gl, int width, int height, Checkpoints& checkpoints);

}  // namespace voxbrick::render
