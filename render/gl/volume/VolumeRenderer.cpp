// A frame: plan -> residency -> geometry and drawing pass -> compositing and readback, each timed.
#include "render/gl/volume/VolumeRenderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <optional>

#include "render/core/FrameStats.h"
#include "render/core/RenderErrors.h"
#include "render/gl/Bindings.h"
#include "render/gl/volume/ComputeRayCast.h"
#include "render/volume/FramePlan.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

VolumeRenderer::VolumeRenderer(GlContext& context, std::shared_ptr<store::BrickCache> cache, size_t gpuBudgetBytes,
                               AtlasFormat format, AtlasUploads uploads, AtlasBricking bricking)
    : mGl(context.gl()),
      mResidency(context, std::move(cache), gpuBudgetBytes, format, uploads, bricking),
      mTransfer(mGl, GL_TEXTURE_1D),
      mPrograms(mGl),
      mCompositor(mGl),
      mSlabs(mGl),
      mRayCast(mGl),
      mPreIntegration(mGl),
      mComputeByDefault(computeRayCasterByDefault(context)) {
  mTransfer.bind(VB_UNIT_TRANSFER);
  mGl.glTexStorage1D(GL_TEXTURE_1D, 1, GL_RGBA32F, kTransferTableTexels);
  mGl.glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  mGl.glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  mGl.glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
}

VolumeRenderer::~VolumeRenderer() = default;

BrickBudget VolumeRenderer::budget() const {
  const store::BrickCache& cache = mResidency.cache();
  return {mResidency.atlas().capacity(),
          int64_t(cache.budgetBytes() / std::max<size_t>(cache.store()->brickBytes(), 1))};
}

void VolumeRenderer::planStats(const FramePlan& plan, FrameStats& stats) const {
  const TraversalStats& visible = plan.visible.stats;
  stats.nodesVisited = visible.nodesVisited;
  stats.bricksSkippedEmpty = visible.bricksSkippedEmpty;
  stats.bricksCulled = visible.bricksCulled;
  stats.bricksOutsidePart = visible.bricksOutsidePart;
  stats.bricksDrawn = visible.bricksDrawn;
  stats.bricksCoarse = visible.bricksCoarse;
  stats.bricksCoarsened = visible.bricksCoarsened;
  stats.bricksPerLevel = visible.bricksPerLevel;
  stats.drawnBox = plan.partDrawn;
  const BrickAtlas& atlas = mResidency.atlas();
  const int64_t slot =
      int64_t(BrickAtlas::slotBytes(mResidency.store().type(), mResidency.store().brickEdge(), atlas.format()));
  stats.bytesWanted = plan.bricksWanted * slot;
  stats.bytesBudget = int64_t(atlas.capacity()) * slot;
  stats.bricksFitCoarsened = plan.bricksWanted - visible.bricksDrawn;
  const auto first =
      std::find_if(visible.bricksPerLevel.begin(), visible.bricksPerLevel.end(), [](int64_t n) { return n > 0; });
  stats.levelFinest = int(first - visible.bricksPerLevel.begin());
  stats.levelCoarsest = plan.coarsestLevel;
}

double VolumeRenderer::estimateSamples(const Scene& scene) {
  return planFrame(scene, mResidency.store(), kTransferTableTexels, budget()).estimatedSamples();
}

SliceGeometry& VolumeRenderer::geometry(const Scene& scene) {
  // Slabs and the ray caster draw box proxies whatever the slicer.
  const bool slabs = scene.slab > 0 || scene.raycast;
  auto& g = mGeometry[slabs ? kSlicers.size() : size_t(scene.slicer)];
  if (!g) {
    if (slabs)
      g = std::make_unique<SlabGeometry>(mGl);
    else if (scene.slicer == Slicer::Cpu)
      g = std::make_unique<CpuSliceGeometry>(mGl);
    else
      g = std::make_unique<GpuSliceGeometry>(mGl, scene.slicer);
  }
  return *g;
}

void VolumeRenderer::draw(const Scene& scene, const FramePlan& plan, const FrameOptions& options,
                          FrameStats& stats) {
  const auto setupStart = Clock::now();
  const RenderMode mode = options.mode;
  const store::BrickStore& store = mResidency.store();
  mResidency.beginFrame(plan.visible.bricks, !plan.rayResidency);
  mCompositor.begin(scene.width, scene.height, mode != RenderMode::Roofline, plan.ert > 0 || plan.ess);
  const std::vector<glm::vec4> table = scene.transferFunction.table(kTransferTableTexels);
  mTransfer.bind(VB_UNIT_TRANSFER);
  mGl.glTexSubImage1D(GL_TEXTURE_1D, 0, 0, kTransferTableTexels, GL_RGBA, GL_FLOAT, table.data());
  mResidency.atlas().texture().bind(VB_UNIT_ATLAS);

  ProgramKey key{plan.slab > 0 || plan.raycast ? Slicer::Vertex : scene.slicer,
                 mode == RenderMode::Roofline ? FragmentModel::Roofline
                 : scene.shading              ? FragmentModel::Shaded
                                              : FragmentModel::Plain,
                 plan.exactOwnership() && !plan.marches(), plan.slab > 0, plan.preIntegration};
  key.raycast = plan.raycast;
  key.compute = plan.raycast && (scene.raycaster == RayCaster::Compute ||
                                 (scene.raycaster == RayCaster::Auto && mComputeByDefault));
  if (plan.raycast) stats.raycaster = key.compute ? "compute" : "fragment";
  key.pagedCells = plan.pagedCells;
  key.rayRequests = plan.rayResidency;
  key.multiOriented = mResidency.atlas().bricking() == AtlasBricking::MultiOriented;
  const VolumeProgram& program = mPrograms.get(key);
  program.setFrame(plan, mResidency.atlas(), store.meta());
  if (plan.preIntegration) {
    const auto [ratioMin, ratioMax] = plan.segmentRatios();
    stats.msPreIntegration = mPreIntegration.update(scene.transferFunction, ratioMin, ratioMax, VB_UNIT_PRE_INTEGRATED);
    program.setTable(mPreIntegration.spec());
  }
  const VolumeProgram* emptyTest = nullptr;
  if (plan.ess) {
    ProgramKey emptyKey = key;
    emptyKey.emptyTest = true;
    emptyTest = &mPrograms.get(emptyKey);
    emptyTest->setFrame(plan, mResidency.atlas(), store.meta());
    if (plan.preIntegration) emptyTest->setTable(mPreIntegration.spec());
  }
  Checkpoints checkpoints(mGl, options.cancelled, options.checkpointSamples);
  stats.msSetup = msSince(setupStart) - stats.msPreIntegration;
  if (plan.raycast)
    mRayCast.draw(plan, mResidency, program, geometry(scene), mCompositor, stats, checkpoints, options.keepCellTable);
  else if (plan.slab > 0)
    mSlabs.draw(plan, mResidency, program, emptyTest, static_cast<SlabGeometry&>(geometry(scene)), mCompositor, stats,
                checkpoints);
  else if (mode == RenderMode::Points) {
    mGl.glPolygonMode(GL_FRONT_AND_BACK, GL_POINT);
    mSlicing.draw(plan, mResidency, program, geometry(scene), stats, checkpoints);
    mGl.glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
  } else {
    mSlicing.draw(plan, mResidency, program, geometry(scene), stats, checkpoints);
  }
}

image::ImageF VolumeRenderer::render(const Scene& scene, FrameStats* stats, const FrameOptions& options) {
  image::ImageF image;
  frame(scene, stats, options, [&](const FramePlan& plan, FrameStats& s) {
    image = mCompositor.finish(scene, s, plan.part.has_value());
  });
  return image;
}

image::Image8 VolumeRenderer::render8(const Scene& scene, FrameStats* stats, const FrameOptions& options) {
  // A part's frame is premultiplied floats for compositing, never 8 bits.
  if (options.part) return FrameRenderer::render8(scene, stats, options);
  image::Image8 image;
  frame(scene, stats, options, [&](const FramePlan&, FrameStats& s) { image = mCompositor.finish8(scene, s); });
  return image;
}

VolumeRenderer::PlannedFrame VolumeRenderer::plan(const Scene& scene, const FrameOptions& options) {
  if (options.meshPart)
    throw RenderInputError(
        "FrameOptions::meshPart is a mesh's world-space box: a grid is drawn in parts by FrameOptions::part, a box of "
        "its level-0 voxels");
  PlannedFrame p{{}, {}, Clock::now()};
  FrameStats& stats = p.stats;
  const store::BrickStore& store = mResidency.store();

  auto t = Clock::now();
  p.plan = planFrame(scene, store, kTransferTableTexels, options.fitBudget ? budget() : BrickBudget{}, options.part);
  FramePlan& plan = p.plan;
  stats.msTraversal = msSince(t);
  t = Clock::now();
  planStats(plan, stats);
  plan.pagedCells = plan.pagedCells || (plan.raycast && options.pagedCellTable);
  stats.fallback = plan.fallback;
  stats.samplesEstimated = plan.estimatedSamples();
  stats.msPlanning = msSince(t);
  if (options.mode == RenderMode::Points && (plan.slab > 0 || plan.raycast))
    throw RenderInputError("the points mode draws the corners of slices: it needs slicing (slab 0, no raycast)");
  if (options.maxSamples > 0 && stats.samplesEstimated > options.maxSamples)
    throw RenderLimitError("the frame would take about " + numberText(std::round(stats.samplesEstimated / 1e6)) +
                           " million samples, above the limit of " + numberText(options.maxSamples / 1e6) +
                           " million; ask for a smaller image, a coarser step or a level of detail");

  if (plan.rayResidency && !(options.keepCellTable && KeptCells::fits(plan, mResidency) && RayRequests::fits(store))) {
    // The rays decide residency on a frame of one batch, whose cell table is kept from frame to frame.
    plan.rayResidency = false;
    stats.fallback =
        "paged by the octree, not the rays: the frame's bricks need more than one atlas batch, or its "
        "cell table is not kept";
  }
  if (options.standIns && !plan.rayResidency) {
    t = Clock::now();
    stats.bricksStandIn = mResidency.standIn(plan.visible.bricks, store.levelCount() - 1);
    for (const BrickDraw& d : plan.visible.bricks)
      plan.coarsestLevel = std::max(plan.coarsestLevel, int(d.key.level + d.standIn));
    stats.msPaging += msSince(t);
  }
  p.planningMs = msSince(p.start);
  return p;
}

void VolumeRenderer::run(const Scene& scene, PlannedFrame& p, const FrameOptions& options,
                         const std::function<void()>& whileDrawing,
                         const std::function<void(const FramePlan&, FrameStats&)>& finish) {
  const auto runStart = Clock::now();
  const FramePlan& plan = p.plan;
  FrameStats& stats = p.stats;
  try {
    draw(scene, plan, options, stats);
    if (whileDrawing) whileDrawing();
    finish(plan, stats);
  } catch (...) {
    // A brick that fails its checks (or any other failure mid-frame) must not leave the context half way through
    // a frame: the next frame, of any dataset, starts from the state every pass expects.
    mCompositor.abort();
    mResidency.abortFrame();
    mGl.glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);  // a points-mode frame given up while slicing
    for (auto& g : mGeometry)
      if (g) g->clear();                                               // boxes queued for a batch that was never drawn
    for (int i = 0; i < 16 && mGl.glGetError() != GL_NO_ERROR; ++i) {  // errors the failure left (bounded: a
    }                                                                  // lost context reports one forever)
    throw;
  }
  const auto t = Clock::now();
  mResidency.endFrame();
  if (plan.raycast)
    mRayCast.finish(stats);
  else if (plan.slab > 0)
    mSlabs.finish(stats);
  else
    stats.samples = stats.fragments;
  stats.msEnding = msSince(t);
  // Its own time: planned ahead, a frame does not count the wait for the frame before it.
  stats.msTotal = p.planningMs + msSince(runStart);
}

void VolumeRenderer::frame(const Scene& scene, FrameStats* statsOut, const FrameOptions& options,
                           const std::function<void(const FramePlan&, FrameStats&)>& finish) {
  PlannedFrame p = plan(scene, options);
  run(scene, p, options, {}, finish);
  if (statsOut) *statsOut = p.stats;
}

void VolumeRenderer::renderSequence8(std::span<const Scene> scenes, const FrameOptions& options,
                                     const FrameDelivery& deliver) {
  // Stand-ins change residency while planning, a part's frame is floats, a cancellable frame stops between
  // checkpoints: those are drawn one after the other.
  if (options.standIns || options.part || options.cancelled) return FrameRenderer::renderSequence8(scenes, options, deliver);
  if (scenes.empty()) return;
  std::optional<PlannedFrame> next = plan(scenes[0], options);
  std::exception_ptr nextFailed;
  for (size_t i = 0; i < scenes.size(); ++i) {
    if (nextFailed) std::rethrow_exception(nextFailed);
    PlannedFrame current = std::move(*next);
    next.reset();
    image::Image8 image;
    // The next frame is planned (on the CPU alone) while the GPU draws this one; its failure is its own frame's.
    auto planNext = [&] {
      if (i + 1 >= scenes.size()) return;
      try {
        next = plan(scenes[i + 1], options);
        next->stats.plannedAhead = true;
      } catch (...) {
        nextFailed = std::current_exception();
      }
    };
    run(scenes[i], current, options, planNext,
        [&](const FramePlan&, FrameStats& s) { image = mCompositor.finish8(scenes[i], s); });
    deliver(i, std::move(image), current.stats);
  }
}

}  // namespace voxbrick::render
