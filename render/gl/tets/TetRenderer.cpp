// A mesh frame's stages in turn (plan, residency, visibility order, cost, table, pass, readback) and the projected
// pass: one instanced draw of the tets in visibility order.
#include "render/gl/tets/TetRenderer.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "render/core/FrameStats.h"
#include "render/core/RenderErrors.h"
#include "render/gl/Bindings.h"
#include "render/gl/Checkpoints.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

/// The shortest segment the table holds, as a share of the longest: shorter ones scale its first layer
/// (tet.frag.glsl), exact to first order in the length.
constexpr double kShortestRatioShare = 1.0 / 64;

/// The most tets one draw call takes: cancellation is checked between draws.
constexpr size_t kTetsPerDraw = 262144;

Program tetProgram(const Gl& gl, bool nullFragment, bool shaded = false, bool part = false) {
  std::vector<std::string> defines;
  if (nullFragment) defines.push_back("NULL_FRAGMENT");
  if (shaded) defines.push_back("SHADING");
  if (part) defines.push_back("PART_CLIP");
  const std::string name = std::string(nullFragment ? "tet-null" : shaded ? "tet-shaded" : "tet") + (part ? "-part" : "");
  return Program(gl,
                 ProgramSources::fromFiles(name, {{GL_VERTEX_SHADER, "tet.vert.glsl"}, {GL_FRAGMENT_SHADER, "tet.frag.glsl"}},
                                           std::move(defines), "tet.glsl"));
}

/// Throws RenderInputError unless `part` is a box (lo <= hi, finite) the frame can clip to.
void checkMeshPart(const MeshPartBox& part) {
  for (size_t a = 0; a < 3; ++a)
    if (!std::isfinite(part.lo[a]) || !std::isfinite(part.hi[a]) || !(part.lo[a] <= part.hi[a]))
      throw RenderInputError("a mesh's part (FrameOptions::meshPart) must be a finite box with lo <= hi on each axis; "
                             "axis " + std::to_string(a) + " runs from " + std::to_string(part.lo[a]) + " to " +
                             std::to_string(part.hi[a]));
}

}  // namespace

size_t TetRenderer::bytesFor(size_t tets) { return TetResidency::bytesFor(tets); }

size_t TetRenderer::minimumBytes() { return TetResidency::minimumBytes(); }

TetRenderer::TetRenderer(GlContext& context, std::shared_ptr<const TetMeshSource> source, size_t gpuBudgetBytes)
    : mGl(context.gl()),
      mResidency(mGl, std::move(source), gpuBudgetBytes),
      mVertices(mGl),
      mOrderBuffer(mGl),
      mEmpty(mGl),
      mProgram(tetProgram(mGl, false)),
      mNullProgram(tetProgram(mGl, true)),
      mShadedProgram(tetProgram(mGl, false, true)),
      mCompositor(mGl),
      mTable(mGl) {
  if (!mResidency.source().paged() && mResidency.hold(mResidency.source().whole())) upload();
}

void TetRenderer::upload() {
  const mesh::TetMesh& m = mResidency.data().mesh;
  if (!mResidency.streamed()) {
    // Resident: every tet uploaded once, in mesh order, drawn through the order buffer.
    std::vector<glm::vec4> texels(m.tets.size() * 4);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, m.tets.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t != r.end(); ++t) writeTet(uint32_t(t), &texels[4 * t]);
    });
    mVertices.allocate(GL_SHADER_STORAGE_BUFFER, texels.size() * sizeof(glm::vec4), texels.data(), GL_STATIC_DRAW);
  } else {
    // Streamed: batches of tets in visibility order are written into one buffer and drawn in turn; the order buffer
    // is the identity over a batch.
    const size_t batchTets = mResidency.batchTets();
    mVertices.allocate(GL_SHADER_STORAGE_BUFFER, batchTets * kBytesPerTet, nullptr, GL_STREAM_DRAW);
    std::vector<uint32_t> identity(batchTets);
    for (size_t i = 0; i < identity.size(); ++i) identity[i] = uint32_t(i);
    mOrderBuffer.allocate(GL_SHADER_STORAGE_BUFFER, identity.size() * 4, identity.data(), GL_STATIC_DRAW);
  }
  checkGlError(mGl, "TetRenderer: uploading the mesh");
  mResidency.uploaded();
}

void TetRenderer::writeTet(uint32_t tet, glm::vec4* out) const {
  // Positions relative to the box's centre keep single precision where the tets are (a mesh far from the origin
  // would otherwise lose its small cells' shape).
  const TetMeshData& data = mResidency.data();
  const mesh::TetMesh& m = data.mesh;
  const glm::dvec3 centre = data.bounds.center();
  for (int i = 0; i < 4; ++i) {
    const uint32_t v = m.tets[tet][i];
    out[i] = glm::vec4(glm::vec3(glm::dvec3(m.points[v]) - centre), m.scalars[v]);
  }
}

TetRenderer::~TetRenderer() = default;

size_t TetRenderer::gpuBytes() const { return mResidency.gpuBytes(); }

image::ImageF TetRenderer::background(const Scene& scene, FrameStats& stats, bool part, TimePoint frameStart,
                                      FrameStats* statsOut) {
  mCompositor.begin(scene.width, scene.height, true);
  image::ImageF image = finishFrame(scene, stats, part);
  mGl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  stats.msTotal = msSince(frameStart);
  if (statsOut) *statsOut = stats;
  return image;
}

image::ImageF TetRenderer::finishFrame(const Scene& scene, FrameStats& stats, bool part) {
  if (!mFrame8) return mCompositor.finish(scene, stats, part);
  *mFrame8 = mCompositor.finish8(scene, stats);
  return {};
}

image::Image8 TetRenderer::render8(const Scene& scene, FrameStats* stats, const FrameOptions& options) {
  // A part's frame stays premultiplied, with no background to finish it over on the GPU.
  if (options.meshPart) return FrameRenderer::render8(scene, stats, options);
  image::Image8 frame;
  mFrame8 = &frame;
  struct Reset {
    image::Image8*& target;
    ~Reset() { target = nullptr; }
  } reset{mFrame8};
  render(scene, stats, options);
  return frame;
}

double TetRenderer::estimateSamples(const Scene& scene) {
  const double pixels = double(scene.width) * scene.height;
  if (mLastPixels > 0) return mLastVertexCost + mLastFragmentCost * pixels / mLastPixels;
  return TetFrameCost::kFragmentsPerTet * double(mResidency.source().constants().tetCount) + pixels;
}

image::ImageF TetRenderer::render(const Scene& scene, FrameStats* statsOut, const FrameOptions& options) {
  const auto frameStart = Clock::now();
  if (options.part)
    throw RenderInputError(
        "FrameOptions::part is a box of a grid's voxels: a tetrahedral mesh is drawn in parts by "
        "FrameOptions::meshPart, a world-space box");
  const MeshPartBox* part = options.meshPart ? &*options.meshPart : nullptr;
  if (part) checkMeshPart(*part);
  FrameStats stats;
  // The plan: view, window, matrices, whether the view allows ray casting (GL-free). A part's frame plans as the
  // whole frame does (the whole mesh's box decides ray casting), so that its parts join into that frame.
  const TetFramePlan plan = planTetFrame(scene, mResidency.source().constants(), options);
  if (part && plan.nullFragment)
    throw RenderInputError("RenderMode::Roofline draws no part of a mesh: its null fragments cannot be clipped");

  // Residency: the frame's tets, uploaded when they are not those on the GPU; a paged mesh's working set is held
  // only while the frame draws it (its GPU copy stays).
  struct Release {
    TetResidency& r;
    ~Release() { r.release(); }
  } release{mResidency};
  std::shared_ptr<const TetMeshData> data = mResidency.source().frameData(scene, plan.view, &stats, part);
  // Nothing in view that the transfer function shows (or, of a part, nothing in its box): the background.
  if (!data) return background(scene, stats, part != nullptr, frameStart, statsOut);
  if (mResidency.hold(std::move(data))) upload();
  const TetMeshData& d = mResidency.data();

  // Ray casting when the plan allows it and the ray caster holds the mesh; otherwise projected in MPVO order.
  const bool rays = plan.rayCast && mResidency.rayCaster() != nullptr;
  // The visibility order, front to back (none when ray casting: each ray finds its own), less the empty tets.
  if (rays)
    mOrder.none(d);
  else
    mOrder.sort(d, plan.view.camera, scene.visibility, stats);
  if (options.cancelled && options.cancelled()) throw FrameCancelled("frame cancelled");
  if (scene.skipEmpty && !rays) mOrder.skipEmpty(d, scene.transferFunction, plan.view, stats);
  // The frame's cost before anything is drawn (TetFrameCost; the ray caster has no vertex stages to add).
  stats.samplesEstimated = mCost.estimate(d, plan, mOrder.drawn(), rays ? 0 : mOrder.size());
  plan.checkCost(stats.samplesEstimated, rays ? d.mesh.tets.size() : mOrder.size());
  mLastVertexCost = rays ? 0 : TetFrameCost::kFragmentsPerTet * double(mOrder.size());
  mLastFragmentCost = stats.samplesEstimated - mLastVertexCost;
  mLastPixels = double(scene.width) * scene.height;
  return draw(scene, plan, rays, stats, options, frameStart, statsOut);
}

image::ImageF TetRenderer::draw(const Scene& scene, const TetFramePlan& plan, bool rays, FrameStats& stats,
                                const FrameOptions& options, TimePoint frameStart, FrameStats* statsOut) {
  // The pre-integrated table over the segment lengths the mesh has, then the pass.
  const TetMeshData& d = mResidency.data();
  const bool nullFragment = plan.nullFragment;
  const double reference = plan.reference;
  const double ratioMax = d.longestEdge / reference;
  const double ratioMin = ratioMax * kShortestRatioShare;
  if (!nullFragment)
    stats.msPreIntegration = mTable.update(scene.transferFunction, ratioMin, ratioMax, VB_UNIT_PRE_INTEGRATED);
  const PreIntegrationSpec& spec = mTable.spec();

  const auto drawStart = Clock::now();
  mCompositor.begin(scene.width, scene.height, true);
  TetFrameUniforms uniforms;
  uniforms.viewProj = plan.viewProj;
  uniforms.rays = plan.pixels;
  uniforms.width = scene.width;
  uniforms.height = scene.height;
  uniforms.windowLo = plan.view.windowLo;
  uniforms.windowScale = plan.windowScale();
  uniforms.reference = reference;
  uniforms.table = spec;
  if (options.meshPart) {
    // The part's box in the centred world the vertices are in; each pass clips every ray to it.
    const glm::dvec3 centre = d.bounds.center();
    uniforms.part = true;
    uniforms.partLo = glm::dvec3(options.meshPart->lo[0], options.meshPart->lo[1], options.meshPart->lo[2]) - centre;
    uniforms.partHi = glm::dvec3(options.meshPart->hi[0], options.meshPart->hi[1], options.meshPart->hi[2]) - centre;
    stats.tetPart = rays ? "raycast" : "projected";
  }
  try {
    if (rays) {
      // Auto keeps the fragment kernel on every device: the compute kernel was 1.02-1.41x its time on llvmpipe
      // (docs/performance.md) and has not been measured on a GPU yet (the GPU kit's tets-1m step measures both).
      const bool compute = scene.raycaster == RayCaster::Compute;
      stats.raycaster = compute ? "compute" : "fragment";
      mResidency.rayCaster()->draw(uniforms, scene.ert, scene.shading, compute, mCompositor, stats, options.cancelled,
                                   options.checkpointSamples);
    } else {
      drawProjected(uniforms, nullFragment ? mNullProgram : projectedProgram(scene.shading, uniforms.part), stats,
                    options.cancelled);
    }
    checkGlError(mGl, "TetRenderer: drawing");
  } catch (...) {
    mCompositor.abort();
    throw;
  }
  stats.msDrawing = msSince(drawStart);
  stats.tetsDrawn = int64_t(mOrder.size());
  image::ImageF image = finishFrame(scene, stats, uniforms.part);
  if (rays) mResidency.rayCaster()->readCounters(stats);
  mGl.glDisable(GL_BLEND);
  mGl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  stats.msTotal = msSince(frameStart);
  if (statsOut) *statsOut = stats;
  return image;
}

const Program& TetRenderer::projectedProgram(bool shading, bool part) {
  if (!part) return shading ? mShadedProgram : mProgram;
  Program& program = shading ? mShadedPartProgram : mPartProgram;
  if (!program) program = tetProgram(mGl, false, shading, true);
  return program;
}

void TetRenderer::drawProjected(const TetFrameUniforms& uniforms, const Program& p, FrameStats& stats,
                                const std::function<bool()>& cancelled) {
  const bool streamed = mResidency.streamed();
  if (!streamed)
    mOrderBuffer.allocate(GL_SHADER_STORAGE_BUFFER, mOrder.size() * sizeof(uint32_t), mOrder.tets().data(),
                          GL_STREAM_DRAW);
  setTetUniforms(p, uniforms);
  p.use();
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_VERTICES, mVertices.id());
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_ORDER, mOrderBuffer.id());
  mEmpty.bind();
  // Cancellation: checked between draws of at most kTetsPerDraw tets, with at most two of them queued
  // (Checkpoints), so that a frame given up stops within about one draw's work.
  Checkpoints checkpoints(mGl, cancelled);
  const GLint orderOffset = p.uniformLocation("uOrderOffset");
  if (!streamed) {
    for (size_t first = 0; first < mOrder.size(); first += kTetsPerDraw) {
      p.set(orderOffset, int(first));
      mGl.glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(std::min(kTetsPerDraw, mOrder.size() - first)));
      checkpoints.pace();
    }
    stats.batches = 1;
  } else {
    p.set(orderOffset, 0);
    // Each batch is written into a fresh store of the buffer (the driver keeps the previous one until its draw has
    // read it), then drawn: the frame is the resident one, batch by batch.
    const size_t batchTets = mResidency.batchTets();
    mStaging.resize(batchTets * 4);
    for (size_t first = 0; first < mOrder.size(); first += batchTets) {
      const size_t count = std::min(batchTets, mOrder.size() - first);
      for (size_t i = 0; i < count; ++i) writeTet(mOrder.tets()[first + i], &mStaging[4 * i]);
      mVertices.allocate(GL_SHADER_STORAGE_BUFFER, batchTets * kBytesPerTet, nullptr, GL_STREAM_DRAW);
      mGl.glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(count * kBytesPerTet), mStaging.data());
      mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_VERTICES, mVertices.id());
      mGl.glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(count));
      checkpoints.pace();
      stats.batches += 1;
    }
  }
}

}  // namespace voxbrick::render
