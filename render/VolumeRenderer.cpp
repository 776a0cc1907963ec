// One frame: traversal -> paging -> slicing -> drawing -> readback, each timed.
#include "render/VolumeRenderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <span>

#include <nlohmann/json.hpp>

#include "render/RenderErrors.h"
#include "render/SliceTables.h"
#include "render/Slicing.h"
#include "render/Traversal.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

constexpr int kTransferTableSize = 4096;
constexpr size_t kPrefetchWindow = 256;  // bricks decoded ahead of the one being paged

/// Vertex input of slice_cpu.vert.glsl.
struct SliceVertex {
  float world[3];
  int32_t payload[4];
};
static_assert(sizeof(SliceVertex) == 28);

}  // namespace

struct VolumeRenderer::Batch {
  std::vector<SliceInstance> instances;
  std::vector<SliceVertex> vertices;
  int64_t maxPlanes = 0;
  double planeIncr = 0;
  void clear() {
    instances.clear();
    vertices.clear();
    maxPlanes = 0;
  }
};

std::string FrameStats::toJson() const {
  nlohmann::json j = {{"nodes_visited", nodesVisited},   {"bricks_skipped_empty", bricksSkippedEmpty},
                      {"bricks_culled", bricksCulled},   {"bricks_drawn", bricksDrawn},
                      {"bricks_paged_in", bricksPagedIn}, {"bricks_evicted", bricksEvicted},
                      {"batches", batches},               {"slices", slices},
                      {"fragments", fragments},
                      {"ms", {{"traversal", msTraversal}, {"paging", msPaging}, {"slicing", msSlicing},
                              {"drawing", msDrawing}, {"readback", msReadback}, {"total", msTotal}}}};
  return j.dump(2);
}

VolumeRenderer::VolumeRenderer(GlContext& context, std::shared_ptr<store::BrickCache> cache, size_t gpuBudgetBytes,
                               AtlasFormat format)
    : mGl(context.gl()),
      mCache(std::move(cache)),
      mAtlas(context, mCache->store()->type(), mCache->store()->brickEdge(), gpuBudgetBytes,
             int(std::min<int64_t>(mCache->store()->level(0).bricksTotal(), 1 << 20)), format) {
  mTransfer = Texture(mGl, GL_TEXTURE_1D);
  mTransfer.bind(1);
  mGl.glTexStorage1D(GL_TEXTURE_1D, 1, GL_RGBA32F, kTransferTableSize);
  mGl.glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  mGl.glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  mGl.glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  mInstances = Buffer(mGl);
  mVertices = Buffer(mGl);
  mVertexArray = VertexArray(mGl);
  mFragments = Query(mGl);
}

VolumeRenderer::~VolumeRenderer() = default;

const Program& VolumeRenderer::program(Slicer slicer, bool shading, bool roofline) {
  Program& p = mPrograms[slicer == Slicer::Cpu][roofline ? 2 : int(shading)];
  if (!p) {
    std::vector<std::string> defines;
    if (roofline) defines.push_back("ROOFLINE");
    else if (shading) defines.push_back("SHADING");
    const char* vertex = slicer == Slicer::Cpu ? "slice_cpu.vert.glsl" : "slice.vert.glsl";
    p = Program(mGl, ProgramSources::fromFiles(std::string("volume/") + vertex,
                                               {{GL_VERTEX_SHADER, vertex}, {GL_FRAGMENT_SHADER, "volume.frag.glsl"}},
                                               defines));
    if (slicer == Slicer::Vertex)
      for (const SliceTableUniform& table : kSliceTableUniforms) p.set(p.requireUniform(table.name), table.values);
  }
  return p;
}

void VolumeRenderer::drawBatch(Batch& batch, const Scene& scene, FrameStats& stats) {
  if (batch.instances.empty() && batch.vertices.empty()) return;
  const auto t = Clock::now();
  mVertexArray.bind();
  const Program& p = program(scene.slicer, scene.shading, mMode == RenderMode::Roofline);
  p.use();
  if (scene.slicer == Slicer::Vertex) {
    mInstances.allocate(GL_ARRAY_BUFFER, batch.instances.size() * sizeof(SliceInstance), batch.instances.data(),
                        GL_STREAM_DRAW);
    const GLsizei stride = sizeof(SliceInstance);
    auto offset = [](size_t bytes) { return reinterpret_cast<void*>(bytes); };
    mGl.glEnableVertexAttribArray(kSliceBoxMinLocation);
    mGl.glVertexAttribPointer(kSliceBoxMinLocation, 3, GL_FLOAT, GL_FALSE, stride,
                              offset(offsetof(SliceInstance, boxMin)));
    mGl.glEnableVertexAttribArray(kSliceBoxMaxLocation);
    mGl.glVertexAttribPointer(kSliceBoxMaxLocation, 3, GL_FLOAT, GL_FALSE, stride,
                              offset(offsetof(SliceInstance, boxMax)));
    mGl.glEnableVertexAttribArray(kSlicePlaneDistanceLocation);
    mGl.glVertexAttribPointer(kSlicePlaneDistanceLocation, 1, GL_FLOAT, GL_FALSE, stride,
                              offset(offsetof(SliceInstance, planeDistance)));
    mGl.glEnableVertexAttribArray(kSlicePayloadLocation);
    mGl.glVertexAttribIPointer(kSlicePayloadLocation, 4, GL_INT, stride, offset(offsetof(SliceInstance, payload)));
    mGl.glEnableVertexAttribArray(kSliceFirstPlaneLocation);
    mGl.glVertexAttribIPointer(kSliceFirstPlaneLocation, 1, GL_INT, stride, offset(offsetof(SliceInstance, firstPlane)));
    for (GLuint a = 0; a < 5; ++a) mGl.glVertexAttribDivisor(a, 1);
    mGl.glDrawArraysInstanced(GL_TRIANGLES, 0, GLsizei(kSliceVerticesPerPolygon * batch.maxPlanes),
                              GLsizei(batch.instances.size()));
  } else {
    mVertices.allocate(GL_ARRAY_BUFFER, batch.vertices.size() * sizeof(SliceVertex), batch.vertices.data(),
                       GL_STREAM_DRAW);
    const GLsizei stride = sizeof(SliceVertex);
    for (GLuint a = 0; a < 4; ++a) mGl.glVertexAttribDivisor(a, 0);
    mGl.glDisableVertexAttribArray(1);
    mGl.glDisableVertexAttribArray(2);
    mGl.glEnableVertexAttribArray(0);
    mGl.glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(offsetof(SliceVertex, world)));
    mGl.glEnableVertexAttribArray(3);
    mGl.glVertexAttribIPointer(3, 4, GL_INT, stride, reinterpret_cast<void*>(offsetof(SliceVertex, payload)));
    mGl.glDrawArrays(GL_TRIANGLES, 0, GLsizei(batch.vertices.size()));
  }
  stats.batches += 1;
  stats.msDrawing += msSince(t);
  batch.clear();
}

ImageF VolumeRenderer::render(const Scene& scene, FrameStats* statsOut, RenderMode mode) {
  const auto frameStart = Clock::now();
  scene.validate();
  mMode = mode;
  FrameStats stats;
  const store::BrickStore& store = *mCache->store();
  const store::StoreMeta& meta = store.meta();
  const int B = store.brickSize();

  // Camera, clip range and frustum.
  auto t = Clock::now();
  const Box box = volumeBox(meta.dims, meta.spacing);
  const Camera camera = scene.camera.resolve(box);
  double nearPlane = 0, farPlane = 0;
  camera.clipRange(box, nearPlane, farPlane);
  const glm::dmat4 viewProj =
      camera.projection(double(scene.width) / double(scene.height), nearPlane, farPlane) * camera.view();
  const Frustum frustum = Frustum::fromMatrix(viewProj);

  // Value window and the transfer function's O(1) range test.
  double lo = scene.window ? (*scene.window)[0] : meta.valueMin;
  double hi = scene.window ? (*scene.window)[1] : meta.valueMax;
  if (!(hi > lo)) hi = lo + 1;  // a constant volume: everything maps to 0
  const double inverseWidth = 1.0 / (hi - lo);
  const TransferFunction& tf = scene.transferFunction;
  // The GPU reads the transfer function from a table of kTransferTableSize texels with linear filtering, so a value
  // within one texel of an opaque region picks up some of its opacity (most visibly at a step). The range test is
  // widened by one texel so that skipping never drops what the GPU would draw.
  const double texel = 1.0 / kTransferTableSize;
  auto contributes = [&](float mn, float mx) {
    return tf.contributes((mn - lo) * inverseWidth - texel, (mx - lo) * inverseWidth + texel);
  };

  const OctreeTraversal traversal(store.octree(), meta.dims, B, meta.spacing);
  const TraversalResult visible = traversal.run(camera, frustum, contributes, {scene.skipEmpty, scene.cullFrustum});
  stats.nodesVisited = visible.stats.nodesVisited;
  stats.bricksSkippedEmpty = visible.stats.bricksSkippedEmpty;
  stats.bricksCulled = visible.stats.bricksCulled;
  stats.bricksDrawn = visible.stats.bricksDrawn;
  stats.msTraversal = msSince(t);

  // Decoding runs ahead on the cache's workers, in the order the bricks will be drawn, a window at a time: the
  // cache's queue drops its oldest requests when full, and those would be the ones needed first.
  std::vector<store::BrickKey> keys;
  keys.reserve(visible.bricks.size());
  for (const BrickDraw& d : visible.bricks)
    if (!mAtlas.slots().resident(d.key)) keys.push_back(d.key);
  size_t prefetched = 0;
  auto prefetchUpTo = [&](size_t end) {
    end = std::min(end, keys.size());
    if (end > prefetched) mCache->prefetch(std::span<const store::BrickKey>(keys).subspan(prefetched, end - prefetched));
    prefetched = std::max(prefetched, end);
  };
  prefetchUpTo(kPrefetchWindow);
  size_t paged = 0;

  // Target, state, uniforms.
  if (mTarget.width() != scene.width || mTarget.height() != scene.height)
    mTarget = Framebuffer::withColor(mGl, scene.width, scene.height, GL_RGBA32F);
  mTarget.bind();
  const float zero[4] = {0, 0, 0, 0};
  mGl.glClearBufferfv(GL_COLOR, 0, zero);
  mGl.glDisable(GL_DEPTH_TEST);
  mGl.glDisable(GL_CULL_FACE);
  if (mode == RenderMode::Roofline)
    mGl.glDisable(GL_BLEND);
  else
    mGl.glEnable(GL_BLEND);
  mGl.glBlendEquation(GL_FUNC_ADD);
  // Front to back with premultiplied colour: C += (1 - A) * c, A += (1 - A) * a.
  mGl.glBlendFuncSeparate(GL_ONE_MINUS_DST_ALPHA, GL_ONE, GL_ONE_MINUS_DST_ALPHA, GL_ONE);

  const std::vector<glm::vec4> table = tf.table(kTransferTableSize);
  mTransfer.bind(1);
  mGl.glTexSubImage1D(GL_TEXTURE_1D, 0, 0, kTransferTableSize, GL_RGBA, GL_FLOAT, table.data());
  mAtlas.texture().bind(0);

  const glm::dvec3 n = camera.viewDirection();
  const double minSpacing = std::min({meta.spacing.x, meta.spacing.y, meta.spacing.z});
  const double step = scene.step * minSpacing;
  const double referenceLength = tf.referenceLength().value_or(minSpacing);
  const Program& p = program(scene.slicer, scene.shading, mode == RenderMode::Roofline);
  p.set(p.uniformLocation("uViewProj"), glm::mat4(viewProj));
  p.set(p.uniformLocation(kSliceNormalUniform), glm::vec3(n));
  p.set(p.uniformLocation(kSlicePlaneIncrUniform), float(step));
  p.set(p.uniformLocation("uAtlas"), 0);
  p.set(p.uniformLocation("uTransfer"), 1);
  p.set(p.uniformLocation("uInvAtlasSize"), mAtlas.inverseSize());
  p.set(p.uniformLocation("uInvSpacing"), glm::vec3(1.0 / meta.spacing.x, 1.0 / meta.spacing.y, 1.0 / meta.spacing.z));
  p.set(p.uniformLocation("uDims"), glm::vec3(double(meta.dims.x), double(meta.dims.y), double(meta.dims.z)));
  p.set(p.uniformLocation("uHalfDims"), glm::vec3(0.5 * double(meta.dims.x), 0.5 * double(meta.dims.y),
                                                  0.5 * double(meta.dims.z)));
  // The window in the units a texture fetch returns (normalised formats return raw * valueScale).
  p.set(p.uniformLocation("uWindowLo"), float(lo * mAtlas.valueScale()));
  p.set(p.uniformLocation("uWindowScale"), float(inverseWidth / mAtlas.valueScale()));
  p.set(p.uniformLocation("uStepOverReference"), float(step / referenceLength));
  p.set(p.uniformLocation("uEye"), glm::vec3(camera.eye));
  p.set(p.uniformLocation("uViewDir"), glm::vec3(n));
  p.set(p.uniformLocation("uOrthographic"), camera.orthographic ? 1 : 0);

  // Page and slice brick by brick, front to back; draw whenever the atlas is full of this batch's bricks.
  mGl.glBeginQuery(GL_SAMPLES_PASSED, mFragments.id());
  Batch batch;
  // Where a brick lies on the volume's surface its box is pushed out by a quarter voxel, and the fragment program
  // discards what lies outside the volume. The volume's outline in each slice is then decided per fragment by one
  // test that does not depend on the bricking, instead of by the rasterised edges of whichever bricks touch the
  // surface (whose endpoints, and so whose rounding, change with the brick size).
  const glm::dvec3 margin(0.25 * meta.spacing.x, 0.25 * meta.spacing.y, 0.25 * meta.spacing.z);
  for (const BrickDraw& visibleBrick : visible.bricks) {
    auto ts = Clock::now();
    BrickDraw draw = visibleBrick;
    for (int a = 0; a < 3; ++a) {
      if (draw.box.min[a] <= box.min[a]) draw.box.min[a] = box.min[a] - margin[a];
      if (draw.box.max[a] >= box.max[a]) draw.box.max[a] = box.max[a] + margin[a];
    }
    // The vertex program decides plane membership in float, so it is given one extra plane each side (the
    // shader's half-open test then draws every plane exactly once); the CPU slicer uses the exact range.
    const PlaneIndexRange planes = scene.slicer == Slicer::Vertex ? slicerPlaneRange(draw.box.min, draw.box.max, n, step)
                                                                  : planeIndexRange(draw.box.min, draw.box.max, n, step);
    stats.msSlicing += msSince(ts);
    if (planes.count() == 0) continue;

    auto tp = Clock::now();
    auto acquired = mAtlas.slots().acquire(draw.key);
    if (!acquired) {
      stats.msPaging += msSince(tp);
      drawBatch(batch, scene, stats);
      mAtlas.slots().unpinAll();
      tp = Clock::now();
      acquired = mAtlas.slots().acquire(draw.key);
    }
    if (!acquired->resident) {
      prefetchUpTo(++paged + kPrefetchWindow);
      mAtlas.upload(acquired->slot, *mCache->get(draw.key));
      stats.bricksPagedIn += 1;
      stats.bricksEvicted += acquired->evicted ? 1 : 0;
    }
    stats.msPaging += msSince(tp);

    ts = Clock::now();
    const glm::ivec3 origin = mAtlas.slotOrigin(acquired->slot);
    const int32_t payload[4] = {origin.x + 1 - int32_t(draw.key.i) * B, origin.y + 1 - int32_t(draw.key.j) * B,
                                origin.z + 1 - int32_t(draw.key.k) * B, 0};
    stats.slices += planes.count();
    if (scene.slicer == Slicer::Vertex) {
      SliceInstance instance{};
      instance.boxMin = glm::vec3(draw.box.min);
      instance.boxMax = glm::vec3(draw.box.max);
      instance.planeDistance = 0;
      instance.firstPlane = int32_t(planes.begin);
      instance.payload = glm::ivec4(payload[0], payload[1], payload[2], payload[3]);
      batch.instances.push_back(instance);
      batch.maxPlanes = std::max(batch.maxPlanes, planes.count());
    } else {
      for (int64_t k = planes.begin; k < planes.end; ++k) {
        const auto polygon = rezkSalamaPolygon(draw.box.min, draw.box.max, n, double(k) * step);
        for (int corner : kSliceFan) {
          SliceVertex v{};
          for (int a = 0; a < 3; ++a) v.world[a] = float(polygon[size_t(corner)][a]), v.payload[a] = payload[a];
          v.payload[3] = payload[3];
          batch.vertices.push_back(v);
        }
      }
    }
    stats.msSlicing += msSince(ts);
  }
  drawBatch(batch, scene, stats);
  mAtlas.slots().unpinAll();
  mGl.glEndQuery(GL_SAMPLES_PASSED);

  // Readback, then the background: out = C + (1 - A) * background, as DESIGN's output rule says.
  t = Clock::now();
  mGl.glFinish();
  stats.msDrawing += msSince(t);
  stats.fragments = int64_t(mFragments.result());
  t = Clock::now();
  const std::vector<float> raw = mTarget.readRgba();
  ImageF image{scene.width, scene.height, std::vector<float>(raw.size())};
  for (int y = 0; y < scene.height; ++y) {
    const float* src = raw.data() + size_t(scene.height - 1 - y) * size_t(scene.width) * 4;
    float* dst = image.pixel(0, y);
    for (int x = 0; x < scene.width; ++x, src += 4, dst += 4) {
      const float a = std::clamp(src[3], 0.0f, 1.0f);
      for (int c = 0; c < 3; ++c) dst[c] = std::clamp(src[c] + (1 - a) * float(scene.background[c]), 0.0f, 1.0f);
      dst[3] = 1;
    }
  }
  stats.msReadback = msSince(t);
  stats.msTotal = msSince(frameStart);
  if (statsOut) *statsOut = stats;
  return image;
}

}  // namespace voxbrick::render
