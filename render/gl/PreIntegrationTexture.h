// The pre-integration table on the GPU: a 3D texture (front value, back value, segment length) made from
// render/core/PreIntegration.h's table for a frame's transfer function and segment lengths, rebuilt only when those
// change (a server answering one transfer function builds it once).
#pragma once

#include <vector>

#include "render/core/PreIntegration.h"
#include "render/gl/GlObjects.h"

namespace voxbrick::render {

class PreIntegrationTexture {
 public:
  /// Table resolution per value axis. 256 keeps the table within 3e-7 of the converged integral on the presets
  /// (render/core/PreIntegration.h); the transfer functions' own features are resolved by the exact integration.
  static constexpr int kResolution = 256;
  /// The largest opacity error the filter's interpolation between length layers may add.
  static constexpr double kMaxLayerError = 1e-3;

  explicit PreIntegrationTexture(const Gl& gl) : mGl(gl), mTexture(gl, GL_TEXTURE_3D) {}

  /// Makes the table of `tf` for segments of [ratioMin, ratioMax] reference lengths current (a grid frame's:
  /// FramePlan::segmentRatios), rebuilding it only if they changed, and binds it on texture unit `unit`. Returns the
  /// milliseconds spent building (0 when it was current).
  double update(const TransferFunction& tf, double ratioMin, double ratioMax, int unit);
  /// The table's shape and texel mapping (valid after update).
  const PreIntegrationSpec& spec() const { return mSpec; }

 private:
  const Gl& mGl;
  Texture mTexture;
  PreIntegrationSpec mSpec;
  bool mBuilt = false;
  std::vector<TransferFunction::Point> mPoints;  // what the current table was built from
  std::optional<double> mReferenceLength;
};

}  // namespace voxbrick::render
