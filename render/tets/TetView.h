// How a frame sees a tetrahedral mesh: the camera about the whole mesh's box and the value window. GL-free.
#pragma once

#include <glm/glm.hpp>

#include "render/core/Camera.h"
#include "render/core/Scene.h"
#include "render/tets/TetMeshData.h"

namespace voxbrick::render {

/// How a frame sees a mesh: its camera about the whole mesh's box and the value window (GL-free; TetRenderer and
/// the exact reference both start from it).
struct TetView {
  Camera camera;
  double nearPlane = 0, farPlane = 0;
  glm::dmat4 clipFromWorld{1.0};  ///< projection times view, world coordinates (not centred on the box)
  double windowLo = 0, windowHi = 1;

  /// The view of a frame of `scene` on a mesh of `constants`; the window is the scene's, or the scalar range (made
  /// one wide when the range is a single value).
  static TetView of(const Scene& scene, const TetMeshConstants& constants);
};

}  // namespace voxbrick::render
