// Slicing a batch of boxes by the global planes.
#include "render/gl/volume/SlicingPass.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "render/core/FrameStats.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

/// The pixels of the screen rectangle around `box`'s projection: at most a slice's fragments in it (the whole
/// image when the box reaches behind the eye).
double boxPixels(const FramePlan& plan, const Box& box) {
  const double whole = double(plan.width) * plan.height;
  glm::dvec2 lo(1), hi(-1);
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 p((c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y,
                       (c & 4) ? box.max.z : box.min.z);
    const glm::dvec4 clip = plan.viewProj * glm::dvec4(p, 1.0);
    if (!(clip.w > 1e-12)) return whole;
    const glm::dvec2 ndc = glm::dvec2(clip) / clip.w;
    lo = glm::min(lo, ndc), hi = glm::max(hi, ndc);
  }
  lo = glm::clamp(lo, -1.0, 1.0), hi = glm::clamp(hi, -1.0, 1.0);
  return std::max(1.0, 0.25 * (hi.x - lo.x) * plan.width * (hi.y - lo.y) * plan.height);
}

}  // namespace

void SlicingPass::draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program,
                       SliceGeometry& geometry, FrameStats& stats, Checkpoints& checkpoints) {
  // A frame that may be cancelled draws whenever the queued slices reach a checkpoint interval's samples (a box's
  // planes split in runs, front to back), not only when a batch ends: the same slices in the same order.
  const double interval = checkpoints.intervalSamples();
  double queued = 0;
  auto drawQueued = [&] {
    queued = 0;
    if (geometry.empty()) return false;
    const auto t = Clock::now();
    program.program().use();
    geometry.draw();
    checkpoints.pace();
    stats.msDrawing += msSince(t);
    return true;
  };
  auto add = [&](const QueuedBox& b) {
    if (interval <= 0) {
      geometry.add(b.box, b.planes, b.payload, b.ownLo, b.ownHi, plan);
      return;
    }
    const double perPlane = boxPixels(plan, b.box);
    const int64_t run = std::max<int64_t>(1, int64_t(std::floor(interval / perPlane)));
    for (int64_t first = b.planes.begin; first < b.planes.end; first += run) {
      const PlaneIndexRange planes{first, std::min(b.planes.end, first + run)};
      if (queued + double(planes.count()) * perPlane > interval) drawQueued();
      geometry.add(b.box, planes, b.payload, b.ownLo, b.ownHi, plan);
      queued += double(planes.count()) * perPlane;
    }
  };
  auto flush = [&] {
    if (drawQueued()) stats.batches += 1;
  };
  mWalk.run(plan, residency, geometry, stats, checkpoints, add, flush);
}

}  // namespace voxbrick::render
