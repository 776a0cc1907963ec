// The reference renderer: one ray per pixel centre, composite midpoint rule along it, everything in double.
#include "render/ReferenceRenderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "render/Camera.h"
#include "render/Compositing.h"
#include "render/RenderErrors.h"

namespace voxbrick::render {

/// Level-0 bricks, fetched from the cache on first use by any thread and held for the renderer's lifetime, so a
/// sample costs one atomic load instead of a cache lookup.
class ReferenceBricks {
 public:
  explicit ReferenceBricks(std::shared_ptr<store::BrickCache> cache)
      : mCache(std::move(cache)),
        mCount(size_t(mCache->store()->level(0).bricksTotal())),
        mPointers(std::make_unique<std::atomic<const void*>[]>(mCount)) {
    for (size_t i = 0; i < mCount; ++i) mPointers[i].store(nullptr, std::memory_order_relaxed);
  }

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
  std::unique_ptr<std::atomic<const void*>[]> mPointers;
  std::mutex mMutex;
  std::vector<store::BrickHandle> mHandles;
};

namespace {

using Clock = std::chrono::steady_clock;

/// Below this transmittance a ray stops (see the class comment).
constexpr double kTerminateTransmittance = 1e-9;

/// Trilinear reconstruction of level 0 at a voxel coordinate (voxel i's centre at i + ½), clamp-to-edge. The cell's
/// lower corner picks the brick, whose one-voxel border holds the upper corner, as on the GPU.
template <typename T>
class GridSampler {
 public:
  GridSampler(ReferenceBricks& bricks, const store::StoreMeta& meta)
      : mBricks(bricks), mDims(meta.dims), mBrick(meta.brickSize), mEdge(meta.brickSize + 2),
        mBrickGrid(meta.levels.at(0).bricks) {}

  double operator()(const glm::dvec3& p) const {
    int64_t brick[3], local[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
      const double u = std::clamp(p[a] - 0.5, 0.0, double(mDims[a] - 1));
      const int64_t i = std::min(int64_t(u), mDims[a] - 1);
      f[a] = u - double(i);
      brick[a] = i / mBrick;
      local[a] = i - brick[a] * mBrick + 1;
    }
    const store::BrickKey key{0, uint32_t(brick[0]), uint32_t(brick[1]), uint32_t(brick[2])};
    const size_t index = size_t(brick[0] + mBrickGrid.x * (brick[1] + mBrickGrid.y * brick[2]));
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
  store::Vec3i mDims;
  int64_t mBrick, mEdge;
  store::Vec3i mBrickGrid;
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

/// The ray parameters where a ray is inside an axis-aligned box; false if it misses.
bool clipToBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi, double& t0,
               double& t1) {
  t0 = -std::numeric_limits<double>::infinity();
  t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
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
  const store::StoreMeta* meta = nullptr;
  glm::dvec3 spacing{1}, dims{1}, halfDims{0.5}, boxMin{0}, boxMax{0};
  glm::dvec3 eye{0}, forward{0}, right{0}, up{0};
  double tanHalfFov = 0, halfHeight = 0, aspect = 1, nearPlane = 0;
  bool orthographic = false;
  double lo = 0, inverseWidth = 1;
  double step = 1;       // longest segment, world units
  double referenceLength = 1;
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
  const double sx = 2.0 * (x + 0.5) / width - 1.0;
  const double sy = 1.0 - 2.0 * (y + 0.5) / height;
  Ray ray;
  double tNear = 0;
  if (f.orthographic) {
    ray.origin = f.eye + sx * f.halfHeight * f.aspect * f.right + sy * f.halfHeight * f.up;
    ray.dir = f.forward;
    tNear = f.nearPlane;
  } else {
    ray.origin = f.eye;
    ray.dir = glm::normalize(f.forward + sx * f.tanHalfFov * f.aspect * f.right + sy * f.tanHalfFov * f.up);
    // The near plane is perpendicular to the view axis, so an oblique ray meets it further out.
    tNear = f.nearPlane / glm::dot(ray.dir, f.forward);
  }
  if (!clipToBox(ray.origin, ray.dir, f.boxMin, f.boxMax, ray.t0, ray.t1)) {
    ray.t0 = ray.t1 = 0;
    return ray;
  }
  ray.t0 = std::max(ray.t0, tNear);
  return ray;
}

/// Integrates one ray; returns its colour over the background and adds to the counters.
template <typename Sampler>
glm::dvec3 integrate(const Frame& f, const Sampler& sample, const Ray& ray, int64_t& samples, int64_t& skipped) {
  const Scene& scene = *f.scene;
  FrontToBack<double> acc;
  const double length = ray.t1 - ray.t0;
  if (length > 0) {
    const double segments = std::ceil(length / f.step);
    const int64_t n = int64_t(segments);
    const double h = length / segments;
    const double stepOverReference = h / f.referenceLength;
    for (int64_t k = 0; k < n; ++k) {
      const double t = ray.t0 + (double(k) + 0.5) * h;
      const glm::dvec3 world = ray.origin + t * ray.dir;
      const glm::dvec3 p = world / f.spacing + f.halfDims;
      if (!f.transparent.empty()) {
        glm::dvec3 lo, hi;
        int64_t index = 0, stride = 1;
        for (int a = 0; a < 3; ++a) {
          const int64_t b = std::clamp<int64_t>(int64_t(std::floor(p[a] / f.brickSize)), 0, f.brickGrid[a] - 1);
          index += b * stride;
          stride *= f.brickGrid[a];
          lo[a] = (double(b) * f.brickSize - f.halfDims[a]) * f.spacing[a];
          hi[a] = (std::min(double(b + 1) * f.brickSize, f.dims[a]) - f.halfDims[a]) * f.spacing[a];
        }
        if (f.transparent[size_t(index)]) {
          // Every midpoint before the ray leaves this brick's box samples only this brick (border included), whose
          // range is transparent: jump to the first midpoint past the exit.
          double exit = std::numeric_limits<double>::infinity();
          for (int a = 0; a < 3; ++a)
            if (ray.dir[a] != 0) exit = std::min(exit, ((ray.dir[a] > 0 ? hi[a] : lo[a]) - ray.origin[a]) / ray.dir[a]);
          const double next = std::ceil((exit - ray.t0) / h - 0.5);
          k = std::max(k, std::isfinite(next) ? int64_t(std::min(next, segments)) - 1 : n);
          skipped += 1;
          continue;
        }
      }
      samples += 1;
      const double value = sample(p);
      const glm::dvec4 c = scene.transferFunction.evaluate(std::clamp((value - f.lo) * f.inverseWidth, 0.0, 1.0));
      const double alpha = TransferFunction::correctOpacity(c.a, stepOverReference);
      if (alpha <= 0) continue;
      glm::dvec3 color(c);
      if (scene.shading) {
        const double ex = 0.5;
        glm::dvec3 gradient;
        for (int a = 0; a < 3; ++a) {
          glm::dvec3 d(0.0);
          d[a] = ex;
          gradient[a] = (sample(p + d) - sample(p - d)) / f.spacing[a];
        }
        const double magnitude = glm::length(gradient);
        if (magnitude > 1e-12) {
          const glm::dvec3 normal = -gradient / magnitude;
          const glm::dvec3 toEye = f.orthographic ? -f.forward : glm::normalize(f.eye - world);
          const double diffuse = std::abs(glm::dot(normal, toEye));
          const double specular = std::pow(diffuse, 32.0);
          color = color * (0.3 + 0.7 * diffuse) + glm::dvec3(0.25 * specular);
        }
      }
      acc.add(color.r, color.g, color.b, alpha);
      if (1 - acc.a < kTerminateTransmittance) break;
    }
  }
  const double t = 1 - std::clamp(acc.a, 0.0, 1.0);
  return glm::clamp(glm::dvec3(acc.r, acc.g, acc.b) + t * scene.background, 0.0, 1.0);
}

}  // namespace

ReferenceRenderer::ReferenceRenderer(std::shared_ptr<store::BrickCache> cache)
    : mCache(std::move(cache)), mBricks(std::make_unique<ReferenceBricks>(mCache)) {}

ReferenceRenderer::~ReferenceRenderer() = default;

ImageF ReferenceRenderer::render(const Scene& scene, const ReferenceOptions& options, ReferenceStats* statsOut) {
  const auto start = Clock::now();
  scene.validate();
  if (!(options.step >= 1e-4 && options.step <= 64))
    throw RenderInputError("ReferenceRenderer: step " + numberText(options.step) + " is outside [1e-4, 64] voxels");
  const store::BrickStore& store = *mCache->store();
  const store::StoreMeta& meta = store.meta();

  Frame f;
  f.scene = &scene;
  f.meta = &meta;
  const Box box = volumeBox(meta.dims, meta.spacing);
  f.boxMin = box.min;
  f.boxMax = box.max;
  for (int a = 0; a < 3; ++a) {
    f.spacing[a] = meta.spacing[a];
    f.dims[a] = double(meta.dims[a]);
  }
  f.halfDims = 0.5 * f.dims;

  const Camera camera = scene.camera.resolve(box);
  double farPlane = 0;
  camera.clipRange(box, f.nearPlane, farPlane);
  f.eye = camera.eye;
  f.forward = camera.viewDirection();
  f.up = camera.upVector();
  f.right = glm::normalize(glm::cross(f.forward, f.up));
  f.up = glm::cross(f.right, f.forward);
  f.orthographic = camera.orthographic;
  f.tanHalfFov = std::tan(0.5 * glm::radians(camera.fovYDegrees));
  f.halfHeight = camera.distance() * f.tanHalfFov;
  f.aspect = double(scene.width) / double(scene.height);

  // The value window exactly as the GPU renderer takes it.
  f.lo = scene.window ? (*scene.window)[0] : meta.valueMin;
  double hi = scene.window ? (*scene.window)[1] : meta.valueMax;
  if (!(hi > f.lo)) hi = f.lo + 1;
  f.inverseWidth = 1.0 / (hi - f.lo);

  const double minSpacing = std::min({meta.spacing.x, meta.spacing.y, meta.spacing.z});
  f.step = options.step * minSpacing;
  f.referenceLength = scene.transferFunction.referenceLength().value_or(minSpacing);

  if (!options.analytic && scene.skipEmpty) {
    const store::LevelMeta& level = meta.levels.at(0);
    f.brickGrid = level.bricks;
    f.brickSize = double(meta.brickSize);
    f.transparent.resize(size_t(level.bricksTotal()));
    for (int64_t k = 0; k < level.bricks.z; ++k)
      for (int64_t j = 0; j < level.bricks.y; ++j)
        for (int64_t i = 0; i < level.bricks.x; ++i) {
          const store::BrickRecord& r = store.record({0, uint32_t(i), uint32_t(j), uint32_t(k)});
          f.transparent[size_t(i + level.bricks.x * (j + level.bricks.y * k))] = !scene.transferFunction.contributes(
              (double(r.min) - f.lo) * f.inverseWidth, (double(r.max) - f.lo) * f.inverseWidth);
        }
  }

  ImageF image{scene.width, scene.height, std::vector<float>(size_t(scene.width) * size_t(scene.height) * 4)};
  std::atomic<int64_t> rays{0}, samples{0}, skipped{0};
  auto renderRows = [&](const auto& sampler) {
    tbb::parallel_for(tbb::blocked_range<int>(0, scene.height), [&](const tbb::blocked_range<int>& rows) {
      int64_t rowRays = 0, rowSamples = 0, rowSkipped = 0;
      for (int y = rows.begin(); y != rows.end(); ++y)
        for (int x = 0; x < scene.width; ++x) {
          const Ray ray = pixelRay(f, x, y, scene.width, scene.height);
          rowRays += ray.t1 > ray.t0 ? 1 : 0;
          const glm::dvec3 c = integrate(f, sampler, ray, rowSamples, rowSkipped);
          float* out = image.pixel(x, y);
          for (int ch = 0; ch < 3; ++ch) out[ch] = float(c[ch]);
          out[3] = 1;
        }
      rays += rowRays;
      samples += rowSamples;
      skipped += rowSkipped;
    });
  };
  if (options.analytic) {
    renderRows(AnalyticSampler(*options.analytic, meta));
  } else {
    store::dispatchType(meta.type, [&](auto zero) { renderRows(GridSampler<decltype(zero)>(*mBricks, meta)); });
  }

  if (statsOut) {
    statsOut->rays = rays;
    statsOut->samples = samples;
    statsOut->bricksSkipped = skipped;
    statsOut->ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  }
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
