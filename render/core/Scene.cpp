// The scene: names of slicers, ray casters, orders and views, the camera as a user gives it, and the scene's reading, checking
// and writing through its schema (SceneSchema.cpp).
#include "render/core/Scene.h"

#include <algorithm>

#include "render/core/RenderErrors.h"
#include "render/core/SceneSchema.h"

namespace voxbrick::render {

const char* const kQualityChosenKeys[7] = {"step", "raycast", "slab", "ert", "pre_integration", "sub_block", "lod"};

TetSort parseTetSort(const std::string& name, const std::string& what) {
  return common::parseName<TetSort, RenderInputError>(name, "visibility order", what);
}

Slicer parseSlicer(const std::string& name, const std::string& what) {
  return common::parseName<Slicer, RenderInputError>(name, "slicer", what);
}

RayCaster parseRayCaster(const std::string& name, const std::string& what) {
  return common::parseName<RayCaster, RenderInputError>(name, "ray caster", what);
}

ResidencyMode parseResidencyMode(const std::string& name, const std::string& what) {
  return common::parseName<ResidencyMode, RenderInputError>(name, "residency mode", what);
}

namespace {

struct NamedView {
  const char* name;
  double azimuth, elevation;
};
// The table of CameraSpec::setView.
constexpr NamedView kViews[] = {{"anterior", 0, 0}, {"posterior", 180, 0}, {"left", 90, 0},
                                {"right", 270, 0},  {"superior", 180, 90}, {"inferior", 0, -90}};

}  // namespace

std::vector<std::string> viewNameList() {
  std::vector<std::string> names;
  for (const NamedView& v : kViews) names.emplace_back(v.name);
  return names;
}

std::string viewNames() {
  std::string names;
  for (const NamedView& v : kViews) names += std::string(names.empty() ? "" : ", ") + v.name;
  return names;
}

void CameraSpec::setView(const std::string& name, const std::string& what) {
  for (const NamedView& v : kViews) {
    if (name != v.name) continue;
    orbit = true;
    azimuth = v.azimuth, elevation = v.elevation;
    upAxis = UpAxis::PosZ;
    return;
  }
  throw RenderInputError(what + ": unknown view '" + name + "' (one of " + viewNames() + ")");
}

Camera CameraSpec::resolve(const Box& localBox, const WorldFrame& frame, double aspect) const {
  Camera c;
  if (orbit) {
    // The world orbit about the box's centre, built in the local frame from the world axes turned into it: the
    // same camera, and for an identity rotation the same floats as an orbit of the local box.
    const OrbitAxes world = OrbitAxes::of(upAxis);
    const OrbitAxes axes{frame.directionToLocal(world.up), frame.directionToLocal(world.front),
                         frame.directionToLocal(world.side)};
    const double d =
        distance ? *distance * localBox.radius() : Camera::fitDistance(localBox.radius(), fovY, aspect, orthographic);
    c = Camera::orbitAt(azimuth, elevation, d, localBox, axes);
  } else {
    c.eye = frame.pointToLocal(eye);
    c.center = frame.pointToLocal(center);
    c.up = frame.directionToLocal(up);
  }
  c.fovYDegrees = fovY;
  c.orthographic = orthographic;
  c.validate();
  return c;
}

Scene Scene::fromJson(const std::string& text, const std::string& what, bool allowPaths) {
  return sceneFromKeys(sceneKeysOf(text, what), SceneNames::of(what), allowPaths);
}

Scene Scene::fromJson(const std::string& text, const std::string& what, const TransferFunctionPresets& presets) {
  return sceneFromKeys(sceneKeysOf(text, what), SceneNames::of(what), false, &presets);
}

void Scene::validate() const { checkSceneValues(*this); }

std::string Scene::toJson() const { return sceneJson(*this).dump(2); }

glm::dvec4 outputPixel(const glm::dvec3& c, double a, const glm::dvec3& background, bool transparent) {
  a = std::clamp(a, 0.0, 1.0);
  if (!transparent) return {glm::clamp(c + (1 - a) * background, 0.0, 1.0), 1.0};
  if (a <= 0) return glm::dvec4(0);
  return {glm::clamp(c / a, 0.0, 1.0), a};
}

glm::dvec4 SceneView::output(const glm::dvec3& c, double a) const { return outputPixel(c, a, background, transparent); }

}  // namespace voxbrick::render
