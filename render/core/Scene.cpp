// Scene JSON: the schema shared by `voxbrick render --scene` and the server's render requests.
#include "render/core/Scene.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "render/core/RenderErrors.h"
#include "render/core/TransferFunctionPresets.h"

namespace voxbrick::render {
namespace {

using nlohmann::json;

double number(const json& j, const std::string& key, const std::string& what) {
  if (!j.is_number()) throw RenderInputError(what + ": '" + key + "' must be a number");
  double v = j.get<double>();
  if (!std::isfinite(v)) throw RenderInputError(what + ": '" + key + "' must be finite");
  return v;
}

glm::dvec3 vec3(const json& j, const std::string& key, const std::string& what) {
  if (!j.is_array() || j.size() != 3) throw RenderInputError(what + ": '" + key + "' must be an array of 3 numbers");
  return {number(j[0], key, what), number(j[1], key, what), number(j[2], key, what)};
}

bool boolean(const json& j, const std::string& key, const std::string& what) {
  if (!j.is_boolean()) throw RenderInputError(what + ": '" + key + "' must be true or false");
  return j.get<bool>();
}

json toJson(const glm::dvec3& v) { return json::array({v.x, v.y, v.z}); }

void checkImageSize(int64_t width, int64_t height, const std::string& prefix) {
  if (width < 1 || height < 1 || width > Scene::kMaxImageSide || height > Scene::kMaxImageSide)
    throw RenderInputError(prefix + "image size " + std::to_string(width) + "x" + std::to_string(height) +
                           " is outside 1.." + std::to_string(Scene::kMaxImageSide) + " per side");
}

// The scene's "camera" object into `camera` (Scene::fromJson lists the keys and what is refused).
void parseCamera(const json& c, const std::string& what, CameraSpec& camera) {
  static const char* kCameraKeys[] = {"orbit", "fit", "up_axis", "view", "eye", "center", "up", "fov", "orthographic"};
  for (auto it = c.begin(); it != c.end(); ++it)
    if (std::find(std::begin(kCameraKeys), std::end(kCameraKeys), it.key()) == std::end(kCameraKeys))
      throw RenderInputError(what + ": unknown key 'camera." + it.key() +
                             "' (one of orbit, fit, up_axis, view, eye, "
                             "center, up, fov, orthographic)");
  if (c.contains("orbit") && c.contains("eye")) throw RenderInputError(what + ": 'camera' has both 'orbit' and 'eye'");
  for (const char* key : {"center", "up"})
    if (c.contains(key) && !c.contains("eye"))
      throw RenderInputError(what + ": 'camera." + key +
                             "' needs 'camera.eye' (an orbit or view looks at the "
                             "volume's centre with its up axis)");
  if (c.contains("view")) {
    for (const char* key : {"orbit", "eye", "up_axis"})
      if (c.contains(key))
        throw RenderInputError(what + ": 'camera.view' cannot be combined with 'camera." + key + "'");
    if (!c["view"].is_string()) throw RenderInputError(what + ": 'camera.view' must be a string");
    camera.setView(c["view"].get<std::string>(), what + ": 'camera.view'");
  }
  if (c.contains("orbit")) {
    const json& o = c["orbit"];
    if (!o.is_array() || (o.size() != 2 && o.size() != 3))
      throw RenderInputError(what + ": 'camera.orbit' must be [az, el] or [az, el, dist]");
    camera.orbit = true;
    camera.azimuth = number(o[0], "camera.orbit", what), camera.elevation = number(o[1], "camera.orbit", what);
    camera.distance = std::nullopt;
    if (o.size() == 3) camera.distance = number(o[2], "camera.orbit", what);
  }
  if (c.contains("up_axis")) {
    if (!c["up_axis"].is_string()) throw RenderInputError(what + ": 'camera.up_axis' must be a string");
    camera.upAxis = parseUpAxis(c["up_axis"].get<std::string>(), what + ": 'camera.up_axis'");
  }
  if (c.contains("eye")) {
    if (c.contains("fit") || c.contains("up_axis"))
      throw RenderInputError(what + ": 'camera.fit' and 'camera.up_axis' apply to an orbit, not to 'camera.eye'");
    camera.orbit = false;
    camera.eye = vec3(c["eye"], "camera.eye", what);
    camera.center = c.contains("center") ? vec3(c["center"], "camera.center", what) : glm::dvec3(0);
    camera.up = c.contains("up") ? vec3(c["up"], "camera.up", what) : glm::dvec3(0, 1, 0);
  }
  // "fit": true asks for the fitted distance over the orbit's; false only confirms a distance.
  if (c.contains("fit") && boolean(c["fit"], "camera.fit", what)) camera.distance = std::nullopt;
  if (c.contains("fit") && !c["fit"].get<bool>() && !camera.distance)
    throw RenderInputError(what + ": 'camera.fit' false needs a distance: 'orbit': [az, el, dist]");
  if (c.contains("fov")) camera.fovY = number(c["fov"], "camera.fov", what);
  if (c.contains("orthographic")) camera.orthographic = boolean(c["orthographic"], "camera.orthographic", what);
}

}  // namespace

const char* const kQualityChosenKeys[7] = {"step", "raycast", "slab", "ert", "pre_integration", "sub_block", "lod"};

const char* slicerName(Slicer slicer) {
  switch (slicer) {
    case Slicer::Vertex: return "vertex";
    case Slicer::Cpu: return "cpu";
    case Slicer::VertexLean: return "vertex-lean";
    case Slicer::Geometry: return "geometry";
    case Slicer::VertexGeometry: return "vertex-geometry";
  }
  return "?";
}

const char* tetSortName(TetSort sort) {
  switch (sort) {
    case TetSort::Mpvo: return "mpvo";
    case TetSort::Centroid: return "centroid";
    case TetSort::Ray: return "raycast";
  }
  return "?";
}

TetSort parseTetSort(const std::string& name, const std::string& what) {
  for (TetSort sort : {TetSort::Mpvo, TetSort::Centroid, TetSort::Ray})
    if (name == tetSortName(sort)) return sort;
  throw RenderInputError(what + " must be \"mpvo\", \"centroid\" or \"raycast\"");
}

std::string slicerNames() {
  std::string names;
  for (Slicer slicer : kSlicers) names += std::string(names.empty() ? "" : ", ") + "\"" + slicerName(slicer) + "\"";
  return names;
}

Slicer parseSlicer(const std::string& name, const std::string& what) {
  for (Slicer slicer : kSlicers)
    if (name == slicerName(slicer)) return slicer;
  throw RenderInputError(what + ": unknown slicer '" + name + "' (one of " + slicerNames() + ")");
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

namespace {

/// The scene object of JSON `text`, its keys checked.
json sceneObject(const std::string& text, const std::string& what) {
  // The JSON parser stops at a NUL as at the end of the text: what follows one would be ignored, not refused.
  if (const size_t nul = text.find('\0'); nul != std::string::npos)
    throw RenderInputError(what + ": not valid JSON (a NUL byte at offset " + std::to_string(nul) + ")");
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw RenderInputError(what + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object()) throw RenderInputError(what + ": a scene must be a JSON object");
  static const char* kKeys[] = {"camera",      "size",          "transfer_function", "step",
                                "background",  "window",        "skip_empty",        "cull",
                                "slicer",      "shading",       "sub_block",         "slab",
                                "raycast",     "ert",           "pre_integration",   "ess",
                                "lod",         "progressive",   "visibility",        "quality",
                                "interactive", "time_budget_ms", "jpeg_quality", "provisional_encoding"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (std::find(std::begin(kKeys), std::end(kKeys), it.key()) == std::end(kKeys))
      throw RenderInputError(what + ": unknown key '" + it.key() + "'");
  return j;
}

/// 'size': [width, height].
void parseSize(const json& z, const std::string& what, Scene& s) {
  if (!z.is_array() || z.size() != 2 || !z[0].is_number_integer() || !z[1].is_number_integer())
    throw RenderInputError(what + ": 'size' must be [width, height] integers");
  const int64_t w = z[0].get<int64_t>(), h = z[1].get<int64_t>();
  // Checked before narrowing to int, so that 2^32 + 512 is refused, not read as 512.
  checkImageSize(w, h, what + ": 'size': ");
  s.width = int(w);
  s.height = int(h);
}

/// 'transfer_function': a preset name (or with `allowPaths` a file), or an inline object.
void parseTransferFunction(const json& t, const std::string& what, bool allowPaths,
                           const TransferFunctionPresets* presets, Scene& s) {
  if (t.is_string()) {
    s.transferFunctionName = t.get<std::string>();
    if (!allowPaths && !TransferFunction::isPresetName(s.transferFunctionName))
      throw RenderInputError(what +
                             ": 'transfer_function' must be a preset name (letters, digits, '-', '_') or "
                             "an inline object; paths are not accepted here");
    s.transferFunction =
        presets ? presets->get(s.transferFunctionName) : TransferFunction::load(s.transferFunctionName);
  } else if (t.is_object()) {
    s.transferFunctionName = "inline";
    s.transferFunction = TransferFunction::parse(t.dump(), what + ": transfer_function");
  } else {
    throw RenderInputError(what + ": 'transfer_function' must be a preset name, a path or an object");
  }
}

/// 'sub_block': 0 or a power of two up to Scene::kMaxSubBlock.
int subBlockSize(const json& value, const std::string& what) {
  const double v = number(value, "sub_block", what);
  if (!(v >= 0 && v <= Scene::kMaxSubBlock) || v != std::floor(v))
    throw RenderInputError(what + ": 'sub_block' must be 0 or a power of two up to " +
                           std::to_string(Scene::kMaxSubBlock));
  return int(v);
}

/// 'quality', which chooses kQualityChosenKeys and so appears without them.
QualityTarget qualityTarget(const json& j, const std::string& what) {
  if (!j["quality"].is_string()) throw RenderInputError(what + ": 'quality' must be a string like \"psnr:40\"");
  for (const char* key : kQualityChosenKeys)
    if (j.contains(key))
      throw RenderInputError(what + ": 'quality' chooses '" + key +
                             "' from the dataset's quality table; give "
                             "one or the other");
  return QualityTarget::parse(j["quality"].get<std::string>(), what + ": 'quality'");
}

/// 'jpeg_quality': an integer in [1, 100].
int parseJpegQuality(const json& value, const std::string& what) {
  if (!value.is_number_integer() || value.get<int64_t>() < 1 || value.get<int64_t>() > 100)
    throw RenderInputError(what + ": 'jpeg_quality' must be an integer in [1, 100]");
  return int(value.get<int64_t>());
}

/// 'provisional_encoding': one of Scene::kEncodingNames.
std::string parseEncodingName(const json& value, const std::string& what) {
  const auto& names = Scene::kEncodingNames;
  if (value.is_string() && std::find(std::begin(names), std::end(names), value.get<std::string>()) != std::end(names))
    return value.get<std::string>();
  throw RenderInputError(what + ": 'provisional_encoding' must be one of \"raw\", \"png\", \"zstd\", \"jpeg\"");
}

}  // namespace

Scene Scene::fromJson(const std::string& text, const std::string& what, bool allowPaths) {
  return parse(text, what, allowPaths, nullptr);
}

Scene Scene::fromJson(const std::string& text, const std::string& what, const TransferFunctionPresets& presets) {
  return parse(text, what, false, &presets);
}

Scene Scene::parse(const std::string& text, const std::string& what, bool allowPaths,
                   const TransferFunctionPresets* presets) {
  const json j = sceneObject(text, what);

  Scene s;
  if (j.contains("camera")) {
    const json& c = j["camera"];
    if (!c.is_object()) throw RenderInputError(what + ": 'camera' must be an object");
    parseCamera(c, what, s.camera);
  }
  if (j.contains("size")) parseSize(j["size"], what, s);
  if (j.contains("transfer_function")) parseTransferFunction(j["transfer_function"], what, allowPaths, presets, s);
  if (j.contains("step")) s.step = number(j["step"], "step", what);
  if (j.contains("background")) {
    s.transparent = j["background"] == "none";
    if (!s.transparent) s.background = vec3(j["background"], "background", what);
  }
  if (j.contains("window")) {
    const json& w = j["window"];
    if (!w.is_array() || w.size() != 2) throw RenderInputError(what + ": 'window' must be [lo, hi]");
    s.window = std::array<double, 2>{number(w[0], "window", what), number(w[1], "window", what)};
  }
  if (j.contains("skip_empty")) s.skipEmpty = boolean(j["skip_empty"], "skip_empty", what);
  if (j.contains("cull")) s.cullFrustum = boolean(j["cull"], "cull", what);
  if (j.contains("slicer")) {
    const json& sl = j["slicer"];
    if (!sl.is_string()) throw RenderInputError(what + ": 'slicer' must be one of " + slicerNames());
    s.slicer = parseSlicer(sl.get<std::string>(), what + ": 'slicer'");
  }
  if (j.contains("visibility")) {
    const json& v = j["visibility"];
    s.visibility = parseTetSort(v.is_string() ? v.get<std::string>() : "", what + ": 'visibility'");
  }
  if (j.contains("shading")) s.shading = boolean(j["shading"], "shading", what);
  if (j.contains("sub_block")) s.subBlock = subBlockSize(j["sub_block"], what);
  if (j.contains("slab")) {
    const double v = number(j["slab"], "slab", what);
    if (!(v >= 0 && v <= kMaxSlab) || v != std::floor(v))
      throw RenderInputError(what + ": 'slab' must be 0 (slicing) or a whole number of planes up to " +
                             std::to_string(kMaxSlab));
    s.slab = int(v);
    s.raycast = false;  // a slab size asks for slicing or slabs, unless 'raycast' says otherwise
  }
  if (j.contains("raycast")) s.raycast = boolean(j["raycast"], "raycast", what);
  if (j.contains("ert")) s.ert = number(j["ert"], "ert", what);
  if (j.contains("pre_integration")) s.preIntegration = boolean(j["pre_integration"], "pre_integration", what);
  if (j.contains("ess")) s.ess = boolean(j["ess"], "ess", what);
  if (j.contains("lod")) s.lod = number(j["lod"], "lod", what);
  if (j.contains("progressive")) s.progressive = boolean(j["progressive"], "progressive", what);
  if (j.contains("interactive")) s.interactive = boolean(j["interactive"], "interactive", what);
  if (j.contains("time_budget_ms")) s.timeBudgetMs = number(j["time_budget_ms"], "time_budget_ms", what);
  if (j.contains("quality")) s.quality = qualityTarget(j, what);
  if (j.contains("jpeg_quality")) s.jpegQuality = parseJpegQuality(j["jpeg_quality"], what);
  if (j.contains("provisional_encoding")) s.provisionalEncoding = parseEncodingName(j["provisional_encoding"], what);
  s.validate();
  return s;
}

void Scene::validate() const {
  checkImageSize(width, height, "");
  if (!(step >= 1e-3 && step <= 64))
    throw RenderInputError("step " + std::to_string(step) + " is outside [0.001, 64] voxels");
  for (int c = 0; c < 3; ++c)
    if (!(background[c] >= 0 && background[c] <= 1)) throw RenderInputError("background components must be in [0, 1]");
  if (window && !((*window)[1] > (*window)[0]))
    throw RenderInputError("window [" + std::to_string((*window)[0]) + ", " + std::to_string((*window)[1]) +
                           "] must have hi > lo");
  if (!(camera.fovY > 0 && camera.fovY <= 179)) throw RenderInputError("fov must be in (0, 179] degrees");
  if (slab < 0 || slab > kMaxSlab)
    throw RenderInputError("slab " + std::to_string(slab) + " must be 0 (slicing) or 1.." + std::to_string(kMaxSlab) +
                           " planes");
  if (!(ert == 0 || (ert >= 0.5 && ert <= 1)))
    throw RenderInputError("ert " + std::to_string(ert) +
                           " must be 0 (no early ray termination) or a threshold in "
                           "[0.5, 1]");
  if (!(lod >= 0 && lod <= kMaxLod))
    throw RenderInputError("lod " + std::to_string(lod) +
                           " must be 0 (level 0 everywhere) or a number of pixels up to " +
                           std::to_string(int(kMaxLod)));
  if (!(timeBudgetMs >= kMinTimeBudgetMs && timeBudgetMs <= kMaxTimeBudgetMs))
    throw RenderInputError("time_budget_ms " + std::to_string(timeBudgetMs) + " is outside [" +
                           numberText(kMinTimeBudgetMs) + ", " + numberText(kMaxTimeBudgetMs) + "] ms");
  if (subBlock != 0 && (subBlock < 2 || subBlock > kMaxSubBlock || (subBlock & (subBlock - 1)) != 0))
    throw RenderInputError("sub-block " + std::to_string(subBlock) +
                           " must be 0 (whole bricks) or a power of two in "
                           "[2, " +
                           std::to_string(kMaxSubBlock) + "]");
}

glm::dvec4 outputPixel(const glm::dvec3& c, double a, const glm::dvec3& background, bool transparent) {
  a = std::clamp(a, 0.0, 1.0);
  if (!transparent) return {glm::clamp(c + (1 - a) * background, 0.0, 1.0), 1.0};
  if (a <= 0) return glm::dvec4(0);
  return {glm::clamp(c / a, 0.0, 1.0), a};
}

glm::dvec4 Scene::output(const glm::dvec3& c, double a) const { return outputPixel(c, a, background, transparent); }

std::string Scene::toJson() const {
  json cam = {{"fov", camera.fovY}, {"orthographic", camera.orthographic}};
  if (camera.orbit)
    cam["orbit"] = camera.distance ? json::array({camera.azimuth, camera.elevation, *camera.distance})
                                   : json::array({camera.azimuth, camera.elevation}),
    cam["up_axis"] = upAxisName(camera.upAxis);
  else
    cam["eye"] = render::toJson(camera.eye), cam["center"] = render::toJson(camera.center),
    cam["up"] = render::toJson(camera.up);
  json points = json::array();
  for (const auto& p : transferFunction.points()) points.push_back({p.x, p.rgba.r, p.rgba.g, p.rgba.b, p.rgba.a});
  json tf = {{"points", points}};
  if (transferFunction.referenceLength()) tf["reference_length"] = *transferFunction.referenceLength();
  json j = {{"camera", cam},
            {"size", {width, height}},
            {"transfer_function", tf},
            {"step", step},
            {"background", transparent ? json("none") : render::toJson(background)},
            {"skip_empty", skipEmpty},
            {"cull", cullFrustum},
            {"slicer", slicerName(slicer)},
            {"shading", shading},
            {"sub_block", subBlock},
            {"slab", slab},
            {"raycast", raycast},
            {"ert", ert},
            {"pre_integration", preIntegration},
            {"ess", ess},
            {"lod", lod},
            {"progressive", progressive},
            {"visibility", tetSortName(visibility)}};
  if (window) j["window"] = json::array({(*window)[0], (*window)[1]});
  if (jpegQuality) j["jpeg_quality"] = *jpegQuality;
  if (provisionalEncoding) j["provisional_encoding"] = *provisionalEncoding;
  if (interactive) j["interactive"] = true, j["time_budget_ms"] = timeBudgetMs;
  if (quality) {
    // The target stands for the settings it chooses, so that the JSON reads back.
    for (const char* key : kQualityChosenKeys) j.erase(key);
    j["quality"] = quality->text();
  }
  return j.dump(2);
}

}  // namespace voxbrick::render
