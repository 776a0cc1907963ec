// The tetrahedral reference renderer: a BVH over the tets, exact Plücker ray–tet intersections with symbolic
// tie-breaking, segments composited with the exact segment integral.
#include "render/reference/TetReference.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "render/core/RenderErrors.h"
#include "render/core/SegmentIntegral.h"
#include "render/reference/Headlight.h"

namespace voxbrick::render {
namespace {

using Clock = std::chrono::steady_clock;

constexpr double kInfinity = std::numeric_limits<double>::infinity();
/// Below this transmittance a ray stops: the rest could change a pixel by less than this, far below float output.
constexpr double kTerminateTransmittance = 1e-15;
/// Tets per BVH leaf at most.
constexpr uint32_t kLeafTets = 4;
/// BVH boxes are grown by this much of the mesh's scale, so that the slab test's round-off never drops a tet the ray
/// touches (the exact test decides; a looser box only costs a test).
constexpr double kBoxPadding = 1e-9;

/// The six edges (i, j), i < j, of a tet in local vertex indices.
constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

struct BvhNode {
  glm::dvec3 lo{0.0}, hi{0.0};
  uint32_t first = 0;  ///< a leaf's first entry in the tet order; an inner node's second child (the first follows it)
  uint32_t count = 0;  ///< a leaf's tets; 0 for an inner node
};

/// The camera basis and projection of a frame, as ReferenceRenderer's makeFrame computes them.
struct View {
  RayBasis basis;
  int width = 1, height = 1;
};

int signOf(double v) { return v > 0 ? 1 : v < 0 ? -1 : 0; }

/// Side tests and their tie terms within this much of their scale are taken as exactly zero. Rounding makes a test
/// that is zero in exact arithmetic (a ray through an edge or in the plane of a face, as a camera on a symmetry plane
/// of the mesh gives) come out a few ulps either way, and the signs of several such tests in one tet need not fit any
/// line; as zeros they go to the tie rule, which decides them as for a line that meets those edges exactly, moved by
/// eps * right + eps^2 * up. That moves the ray by about 1e-12 of its distance to the vertex (more for an edge nearly
/// along the ray), far above round-off (about 1e-15 of it) and far below anything an image shows.
constexpr double kSnap = 1e-12;

/// The sign of the side test of edge a -> b (e = b - a) for the ray moved by eps * right + eps^2 * up (eps -> 0+),
/// where the test itself is zero. The test d . ((a - o) x (b - a)) changes by delta . ((a - b) x d) when the origin
/// moves by delta. Zero only for an edge parallel to the ray, which lies in faces the ray cannot cross (they then count
/// as missed, which is right: a ray parallel to a face never passes through it).
int tieSign(const TetRay& ray, const glm::dvec3& e) {
  const glm::dvec3 m = glm::cross(ray.direction, e);  // (a - b) x d
  const double tolerance = kSnap * glm::length(e);
  const double first = glm::dot(ray.right, m);
  if (std::abs(first) > tolerance) return signOf(first);
  const double second = glm::dot(ray.up, m);
  return std::abs(second) > tolerance ? signOf(second) : 0;
}

enum class Crossing { Miss, Segment, Ambiguous };

/// Whether the ray beyond tNear meets the box (slab test; `inverse` is 1 / direction).
bool meetsBox(const glm::dvec3& lo, const glm::dvec3& hi, const TetRay& ray, const glm::dvec3& inverse) {
  double t0 = ray.tNear, t1 = kInfinity;
  for (int a = 0; a < 3; ++a) {
    if (ray.direction[a] == 0) {
      if (ray.origin[a] < lo[a] || ray.origin[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - ray.origin[a]) * inverse[a], tb = (hi[a] - ray.origin[a]) * inverse[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

struct TetReference::Data {
  std::vector<glm::dvec3> points;
  std::vector<double> scalars;
  std::vector<mesh::Tet> tets;
  std::vector<int8_t> orientation;  ///< sign of each tet's volume; 0: flat, ignored
  std::vector<uint32_t> order;      ///< the non-flat tets, in BVH leaf order
  std::vector<Box> boxes;           ///< each tet's padded bounding box, in leaf order (tested before the tet)
  std::vector<BvhNode> nodes;
  Box bounds;
  bool hasBounds = false;

  void buildBvh();
  uint32_t buildNode(uint32_t first, uint32_t count, const std::vector<glm::dvec3>& lo,
                     const std::vector<glm::dvec3>& hi);
  Crossing cross(uint32_t tet, const TetRay& ray, TetSegment& out) const;
  void collect(const TetRay& ray, std::vector<TetSegment>& out, int64_t& tests, int64_t& ambiguous) const;
};

void TetReference::Data::buildBvh() {
  glm::dvec3 scale(0.0);
  if (hasBounds) scale = glm::max(glm::abs(bounds.min), glm::abs(bounds.max)) + bounds.extent();
  const double pad = kBoxPadding * std::max({scale.x, scale.y, scale.z});
  std::vector<glm::dvec3> lo(tets.size()), hi(tets.size());
  for (uint32_t t = 0; t < tets.size(); ++t) {
    if (orientation[t] == 0) continue;
    lo[t] = hi[t] = points[tets[t][0]];
    for (int i = 1; i < 4; ++i) {
      lo[t] = glm::min(lo[t], points[tets[t][i]]);
      hi[t] = glm::max(hi[t], points[tets[t][i]]);
    }
    lo[t] -= pad;
    hi[t] += pad;
    order.push_back(t);
  }
  if (order.empty()) return;
  buildNode(0, uint32_t(order.size()), lo, hi);
  for (uint32_t t : order) boxes.push_back({lo[t], hi[t]});
}

// Median split on the axis where the boxes' centres spread most: always halves, so the depth is log2(n / 4) whatever
// the mesh (coincident centres included).
uint32_t TetReference::Data::buildNode(uint32_t first, uint32_t count, const std::vector<glm::dvec3>& lo,
                                       const std::vector<glm::dvec3>& hi) {
  const uint32_t index = uint32_t(nodes.size());
  nodes.emplace_back();
  BvhNode node;
  node.lo = glm::dvec3(kInfinity);
  node.hi = glm::dvec3(-kInfinity);
  glm::dvec3 centreLo(kInfinity), centreHi(-kInfinity);
  for (uint32_t k = first; k < first + count; ++k) {
    const uint32_t t = order[k];
    node.lo = glm::min(node.lo, lo[t]);
    node.hi = glm::max(node.hi, hi[t]);
    centreLo = glm::min(centreLo, lo[t] + hi[t]);
    centreHi = glm::max(centreHi, lo[t] + hi[t]);
  }
  if (count <= kLeafTets) {
    node.first = first;
    node.count = count;
  } else {
    const glm::dvec3 spread = centreHi - centreLo;
    const int axis = spread.x >= spread.y && spread.x >= spread.z ? 0 : spread.y >= spread.z ? 1 : 2;
    const uint32_t half = count / 2;
    std::nth_element(order.begin() + first, order.begin() + first + half, order.begin() + first + count,
                     [&](uint32_t a, uint32_t b) { return lo[a][axis] + hi[a][axis] < lo[b][axis] + hi[b][axis]; });
    buildNode(first, half, lo, hi);
    node.first = buildNode(first + half, count - half, lo, hi);
  }
  nodes[index] = node;
  return index;
}

// Plücker side tests (Platis & Theoharis): the line meets face (a, b, c) iff its tests against the face's three
// edges, taken around the face, have one sign, and the sign says in which direction it crosses. Each edge's test is
// computed once, from its vertex of lower index to the higher, so every tet around an edge uses the same number, and
// a face's point from its vertices sorted by index, so both tets of a face compute the same point, bit for bit. The
// test is taken as d . ((a - o) x (b - a)) (equal to d . ((a - o) x (b - o))): its round-off is then about 1e-16 of
// |a - o| |b - a|, rather than of |a - o| |b - o|, which matters for a distant eye.
Crossing TetReference::Data::cross(uint32_t tet, const TetRay& ray, TetSegment& out) const {
  const mesh::Tet& v = tets[tet];
  glm::dvec3 q[4];
  for (int i = 0; i < 4; ++i) q[i] = points[v[i]] - ray.origin;
  double side[4][4];
  int sign[4][4];
  for (const auto& edge : kEdges) {
    const int a = v[edge[0]] < v[edge[1]] ? edge[0] : edge[1], b = edge[0] + edge[1] - a;
    const glm::dvec3 e = points[v[b]] - points[v[a]];
    double s = glm::dot(ray.direction, glm::cross(q[a], e));
    int g = signOf(s);
    if (s * s <= kSnap * kSnap * glm::dot(q[a], q[a]) * glm::dot(e, e)) s = 0, g = tieSign(ray, e);
    side[a][b] = s, side[b][a] = -s;
    sign[a][b] = g, sign[b][a] = -g;
  }
  int entries = 0, exits = 0;
  for (int i = 0; i < 4; ++i) {
    // The face opposite vertex i, sorted by vertex index; det(a, b, c, v_i) = parity * det(v0, v1, v2, v3).
    std::array<int, 3> f;
    for (int k = 0, n = 0; k < 4; ++k)
      if (k != i) f[size_t(n++)] = k;
    int parity = i % 2 == 1 ? 1 : -1;
    for (int pass = 0; pass < 2; ++pass)
      for (size_t k = 0; k + 1 < 3 - size_t(pass); ++k)
        if (v[f[k]] > v[f[k + 1]]) std::swap(f[k], f[k + 1]), parity = -parity;
    const int a = f[0], b = f[1], c = f[2];
    const int s = sign[a][b];
    if (s == 0 || sign[b][c] != s || sign[c][a] != s) continue;
    // Barycentric weights of the crossing point: each vertex's is the test of the opposite edge.
    const double wa = side[b][c], wb = side[c][a], wc = side[a][b];
    const double w = wa + wb + wc;
    if (w == 0) return Crossing::Ambiguous;
    const double t =
        (wa * glm::dot(q[a], ray.direction) + wb * glm::dot(q[b], ray.direction) + wc * glm::dot(q[c], ray.direction)) /
        w;
    const double value = (wa * scalars[v[a]] + wb * scalars[v[b]] + wc * scalars[v[c]]) / w;
    // Positive tests: the ray runs along the normal (b - a) x (c - a), which points into the tet iff
    // det(a, b, c, v_i) > 0.
    if ((s > 0) == (parity * orientation[tet] > 0)) {
      ++entries;
      out.t0 = t, out.value0 = value;
    } else {
      ++exits;
      out.t1 = t, out.value1 = value;
    }
  }
  if (entries == 0 && exits == 0) return Crossing::Miss;
  if (entries != 1 || exits != 1) return Crossing::Ambiguous;
  out.tet = tet;
  return Crossing::Segment;
}

void TetReference::Data::collect(const TetRay& ray, std::vector<TetSegment>& out, int64_t& tests,
                                 int64_t& ambiguous) const {
  out.clear();
  if (nodes.empty()) return;
  const glm::dvec3 inverse = 1.0 / ray.direction;
  uint32_t stack[64];
  int depth = 0;
  stack[depth++] = 0;
  while (depth > 0) {
    const BvhNode& node = nodes[stack[--depth]];
    if (!meetsBox(node.lo, node.hi, ray, inverse)) continue;
    if (node.count == 0) {
      stack[depth++] = node.first;
      stack[depth++] = uint32_t(&node - nodes.data()) + 1;
      continue;
    }
    for (uint32_t k = node.first; k < node.first + node.count; ++k) {
      if (!meetsBox(boxes[k].min, boxes[k].max, ray, inverse)) continue;
      ++tests;
      TetSegment segment;
      const Crossing crossing = cross(order[k], ray, segment);
      if (crossing == Crossing::Ambiguous) ++ambiguous;
      if (crossing != Crossing::Segment || !(segment.t1 > ray.tNear) || !(segment.t1 > segment.t0)) continue;
      if (segment.t0 < ray.tNear) {
        // The near plane cuts the tet: the scalar is linear along the segment.
        const double u = (ray.tNear - segment.t0) / (segment.t1 - segment.t0);
        segment.value0 += u * (segment.value1 - segment.value0);
        segment.t0 = ray.tNear;
      }
      out.push_back(segment);
    }
  }
  std::sort(out.begin(), out.end(),
            [](const TetSegment& x, const TetSegment& y) { return x.t0 != y.t0 ? x.t0 < y.t0 : x.t1 < y.t1; });
}

namespace {

View makeView(const TetReferenceParams& params, const Box& bounds, bool hasBounds) {
  double nearPlane = 0, farPlane = 0;
  if (hasBounds) params.camera.clipRange(bounds, nearPlane, farPlane);
  return {RayBasis::of(params.camera, double(params.width) / double(params.height), nearPlane), params.width,
          params.height};
}

/// ReferenceRenderer's pixel ray (RayBasis): through the pixel centre, from the near plane.
TetRay viewRay(const View& v, int x, int y) {
  TetRay ray;
  ray.right = v.basis.right;
  ray.up = v.basis.up;
  v.basis.pixelRay(x, y, v.width, v.height, ray.origin, ray.direction, ray.tNear);
  return ray;
}

/// What shading needs of the mesh: each tet's points and scalars.
struct TetGeometry {
  const std::vector<glm::dvec3>& points;
  const std::vector<double>& scalars;
  const std::vector<mesh::Tet>& tets;
};

/// The raw scalar's gradient in tet `t` (per world unit; zero for a flat tet): the g with g . (p_i - p_0) =
/// s_i - s_0 for the three edges from vertex 0.
glm::dvec3 tetGradient(const TetGeometry& g, uint32_t t) {
  const mesh::Tet& tet = g.tets[t];
  const glm::dvec3 p0 = g.points[tet[0]];
  const glm::dvec3 e1 = g.points[tet[1]] - p0, e2 = g.points[tet[2]] - p0, e3 = g.points[tet[3]] - p0;
  const double s0 = g.scalars[tet[0]];
  const double det = glm::dot(e1, glm::cross(e2, e3));
  if (det == 0) return glm::dvec3(0.0);
  return ((g.scalars[tet[1]] - s0) * glm::cross(e2, e3) + (g.scalars[tet[2]] - s0) * glm::cross(e3, e1) +
          (g.scalars[tet[3]] - s0) * glm::cross(e1, e2)) /
         det;
}

/// Premultiplied colour `c` and opacity `a` of a segment along `direction` (unit length) in a tet whose scalar has
/// `gradient`, shaded by the headlight (render/reference/Headlight.h): c x + y a.
glm::dvec3 shadeSegment(const glm::dvec3& c, double a, const glm::dvec3& gradient, const glm::dvec3& direction) {
  const double magnitude = glm::length(gradient);
  if (!(magnitude > 1e-12)) return c;
  const glm::dvec2 light = headlight(std::abs(glm::dot(gradient / magnitude, direction)));
  return c * light.x + glm::dvec3(light.y * a);
}

/// Front-to-back compositing of sorted segments: premultiplied colour and opacity (each segment shaded if asked).
glm::dvec4 composite(const std::vector<TetSegment>& segments, const TetReferenceParams& params,
                     const TetGeometry& geometry, const glm::dvec3& direction) {
  const double inverseWidth = 1.0 / (params.windowHi - params.windowLo);
  RaySpan sum;
  for (const TetSegment& s : segments) {
    glm::dvec4 c =
        integrateSegment(params.transferFunction, (s.value0 - params.windowLo) * inverseWidth,
                         (s.value1 - params.windowLo) * inverseWidth, (s.t1 - s.t0) / params.referenceLength);
    if (params.shading) c = glm::dvec4(shadeSegment(glm::dvec3(c), c.a, tetGradient(geometry, s.tet), direction), c.a);
    sum = over(sum, {glm::dvec3(c), 1 - c.a});
    if (sum.transmittance < kTerminateTransmittance) break;
  }
  return {sum.color, 1 - sum.transmittance};
}

}  // namespace

TetReferenceParams TetReferenceParams::fromScene(const Scene& scene, const mesh::TetMesh& mesh,
                                                 double defaultReferenceLength) {
  if (mesh.points.empty()) throw RenderInputError("TetReferenceParams::fromScene: the mesh has no points");
  TetMeshConstants constants;
  const auto [lo, hi] = mesh.bounds();
  constants.bounds = Box{glm::dvec3(lo), glm::dvec3(hi)};
  std::tie(constants.scalarMin, constants.scalarMax) = mesh.scalarRange();
  constants.meanEdgeLength = defaultReferenceLength;
  return fromScene(scene, constants);
}

TetReferenceParams TetReferenceParams::fromScene(const Scene& scene, const TetMeshConstants& constants) {
  scene.validate();
  // A mesh's points are in the world: the identity frame; the camera and the window as the GPU renderers take them.
  const TetView view = TetView::of(scene, constants);
  TetReferenceParams p;
  p.camera = view.camera;
  p.transferFunction = scene.transferFunction;
  p.width = scene.width;
  p.height = scene.height;
  p.background = scene.background;
  p.transparent = scene.transparent;
  p.shading = scene.shading;
  p.windowLo = view.windowLo;
  p.windowHi = view.windowHi;
  p.referenceLength = scene.transferFunction.referenceLength().value_or(constants.meanEdgeLength);
  p.validate();
  return p;
}

void TetReferenceParams::validate() const {
  const std::string what = "TetReferenceParams: ";
  camera.validate();
  if (width < 1 || height < 1 || width > Scene::kMaxImageSide || height > Scene::kMaxImageSide)
    throw RenderInputError(what + "image size " + std::to_string(width) + "x" + std::to_string(height) +
                           " is outside 1.." + std::to_string(Scene::kMaxImageSide) + " per side");
  if (!std::isfinite(windowLo) || !std::isfinite(windowHi) || !(windowHi > windowLo))
    throw RenderInputError(what + "window [" + numberText(windowLo) + ", " + numberText(windowHi) +
                           "] must be finite with hi > lo");
  if (!(referenceLength > 0) || !std::isfinite(referenceLength))
    throw RenderInputError(what + "reference length " + numberText(referenceLength) + " is not finite and positive");
  for (int c = 0; c < 3; ++c)
    if (!(background[c] >= 0 && background[c] <= 1))
      throw RenderInputError(what + "background component " + numberText(background[c]) + " is outside [0, 1]");
}

TetReference::TetReference(const mesh::TetMesh& mesh) : mData(std::make_unique<Data>()) {
  Data& d = *mData;
  if (mesh.scalars.size() != mesh.points.size())
    throw RenderInputError("TetReference: " + std::to_string(mesh.scalars.size()) + " scalars for " +
                           std::to_string(mesh.points.size()) + " points");
  d.points.assign(mesh.points.begin(), mesh.points.end());
  d.scalars.assign(mesh.scalars.begin(), mesh.scalars.end());
  d.tets = mesh.tets;
  d.orientation.resize(d.tets.size());
  for (size_t t = 0; t < d.tets.size(); ++t) {
    for (uint32_t index : d.tets[t])
      if (index >= d.points.size())
        throw RenderInputError("TetReference: tet " + std::to_string(t) + " names vertex " + std::to_string(index) +
                               " of " + std::to_string(d.points.size()));
    const glm::dvec3 p0 = d.points[d.tets[t][0]];
    const double volume =
        glm::dot(d.points[d.tets[t][1]] - p0, glm::cross(d.points[d.tets[t][2]] - p0, d.points[d.tets[t][3]] - p0));
    d.orientation[t] = int8_t(std::isfinite(volume) ? signOf(volume) : 0);
  }
  if (!mesh.points.empty()) {
    const auto [lo, hi] = mesh.bounds();
    d.bounds = Box{glm::dvec3(lo), glm::dvec3(hi)};
    d.hasBounds = d.bounds.radius() > 0 && std::isfinite(d.bounds.radius());
  }
  d.buildBvh();
}

TetReference::~TetReference() = default;
TetReference::TetReference(TetReference&&) noexcept = default;
TetReference& TetReference::operator=(TetReference&&) noexcept = default;

Box TetReference::bounds() const { return mData->bounds; }

TetRay TetReference::pixelRay(const TetReferenceParams& params, int x, int y) const {
  params.validate();
  return viewRay(makeView(params, mData->bounds, mData->hasBounds), x, y);
}

std::vector<TetSegment> TetReference::segments(const TetRay& ray, int64_t* ambiguous) const {
  std::vector<TetSegment> out;
  int64_t tests = 0, unclear = 0;
  mData->collect(ray, out, tests, unclear);
  if (ambiguous) *ambiguous += unclear;
  return out;
}

glm::dvec4 TetReference::integrate(const TetRay& ray, const TetReferenceParams& params) const {
  return composite(segments(ray), params, {mData->points, mData->scalars, mData->tets}, ray.direction);
}

image::ImageF TetReference::render(const TetReferenceParams& params, TetReferenceStats* statsOut) const {
  const auto start = Clock::now();
  params.validate();
  const View view = makeView(params, mData->bounds, mData->hasBounds);
  const TetGeometry geometry{mData->points, mData->scalars, mData->tets};
  image::ImageF image{params.width, params.height,
                      std::vector<float>(size_t(params.width) * size_t(params.height) * 4)};
  std::atomic<int64_t> rays{0}, segments{0}, tests{0}, ambiguous{0};
  tbb::parallel_for(tbb::blocked_range<int>(0, params.height), [&](const tbb::blocked_range<int>& rows) {
    int64_t rowRays = 0, rowSegments = 0, rowTests = 0, rowAmbiguous = 0;
    std::vector<TetSegment> found;
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < params.width; ++x) {
        const TetRay ray = viewRay(view, x, y);
        mData->collect(ray, found, rowTests, rowAmbiguous);
        rowRays += found.empty() ? 0 : 1;
        rowSegments += int64_t(found.size());
        const glm::dvec4 c = composite(found, params, geometry, ray.direction);
        const glm::dvec4 out = outputPixel(glm::dvec3(c), c.a, params.background, params.transparent);
        float* pixel = image.pixel(x, y);
        for (int ch = 0; ch < 4; ++ch) pixel[ch] = float(out[ch]);
      }
    rays += rowRays, segments += rowSegments, tests += rowTests, ambiguous += rowAmbiguous;
  });
  if (statsOut) {
    statsOut->rays = rays;
    statsOut->segments = segments;
    statsOut->tetTests = tests;
    statsOut->ambiguous = ambiguous;
    statsOut->ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  }
  return image;
}

image::ImageF renderTetReference(const mesh::TetMesh& mesh, const TetReferenceParams& params,
                                 TetReferenceStats* stats) {
  return TetReference(mesh).render(params, stats);
}

}  // namespace voxbrick::render
