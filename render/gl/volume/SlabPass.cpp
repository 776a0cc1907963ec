// Slab-major drawing of each batch, with the termination pass of the silhouette map between slabs.
#include "render/gl/volume/SlabPass.h"

#include <algorithm>
#include <chrono>
#include <limits>

#include "render/core/FrameStats.h"
#include "render/gl/Bands.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

constexpr double kSlabDepthStep = 1.0 / (1 << 22);  // depths 1 - k * step are exact in float for k < 2^22

int64_t floorDiv(int64_t a, int64_t b) { return a / b - ((a % b != 0) && ((a < 0) != (b < 0))); }

}  // namespace

SlabPass::SlabPass(const Gl& gl) : mGl(gl), mTermination(gl), mCounters(gl) {}

void SlabPass::draw(const FramePlan& plan, Residency& residency, const VolumeProgram& program,
                    const VolumeProgram* emptyTest, SlabGeometry& geometry, Compositor& compositor, FrameStats& stats,
                    Checkpoints& checkpoints) {
  mSlabsDrawn = 0;
  mCounters.reset();
  mBoxes.clear();
  auto add = [&](const QueuedBox& b) { mBoxes.push_back(b); };
  auto flush = [&] {
    drawBatch(plan, program, plan.ess ? emptyTest : nullptr, geometry, compositor, stats, checkpoints);
    mBoxes.clear();
  };
  mWalk.run(plan, residency, geometry, stats, checkpoints, add, flush);
}

void SlabPass::drawBatch(const FramePlan& plan, const VolumeProgram& program, const VolumeProgram* emptyTest,
                         SlabGeometry& geometry, Compositor& compositor, FrameStats& stats, Checkpoints& checkpoints) {
  if (mBoxes.empty()) return;
  int64_t lo = std::numeric_limits<int64_t>::max(), hi = std::numeric_limits<int64_t>::min();
  for (const QueuedBox& b : mBoxes) lo = std::min(lo, b.planes.begin), hi = std::max(hi, b.planes.end);
  const int64_t n = std::max(plan.slab, 1);
  stats.batches += 1;
  for (int64_t first = floorDiv(lo, n) * n; first < hi; first += n) {
    auto t = Clock::now();
    for (const QueuedBox& b : mBoxes) {
      const PlaneIndexRange planes{std::max(b.planes.begin, first), std::min(b.planes.end, first + n)};
      if (planes.count() > 0) geometry.add(b.box, planes, b.payload, b.ownLo, b.ownHi, plan);
    }
    stats.msSlicing += msSince(t);
    if (geometry.empty()) continue;
    t = Clock::now();
    // One depth for every fragment of the slab, exactly (slab.vert.glsl).
    const bool test = emptyTest && mSlabsDrawn + 1 < int64_t(1) << 22;
    const double depth = test ? 1.0 - double(++mSlabsDrawn) * kSlabDepthStep : 0.5;
    auto drawSlab = [&] {
      mGl.glDepthRange(depth, depth);
      if (test) {
        emptyTest->program().use();
        mGl.glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
        mGl.glDepthMask(GL_TRUE);
        geometry.drawKeep();
        mGl.glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
        mGl.glDepthMask(GL_FALSE);
        mGl.glDepthFunc(GL_EQUAL);
        program.program().use();
        geometry.drawKeep();
        mGl.glDepthFunc(GL_LESS);
      } else {
        program.program().use();
        geometry.drawKeep();
      }
      mGl.glDepthRange(0, 1);
    };
    // A slab takes at most n samples a pixel: one larger than a checkpoint interval is drawn in tiles of the screen.
    if (checkpoints.intervalSamples() > 0 && double(n) * plan.width * plan.height > checkpoints.intervalSamples())
      drawTiled(mGl, plan.width, plan.height, checkpoints, double(n), drawSlab);
    else
      drawSlab();
    geometry.clear();
    stats.slabPasses += 1;
    if (plan.ert > 0 && first + n < hi) mTermination.run(plan.ert, compositor);
    checkpoints.pace();
    stats.msDrawing += msSince(t);
  }
}

void SlabPass::finish(FrameStats& stats) const { mCounters.read(stats); }

}  // namespace voxbrick::render
