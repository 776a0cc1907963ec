// Cancellation checkpoints of a frame: where a frame may be given up, and the pacing that makes giving up prompt.
#pragma once

#include <functional>

#include "render/gl/GlFunctions.h"

namespace voxbrick::render {

/// A frame's checkpoints (FrameOptions::cancelled). poll() throws FrameCancelled once the caller no longer wants the
/// frame; pace() does too, and then keeps at most two checkpoints of GL work queued: it waits (flushing) for the GL
/// work issued before the previous checkpoint, so that a driver that queues a whole frame before executing any of
/// it (llvmpipe) does its work as the frame is issued and giving up skips the rest. Without a `cancelled` function
/// both do nothing. The context must be current; the destructor deletes the fences.
class Checkpoints {
 public:
  /// `intervalSamples`: the work one checkpoint interval should hold, in estimated samples (about 50 ms on this
  /// device: FrameOptions::checkpointSamples); 0 leaves the passes' own bands.
  Checkpoints(const Gl& gl, std::function<bool()> cancelled, double intervalSamples = 0)
      : mGl(gl), mCancelled(std::move(cancelled)), mIntervalSamples(intervalSamples) {}
  ~Checkpoints();
  Checkpoints(const Checkpoints&) = delete;
  Checkpoints& operator=(const Checkpoints&) = delete;

  /// Between bricks: throws FrameCancelled if the frame is no longer wanted.
  void poll() const;
  /// After a batch or a slab is issued: poll(), then the pacing above.
  void pace();
  /// Whether the frame may be given up (a `cancelled` function was given).
  bool active() const { return bool(mCancelled); }
  /// The samples one interval should hold; 0 when not active or not given.
  double intervalSamples() const { return active() ? mIntervalSamples : 0; }

 private:
  const Gl& mGl;
  std::function<bool()> mCancelled;
  double mIntervalSamples = 0;
  GLsync mFences[2] = {nullptr, nullptr};  // the older first
};

}  // namespace voxbrick::render
