// The visibility order of a mesh frame's projected tets, and the tets it skips as empty.
#include "render/tets/TetOrder.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mesh/Visibility.h"

namespace voxbrick::render {

void TetOrder::sort(const TetMeshData& data, const Camera& camera, TetSort sort, FrameStats& stats) {
  mOrder.clear();
  const mesh::ViewPoint eye{camera.eye, camera.viewDirection(), camera.orthographic};
  mesh::VisibilityStats sortStats;
  if (sort == TetSort::Centroid)
    mesh::centroidOrder(data.mesh, eye, mOrder, &sortStats);
  else
    mesh::mpvoOrder(data.mesh, data.topology, eye, mOrder, &sortStats);
  stats.msSorting = sortStats.ms;
  mDrawn.assign(data.mesh.tets.size(), 1);
}

void TetOrder::none(const TetMeshData& data) {
  mOrder.clear();
  mDrawn.assign(data.mesh.tets.size(), 1);
}

void TetOrder::skipEmpty(const TetMeshData& data, const TransferFunction& tf, const TetView& view, FrameStats& stats) {
  const double lo = view.windowLo;
  const double inverse = 1.0 / (view.windowHi - lo);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mDrawn.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      const auto [tetLo, tetHi] = data.tetRanges[t];
      mDrawn[t] = tf.contributes((double(tetLo) - lo) * inverse, (double(tetHi) - lo) * inverse);
    }
  });
  const size_t before = mOrder.size();
  std::erase_if(mOrder, [&](uint32_t t) { return !mDrawn[t]; });
  stats.tetsSkippedEmpty = int64_t(before - mOrder.size());
}

}  // namespace voxbrick::render
