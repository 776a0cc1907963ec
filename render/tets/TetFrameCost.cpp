// A mesh frame's estimated cost: each tet's projected bounding box.
#include "render/tets/TetFrameCost.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace voxbrick::render {

double TetFrameCost::estimate(const TetMeshData& data, const TetFramePlan& plan, const std::vector<uint8_t>& drawn,
                              size_t vertexStages) {
  // Each point projected once (window coordinates; points at or behind the eye plane marked), then per tet to be
  // drawn the pixels of its projection's bounding box inside the window: a tet with a point behind the eye plane may
  // cover the window.
  const mesh::TetMesh& m = data.mesh;
  const glm::dvec3 centre = data.bounds.center();
  const glm::dmat4& viewProj = plan.viewProj;
  const int width = plan.width, height = plan.height;
  mProjected.resize(m.points.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, m.points.size(), 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const glm::dvec4 clip = viewProj * glm::dvec4(glm::dvec3(m.points[i]) - centre, 1.0);
      mProjected[i] = clip.w > 1e-12
                          ? glm::vec3((clip.x / clip.w + 1) * 0.5 * width, (clip.y / clip.w + 1) * 0.5 * height, 1.0f)
                          : glm::vec3(0.0f);
    }
  });
  const double window = double(width) * double(height);
  // In mesh order (`drawn`: the tets of the frame), where neighbouring tets share points.
  const double fragments = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, m.tets.size(), 16384), 0.0,
      [&](const tbb::blocked_range<size_t>& r, double sum) {
        for (size_t t = r.begin(); t != r.end(); ++t) {
          if (!drawn[t]) continue;
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

}  // namespace voxbrick::render
