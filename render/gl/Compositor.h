// The compositing stage: the float target that drawing passes blend into front to back, and the readback that
// composites the result over the scene's background (ARCHITECTURE.md, optical model: output).
#pragma once

#include <vector>

#include "image/Image.h"
#include "render/core/FrameStats.h"
#include "render/core/Scene.h"
#include "render/gl/GlObjects.h"

namespace voxbrick::render {

class Compositor {
 public:
  explicit Compositor(const Gl& gl);

  /// Binds a cleared RGBA32F target of the scene's size and sets front-to-back blending (premultiplied colour:
  /// C += (1 - A) * c, A += (1 - A) * a), or no blending at all for the roofline probe. Starts counting fragments.
  /// With `silhouette`, the target also has a depth buffer, cleared to 1, tested (GL_LESS) and not written: the
  /// slab silhouette map of render/gl/volume/SlabPass.h.
  void begin(int width, int height, bool blend, bool silhouette = false);
  /// The colour accumulated so far, for a pass that reads it while bound to silhouette().
  const Texture& accumulated() const { return mTarget.color(); }
  /// Binds a framebuffer holding only the target's depth buffer (begin with `silhouette`), for a pass that writes
  /// the silhouette map while it reads accumulated(); target() binds the whole target again.
  void bindSilhouette() const;
  void bindTarget() const { mTarget.bind(); }
  /// Binds the target's colour to image unit `unit` (GL_RGBA32F, read and write), for a compute pass that composites
  /// into it itself (render/gl/volume/ComputeRayCast.h): blending, the silhouette map and the fragment count do not
  /// apply to it, and it must issue its own memory barriers before the target is read or drawn to again.
  void bindImage(GLuint unit) const;
  /// Waits for the passes, reads the target back and composites it over the scene's background, out = C + (1 - A)
  /// * bg, or keeps the opacity as alpha when the background is transparent (Scene::output). Fills fragments,
  /// msDrawing (the wait) and msReadback. With `premultiplied` (a part's frame in sort-last rendering) the target is
  /// returned as it is, premultiplied colour and opacity with no background (render/core/PartialFrame.h).
  image::ImageF finish(const Scene& scene, FrameStats& stats, bool premultiplied = false);
  /// As finish, as 8-bit RGBA: the frame image::toImage8(finish(scene, stats)) gives, the same bytes, but finished
  /// on the GPU (finish.comp.glsl: the background composited and each channel rounded there) and read back as a
  /// quarter of the float target's bytes, with no pass over the pixels on the CPU. A transparent background's
  /// straight colour (c / a, in double on the CPU) is finished by finish and rounded after.
  image::Image8 finish8(const Scene& scene, FrameStats& stats);
  /// After a frame failed between begin() and finish(): ends the fragment count and puts back the state every
  /// pass expects at the start of a frame (colour and depth writes, depth range), so the next frame starts clean.
  void abort();

 private:
  /// Ends the fragment count and waits for the passes (msDrawing, fragments).
  void endPasses(FrameStats& stats);

  const Gl& mGl;
  Framebuffer mTarget;
  Texture mDepth;  // GL_DEPTH_COMPONENT32F, attached to mTarget and mDepthOnly when silhouettes are used
  Framebuffer mDepthOnly;
  Query mFragments;
  bool mCounting = false;   // between begin() and finish()/abort(): the fragment query is active
  std::vector<float> mRaw;  // the readback, kept: faulting in 4 MB of fresh pages costs 13 ms on a VM
  Program mFinish8;         // finish.comp.glsl, made on the first finish8
  GLint mFinish8Size = -1, mFinish8Background = -1;  // its uniforms' locations
  Buffer mFrame8;           // its output, a uint a pixel
  size_t mFrame8Bytes = 0;  // mFrame8's size
};

}  // namespace voxbrick::render
