// Cancellation checkpoints with fence pacing.
#include "render/gl/Checkpoints.h"

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

Checkpoints::~Checkpoints() {
  for (GLsync fence : mFences)
    if (fence) mGl.glDeleteSync(fence);
}

void Checkpoints::poll() const {
  if (mCancelled && mCancelled()) throw FrameCancelled("frame cancelled: its request is no longer wanted");
}

void Checkpoints::pace() {
  if (!mCancelled) return;
  poll();
  if (GLsync older = mFences[0]) {
    GLenum state = mGl.glClientWaitSync(older, GL_SYNC_FLUSH_COMMANDS_BIT, 0);
    while (state == GL_TIMEOUT_EXPIRED) {
      state = mGl.glClientWaitSync(older, 0, 20'000'000);  // 20 ms slices: the request may go meanwhile
      if (state == GL_TIMEOUT_EXPIRED) poll();
    }
    mGl.glDeleteSync(older);
    if (state == GL_WAIT_FAILED) {
      mFences[0] = nullptr;
      throw RenderError("Checkpoints: waiting for a fence failed");
    }
  }
  mFences[0] = mFences[1];
  mFences[1] = mGl.glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
}

}  // namespace voxbrick::render
