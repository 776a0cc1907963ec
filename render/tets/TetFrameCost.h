// A mesh frame's cost before anything is drawn, in the unit of FrameOptions::maxSamples. GL-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "render/tets/TetFramePlan.h"
#include "render/tets/TetMeshData.h"

namespace voxbrick::render {

/// Estimates what drawing a frame's tets costs; kept between frames for its storage.
class TetFrameCost {
 public:
  /// A tet's vertex stage (its strip's hull and planes, for each of four strip vertices) in fragments' work: about
  /// 0.7 s for a million tets on llvmpipe against about 45 ns a fragment, both measured.
  static constexpr double kFragmentsPerTet = 16;

  /// The cost of drawing the tets of `data` that `drawn` marks (per tet in mesh order) as `plan` sees them: a
  /// fragment counts as a sample, and each tet's projected bounding box inside the window bounds its fragments (and
  /// so the ray caster's segments in it; the whole window for a tet reaching behind the eye plane), plus
  /// kFragmentsPerTet for each of `vertexStages` tets drawn projected (none when ray casting).
  double estimate(const TetMeshData& data, const TetFramePlan& plan, const std::vector<uint8_t>& drawn,
                  size_t vertexStages);

 private:
  std::vector<glm::vec3> mProjected;  // each point's window position, z 0 at or behind the eye
};

}  // namespace voxbrick::render
