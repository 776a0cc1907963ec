// The marching fragment programs' counters (slabs, the frame ray caster, the mesh ray caster).
#pragma once

#include "render/core/FrameStats.h"
#include "render/gl/GlObjects.h"

namespace voxbrick::render {

/// The marching fragments' counters (SlabCounters of volume_counters.glsl, storage binding VB_BINDING_SAMPLE_COUNTERS
/// of render/gl/Bindings.h): fragments started,
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

}  // namespace voxbrick::render
