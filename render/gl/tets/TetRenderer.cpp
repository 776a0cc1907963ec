// A mesh frame: visibility order on the CPU, the table, one instanced draw, readback.
#include "render/gl/tets/TetRenderer.h"

#include <chrono>
#include <cmath>
#include <functional>
#include <limits>

#include <glm/gtc/matrix_transform.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "mesh/Visibility.h"
#include "render/gl/Bindings.h"
#include "render/gl/Checkpoints.h"
#include "render/core/PixelRays.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

/// The shortest segment the table holds, as a share of the longest: shorter ones scale its first layer
/// (tet.frag.glsl), exact to first order in the length.
constexpr double kShortestRatioShare = 1.0 / 64;

/// The most tets one draw call takes: cancellation is checked between draws.
constexpr size_t kTetsPerDraw = 262144;

/// A tet's vertex stage (its strip's hull and planes, for each of four strip vertices) in fragments' work: about
/// 0.7 s for a million tets on llvmpipe against about 45 ns a fragment (bench/results/tets.md).
constexpr double kFragmentsPerTet = 16;

Program tetProgram(const Gl& gl, bool nullFragment, bool shaded = false) {
  std::vector<std::string> defines;
  if (nullFragment) defines.push_back("NULL_FRAGMENT");
  if (shaded) defines.push_back("SHADING");
  return Program(gl, ProgramSources::fromFiles(nullFragment ? "tet-null" : shaded ? "tet-shaded" : "tet",
                                               {{GL_VERTEX_SHADER, "tet.vert.glsl"}, {GL_FRAGMENT_SHADER, "tet.frag.glsl"}},
                                               std::move(defines), "tet.glsl"));
}

}  // namespace

size_t TetRenderer::tableBytes() {
  return size_t(PreIntegrationTexture::kResolution) * PreIntegrationTexture::kResolution * 64 * 16;
}

size_t TetRenderer::bytesFor(size_t tets) { return tets * (kBytesPerTet + 4) + tableBytes(); }

size_t TetRenderer::minimumBytes() { return kMinBatchTets * (kBytesPerTet + 4) + tableBytes(); }

TetRenderer::TetRenderer(GlContext& context, std::shared_ptr<const TetMeshSource> source, size_t gpuBudgetBytes)
    : mGl(context.gl()),
      mSource(std::move(source)),
      mGpuBudget(gpuBudgetBytes),
      mVertices(mGl),
      mOrderBuffer(mGl),
      mEmpty(mGl),
      mProgram(tetProgram(mGl, false)),
      mNullProgram(tetProgram(mGl, true)),
      mShadedProgram(tetProgram(mGl, false, true)),
      mCompositor(mGl),
      mTable(mGl) {
  if (gpuBudgetBytes < minimumBytes())
    throw RenderInputError("tet mesh: a GPU budget of " + std::to_string(gpuBudgetBytes) +
                           " bytes holds no batch of tets (the pre-integration table and " +
                           std::to_string(kMinBatchTets) + " tets take " + std::to_string(minimumBytes()) + ")");
  if (!mSource->paged()) upload(mSource->whole());
}

void TetRenderer::upload(std::shared_ptr<const TetMeshData> data) {
  mData = std::move(data);
  mRayCaster.reset();
  mUploaded = 0;
  const mesh::TetMesh& m = mData->mesh;
  if (bytesFor(m.tets.size()) <= mGpuBudget) {
    // Resident: every tet uploaded once, in mesh order, drawn through the order buffer.
    mStreamed = false;
    mBatchTets = m.tets.size();
    std::vector<glm::vec4> texels(m.tets.size() * 4);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, m.tets.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t != r.end(); ++t) writeTet(uint32_t(t), &texels[4 * t]);
    });
    mVertices.allocate(GL_SHADER_STORAGE_BUFFER, texels.size() * sizeof(glm::vec4), texels.data(), GL_STATIC_DRAW);
  } else {
    // Streamed: batches of tets in visibility order are written into one buffer and drawn in turn, as many as the
    // budget holds; the order buffer is the identity over a batch.
    mStreamed = true;
    mBatchTets = std::max(kMinBatchTets, (mGpuBudget - tableBytes()) / (kBytesPerTet + 4));
    mVertices.allocate(GL_SHADER_STORAGE_BUFFER, mBatchTets * kBytesPerTet, nullptr, GL_STREAM_DRAW);
    std::vector<uint32_t> identity(mBatchTets);
    for (size_t i = 0; i < identity.size(); ++i) identity[i] = uint32_t(i);
    mOrderBuffer.allocate(GL_SHADER_STORAGE_BUFFER, identity.size() * 4, identity.data(), GL_STATIC_DRAW);
  }
  checkGlError(mGl, "TetRenderer: uploading the mesh");
  mUploaded = mData->id;
}

void TetRenderer::writeTet(uint32_t tet, glm::vec4* out) const {
  // Positions relative to the box's centre keep single precision where the tets are (a mesh far from the origin
  // would otherwise lose its small cells' shape).
  const mesh::TetMesh& m = mData->mesh;
  const glm::dvec3 centre = mData->bounds.center();
  for (int i = 0; i < 4; ++i) {
    const uint32_t v = m.tets[tet][i];
    out[i] = glm::vec4(glm::vec3(glm::dvec3(m.points[v]) - centre), m.scalars[v]);
  }
}

TetRenderer::~TetRenderer() = default;

size_t TetRenderer::gpuBytes() const {
  return mBatchTets * (kBytesPerTet + 4) + tableBytes() + (mRayCaster ? mRayCaster->gpuBytes() : 0);
}

bool TetRenderer::rayCastable(const Camera& camera, double nearPlane) {
  if (mStreamed) return false;
  const Box& box = mData->bounds;
  const glm::dvec3 d = camera.viewDirection();
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 corner{(c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y,
                            (c & 4) ? box.max.z : box.min.z};
    if (glm::dot(corner - camera.eye, d) < nearPlane) return false;
  }
  if (!mRayCaster) {
    const size_t tets = mData->mesh.tets.size();
    if (tets > TetRayCaster::kMaxTets ||
        gpuBytes() + TetRayCaster::bytesFor(tets, mData->topology.boundary.size()) > mGpuBudget)
      return false;
    mRayCaster = std::make_unique<TetRayCaster>(mGl, *mData);
  }
  return true;
}

double TetRenderer::estimatedCost(const glm::dmat4& viewProj, int width, int height, size_t vertexStages) {
  // Each point projected once (window coordinates; points at or behind the eye plane marked), then per tet to be
  // drawn the pixels of its projection's bounding box inside the window: a tet with a point behind the eye plane may
  // cover the window.
  const mesh::TetMesh& m = mData->mesh;
  const glm::dvec3 centre = mData->bounds.center();
  mProjected.resize(m.points.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, m.points.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const glm::dvec4 clip = viewProj * glm::dvec4(glm::dvec3(m.points[i]) - centre, 1.0);
      mProjected[i] = clip.w > 1e-12 ? glm::vec3((clip.x / clip.w + 1) * 0.5 * width,
                                                 (clip.y / clip.w + 1) * 0.5 * height, 1.0f)
                                     : glm::vec3(0.0f);
    }
  });
  const double window = double(width) * double(height);
  // In mesh order (mDrawn: the tets of the frame), where neighbouring tets share points.
  const double fragments = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, m.tets.size(), 16384), 0.0,
      [&](const tbb::blocked_range<size_t>& r, double sum) {
        for (size_t t = r.begin(); t != r.end(); ++t) {
          if (!mDrawn[t]) continue;
          glm::vec2 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
          bool behind = false;
          for (uint32_t v : m.tets[t]) {
            const glm::vec3& p = mProjected[v];
            behind = behind || p.z == 0.0f;
            lo = glm::min(lo, glm::vec2(p));
            hi = glm::max(hi, glm::vec2(p));
          }
          if (behind) {
            sum += window;
            continue;
          }
          const double w = std::min(double(hi.x), double(width)) - std::max(double(lo.x), 0.0);
          const double h = std::min(double(hi.y), double(height)) - std::max(double(lo.y), 0.0);
          if (w > 0 && h > 0) sum += (std::ceil(w) + 1) * (std::ceil(h) + 1);
        }
        return sum;
      },
      std::plus<double>());
  return fragments + kFragmentsPerTet * double(vertexStages);
}

image::ImageF TetRenderer::render(const Scene& scene, FrameStats* statsOut, const FrameOptions& options) {
  scene.validate();
  const auto frameStart = Clock::now();
  FrameStats stats;
  const TetView view = TetView::of(scene, mSource->constants());
  const Camera& camera = view.camera;
  const double nearPlane = view.nearPlane;
  // World centred on the box, as the vertices are.
  const glm::dvec3 centre = mSource->constants().bounds.center();
  const glm::dmat4 viewProj = view.clipFromWorld * glm::translate(glm::dmat4(1.0), centre);
  const PixelRays pixels = pixelRays(viewProj, scene.width, scene.height);
  if (options.mode == RenderMode::Points)
    throw RenderInputError("a tet mesh has no slices to draw as points (RenderMode::Points)");

  // The frame's tets: a paged mesh's working set is held only while the frame draws it (its GPU copy stays).
  struct Release {
    TetRenderer& r;
    ~Release() {
      if (r.mSource->paged()) r.mData.reset();
    }
  } release{*this};
  if (std::shared_ptr<const TetMeshData> data = mSource->frameData(scene, view, &stats); !data) {
    // Nothing in view that the transfer function shows: the background.
    mCompositor.begin(scene.width, scene.height, true);
    image::ImageF image = mCompositor.finish(scene, stats);
    mGl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
    stats.msTotal = msSince(frameStart);
    if (statsOut) *statsOut = stats;
    return image;
  } else if (data->id != mUploaded) {
    upload(std::move(data));
  } else {
    mData = std::move(data);
  }
  const TetMeshData& d = *mData;

  const bool nullFragment = options.mode == RenderMode::Roofline;
  // Ray casting when asked for and possible (rayCastable); otherwise projected in MPVO order.
  const bool rays = scene.visibility == TetSort::Ray && !nullFragment && rayCastable(camera, nearPlane);

  // The visibility order, front to back (none when ray casting: each ray finds its own).
  mOrder.clear();
  if (!rays) {
    const mesh::ViewPoint eye{camera.eye, camera.viewDirection(), camera.orthographic};
    mesh::VisibilityStats sortStats;
    if (scene.visibility == TetSort::Centroid)
      mesh::centroidOrder(d.mesh, eye, mOrder, &sortStats);
    else
      mesh::mpvoOrder(d.mesh, d.topology, eye, mOrder, &sortStats);
    stats.msSorting = sortStats.ms;
  }
  if (options.cancelled && options.cancelled()) throw FrameCancelled("frame cancelled");

  // The value window (default the scalars' range) and the segment lengths of the table.
  const double lo = view.windowLo, hi = view.windowHi;
  // Empty-space skipping per tet: one whose value range the transfer function makes transparent is left out of the
  // order (after sorting: MPVO needs every tet's faces to order the others).
  const size_t tetCount = d.mesh.tets.size();
  mDrawn.assign(tetCount, 1);
  if (scene.skipEmpty && !rays) {
    const double inverse = 1.0 / (hi - lo);
    const TransferFunction& tf = scene.transferFunction;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tetCount, 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t != r.end(); ++t) {
        const auto [tetLo, tetHi] = d.tetRanges[t];
        mDrawn[t] = tf.contributes((double(tetLo) - lo) * inverse, (double(tetHi) - lo) * inverse);
      }
    });
    const size_t before = mOrder.size();
    std::erase_if(mOrder, [&](uint32_t t) { return !mDrawn[t]; });
    stats.tetsSkippedEmpty = int64_t(before - mOrder.size());
  }
  // The frame's cost before anything is drawn, in the unit of FrameOptions::maxSamples: a fragment counts as a
  // sample, and each tet's projected bounding box bounds its fragments (and so the ray caster's segments, which have
  // no vertex stages to add).
  stats.samplesEstimated = estimatedCost(viewProj, scene.width, scene.height, rays ? 0 : mOrder.size());
  if (options.maxSamples > 0 && stats.samplesEstimated > options.maxSamples)
    throw RenderLimitError("the mesh frame would take about " + numberText(std::round(stats.samplesEstimated / 1e6)) +
                           " million fragments' work (" + std::to_string(rays ? tetCount : mOrder.size()) +
                           " tets), above the limit of " + numberText(options.maxSamples / 1e6) +
                           " million samples; ask for a smaller image or a view with less of the mesh");
  const double reference = scene.transferFunction.referenceLength().value_or(d.meanEdgeLength);
  const double ratioMax = d.longestEdge / reference;
  const double ratioMin = ratioMax * kShortestRatioShare;
  if (!nullFragment)
    stats.msPreIntegration = mTable.update(scene.transferFunction, ratioMin, ratioMax, VB_UNIT_PRE_INTEGRATED);
  const PreIntegrationSpec& spec = mTable.spec();

  const auto drawStart = Clock::now();
  mCompositor.begin(scene.width, scene.height, true);
  TetFrameUniforms uniforms;
  uniforms.viewProj = viewProj;
  uniforms.rays = pixels;
  uniforms.width = scene.width;
  uniforms.height = scene.height;
  uniforms.windowLo = lo;
  uniforms.windowScale = 1.0 / (hi - lo);
  uniforms.reference = reference;
  uniforms.tableUnit = VB_UNIT_PRE_INTEGRATED;
  uniforms.table = spec;
  try {
    if (rays)
      mRayCaster->draw(uniforms, scene.ert, scene.shading, mCompositor, stats, options.cancelled);
    else
      drawProjected(uniforms, nullFragment ? mNullProgram : scene.shading ? mShadedProgram : mProgram, stats,
                    options.cancelled);
    checkGlError(mGl, "TetRenderer: drawing");
  } catch (...) {
    mCompositor.abort();
    throw;
  }
  stats.msDrawing = msSince(drawStart);
  stats.tetsDrawn = int64_t(mOrder.size());
  image::ImageF image = mCompositor.finish(scene, stats);
  if (rays) mRayCaster->readCounters(stats);
  mGl.glDisable(GL_BLEND);
  mGl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  stats.msTotal = msSince(frameStart);
  if (statsOut) *statsOut = stats;
  return image;
}

void TetRenderer::drawProjected(const TetFrameUniforms& uniforms, const Program& p, FrameStats& stats,
                                const std::function<bool()>& cancelled) {
  if (!mStreamed)
    mOrderBuffer.allocate(GL_SHADER_STORAGE_BUFFER, mOrder.size() * sizeof(uint32_t), mOrder.data(), GL_STREAM_DRAW);
  setTetUniforms(p, uniforms);
  p.use();
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_VERTICES, mVertices.id());
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_ORDER, mOrderBuffer.id());
  mEmpty.bind();
  // Cancellation: checked between draws of at most kTetsPerDraw tets, with at most two of them queued
  // (Checkpoints), so that a frame given up stops within about one draw's work.
  Checkpoints checkpoints(mGl, cancelled);
  const GLint orderOffset = p.uniformLocation("uOrderOffset");
  if (!mStreamed) {
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
    mStaging.resize(mBatchTets * 4);
    for (size_t first = 0; first < mOrder.size(); first += mBatchTets) {
      const size_t count = std::min(mBatchTets, mOrder.size() - first);
      for (size_t i = 0; i < count; ++i) writeTet(mOrder[first + i], &mStaging[4 * i]);
      mVertices.allocate(GL_SHADER_STORAGE_BUFFER, mBatchTets * kBytesPerTet, nullptr, GL_STREAM_DRAW);
      mGl.glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(count * kBytesPerTet), mStaging.data());
      mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_VERTICES, mVertices.id());
      mGl.glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(count));
      checkpoints.pace();
      stats.batches += 1;
    }
  }
}

}  // namespace voxbrick::render
