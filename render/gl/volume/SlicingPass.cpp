// Slicing a batch of boxes by the global planes.
#include "render/gl/volume/SlicingPass.h"

#include <chrono>

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

void SlicingPass::draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program,
                       SliceGeometry& geometry, FrameStats& stats, Checkpoints& checkpoints) {
  auto add = [&](const QueuedBox& b) { geometry.add(b.box, b.planes, b.payload, b.ownLo, b.ownHi, plan); };
  auto flush = [&] {
    if (geometry.empty()) return;
    const auto t = Clock::now();
    program.program().use();
    geometry.draw();
    stats.batches += 1;
    checkpoints.pace();
    stats.msDrawing += msSince(t);
  };
  mWalk.run(plan, residency, geometry, stats, checkpoints, add, flush);
}

}  // namespace voxbrick::render
