// Staged texture uploads: a ring of regions in one pixel-unpack buffer, each fenced after the copy that reads it.
#pragma once

#include <cstddef>
#include <vector>

#include "render/gl/GlFunctions.h"
#include "render/gl/GlObjects.h"

namespace voxbrick::render {

/// The CPU writes the next region (mapped unsynchronised, so the driver never stalls on the buffer as a whole), the
/// caller queues a glTex*SubImage from it, and the region is fenced; the fence is waited on only when the ring comes
/// round to that region again. So uploads overlap the GPU's copies and draws of earlier bricks, as long as the ring
/// holds more than one region. The context must be current for every call, the destructor included.
class UploadRing {
 public:
  /// `regions` regions of `regionBytes` each; throws RenderError if the buffer cannot be allocated.
  UploadRing(const Gl& gl, size_t regionBytes, int regions);
  ~UploadRing();
  UploadRing(const UploadRing&) = delete;
  UploadRing& operator=(const UploadRing&) = delete;

  /// Maps the next region for writing, after waiting for the copy that last read it; throws RenderError.
  void* map();
  /// Unmaps the region map() returned and leaves the buffer bound to GL_PIXEL_UNPACK_BUFFER: pass the returned
  /// offset as the data pointer of the glTex*SubImage call that reads it, then call fence().
  size_t unmap();
  /// Fences the region after the copy just queued from it and unbinds GL_PIXEL_UNPACK_BUFFER.
  void fence();

  size_t bytes() const { return mRegionBytes * mFences.size(); }
  /// How many map() calls had to wait for the GPU (the ring was too short for the copies in flight).
  size_t waits() const { return mWaits; }

 private:
  const Gl& mGl;
  Buffer mBuffer;
  size_t mRegionBytes;
  std::vector<GLsync> mFences;  // one per region; nullptr when nothing is in flight from it
  size_t mNext = 0, mMapped = 0, mWaits = 0;
};

}  // namespace voxbrick::render
