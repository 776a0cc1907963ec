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
#include "render/SubBlocks.h"
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
  int32_t plane;  ///< global index of the vertex's plane
  int32_t ownLo[3], ownHi[3];
};
static_assert(sizeof(SliceVertex) == 56);

/// How far past the voxels it owns a box is drawn, in voxels, so that the fragment stage's ownership test decides
/// coverage: at the volume's surface, and between neighbouring sub-block boxes (far above the rasterised edges'
/// round-off).
constexpr double kSurfaceMargin = 0.25;
constexpr double kInteriorMargin = 1.0 / 64;

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
  mSlotRanges.resize(size_t(mAtlas.slots().capacity()));
}

VolumeRenderer::~VolumeRenderer() = default;

const Program& VolumeRenderer::program(Slicer slicer, bool shading, bool roofline, bool exactOwnership) {
  Program& p = mPrograms[slicer == Slicer::Cpu][roofline ? 2 : int(shading)][int(exactOwnership)];
  if (!p) {
    std::vector<std::string> defines;
    if (exactOwnership) defines.push_back("EXACT_OWNERSHIP");
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

void VolumeRenderer::drawBatch(Batch& batch, const Program& p, Slicer slicer, FrameStats& stats) {
  if (batch.instances.empty() && batch.vertices.empty()) return;
  const auto t = Clock::now();
  mVertexArray.bind();
  p.use();
  if (slicer == Slicer::Vertex) {
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
    mGl.glEnableVertexAttribArray(kSliceOwnLoLocation);
    mGl.glVertexAttribIPointer(kSliceOwnLoLocation, 3, GL_INT, stride, offset(offsetof(SliceInstance, ownLo)));
    mGl.glEnableVertexAttribArray(kSliceOwnHiLocation);
    mGl.glVertexAttribIPointer(kSliceOwnHiLocation, 3, GL_INT, stride, offset(offsetof(SliceInstance, ownHi)));
    for (GLuint a = 0; a < 7; ++a) mGl.glVertexAttribDivisor(a, 1);
    mGl.glDrawArraysInstanced(GL_TRIANGLES, 0, GLsizei(kSliceVerticesPerPolygon * batch.maxPlanes),
                              GLsizei(batch.instances.size()));
  } else {
    mVertices.allocate(GL_ARRAY_BUFFER, batch.vertices.size() * sizeof(SliceVertex), batch.vertices.data(),
                       GL_STREAM_DRAW);
    const GLsizei stride = sizeof(SliceVertex);
    auto offset = [](size_t bytes) { return reinterpret_cast<void*>(bytes); };
    for (GLuint a = 0; a < 7; ++a) mGl.glVertexAttribDivisor(a, 0);
    mGl.glDisableVertexAttribArray(1);
    mGl.glDisableVertexAttribArray(2);
    mGl.glEnableVertexAttribArray(0);
    mGl.glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, offset(offsetof(SliceVertex, world)));
    mGl.glEnableVertexAttribArray(3);
    mGl.glVertexAttribIPointer(3, 4, GL_INT, stride, offset(offsetof(SliceVertex, payload)));
    mGl.glEnableVertexAttribArray(4);
    mGl.glVertexAttribIPointer(4, 1, GL_INT, stride, offset(offsetof(SliceVertex, plane)));
    mGl.glEnableVertexAttribArray(5);
    mGl.glVertexAttribIPointer(5, 3, GL_INT, stride, offset(offsetof(SliceVertex, ownLo)));
    mGl.glEnableVertexAttribArray(6);
    mGl.glVertexAttribIPointer(6, 3, GL_INT, stride, offset(offsetof(SliceVertex, ownHi)));
    mGl.glDrawArrays(GL_TRIANGLES, 0, GLsizei(batch.vertices.size()));
  }
  stats.batches += 1;
  stats.msDrawing += msSince(t);
  batch.clear();
}

ImageF VolumeRenderer::render(const Scene& scene, FrameStats* statsOut, RenderMode mode) {
  const auto frameStart = Clock::now();
  scene.validate();
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
  const int subBlock = scene.subBlock > 0 && scene.subBlock < B ? scene.subBlock : 0;
  const Program& p = program(scene.slicer, scene.shading, mode == RenderMode::Roofline, subBlock > 0);
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
  // Pixel rays for exact ownership: the points at clip depth -1 and +1 are affine in window coordinates (the inverse
  // projection's w does not depend on x and y), so origin and direction are three vectors each.
  const glm::dmat4 inverseViewProj = glm::inverse(viewProj);
  auto unproject = [&](double wx, double wy, double depth) {
    const glm::dvec4 h = inverseViewProj * glm::dvec4(2 * wx / scene.width - 1, 2 * wy / scene.height - 1, depth, 1);
    return glm::dvec3(h) / h.w;
  };
  const glm::dvec3 near0 = unproject(0, 0, -1), far0 = unproject(0, 0, 1);
  const glm::dvec3 nearX = unproject(1, 0, -1), nearY = unproject(0, 1, -1);
  p.set(p.uniformLocation("uRayOrigin"), glm::vec3(near0));
  p.set(p.uniformLocation("uRayOriginDx"), glm::vec3(nearX - near0));
  p.set(p.uniformLocation("uRayOriginDy"), glm::vec3(nearY - near0));
  p.set(p.uniformLocation("uRayDirection"), glm::vec3(far0 - near0));
  p.set(p.uniformLocation("uRayDirectionDx"), glm::vec3((unproject(1, 0, 1) - nearX) - (far0 - near0)));
  p.set(p.uniformLocation("uRayDirectionDy"), glm::vec3((unproject(0, 1, 1) - nearY) - (far0 - near0)));

  // Page and slice brick by brick, front to back; draw whenever the atlas is full of this batch's bricks.
  mGl.glBeginQuery(GL_SAMPLES_PASSED, mFragments.id());
  Batch batch;
  // Boxes are drawn a little larger than the voxels they own and the fragment program keeps only the samples they
  // own (volume.frag.glsl). Whole bricks own the whole volume: only the outline is cut, the same for every
  // bricking. Sub-block boxes own their voxels and, with exact ownership, overlap their neighbours by a margin.
  const double interiorMargin = subBlock ? kInteriorMargin : 0.0;
  auto withMargin = [&](Box b) {
    for (int a = 0; a < 3; ++a) {
      b.min[a] -= (b.min[a] <= box.min[a] ? kSurfaceMargin : interiorMargin) * meta.spacing[a];
      b.max[a] += (b.max[a] >= box.max[a] ? kSurfaceMargin : interiorMargin) * meta.spacing[a];
    }
    return b;
  };
  // The vertex program decides plane membership in float, so it is given one extra plane each side (the shader's
  // half-open test then draws every plane exactly once); the CPU slicer uses the exact range.
  auto planeRange = [&](const Box& b) {
    return scene.slicer == Slicer::Vertex ? slicerPlaneRange(b.min, b.max, n, step) : planeIndexRange(b.min, b.max, n, step);
  };
  SubBlockWalkStats subStats;
  std::vector<VoxelSpan> spans;
  const glm::ivec3 volumeHi(meta.dims.x, meta.dims.y, meta.dims.z);
  for (const BrickDraw& visibleBrick : visible.bricks) {
    auto ts = Clock::now();
    const PlaneIndexRange brickPlanes = planeRange(withMargin(visibleBrick.box));
    stats.msSlicing += msSince(ts);
    if (brickPlanes.count() == 0) continue;

    auto tp = Clock::now();
    const store::BrickKey& key = visibleBrick.key;
    auto acquired = mAtlas.slots().acquire(key);
    if (!acquired) {
      stats.msPaging += msSince(tp);
      drawBatch(batch, p, scene.slicer, stats);
      mAtlas.slots().unpinAll();
      tp = Clock::now();
      acquired = mAtlas.slots().acquire(key);
    }
    SubBlockRanges& ranges = mSlotRanges[size_t(acquired->slot.index)];
    const store::Vec3i brickLo{int64_t(key.i) * B, int64_t(key.j) * B, int64_t(key.k) * B};
    const store::Vec3i brickHi{std::min<int64_t>(brickLo.x + B, meta.dims.x), std::min<int64_t>(brickLo.y + B, meta.dims.y),
                               std::min<int64_t>(brickLo.z + B, meta.dims.z)};
    const store::Vec3i owned{brickHi.x - brickLo.x, brickHi.y - brickLo.y, brickHi.z - brickLo.z};
    if (!acquired->resident) {
      prefetchUpTo(++paged + kPrefetchWindow);
      const store::BrickHandle brick = mCache->get(key);
      mAtlas.upload(acquired->slot, *brick);
      ranges = subBlock ? SubBlockRanges(*brick, B, subBlock, owned) : SubBlockRanges();
      stats.bricksPagedIn += 1;
      stats.bricksEvicted += acquired->evicted ? 1 : 0;
    } else if (subBlock && ranges.subBlock() != subBlock) {
      ranges = SubBlockRanges(*mCache->get(key), B, subBlock, owned);
    }
    stats.msPaging += msSince(tp);

    ts = Clock::now();
    spans.clear();
    if (subBlock)
      subBlockBoxes(ranges, brickLo, meta.dims, meta.spacing, camera, contributes, spans, subStats);
    else
      spans.push_back({brickLo, brickHi});
    const glm::ivec3 origin = mAtlas.slotOrigin(acquired->slot);
    const glm::ivec4 payload(origin.x + 1 - int32_t(brickLo.x), origin.y + 1 - int32_t(brickLo.y),
                             origin.z + 1 - int32_t(brickLo.z), 0);
    for (const VoxelSpan& span : spans) {
      const Box drawBox = withMargin(voxelSpanBox(span.lo, span.hi, meta.dims, meta.spacing));
      const PlaneIndexRange planes = subBlock ? planeRange(drawBox) : brickPlanes;
      if (planes.count() == 0) continue;
      const glm::ivec3 ownLo = subBlock ? glm::ivec3(span.lo.x, span.lo.y, span.lo.z) : glm::ivec3(0);
      const glm::ivec3 ownHi = subBlock ? glm::ivec3(span.hi.x, span.hi.y, span.hi.z) : volumeHi;
      stats.slices += planes.count();
      if (scene.slicer == Slicer::Vertex) {
        batch.instances.push_back({glm::vec3(drawBox.min), glm::vec3(drawBox.max), 0.0f, payload,
                                   int32_t(planes.begin), ownLo, ownHi});
        batch.maxPlanes = std::max(batch.maxPlanes, planes.count());
      } else {
        for (int64_t k = planes.begin; k < planes.end; ++k) {
          const auto polygon = rezkSalamaPolygon(drawBox.min, drawBox.max, n, double(k) * step);
          for (int corner : kSliceFan) {
            SliceVertex v{};
            for (int a = 0; a < 3; ++a) {
              v.world[a] = float(polygon[size_t(corner)][a]);
              v.ownLo[a] = ownLo[a], v.ownHi[a] = ownHi[a];
            }
            for (int a = 0; a < 4; ++a) v.payload[a] = payload[a];
            v.plane = int32_t(k);
            batch.vertices.push_back(v);
          }
        }
      }
    }
    stats.msSlicing += msSince(ts);
  }
  stats.subBlocksSkipped = subStats.subBlocksSkipped;
  stats.boxesDrawn = subBlock ? subStats.boxes : stats.bricksDrawn;
  drawBatch(batch, p, scene.slicer, stats);
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
