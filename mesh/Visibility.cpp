// MPVO and the centroid sort.
#include "mesh/Visibility.h"

#include <algorithm>
#include <chrono>
#include <queue>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

namespace voxbrick::mesh {
namespace {

using Clock = std::chrono::steady_clock;

/// The sort key of a point: its distance from the eye, or its depth along the view for an orthographic view.
double depthOf(const glm::dvec3& p, const ViewPoint& view) {
  return view.orthographic ? glm::dot(p - view.eye, view.direction) : glm::length(p - view.eye);
}

std::vector<double> centroidDepths(const TetMesh& mesh, const ViewPoint& view) {
  std::vector<double> depth(mesh.tets.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.tets.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      glm::dvec3 c(0.0);
      for (uint32_t v : mesh.tets[t]) c += glm::dvec3(mesh.points[v]);
      depth[t] = depthOf(0.25 * c, view);
    }
  });
  return depth;
}

/// Whether tet `t` lies in front of its neighbour across face `f` (+1), behind it (-1), or neither (0: the face is
/// seen edge on). Computed from the face's vertices in index order, so both tets of a face get opposite answers.
int inFront(const TetMesh& mesh, uint32_t t, int f, const ViewPoint& view) {
  const Tet& tet = mesh.tets[t];
  uint32_t face[3] = {tet[(f + 1) & 3], tet[(f + 2) & 3], tet[(f + 3) & 3]};
  std::sort(face, face + 3);
  const glm::dvec3 a(mesh.points[face[0]]), b(mesh.points[face[1]]), c(mesh.points[face[2]]);
  const glm::dvec3 n = glm::cross(b - a, c - a);
  const double eyeSide = view.orthographic ? -glm::dot(n, view.direction) : glm::dot(n, view.eye - a);
  const double mySide = glm::dot(n, glm::dvec3(mesh.points[tet[f]]) - a);
  if (eyeSide == 0 || mySide == 0) return 0;
  return (eyeSide > 0) == (mySide > 0) ? 1 : -1;
}

}  // namespace

void centroidOrder(const TetMesh& mesh, const ViewPoint& view, std::vector<uint32_t>& order, VisibilityStats* stats) {
  const auto start = Clock::now();
  const std::vector<double> depth = centroidDepths(mesh, view);
  order.resize(mesh.tets.size());
  for (size_t t = 0; t < order.size(); ++t) order[t] = uint32_t(t);
  tbb::parallel_sort(order.begin(), order.end(),
                     [&](uint32_t a, uint32_t b) { return depth[a] < depth[b] || (depth[a] == depth[b] && a < b); });
  if (stats) {
    *stats = {};
    stats->ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  }
}

void mpvoOrder(const TetMesh& mesh, const Topology& topology, const ViewPoint& view, std::vector<uint32_t>& order,
               VisibilityStats* stats) {
  const auto start = Clock::now();
  const size_t n = mesh.tets.size();
  // Per tet: how many neighbours lie in front of it, and which of its faces lead to a neighbour behind it.
  std::vector<uint8_t> waiting(n), behindMask(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      uint8_t count = 0, mask = 0;
      for (int f = 0; f < 4; ++f) {
        if (topology.neighbours[t][f] == Topology::kBoundary) continue;
        const int side = inFront(mesh, uint32_t(t), f, view);
        if (side < 0) ++count;
        if (side > 0) mask |= uint8_t(1u << f);
      }
      waiting[t] = count;
      behindMask[t] = mask;
    }
  });
  const std::vector<double> depth = centroidDepths(mesh, view);
  // Free tets, nearest first.
  auto nearer = [&](uint32_t a, uint32_t b) { return depth[a] > depth[b] || (depth[a] == depth[b] && a > b); };
  std::priority_queue<uint32_t, std::vector<uint32_t>, decltype(nearer)> ready(nearer);
  VisibilityStats local;
  for (size_t t = 0; t < n; ++t)
    if (waiting[t] == 0) ready.push(uint32_t(t));
  local.sources = ready.size();
  // For breaking cycles: every tet by depth, and how far the nearest unplaced one is along that list.
  std::vector<uint32_t> byDepth;
  size_t nextByDepth = 0;
  std::vector<uint8_t> placed(n, 0);
  order.clear();
  order.reserve(n);
  while (order.size() < n) {
    if (ready.empty()) {
      if (byDepth.empty()) {
        byDepth.resize(n);
        for (size_t t = 0; t < n; ++t) byDepth[t] = uint32_t(t);
        tbb::parallel_sort(byDepth.begin(), byDepth.end(), [&](uint32_t a, uint32_t b) {
          return depth[a] < depth[b] || (depth[a] == depth[b] && a < b);
        });
      }
      while (placed[byDepth[nextByDepth]]) ++nextByDepth;
      ready.push(byDepth[nextByDepth]);
      waiting[byDepth[nextByDepth]] = 0;
      ++local.cyclesBroken;
    }
    const uint32_t t = ready.top();
    ready.pop();
    if (placed[t]) continue;  // a tet forced out of a cycle may also become free later
    placed[t] = 1;
    order.push_back(t);
    for (int f = 0; f < 4; ++f) {
      if (!(behindMask[t] & (1u << f))) continue;
      const uint32_t next = uint32_t(topology.neighbours[t][f]);
      if (!placed[next] && waiting[next] > 0 && --waiting[next] == 0) ready.push(next);
    }
  }
  local.ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  if (stats) *stats = local;
}

}  // namespace voxbrick::mesh
