// The compositing stage: the float target that drawing passes blend into front to back, and the readback that
// composites the result over the scene's background (ARCHITECTURE.md, optical model: output).
#pragma once

#include "render/FrameStats.h"
#include "render/GlObjects.h"
#include "image/Image.h"
#include "render/Scene.h"

namespace voxbrick::render {

class Compositor {
 public:
  explicit Compositor(const Gl& gl);

  /// Binds a cleared RGBA32F target of the scene's size and sets front-to-back blending (premultiplied colour:
  /// C += (1 - A) * c, A += (1 - A) * a), or no blending at all for the roofline probe. Starts counting fragments.
  void begin(int width, int height, bool blend);
  /// Waits for the passes, reads the target back and composites it over `background`: out = C + (1 - A) * bg.
  /// Fills fragments, msDrawing (the wait) and msReadback.
  image::ImageF finish(const glm::dvec3& background, FrameStats& stats);

 private:
  const Gl& mGl;
  Framebuffer mTarget;
  Query mFragments;
};

}  // namespace voxbrick::render
