// The reference renderer: one ray per pixel centre, composite midpoint rule along it, everything in double.
#include "render/reference/ReferenceRenderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "render/core/Camera.h"
#include "render/reference/Compositing.h"
#include "render/volume/FramePlan.h"
#include "render/reference/Headlight.h"
#include "render/core/RenderErrors.h"
#include "render/core/WorldFrame.h"

namespace voxbrick::render {

/// Level-0 bricks, fetched from the cache on first use by any thread and held for the renderer's lifetime, so a
/// sample costs one atomic load instead of a cache lookup.
class ReferenceBricks {
 public:
  explicit ReferenceBricks(std::shared_ptr<store::BrickCache> cache) : mCache(std::move(cache)) {
    // One pointer per brick of every level, level after level.
    mCount = 0;
    for (int l = 0; l < mCache->store()->levelCount(); ++l) {
      mLevelFirst.push_back(mCount);
      mCount += size_t(mCache->store()->level(l).bricksTotal());
    }
    mPointers = std::make_unique<std::atomic<const void*>[]>(mCount);
    for (size_t i = 0; i < mCount; ++i) mPointers[i].store(nullptr, std::memory_order_relaxed);
  }

  /// The index of `key`'s pointer from its index within its level.
  size_t index(const store::BrickKey& key, size_t inLevel) const { return mLevelFirst[key.level] + inLevel; }

  const void* data(const store::BrickKey& key, size_t index) {
    const void* p = mPointers[index].load(std::memory_order_acquire);
    return p ? p : load(key, index);
  }

 private:
  const void* load(const store::BrickKey& key, size_t index) {
    store::BrickHandle brick = mCache->get(key);
    std::lock_guard lock(mMutex);
    if (const void* p = mPointers[index].load(std::memory_order_relaxed)) return p;
    mPointers[index].store(brick->data(), std::memory_order_release);
    mHandles.push_back(std::move(brick));
    return mHandles.back()->data();
  }

  std::shared_ptr<store::BrickCache> mCache;
  size_t mCount;
  std::vector<size_t> mLevelFirst;
  std::unique_ptr<std::atomic<const void*>[]> mPointers;
  std::mutex mMutex;
  std::vector<store::BrickHandle> mHandles;
};

namespace {

using Clock = std::chrono::steady_clock;

/// Below this transmittance a ray stops (see the class comment).
constexpr double kTerminateTransmittance = 1e-9;

/// Trilinear reconstruction at a level-0 voxel coordinate (voxel i's centre at i + ½), clamp-to-edge, of level 0 or,
/// with per-brick levels, of the level chosen for the level-0 brick the point lies in (at the coordinate clamped to
/// the volume times 2^-m). The cell's lower corner picks the brick of that level, whose one-voxel border holds the
/// upper corner, as on the GPU.
template <typename T>
class GridSampler {
 public:
  GridSampler(ReferenceBricks& bricks, const store::StoreMeta& meta, const std::vector<uint8_t>& brickLevels)
      : mBricks(bricks), mMeta(meta), mDims(meta.dims), mBrick(meta.brickSize), mEdge(meta.brickSize + 2),
        mBrickGrid(meta.levels.at(0).bricks), mBrickLevels(brickLevels) {}

  double operator()(const glm::dvec3& p) const {
    int level = 0;
    glm::dvec3 q = p;
    if (!mBrickLevels.empty()) {
      int64_t b[3];
      for (int a = 0; a < 3; ++a) {
        q[a] = std::clamp(p[a], 0.0, double(mDims[a]));
        b[a] = std::min(int64_t(q[a]), mDims[a] - 1) / mBrick;
      }
      level = mBrickLevels[size_t(b[0] + mBrickGrid.x * (b[1] + mBrickGrid.y * b[2]))];
      q = std::ldexp(1.0, -level) * q;
    }
    const store::LevelMeta& lm = mMeta.levels[size_t(level)];
    int64_t brick[3], local[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
      const double u = std::clamp(q[a] - 0.5, 0.0, double(lm.dims[a] - 1));
      const int64_t i = std::min(int64_t(u), lm.dims[a] - 1);
      f[a] = u - double(i);
      brick[a] = i / mBrick;
      local[a] = i - brick[a] * mBrick + 1;
    }
    const store::BrickKey key{uint32_t(level), uint32_t(brick[0]), uint32_t(brick[1]), uint32_t(brick[2])};
    const size_t index = mBricks.index(key, size_t(brick[0] + lm.bricks.x * (brick[1] + lm.bricks.y * brick[2])));
    const T* v = static_cast<const T*>(mBricks.data(key, index)) + (local[0] + mEdge * (local[1] + mEdge * local[2]));
    const int64_t dy = mEdge, dz = mEdge * mEdge;
    auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
    const double x00 = lerp(double(v[0]), double(v[1]), f[0]);
    const double x10 = lerp(double(v[dy]), double(v[dy + 1]), f[0]);
    const double x01 = lerp(double(v[dz]), double(v[dz + 1]), f[0]);
    const double x11 = lerp(double(v[dz + dy]), double(v[dz + dy + 1]), f[0]);
    return lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2]);
  }

 private:
  ReferenceBricks& mBricks;
  const store::StoreMeta& mMeta;
  store::Vec3i mDims;
  int64_t mBrick, mEdge;
  store::Vec3i mBrickGrid;
  const std::vector<uint8_t>& mBrickLevels;
};

/// The analytic function at a voxel coordinate, clamped to the box (where it is defined).
class AnalyticSampler {
 public:
  AnalyticSampler(const store::SyntheticField& field, const store::StoreMeta& meta) : mField(field), mMeta(meta) {}

  double operator()(const glm::dvec3& p) const {
    double x[3];
    for (int a = 0; a < 3; ++a) {
      const double n = double(mMeta.dims[a]);
      x[a] = (std::clamp(p[a], 0.0, n) - 0.5 * n) * mMeta.spacing[a];
    }
    return mField.evaluate(x[0], x[1], x[2]);
  }

 private:
  const store::SyntheticField& mField;
  const store::StoreMeta& mMeta;
};

/// The ray parameters where a ray is inside an axis-aligned box; false if it misses. A ray in the plane of a face
/// belongs to the box on its low face and not on its high one: the GPU's half-open rule, so that the two agree on
/// the pixel centres that views along an axis put exactly on a face.
bool clipToBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi, double& t0,
               double& t1) {
  t0 = -std::numeric_limits<double>::infinity();
  t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < lo[a] || o[a] >= hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 < t1;
}

/// Everything a ray needs that is the same for the whole frame.
struct Frame {
  const Scene* scene = nullptr;
  glm::dvec3 spacing{1}, dims{1}, halfDims{0.5}, boxMin{0}, boxMax{0};
  RayBasis basis;
  double lo = 0, inverseWidth = 1;
  double step = 1;       // longest segment, world units
  double referenceLength = 1;
  std::vector<double> kinks;  // the transfer function's control points, distinct and sorted
  // Empty-space skipping: transparent[i] for each level-0 brick; empty when off.
  std::vector<uint8_t> transparent;
  store::Vec3i brickGrid;
  double brickSize = 32;
};

/// The time from the near plane to the box's exit for one pixel: origin, unit direction, interval.
struct Ray {
  glm::dvec3 origin, dir;
  double t0 = 0, t1 = 0;
};

Ray pixelRay(const Frame& f, int x, int y, int width, int height) {
  Ray ray;
  double tNear = 0;
  f.basis.pixelRay(x, y, width, height, ray.origin, ray.dir, tNear);
  if (!clipToBox(ray.origin, ray.dir, f.boxMin, f.boxMax, ray.t0, ray.t1)) {
    ray.t0 = ray.t1 = 0;
    return ray;
  }
  ray.t0 = std::max(ray.t0, tNear);
  return ray;
}

/// The GPU's shading of colour `c` at ray parameter t: central differences half a voxel each way, two-sided Phong
/// headlight.
template <typename Sampler>
glm::dvec3 shade(const Frame& f, const Sampler& sample, const Ray& ray, double t, const glm::dvec3& c) {
  const glm::dvec3 world = ray.origin + t * ray.dir;
  const glm::dvec3 p = world / f.spacing + f.halfDims;
  glm::dvec3 gradient;
  for (int a = 0; a < 3; ++a) {
    glm::dvec3 d(0.0);
    d[a] = 0.5;
    gradient[a] = (sample(p + d) - sample(p - d)) / f.spacing[a];
  }
  const double magnitude = glm::length(gradient);
  if (!(magnitude > 1e-12)) return c;
  const glm::dvec3 normal = -gradient / magnitude;
  const glm::dvec3 toEye = f.basis.orthographic ? -f.basis.forward : glm::normalize(f.basis.eye - world);
  const glm::dvec2 light = headlight(std::abs(glm::dot(normal, toEye)));
  return c * light.x + glm::dvec3(light.y);
}

/// Integrates one ray: its output pixel (Scene::output: over the background, or with alpha), with its samples and skipped bricks added to the counters.
///
/// Samples sit at the midpoints t_k of n equal segments of length h, and each sample's segment is composited as two
/// halves (which equals the midpoint rule). Between two consecutive samples whose normalised values straddle a
/// control point of the transfer function, or whose alphas differ by more than 1/16, the two halves are replaced by
/// a finer rule: the interval is cut where the value crosses each control point (bisection), and each piece gets
/// midpoint samples, more where alpha changes more. On every piece the transfer function is then linear in the
/// value and the extinction well resolved, so steps, spikes and kinks converge like smooth parts instead of O(h).
template <typename Sampler>
class RayIntegrator {
 public:
  RayIntegrator(const Frame& frame, const Sampler& sample, const Ray& ray, int64_t& samples, int64_t& skipped)
      : mFrame(frame), mScene(*frame.scene), mSample(sample), mRay(ray), mSamples(samples), mSkipped(skipped) {}

  glm::dvec4 run();

 private:
  struct Piece {
    glm::dvec3 color{0.0};
    double alpha = 0;    // corrected for the piece's length
    double tfAlpha = 0;  // the transfer function's, per reference length
  };

  double at(int64_t k) const { return mRay.t0 + (double(k) + 0.5) * mSegment; }
  glm::dvec3 voxel(double t) const { return (mRay.origin + t * mRay.dir) / mFrame.spacing + mFrame.halfDims; }
  double valueAt(double t) {
    ++mSamples;
    return std::clamp((mSample(voxel(t)) - mFrame.lo) * mFrame.inverseWidth, 0.0, 1.0);
  }
  Piece classify(double t, double s, double pieceLength) const {
    const glm::dvec4 c = mScene.transferFunction.evaluate(s);
    Piece piece{glm::dvec3(c), TransferFunction::correctOpacity(c.a, pieceLength / mFrame.referenceLength), c.a};
    if (piece.alpha > 0 && mScene.shading) piece.color = shade(mFrame, mSample, mRay, t, piece.color);
    return piece;
  }
  void add(const Piece& p) {
    if (p.alpha > 0) mAcc.add(p.color.r, p.color.g, p.color.b, p.alpha);
  }
  bool opaque() const { return 1 - mAcc.a < kTerminateTransmittance; }
  void refine(double ta, double sa, double tb, double sb);
  void integratePiece(double a, double b, double& sLeft, double sRight);
  bool refined(double sa, const Piece& a, double sb, const Piece& b) const;
  std::optional<double> transparentUntil(double t) const;

  const Frame& mFrame;
  const Scene& mScene;
  const Sampler& mSample;
  const Ray& mRay;
  int64_t& mSamples;
  int64_t& mSkipped;
  FrontToBack<double> mAcc;
  double mSegment = 0;  // h, the length of one segment
};

template <typename Sampler>
glm::dvec4 RayIntegrator<Sampler>::run() {
  const double length = mRay.t1 - mRay.t0;
  if (length > 0) {
    const double segments = std::ceil(length / mFrame.step);
    const int64_t n = int64_t(segments);
    mSegment = length / segments;
    double tPrev = at(0), sPrev = valueAt(tPrev);
    Piece halfPrev = classify(tPrev, sPrev, 0.5 * mSegment);
    add(halfPrev);
    for (int64_t k = 1; k < n && !opaque(); ++k) {
      const double t = at(k), s = valueAt(t);
      const Piece half = classify(t, s, 0.5 * mSegment);
      if (refined(sPrev, halfPrev, s, half)) {
        refine(tPrev, sPrev, t, s);
      } else {
        add(halfPrev);
        add(half);
      }
      tPrev = t, sPrev = s, halfPrev = half;
      // Every sample before the ray leaves a transparent brick's box reads only that brick (border included), so
      // the intervals between them add exactly nothing: continue from the last sample inside.
      if (const std::optional<double> exit = transparentUntil(t)) {
        const double past = std::ceil((*exit - mRay.t0) / mSegment - 0.5);  // first midpoint past the exit
        const int64_t inside = std::clamp<int64_t>(int64_t(std::min(past, segments)) - 1, k, n - 1);
        if (inside > k) {
          tPrev = at(inside), sPrev = valueAt(tPrev), halfPrev = classify(tPrev, sPrev, 0.5 * mSegment);
          k = inside;
          mSkipped += 1;
        }
      }
    }
    if (!opaque()) add(halfPrev);
  }
  return mScene.output(glm::dvec3(mAcc.r, mAcc.g, mAcc.b), mAcc.a);
}

// Integrates the interval [ta, tb] between two mSamples finely: cut where the value crosses each control point
// between sa and sb, then several mSamples per piece.
template <typename Sampler>
void RayIntegrator<Sampler>::refine(double ta, double sa, double tb, double sb) {
  const bool rising = sa < sb;
  const auto first = std::upper_bound(mFrame.kinks.begin(), mFrame.kinks.end(), std::min(sa, sb));
  const auto last = std::upper_bound(mFrame.kinks.begin(), mFrame.kinks.end(), std::max(sa, sb));
  double left = ta;
  double sLeft = sa;
  for (ptrdiff_t i = 0; i < last - first; ++i) {
    const double x = rising ? first[i] : last[-1 - i];
    // Bisection keeps lo on the side of the value at `left`; 16 halvings place the cut within h / 65536.
    double lo = left, hi = tb;
    const bool above = (left == ta ? sa : valueAt(left)) >= x;
    if ((sb >= x) == above) continue;  // not monotone here: no crossing to cut at
    for (int iteration = 0; iteration < 16; ++iteration) {
      const double mid = 0.5 * (lo + hi);
      if ((valueAt(mid) >= x) == above)
        lo = mid;
      else
        hi = mid;
    }
    const double cut = 0.5 * (lo + hi);
    integratePiece(left, cut, sLeft, x);
    left = cut;
  }
  integratePiece(left, tb, sLeft, sb);
}

// Extinction −ln(1 − α) is not linear where α is, so a piece gets more mSamples the more α changes on it. The
// piece's values run from sLeft to sRight; sLeft moves on to sRight.
template <typename Sampler>
void RayIntegrator<Sampler>::integratePiece(double a, double b, double& sLeft, double sRight) {
  const double change = std::abs(mScene.transferFunction.evaluate(sRight).a - mScene.transferFunction.evaluate(sLeft).a);
  const int m = 2 + int(32 * change);
  for (int j = 0; j < m; ++j) {
    const double t = a + (j + 0.5) / m * (b - a);
    add(classify(t, valueAt(t), (b - a) / m));
  }
  sLeft = sRight;
}

// Refined: an interval where the value crosses a control point, or where alpha changes by more than 1/16.
template <typename Sampler>
bool RayIntegrator<Sampler>::refined(double sa, const Piece& a, double sb, const Piece& b) const {
  return std::abs(a.tfAlpha - b.tfAlpha) > 1.0 / 16 ||
         std::upper_bound(mFrame.kinks.begin(), mFrame.kinks.end(), std::min(sa, sb)) !=
             std::upper_bound(mFrame.kinks.begin(), mFrame.kinks.end(), std::max(sa, sb));
}

// The brick of the sample at t, if rays may jump over it: the parameter where the ray leaves its box.
template <typename Sampler>
std::optional<double> RayIntegrator<Sampler>::transparentUntil(double t) const {
  if (mFrame.transparent.empty()) return std::nullopt;
  const glm::dvec3 p = voxel(t);
  glm::dvec3 lo, hi;
  int64_t index = 0, stride = 1;
  for (int a = 0; a < 3; ++a) {
    const int64_t b = std::clamp<int64_t>(int64_t(std::floor(p[a] / mFrame.brickSize)), 0, mFrame.brickGrid[a] - 1);
    index += b * stride;
    stride *= mFrame.brickGrid[a];
    lo[a] = (double(b) * mFrame.brickSize - mFrame.halfDims[a]) * mFrame.spacing[a];
    hi[a] = (std::min(double(b + 1) * mFrame.brickSize, mFrame.dims[a]) - mFrame.halfDims[a]) * mFrame.spacing[a];
  }
  if (!mFrame.transparent[size_t(index)]) return std::nullopt;
  double exit = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (mRay.dir[a] != 0) exit = std::min(exit, ((mRay.dir[a] > 0 ? hi[a] : lo[a]) - mRay.origin[a]) / mRay.dir[a]);
  return exit;
}

/// Everything of the frame that is the same for every ray: camera basis, box, value window, control points, step.
Frame makeFrame(const Scene& scene, const ReferenceOptions& options, const store::StoreMeta& meta) {
  Frame f;
  f.scene = &scene;
  const Box box = volumeBox(meta.dims, meta.spacing);
  f.boxMin = box.min;
  f.boxMax = box.max;
  for (int a = 0; a < 3; ++a) {
    f.spacing[a] = meta.spacing[a];
    f.dims[a] = double(meta.dims[a]);
  }
  f.halfDims = 0.5 * f.dims;

  const double aspect = double(scene.width) / double(scene.height);
  const Camera camera = scene.camera.resolve(box, WorldFrame::of(meta.orientation, meta.dims, meta.spacing), aspect);
  double nearPlane = 0, farPlane = 0;
  camera.clipRange(box, nearPlane, farPlane);
  f.basis = RayBasis::of(camera, aspect, nearPlane);

  // The value window exactly as the GPU renderer takes it.
  const ValueWindow window = valueWindow(scene, meta);
  f.lo = window.lo;
  f.inverseWidth = window.inverseWidth;

  for (const TransferFunction::Point& p : scene.transferFunction.points())
    if (f.kinks.empty() || p.x > f.kinks.back()) f.kinks.push_back(p.x);

  const double minSpacing = std::min({meta.spacing.x, meta.spacing.y, meta.spacing.z});
  f.step = options.step * minSpacing;
  f.referenceLength = scene.transferFunction.referenceLength().value_or(minSpacing);
  return f;
}

/// Marks the level-0 bricks whose [min, max] the transfer function maps to zero opacity, for rays to jump over;
/// never those sampled at a coarser level, whose reconstruction reads beyond them.
void markTransparentBricks(Frame& f, const store::BrickStore& store, const std::vector<uint8_t>& brickLevels) {
  const store::StoreMeta& meta = store.meta();
  const store::LevelMeta& level = meta.levels.at(0);
  f.brickGrid = level.bricks;
  f.brickSize = double(meta.brickSize);
  f.transparent.resize(size_t(level.bricksTotal()));
  for (int64_t k = 0; k < level.bricks.z; ++k)
    for (int64_t j = 0; j < level.bricks.y; ++j)
      for (int64_t i = 0; i < level.bricks.x; ++i) {
        const store::BrickRecord& r = store.record({0, uint32_t(i), uint32_t(j), uint32_t(k)});
        const size_t index = size_t(i + level.bricks.x * (j + level.bricks.y * k));
        f.transparent[index] = (brickLevels.empty() || brickLevels[index] == 0) &&
                               !f.scene->transferFunction.contributes((double(r.min) - f.lo) * f.inverseWidth,
                                                                      (double(r.max) - f.lo) * f.inverseWidth);
      }
}

}  // namespace

ReferenceRenderer::ReferenceRenderer(std::shared_ptr<store::BrickCache> cache)
    : mCache(std::move(cache)), mBricks(std::make_unique<ReferenceBricks>(mCache)) {}

ReferenceRenderer::~ReferenceRenderer() = default;

image::ImageF ReferenceRenderer::render(const Scene& scene, const ReferenceOptions& options, ReferenceStats* statsOut) {
  const auto start = Clock::now();
  scene.validate();
  if (!(options.step >= 1e-4 && options.step <= 64))
    throw RenderInputError("ReferenceRenderer: step " + numberText(options.step) + " is outside [1e-4, 64] voxels");
  const store::BrickStore& store = *mCache->store();
  const store::StoreMeta& meta = store.meta();

  if (!options.brickLevels.empty()) {
    if (options.analytic) throw RenderInputError("ReferenceRenderer: per-brick levels sample the store, not a field");
    if (options.brickLevels.size() != size_t(meta.levels.at(0).bricksTotal()))
      throw RenderInputError("ReferenceRenderer: " + std::to_string(options.brickLevels.size()) +
                             " brick levels for " + std::to_string(meta.levels.at(0).bricksTotal()) + " bricks");
    for (uint8_t l : options.brickLevels)
      if (int(l) >= store.levelCount())
        throw RenderInputError("ReferenceRenderer: brick level " + std::to_string(int(l)) + " beyond the store's " +
                               std::to_string(store.levelCount()) + " levels");
  }
  Frame f = makeFrame(scene, options, meta);
  if (!options.analytic && scene.skipEmpty) markTransparentBricks(f, store, options.brickLevels);

  image::ImageF image{scene.width, scene.height, std::vector<float>(size_t(scene.width) * size_t(scene.height) * 4)};
  std::atomic<int64_t> rays{0}, samples{0}, skipped{0};
  auto renderRows = [&](const auto& sampler) {
    tbb::parallel_for(tbb::blocked_range<int>(0, scene.height), [&](const tbb::blocked_range<int>& rows) {
      int64_t rowRays = 0, rowSamples = 0, rowSkipped = 0;
      for (int y = rows.begin(); y != rows.end(); ++y)
        for (int x = 0; x < scene.width; ++x) {
          const Ray ray = pixelRay(f, x, y, scene.width, scene.height);
          rowRays += ray.t1 > ray.t0 ? 1 : 0;
          const glm::dvec4 c = RayIntegrator(f, sampler, ray, rowSamples, rowSkipped).run();
          float* out = image.pixel(x, y);
          for (int ch = 0; ch < 4; ++ch) out[ch] = float(c[ch]);
        }
      rays += rowRays;
      samples += rowSamples;
      skipped += rowSkipped;
    });
  };
  if (options.analytic) {
    renderRows(AnalyticSampler(*options.analytic, meta));
  } else {
    store::dispatchType(meta.type, [&](auto zero) {
      renderRows(GridSampler<decltype(zero)>(*mBricks, meta, options.brickLevels));
    });
  }

  if (statsOut) {
    statsOut->rays = rays;
    statsOut->samples = samples;
    statsOut->bricksSkipped = skipped;
    statsOut->ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  }
  finishImage(WorldFrame::of(meta.orientation, meta.dims, meta.spacing), image);
  return image;
}

store::SyntheticField analyticFieldFor(const store::StoreMeta& meta, const std::string& spec) {
  const std::string name = spec.substr(0, spec.find(','));
  // prep records a synthetic source as "synthetic NAME NXxNYxNZ".
  const std::string recorded = "synthetic " + name + " ";
  if (meta.source.rfind(recorded, 0) != 0)
    throw RenderInputError("analytic field '" + spec + "': the store was made from '" + meta.source +
                           "', not from synthetic:" + name);
  const bool hasDims = spec.find(",n=") != std::string::npos || spec.find(",nx=") != std::string::npos ||
                       spec.find(",ny=") != std::string::npos || spec.find(",nz=") != std::string::npos;
  const std::string full = hasDims ? spec
                                   : spec + ",nx=" + std::to_string(meta.dims.x) + ",ny=" +
                                         std::to_string(meta.dims.y) + ",nz=" + std::to_string(meta.dims.z);
  store::SyntheticField field = store::SyntheticField::parse(full);
  if (!(field.dims() == meta.dims))
    throw RenderInputError("analytic field '" + spec + "': dims " + std::to_string(field.dims().x) + "x" +
                           std::to_string(field.dims().y) + "x" + std::to_string(field.dims().z) +
                           " differ from the store's");
  field.setSpacing(meta.spacing);
  return field;
}

}  // namespace voxbrick::render
