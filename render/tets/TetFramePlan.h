// The first stage of a mesh frame, without GL: the view and value window, the matrix and pixel rays the programs
// take, whether the frame may be ray cast as far as the view decides, the reference length, and the cost check.
// Later stages (residency, visibility order, passes) only read it.
#pragma once

#include <cstddef>

#include <glm/glm.hpp>

#include "render/core/FrameRenderer.h"
#include "render/core/PixelRays.h"
#include "render/core/Scene.h"
#include "render/tets/TetMeshData.h"
#include "render/tets/TetView.h"

namespace voxbrick::render {

struct TetFramePlan {
  TetView view;               ///< camera, clip range and value window
  glm::dmat4 viewProj{1.0};   ///< world centred on the mesh's box (as the GPU's vertices are) to clip
  PixelRays pixels;           ///< each pixel's ray, in the same centred world
  int width = 0, height = 0;  ///< image size in pixels
  /// RenderMode::Roofline: projected tets drawn with the null fragment program, no table.
  bool nullFragment = false;
  /// The scene asks for the ray caster (TetSort::Ray), the mode classifies, and the mesh's box lies wholly beyond
  /// the near plane (each ray then meets the mesh first at a boundary face). The GPU may still draw projected tets
  /// where the ray caster cannot hold the mesh (TetResidency::rayCaster).
  bool rayCast = false;
  /// The length the transfer function's opacities are given for: the scene's, else the mesh's mean edge length.
  double reference = 1;
  double maxSamples = 0;  ///< FrameOptions::maxSamples: 0 for no limit

  /// 1 / (hi - lo) of the view's value window.
  double windowScale() const { return 1.0 / (view.windowHi - view.windowLo); }
  /// Throws RenderLimitError when `samplesEstimated` (TetFrameCost) is above maxSamples, naming the `tets` drawn.
  void checkCost(double samplesEstimated, size_t tets) const;
};

/// Plans a frame of `scene` on a mesh of `constants`. Throws RenderInputError for an invalid scene, and for
/// RenderMode::Points (a mesh has no slices).
TetFramePlan planTetFrame(const Scene& scene, const TetMeshConstants& constants, const FrameOptions& options);

/// Whether `box` lies wholly beyond `camera`'s near plane at `nearPlane` along the view direction.
bool beyondNearPlane(const Box& box, const Camera& camera, double nearPlane);

}  // namespace voxbrick::render
