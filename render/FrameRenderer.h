// The one call every renderer answers, whatever kind of dataset it draws. GL-free.
#pragma once

#include "render/FrameStats.h"
#include "image/Image.h"
#include "render/Scene.h"

namespace voxbrick::render {

/// What the fragment stage does: the optical model, or (for benchmarks) exactly one sample per fragment with no
/// classification and no blending, the sampling roofline of the same geometry.
enum class RenderMode { Normal, Roofline };

/// A renderer of one dataset on one GL context (so one render thread); it keeps its GPU state between frames.
class FrameRenderer {
 public:
  virtual ~FrameRenderer() = default;
  /// Renders `scene`; throws RenderInputError for an invalid scene and RenderError for GL failures.
  virtual image::ImageF render(const Scene& scene, FrameStats* stats = nullptr, RenderMode mode = RenderMode::Normal) = 0;
};

}  // namespace voxbrick::render
