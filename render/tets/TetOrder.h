// A mesh frame's visibility order on the CPU: the tets front to back (mesh/Visibility.h: MPVO or by centroid), less
// those the transfer function makes transparent. GL-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "render/core/Camera.h"
#include "render/core/FrameStats.h"
#include "render/core/Scene.h"
#include "render/tets/TetMeshData.h"
#include "render/tets/TetView.h"

namespace voxbrick::render {

/// The tets a frame draws projected, in the order it draws them; kept between frames for its storage.
class TetOrder {
 public:
  /// Sorts every tet of `data` front to back as seen from `camera`, by `sort` (TetSort::Ray sorts by MPVO: the
  /// projected tets a ray-cast frame falls back to), its time into stats.msSorting. Every tet is marked drawn.
  void sort(const TetMeshData& data, const Camera& camera, TetSort sort, FrameStats& stats);
  /// No order (a ray-cast frame: each ray finds its own), every tet of `data` marked drawn.
  void none(const TetMeshData& data);
  /// Empty-space skipping per tet: one whose value range `tf` makes transparent over `view`'s window is marked not
  /// drawn and left out of the order (after sorting: MPVO needs every tet's faces to order the others); their count
  /// into stats.tetsSkippedEmpty.
  void skipEmpty(const TetMeshData& data, const TransferFunction& tf, const TetView& view, FrameStats& stats);

  /// The tets to draw, front to back.
  const std::vector<uint32_t>& tets() const { return mOrder; }
  size_t size() const { return mOrder.size(); }
  /// Per tet in mesh order: 1 if the frame draws it.
  const std::vector<uint8_t>& drawn() const { return mDrawn; }

 private:
  std::vector<uint32_t> mOrder;
  std::vector<uint8_t> mDrawn;
};

}  // namespace voxbrick::render
