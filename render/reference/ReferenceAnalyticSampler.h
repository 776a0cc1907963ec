// The reference renderer's sampling of a synthetic field itself, in place of the grid made from it.
#pragma once

#include <algorithm>

#include <glm/glm.hpp>

#include "brickstore/format/StoreMeta.h"
#include "brickstore/ingest/synthetic/SyntheticField.h"

namespace voxbrick::render::reference {

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

}  // namespace voxbrick::render::reference
