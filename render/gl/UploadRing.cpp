// Staged texture uploads through a fenced ring of pixel-unpack buffer regions.
#include "render/gl/UploadRing.h"

#include <string>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

UploadRing::UploadRing(const Gl& gl, size_t regionBytes, int regions)
    : mGl(gl), mBuffer(gl), mRegionBytes(regionBytes), mFences(size_t(std::max(1, regions)), nullptr) {
  mBuffer.allocate(GL_PIXEL_UNPACK_BUFFER, bytes(), nullptr, GL_STREAM_DRAW);
  mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
}

UploadRing::~UploadRing() {
  for (GLsync fence : mFences)
    if (fence) mGl.glDeleteSync(fence);
}

void* UploadRing::map() {
  GLsync& fence = mFences[mNext];
  if (fence) {
    // A first poll without waiting tells whether the ring was short; then wait in slices, flushing once.
    GLenum state = mGl.glClientWaitSync(fence, GL_SYNC_FLUSH_COMMANDS_BIT, 0);
    if (state == GL_TIMEOUT_EXPIRED) ++mWaits;
    while (state == GL_TIMEOUT_EXPIRED) state = mGl.glClientWaitSync(fence, 0, 100'000'000);
    mGl.glDeleteSync(fence);
    fence = nullptr;
    if (state == GL_WAIT_FAILED) throw RenderError("UploadRing: waiting for an upload's fence failed");
  }
  mBuffer.bind(GL_PIXEL_UNPACK_BUFFER);
  void* data = mGl.glMapBufferRange(GL_PIXEL_UNPACK_BUFFER, GLintptr(mNext * mRegionBytes), GLsizeiptr(mRegionBytes),
                                    GL_MAP_WRITE_BIT | GL_MAP_INVALIDATE_RANGE_BIT | GL_MAP_UNSYNCHRONIZED_BIT);
  if (!data) {
    const GLenum error = mGl.glGetError();
    mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    throw RenderError("UploadRing: cannot map " + std::to_string(mRegionBytes) +
                      " bytes of the upload buffer (GL error " + std::to_string(error) + ")");
  }
  mMapped = mNext;
  mNext = (mNext + 1) % mFences.size();
  return data;
}

size_t UploadRing::unmap() {
  if (!mGl.glUnmapBuffer(GL_PIXEL_UNPACK_BUFFER)) {
    mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    throw RenderError("UploadRing: the upload buffer's contents were lost while mapped");
  }
  return mMapped * mRegionBytes;
}

void UploadRing::fence() {
  mFences[mMapped] = mGl.glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
  mGl.glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
}

}  // namespace voxbrick::render
