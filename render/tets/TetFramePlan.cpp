// A mesh frame's plan: what it decides before any tet is paged, sorted or drawn.
#include "render/tets/TetFramePlan.h"

#include <cmath>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

bool beyondNearPlane(const Box& box, const Camera& camera, double nearPlane) {
  const glm::dvec3 d = camera.viewDirection();
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 corner{(c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y,
                            (c & 4) ? box.max.z : box.min.z};
    if (glm::dot(corner - camera.eye, d) < nearPlane) return false;
  }
  return true;
}

TetFramePlan planTetFrame(const Scene& scene, const TetMeshConstants& constants, const FrameOptions& options) {
  scene.validate();
  TetFramePlan plan;
  plan.view = TetView::of(scene, constants);
  // World centred on the box, as the vertices are.
  const glm::dvec3 centre = constants.bounds.center();
  plan.viewProj = plan.view.clipFromWorld * glm::translate(glm::dmat4(1.0), centre);
  plan.pixels = pixelRays(plan.viewProj, scene.width, scene.height);
  plan.width = scene.width;
  plan.height = scene.height;
  if (options.mode == RenderMode::Points)
    throw RenderInputError("a tet mesh has no slices to draw as points (RenderMode::Points)");
  plan.nullFragment = options.mode == RenderMode::Roofline;
  plan.rayCast = scene.visibility == TetSort::Ray && !plan.nullFragment &&
                 beyondNearPlane(constants.bounds, plan.view.camera, plan.view.nearPlane);
  plan.reference = scene.transferFunction.referenceLength().value_or(constants.meanEdgeLength);
  plan.maxSamples = options.maxSamples;
  return plan;
}

void TetFramePlan::checkCost(double samplesEstimated, size_t tets) const {
  if (maxSamples > 0 && samplesEstimated > maxSamples)
    throw RenderLimitError("the mesh frame would take about " + numberText(std::round(samplesEstimated / 1e6)) +
                           " million fragments' work (" + std::to_string(tets) + " tets), above the limit of " +
                           numberText(maxSamples / 1e6) +
                           " million samples; ask for a smaller image or a view with less of the mesh");
}

}  // namespace voxbrick::render
