// The scene's schema: the table of keys, their checks, the rules between them, reading, layering and writing.
#include "render/core/SceneSchema.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <type_traits>

#include "common/Names.h"
#include "render/core/RenderErrors.h"
#include "render/core/TransferFunctionPresets.h"

namespace voxbrick::render {
namespace {

using nlohmann::json;

/// A number as a person writes it: a whole number in full ("100000", not "1e+05"), another as it reads back.
std::string plainNumber(double v) {
  if (v == std::floor(v) && std::fabs(v) < 1e15) {
    char text[32];
    std::snprintf(text, sizeof text, "%.0f", v);
    return text;
  }
  return numberText(v);
}

/// A value as an error quotes it: numbers as a person writes them, strings in quotes, arrays of them.
std::string valueText(const json& v) {
  if (v.is_number()) return plainNumber(v.get<double>());
  if (v.is_array()) {
    std::string text = "[";
    for (size_t i = 0; i < v.size(); ++i) text += (i ? ", " : "") + valueText(v[i]);
    return text + "]";
  }
  std::string text = v.dump();
  return text.size() > 60 ? text.substr(0, 57) + "..." : text;
}

/// "a", "b" or "\"a\", \"b\"".
std::string nameList(const std::vector<std::string>& names, bool quoted) {
  std::string text;
  for (const std::string& n : names) text += (text.empty() ? "" : ", ") + (quoted ? "\"" + n + "\"" : n);
  return text;
}

bool integral(double v) { return std::isfinite(v) && v == std::floor(v); }

/// "between 2 and 256 voxels", "above 0 and at most 179 degrees", "0 or between 0.5 and 1"; `integer`: "an integer
/// between 1 and 100"; `plural` for each of several numbers: "each between 0 and 1", "integers between 1 and 8192".
std::string rangeWords(const SceneRange& r, const std::string& unit, bool integer, bool plural = false) {
  std::string text = r.powerOfTwo ? (plural ? "powers of two" : "a power of two")
                     : integer    ? (plural ? "integers" : "an integer")
                                  : (plural ? "each" : "");
  std::string bounds;
  if (std::isfinite(r.lo) && std::isfinite(r.hi))
    bounds = (r.loOpen ? "above " : "between ") + plainNumber(r.lo) + (r.loOpen ? " and at most " : " and ") +
             plainNumber(r.hi);
  else if (std::isfinite(r.lo))
    bounds = (r.loOpen ? "above " : "at least ") + plainNumber(r.lo);
  else if (std::isfinite(r.hi))
    bounds = "at most " + plainNumber(r.hi);
  if (!bounds.empty()) text += (text.empty() ? "" : " ") + bounds;
  if (text.empty()) text = "a number";
  if (!unit.empty()) text += " " + unit;
  return (r.zeroToo ? "0 or " : "") + text;
}

/// A default-constructed scene, the source of every default.
const Scene& defaultScene() {
  static const Scene scene;
  return scene;
}

json vec3(const glm::dvec3& v) { return json::array({v.x, v.y, v.z}); }
glm::dvec3 vec3(const json& v) { return {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()}; }
std::string tripleText(const glm::dvec3& v) {
  return plainNumber(v.x) + "," + plainNumber(v.y) + "," + plainNumber(v.z);
}

/// The key's value and setter as a field of Scene (of one of its concern structs).
template <auto M>
void field(SceneKey& k) {
  k.value = [](const Scene& s) { return json(s.*M); };
  k.set = [](Scene& s, const json& v, const SceneSetting&) { s.*M = v.get<std::remove_cvref_t<decltype(s.*M)>>(); };
}

SceneKey& add(std::vector<SceneKey>& keys, std::string key, SceneType type, SceneConcern concern, SceneApplies applies,
              std::string help) {
  SceneKey& k = keys.emplace_back();
  k.key = std::move(key);
  k.type = type;
  k.concern = concern;
  k.applies = applies;
  k.help = std::move(help);
  return k;
}

/// The transfer function of `v`: a preset name (or with `allowPaths` a file), or an inline object.
void setTransferFunction(Scene& s, const json& v, const SceneSetting& setting) {
  if (v.is_string()) {
    const std::string name = v.get<std::string>();
    if (!setting.allowPaths && !TransferFunction::isPresetName(name))
      throw RenderInputError(setting.name +
                             " must be a preset name (letters, digits, '-', '_') or an inline object; paths are not "
                             "accepted here");
    s.transferFunction = setting.presets ? setting.presets->get(name) : TransferFunction::load(name);
    s.transferFunctionName = name;
  } else {
    s.transferFunction = TransferFunction::parse(v.dump(), setting.name);
    s.transferFunctionName = "inline";
  }
}

json transferFunctionJson(const TransferFunction& tf) {
  json points = json::array();
  for (const auto& p : tf.points()) points.push_back({p.x, p.rgba.r, p.rgba.g, p.rgba.b, p.rgba.a});
  json j = {{"points", points}};
  if (tf.referenceLength()) j["reference_length"] = *tf.referenceLength();
  return j;
}

std::vector<SceneKey> buildSchema() {
  using C = SceneConcern;
  using A = SceneApplies;
  using T = SceneType;
  std::vector<SceneKey> keys;

  // The view.
  {
    SceneKey& k = add(keys, "camera", T::Object, C::View, A::Both,
                      "the camera: an orbit (the default), a named view, or an eye with center and up");
    k.written = SceneWritten::Never;
    k.value = [](const Scene&) { return json(); };
    k.set = [](Scene&, const json&, const SceneSetting&) {};
    k.absent = "an orbit";
  }
  {
    SceneKey& k = add(keys, "camera.orbit", T::Numbers, C::View, A::Both,
                      "azimuth and elevation in degrees about the up axis (az 0 from +y, 90 from -x about +z), and the "
                      "distance in bounding-sphere radii (absent: fitted, the whole volume in frame)");
    k.minCount = 2, k.maxCount = 3;
    k.shape = "[az, el] or [az, el, dist]";
    k.option = "--orbit", k.optionForm = "AZ,EL[,DIST]";
    k.example = json::array({10, 20, 3});
    k.value = [](const Scene& s) {
      if (!s.camera.orbit) return json();
      json o = json::array({s.camera.azimuth, s.camera.elevation});
      if (s.camera.distance) o.push_back(*s.camera.distance);
      return o;
    };
    k.set = [](Scene& s, const json& v, const SceneSetting&) {
      s.camera.orbit = true;
      s.camera.azimuth = v[0].get<double>(), s.camera.elevation = v[1].get<double>();
      s.camera.distance = std::nullopt;
      if (v.size() == 3) s.camera.distance = v[2].get<double>();
    };
  }
  {
    SceneKey& k = add(keys, "camera.fit", T::Bool, C::View, A::Both,
                      "the orbit's distance fitted to the frame, the whole volume in view at any angle (false "
                      "confirms the orbit's own distance)");
    k.option = "--fit", k.flagValue = true;
    k.written = SceneWritten::Never;
    k.value = [](const Scene& s) { return s.camera.orbit ? json(!s.camera.distance) : json(); };
    k.set = [](Scene& s, const json& v, const SceneSetting& setting) {
      if (v.get<bool>())
        s.camera.distance = std::nullopt;
      else if (!s.camera.distance)
        throw RenderInputError(setting.name + " false needs a distance: 'camera.orbit' [az, el, dist]");
    };
  }
  {
    SceneKey& k = add(keys, "camera.up_axis", T::Name, C::View, A::Both,
                      "the orbit's pole (+z: superior for patient data; x, y, z mean +x, +y, +z)");
    k.names = common::enumNameList<UpAxis>();
    k.names.insert(k.names.end(), {"x", "y", "z"});
    k.option = "--up-axis", k.optionForm = "AXIS";
    k.example = "-y";
    k.value = [](const Scene& s) { return s.camera.orbit ? json(upAxisName(s.camera.upAxis)) : json(); };
    k.set = [](Scene& s, const json& v, const SceneSetting& setting) {
      s.camera.upAxis = parseUpAxis(v.get<std::string>(), setting.name);
    };
  }
  {
    SceneKey& k = add(keys, "camera.view", T::Name, C::View, A::Both,
                      "a named view: an orbit about +z at the fitted distance (for data without a patient frame, "
                      "from +y, -y, -x, +x, +z, -z)");
    k.names = viewNameList();
    k.option = "--view", k.optionForm = "NAME";
    k.written = SceneWritten::Never;
    k.absent = "none";
    k.example = "left";
    k.value = [](const Scene&) { return json(); };
    k.set = [](Scene& s, const json& v, const SceneSetting& setting) {
      s.camera.setView(v.get<std::string>(), setting.name);
    };
  }
  {
    SceneKey& k = add(keys, "camera.eye", T::Numbers, C::View, A::Both,
                      "the eye in world coordinates (RAS millimetres for patient data), in place of an orbit");
    k.minCount = k.maxCount = 3;
    k.shape = "[x, y, z]";
    k.option = "--eye", k.optionForm = "X,Y,Z";
    k.absent = "none: an orbit";
    k.example = json::array({0, -300, 0});
    k.value = [](const Scene& s) { return s.camera.orbit ? json() : vec3(s.camera.eye); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) {
      s.camera.orbit = false;
      s.camera.eye = vec3(v);
    };
  }
  {
    SceneKey& k =
        add(keys, "camera.center", T::Numbers, C::View, A::Both, "the point an eye looks at, in world coordinates");
    k.minCount = k.maxCount = 3;
    k.shape = "[x, y, z]";
    k.option = "--center", k.optionForm = "X,Y,Z";
    k.example = json::array({0, 0, 10});
    k.describe = [](const Scene& s) { return tripleText(s.camera.center); };
    k.value = [](const Scene& s) { return s.camera.orbit ? json() : vec3(s.camera.center); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) { s.camera.center = vec3(v); };
  }
  {
    SceneKey& k = add(keys, "camera.up", T::Numbers, C::View, A::Both,
                      "the screen's up direction for an eye, in world coordinates");
    k.minCount = k.maxCount = 3;
    k.shape = "[x, y, z]";
    k.option = "--up", k.optionForm = "X,Y,Z";
    k.example = json::array({0, 0, 1});
    k.describe = [](const Scene& s) { return tripleText(s.camera.up); };
    k.value = [](const Scene& s) { return s.camera.orbit ? json() : vec3(s.camera.up); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) { s.camera.up = vec3(v); };
  }
  {
    SceneKey& k = add(keys, "camera.fov", T::Number, C::View, A::Both, "the vertical field of view");
    k.range = {.lo = 0, .hi = 179, .loOpen = true};
    k.unit = "degrees";
    k.option = "--fov", k.optionForm = "DEG";
    k.example = 45;
    k.value = [](const Scene& s) { return json(s.camera.fovY); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) { s.camera.fovY = v.get<double>(); };
  }
  {
    SceneKey& k = add(keys, "camera.orthographic", T::Bool, C::View, A::Both,
                      "parallel projection, as high as the perspective view in the plane through the centre");
    k.option = "--ortho", k.flagValue = true;
    k.example = true;
    k.value = [](const Scene& s) { return json(s.camera.orthographic); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) { s.camera.orthographic = v.get<bool>(); };
  }
  {
    SceneKey& k = add(keys, "size", T::Numbers, C::View, A::Both, "the frame's width and height");
    k.minCount = k.maxCount = 2;
    k.integers = true;
    k.range = {.lo = 1, .hi = double(SceneView::kMaxImageSide)};
    k.unit = "pixels";
    k.shape = "[width, height]";
    k.option = "--size", k.optionForm = "WxH", k.separator = 'x';
    k.example = json::array({320, 200});
    k.value = [](const Scene& s) { return json::array({s.width, s.height}); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) {
      s.width = v[0].get<int>();
      s.height = v[1].get<int>();
    };
  }
  {
    SceneKey& k = add(keys, "background", T::Numbers, C::View, A::Both,
                      "the opaque colour behind the volume; none: a transparent frame (alpha the accumulated "
                      "opacity, straight colour; PNG only)");
    k.minCount = k.maxCount = 3;
    k.range = {.lo = 0, .hi = 1};
    k.names = {"none"};
    k.shape = "[r, g, b]";
    k.option = "--background", k.optionForm = "R,G,B";
    k.example = json::array({0.1, 0.2, 0.3});
    k.value = [](const Scene& s) { return s.transparent ? json("none") : vec3(s.background); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) {
      s.transparent = v.is_string();
      if (!s.transparent) s.background = vec3(v);
    };
  }

  // Classification.
  {
    SceneKey& k = add(keys, "transfer_function", T::TransferFunction, C::Classification, A::Both,
                      "a preset (`voxbrick presets` lists them), a JSON file, or inline {\"points\": [[x, r, g, b, "
                      "a], ...], \"reference_length\": L}");
    k.option = "--tf", k.optionForm = "NAME|FILE";
    k.example = "hot";
    k.describe = [](const Scene& s) { return s.transferFunctionName; };
    k.value = [](const Scene& s) { return transferFunctionJson(s.transferFunction); };
    k.set = setTransferFunction;
  }
  {
    SceneKey& k = add(keys, "window", T::Numbers, C::Classification, A::Both,
                      "the values mapped to the transfer function's 0 to 1");
    k.minCount = k.maxCount = 2;
    k.increasing = true;
    k.shape = "[lo, hi]";
    k.option = "--window", k.optionForm = "LO,HI";
    k.absent = "the dataset's value range";
    k.example = json::array({10, 200});
    k.value = [](const Scene& s) { return s.window ? json::array({(*s.window)[0], (*s.window)[1]}) : json(); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) {
      s.window = std::array<double, 2>{v[0].get<double>(), v[1].get<double>()};
    };
  }
  {
    SceneKey& k = add(keys, "shading", T::Bool, C::Classification, A::Both,
                      "gradient shading (central differences; a mesh's tet gradients) with a Phong headlight");
    k.option = "--shading", k.flagValue = true;
    k.example = true;
    field<&Scene::shading>(k);
  }

  // How grids are drawn.
  {
    SceneKey& k = add(keys, "step", T::Number, C::Grid, A::Grids,
                      "the sample spacing along a ray, in voxels of level 0 (the smallest spacing)");
    k.range = {.lo = 0.001, .hi = 64};
    k.unit = "voxels";
    k.option = "--step", k.optionForm = "S";
    k.example = 0.5;
    field<&Scene::step>(k);
  }
  {
    SceneKey& k = add(keys, "skip_empty", T::Bool, C::Grid, A::Both,
                      "skip bricks (and tets) the transfer function makes transparent; the same image");
    k.option = "--no-skip", k.flagValue = false;
    k.example = false;
    field<&Scene::skipEmpty>(k);
  }
  {
    SceneKey& k = add(keys, "cull", T::Bool, C::Grid, A::Grids, "skip bricks outside the view");
    k.option = "--no-cull", k.flagValue = false;
    k.example = false;
    field<&Scene::cullFrustum>(k);
  }
  {
    SceneKey& k = add(keys, "slicer", T::Name, C::Grid, A::Grids,
                      "where slice polygons are computed when slicing (slab 0, no raycast); the same polygons");
    k.names = common::enumNameList<Slicer>();
    k.option = "--slicer", k.optionForm = "NAME";
    k.example = "cpu";
    k.value = [](const Scene& s) { return json(slicerName(s.slicer)); };
    k.set = [](Scene& s, const json& v, const SceneSetting& setting) {
      s.slicer = parseSlicer(v.get<std::string>(), setting.name);
    };
  }
  {
    SceneKey& k = add(keys, "sub_block", T::Integer, C::Grid, A::Grids,
                      "skip empty sub-blocks of this many voxels inside bricks (0: whole bricks)");
    k.range = {.lo = 2, .hi = double(GridTechnique::kMaxSubBlock), .zeroToo = true, .powerOfTwo = true};
    k.unit = "voxels";
    k.option = "--sub-block", k.optionForm = "N";
    k.example = 4;
    field<&Scene::subBlock>(k);
  }
  {
    SceneKey& k = add(keys, "slab", T::Integer, C::Grid, A::Grids,
                      "texture slabs of this many planes when not ray casting (0: slicing)");
    k.range = {.lo = 0, .hi = double(GridTechnique::kMaxSlab)};
    k.unit = "planes";
    k.option = "--slab", k.optionForm = "N";
    k.example = 8;
    field<&Scene::slab>(k);
  }
  {
    SceneKey& k = add(keys, "raycast", T::Bool, C::Grid, A::Grids,
                      "the frame ray caster: one fragment per pixel marches its whole ray (the same samples as "
                      "slabs)");
    k.option = "--raycast", k.flagValue = true;
    k.example = false;
    field<&Scene::raycast>(k);
  }
  {
    SceneKey& k =
        add(keys, "raycaster", T::Name, C::Grid, A::Both,
            "the ray casters' kernel, a grid's and a mesh's: fragment (a pixel per fragment, blended) or "
            "compute (a pixel per invocation); the same samples; auto: the faster on the device as measured (a mesh: "
            "fragment)");
    k.names = common::enumNameList<RayCaster>();
    k.option = "--raycaster", k.optionForm = "NAME";
    k.example = "compute";
    k.value = [](const Scene& s) { return json(rayCasterName(s.raycaster)); };
    k.set = [](Scene& s, const json& v, const SceneSetting& setting) {
      s.raycaster = parseRayCaster(v.get<std::string>(), setting.name);
    };
  }
  {
    SceneKey& k = add(keys, "residency", T::Name, C::Grid, A::Grids,
                      "what pages a ray-cast frame's bricks: octree (every visible brick, before the frame) or rays "
                      "(the bricks the rays reach, drawn from a resident ancestor until paged); the same image once "
                      "converged");
    k.names = common::enumNameList<ResidencyMode>();
    k.option = "--residency", k.optionForm = "NAME";
    k.example = "rays";
    k.value = [](const Scene& s) { return json(residencyModeName(s.residency)); };
    k.set = [](Scene& s, const json& v, const SceneSetting& setting) {
      s.residency = parseResidencyMode(v.get<std::string>(), setting.name);
    };
  }
  {
    SceneKey& k = add(keys, "ert", T::Number, C::Grid, A::Both,
                      "early ray termination: a ray stops at this opacity (0: off), moving a pixel by at most 1 - ert");
    k.range = {.lo = 0.5, .hi = 1, .zeroToo = true};
    k.option = "--ert", k.optionForm = "T";
    k.example = 0.99;
    field<&Scene::ert>(k);
  }
  {
    SceneKey& k = add(keys, "pre_integration", T::Bool, C::Grid, A::Grids,
                      "pre-integrated classification of each segment between samples (slabs, the ray caster)");
    k.option = "--pre-integration", k.flagValue = true;
    k.example = true;
    field<&Scene::preIntegration>(k);
  }
  {
    SceneKey& k = add(keys, "ess", T::Bool, C::Grid, A::Grids,
                      "empty-space silhouette maps on slabs: only pixels with something to draw; the same image");
    k.option = "--ess", k.flagValue = true;
    k.example = true;
    field<&Scene::ess>(k);
  }
  {
    SceneKey& k = add(keys, "lod", T::Number, C::Grid, A::Grids,
                      "level of detail: a coarser level where its voxels are at most this many pixels tall (0: level "
                      "0 everywhere)");
    k.range = {.lo = 0, .hi = GridTechnique::kMaxLod};
    k.unit = "pixels";
    k.option = "--lod", k.optionForm = "PIXELS";
    k.example = 2;
    field<&Scene::lod>(k);
  }
  {
    SceneKey& k = add(keys, "quality", T::Text, C::Grid, A::Both,
                      "quality by target from the dataset's quality table (`voxbrick bench --calibrate`): the fastest "
                      "setting measured at DB + 1 dB, or the most accurate within 0.9 N ms");
    k.shape = "\"psnr:DB\" or \"ms:N\"";
    k.option = "--quality", k.optionForm = "psnr:DB|ms:N";
    k.absent = "none";
    k.example = "psnr:40";
    k.value = [](const Scene& s) { return s.quality ? json(s.quality->text()) : json(); };
    k.set = [](Scene& s, const json& v, const SceneSetting& setting) {
      s.quality = QualityTarget::parse(v.get<std::string>(), setting.name);
    };
  }

  // How meshes are drawn.
  {
    SceneKey& k = add(keys, "visibility", T::Name, C::Mesh, A::Meshes,
                      "how a mesh's cells are put in order: raycast (each pixel's ray walks the adjacency; ert "
                      "applies), or projected tets sorted by mpvo or centroid");
    k.names = common::enumNameList<TetSort>();
    k.option = "--visibility", k.optionForm = "NAME";
    k.example = "mpvo";
    k.value = [](const Scene& s) { return json(tetSortName(s.visibility)); };
    k.set = [](Scene& s, const json& v, const SceneSetting& setting) {
      s.visibility = parseTetSort(v.get<std::string>(), setting.name);
    };
  }

  // Delivery.
  {
    SceneKey& k = add(keys, "progressive", T::Bool, C::Delivery, A::Grids,
                      "coarse to fine: a provisional frame with bricks not yet in memory drawn from a coarser level, "
                      "then the exact frame");
    k.option = "--progressive", k.flagValue = true;
    k.example = true;
    field<&Scene::progressive>(k);
  }
  {
    SceneKey& k = add(keys, "interactive", T::Bool, C::Delivery, A::Both,
                      "a camera in motion: a provisional frame within time_budget_ms, the exact one once it rests");
    k.written = SceneWritten::Changed;
    k.example = true;
    field<&Scene::interactive>(k);
  }
  {
    SceneKey& k =
        add(keys, "time_budget_ms", T::Number, C::Delivery, A::Both, "the time an interactive frame may take");
    k.range = {.lo = SceneDelivery::kMinTimeBudgetMs, .hi = SceneDelivery::kMaxTimeBudgetMs};
    k.unit = "ms";
    k.written = SceneWritten::Changed;
    k.example = 50;
    field<&Scene::timeBudgetMs>(k);
  }
  {
    SceneKey& k = add(keys, "jpeg_quality", T::Integer, C::Delivery, A::Both,
                      "the JPEG quality of a frame sent as jpeg (libjpeg's scale)");
    k.range = {.lo = 1, .hi = 100};
    k.absent = "the server's default";
    k.example = 60;
    k.value = [](const Scene& s) { return s.jpegQuality ? json(*s.jpegQuality) : json(); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) { s.jpegQuality = v.get<int>(); };
  }
  {
    SceneKey& k = add(keys, "provisional_encoding", T::Name, C::Delivery, A::Both,
                      "the encoding of a request's provisional frames");
    k.names.assign(std::begin(SceneDelivery::kEncodingNames), std::end(SceneDelivery::kEncodingNames));
    k.absent = "the request's own encoding";
    k.example = "jpeg";
    k.value = [](const Scene& s) { return s.provisionalEncoding ? json(*s.provisionalEncoding) : json(); };
    k.set = [](Scene& s, const json& v, const SceneSetting&) { s.provisionalEncoding = v.get<std::string>(); };
  }
  {
    SceneKey& k = add(keys, "keyframe", T::Bool, C::Delivery, A::Both,
                      "the session's video stream starts again: its next video frame is a key frame");
    k.written = SceneWritten::Changed;
    k.example = true;
    field<&Scene::keyframe>(k);
  }
  {
    SceneKey& k = add(keys, "accepts_webp", T::Bool, C::Delivery, A::Both,
                      "the client decodes webp: png frames may come as lossless webp, which the server sends while "
                      "the session's link is slow");
    k.example = true;
    field<&Scene::acceptsWebp>(k);
  }
  {
    SceneKey& k = add(keys, "accepts_vp9_444", T::Bool, C::Delivery, A::Both,
                      "the client decodes VP9 in 4:4:4 (profile 1): a vp9 video stream then carries colour at every "
                      "pixel, more picture for its bytes");
    k.example = true;
    field<&Scene::acceptsVp9_444>(k);
  }
  {
    SceneKey& k = add(keys, "batch", T::Bool, C::Delivery, A::Both,
                      "work nobody watches as it happens (a script): served after viewers' frames, refused with Busy "
                      "first");
    k.option = "--batch", k.flagValue = true;
    k.example = true;
    field<&Scene::batch>(k);
  }
  return keys;
}

std::vector<SceneRule> buildRules() {
  using K = SceneRuleKind;
  std::vector<SceneRule> rules;
  const auto rule = [&](K kind, std::string a, std::string b, bool aReplacesB, bool bReplacesA, std::string reason) {
    SceneRule& r = rules.emplace_back();
    r.kind = kind, r.a = std::move(a), r.b = std::move(b);
    r.aReplacesB = aReplacesB, r.bReplacesA = bReplacesA;
    r.reason = std::move(reason);
    return &r;
  };
  const std::string placement = "a camera is placed by one of orbit, view and eye";
  rule(K::Excludes, "camera.orbit", "camera.eye", true, true, placement);
  rule(K::Excludes, "camera.view", "camera.orbit", true, true, placement);
  rule(K::Excludes, "camera.view", "camera.eye", true, true, placement);
  rule(K::Excludes, "camera.view", "camera.up_axis", true, false,
       "a view turns about +z; give an orbit with an up axis for another pole");
  rule(K::Excludes, "camera.fit", "camera.eye", false, true, "the fitted distance is an orbit's or a view's");
  rule(K::Excludes, "camera.up_axis", "camera.eye", false, true, "an up axis is an orbit's; an eye has 'up'");
  rule(K::Needs, "camera.center", "camera.eye", false, false, "an orbit or a view looks at the volume's centre");
  rule(K::Needs, "camera.up", "camera.eye", false, false, "an orbit or a view has its up axis");
  for (const char* key : kQualityChosenKeys)
    rule(K::Excludes, "quality", key, true, true, "a quality target chooses it from the dataset's quality table");
  rule(K::Resets, "slab", "raycast", true, false, "a slab size asks for slicing or slabs")->value = false;
  return rules;
}

/// Drops `key` from `keys`, and the keys of it that need it (unless `top` gives them).
void drop(SceneKeys& keys, const std::string& key, const SceneKeys& top) {
  if (!keys.erase(key)) return;
  for (const SceneRule& r : sceneRules())
    if (r.kind == SceneRuleKind::Needs && r.b == key && !top.count(r.a)) drop(keys, r.a, top);
}

}  // namespace

bool SceneRange::contains(double v) const {
  if (!std::isfinite(v)) return false;
  if (zeroToo && v == 0) return true;
  if (loOpen ? !(v > lo) : !(v >= lo)) return false;
  if (!(v <= hi)) return false;
  if (powerOfTwo) {
    if (!integral(v) || v < 1) return false;
    const auto n = int64_t(v);
    return (n & (n - 1)) == 0;
  }
  return true;
}

std::string SceneKey::allowed(bool asOption) const {
  switch (type) {
    case SceneType::Object: return "an object";
    case SceneType::Bool: return "true or false";
    case SceneType::Number: return rangeWords(range, unit, false);
    case SceneType::Integer: return rangeWords(range, unit, true);
    case SceneType::Name: return "one of " + nameList(names, !asOption);
    case SceneType::Text: return asOption ? optionForm : shape;
    case SceneType::Numbers: {
      std::string text = asOption ? optionForm : shape;
      if (increasing) text += " in increasing order";
      const bool bounded = std::isfinite(range.lo) || std::isfinite(range.hi);
      if (bounded) text += ", " + rangeWords(range, unit, integers, true);
      if (!names.empty()) text += ", or " + nameList(names, !asOption);
      return text;
    }
    case SceneType::TransferFunction:
      return asOption ? "a preset name or a JSON file"
                      : "a preset name, a file path (not on a server) or an object {\"points\": [[x, r, g, b, a], "
                        "...]}";
  }
  return "?";
}

std::string SceneKey::problem(const json& v, bool asOption) const {
  bool ok = false;
  switch (type) {
    case SceneType::Object: ok = v.is_object(); break;
    case SceneType::Bool: ok = v.is_boolean(); break;
    case SceneType::Number: ok = v.is_number() && range.contains(v.get<double>()); break;
    case SceneType::Integer: ok = v.is_number() && integral(v.get<double>()) && range.contains(v.get<double>()); break;
    case SceneType::Name:
      ok = v.is_string() && std::find(names.begin(), names.end(), v.get<std::string>()) != names.end();
      break;
    case SceneType::Text: ok = v.is_string(); break;
    case SceneType::Numbers:
      if (v.is_string()) {
        ok = std::find(names.begin(), names.end(), v.get<std::string>()) != names.end();
      } else if (v.is_array() && int(v.size()) >= minCount && int(v.size()) <= maxCount) {
        ok = true;
        for (size_t i = 0; i < v.size() && ok; ++i) {
          ok = v[i].is_number() && std::isfinite(v[i].get<double>()) && range.contains(v[i].get<double>()) &&
               (!integers || integral(v[i].get<double>()));
          if (ok && increasing && i > 0) ok = v[i].get<double>() > v[i - 1].get<double>();
        }
      }
      break;
    case SceneType::TransferFunction: ok = v.is_string() || v.is_object(); break;
  }
  return ok ? std::string() : "must be " + allowed(asOption);
}

std::string SceneKey::hint(const json& v, bool asOption) const {
  if (!names.empty() && v.is_string()) {
    const auto closest = common::closestName(v.get<std::string>(), names);
    if (closest && *closest != v.get<std::string>())
      return "; did you mean " + (asOption ? "'" + *closest + "'" : json(*closest).dump()) + "?";
  }
  // A value of a shape (numbers, a target) gets an example of one; a number's range needs none.
  if ((type == SceneType::Numbers || type == SceneType::Text) && !example.is_null())
    return "; e.g. " + (asOption ? optionText(example) : example.dump());
  return "";
}

json SceneKey::defaultValue() const { return value(defaultScene()); }

std::string SceneKey::optionText(const json& v) const {
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number()) return plainNumber(v.get<double>());
  if (v.is_string()) return v.get<std::string>();
  if (v.is_array()) {
    std::string text;
    for (size_t i = 0; i < v.size(); ++i) text += (i ? std::string(1, separator) : "") + optionText(v[i]);
    return text;
  }
  return v.dump();
}

std::string SceneKey::defaultText() const {
  if (describe) return describe(defaultScene());
  const json v = defaultValue();
  if (!v.is_null()) return optionText(v);
  return absent.empty() ? "none" : absent;
}

const std::vector<SceneKey>& sceneSchema() {
  static const std::vector<SceneKey> keys = buildSchema();
  return keys;
}

const SceneKey* findSceneKey(const std::string& key) {
  for (const SceneKey& k : sceneSchema())
    if (k.key == key) return &k;
  return nullptr;
}

const std::vector<SceneRule>& sceneRules() {
  static const std::vector<SceneRule> rules = buildRules();
  return rules;
}

SceneNames SceneNames::of(const std::string& what) {
  return {what + ": ", [](const std::string& key) { return "'" + key + "'"; }};
}

SceneKeys sceneKeysOf(const std::string& text, const std::string& what) {
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
  // The keys a group (or the scene itself) may hold, for an unknown key's error.
  const auto known = [](const std::string& group) {
    std::string list;
    for (const SceneKey& k : sceneSchema()) {
      const size_t dot = k.key.rfind('.');
      const std::string parent = dot == std::string::npos ? "" : k.key.substr(0, dot);
      if (parent == group) list += (list.empty() ? "" : ", ") + k.key.substr(dot == std::string::npos ? 0 : dot + 1);
    }
    return list;
  };
  SceneKeys keys;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const SceneKey* k = findSceneKey(it.key());
    if (!k) throw RenderInputError(what + ": unknown key '" + it.key() + "' (one of " + known("") + ")");
    keys[it.key()] = it.value();
    if (k->type != SceneType::Object || !it.value().is_object()) continue;
    for (auto member = it.value().begin(); member != it.value().end(); ++member) {
      const std::string full = it.key() + "." + member.key();
      if (!findSceneKey(full))
        throw RenderInputError(what + ": unknown key '" + full + "' (one of " + known(it.key()) + ")");
      keys[full] = member.value();
    }
  }
  return keys;
}

Scene sceneFromKeys(const SceneKeys& keys, const SceneNames& names, bool allowPaths,
                    const TransferFunctionPresets* presets) {
  for (const auto& [key, value] : keys) {
    const SceneKey* k = findSceneKey(key);
    if (!k) throw RenderInputError(names.prefix + "unknown key '" + key + "'");
    if (const std::string problem = k->problem(value); !problem.empty())
      throw RenderInputError(names.prefix + names.name(key) + " " + problem + ", not " + valueText(value) +
                             k->hint(value));
  }
  for (const SceneRule& r : sceneRules()) {
    const bool a = keys.count(r.a), b = keys.count(r.b);
    if (r.kind == SceneRuleKind::Excludes && a && b)
      throw RenderInputError(names.prefix + names.name(r.a) + " cannot be combined with " + names.name(r.b) + ": " +
                             r.reason);
    if (r.kind == SceneRuleKind::Needs && a && !b)
      throw RenderInputError(names.prefix + names.name(r.a) + " needs " + names.name(r.b) + ": " + r.reason);
  }
  Scene s;
  for (const SceneKey& k : sceneSchema()) {
    const auto it = keys.find(k.key);
    if (it != keys.end()) k.set(s, it->second, {names.prefix + names.name(k.key), allowPaths, presets});
  }
  for (const SceneRule& r : sceneRules())
    if (r.kind == SceneRuleKind::Resets && keys.count(r.a) && !keys.count(r.b))
      findSceneKey(r.b)->set(s, r.value, {names.prefix + names.name(r.b), allowPaths, presets});
  s.validate();
  return s;
}

SceneKeys layerSceneKeys(SceneKeys base, const SceneKeys& top, const SceneNames& names) {
  // A rule as seen from one of its keys given above: `self` (that key), `other` and whether self replaces it.
  struct Side {
    const SceneRule& rule;
    const std::string &self, &other;
    bool replaces;
  };
  const auto sides = [](const SceneRule& r) {
    return std::array<Side, 2>{Side{r, r.a, r.b, r.aReplacesB}, Side{r, r.b, r.a, r.bReplacesA}};
  };
  // First what the keys above replace, then what they exclude and does not replace: what remains of the scene below.
  for (const SceneRule& r : sceneRules())
    for (const Side& side : sides(r))
      if (side.replaces && top.count(side.self) && !top.count(side.other)) drop(base, side.other, top);
  for (const SceneRule& r : sceneRules())
    for (const Side& side : sides(r))
      if (r.kind == SceneRuleKind::Excludes && top.count(side.self) && !top.count(side.other) && base.count(side.other))
        throw RenderInputError(names.prefix + names.name(side.self) + " cannot be combined with " +
                               names.name(side.other) + ": " + r.reason);
  for (const auto& [key, value] : top) base[key] = value;
  return base;
}

void checkSceneValues(const Scene& scene) {
  for (const SceneKey& k : sceneSchema()) {
    // Booleans cannot be wrong, and the transfer function was checked when it was read.
    if (k.type == SceneType::Object || k.type == SceneType::Bool || k.type == SceneType::TransferFunction) continue;
    const json v = k.value(scene);
    if (v.is_null()) continue;
    if (const std::string problem = k.problem(v); !problem.empty())
      throw RenderInputError("'" + k.key + "' " + problem + ", not " + valueText(v) + k.hint(v));
  }
}

json sceneJson(const Scene& scene) {
  json j = json::object();
  for (const SceneKey& k : sceneSchema()) {
    if (k.written == SceneWritten::Never) continue;
    const json v = k.value(scene);
    if (v.is_null() || (k.written == SceneWritten::Changed && v == k.defaultValue())) continue;
    std::string pointer = "/" + k.key;
    std::replace(pointer.begin(), pointer.end(), '.', '/');
    j[json::json_pointer(pointer)] = v;
  }
  // The first key of an exclusion stands for the second: a quality target for the settings it chooses.
  for (const SceneRule& r : sceneRules()) {
    if (r.kind != SceneRuleKind::Excludes || r.a.find('.') != std::string::npos || r.b.find('.') != std::string::npos)
      continue;
    if (j.contains(r.a) && j.contains(r.b)) j.erase(r.b);
  }
  return j;
}

json sceneSchemaJson() {
  json keys = json::array();
  for (const SceneKey& k : sceneSchema()) {
    json e = {{"key", k.key},
              {"type", sceneTypeName(k.type)},
              {"concern", sceneConcernName(k.concern)},
              {"applies", sceneAppliesName(k.applies)},
              {"help", k.help},
              {"option", k.option.empty() ? json() : json(k.option)},
              {"default", k.defaultValue()},
              {"default_text", k.defaultText()},
              {"allowed", k.allowed()},
              {"example", k.example},
              {"written", k.written == SceneWritten::Always    ? "always"
                          : k.written == SceneWritten::Changed ? "changed"
                                                               : "never"}};
    if (!k.option.empty()) {
      e["option_form"] = k.optionForm;
      if (k.flagValue)
        e["flag_value"] = *k.flagValue;
      else
        e["option_allowed"] = k.allowed(true);
      if (!k.example.is_null() && !k.flagValue) e["option_example"] = k.optionText(k.example);
    }
    if (std::isfinite(k.range.lo)) e["min"] = k.range.lo;
    if (std::isfinite(k.range.hi)) e["max"] = k.range.hi;
    if (k.range.loOpen) e["min_open"] = true;
    if (k.range.zeroToo) e["zero_too"] = true;
    if (k.range.powerOfTwo) e["power_of_two"] = true;
    if (!k.names.empty()) e["names"] = k.names;
    if (k.type == SceneType::Numbers) {
      e["count"] = {k.minCount, k.maxCount};
      e["integers"] = k.integers;
      e["increasing"] = k.increasing;
    }
    if (!k.unit.empty()) e["unit"] = k.unit;
    keys.push_back(e);
  }
  json rules = json::array();
  for (const SceneRule& r : sceneRules()) {
    json e = {{"kind", r.kind == SceneRuleKind::Excludes ? "excludes"
                       : r.kind == SceneRuleKind::Needs  ? "needs"
                                                         : "resets"},
              {"keys", {r.a, r.b}},
              {"a_replaces_b", r.aReplacesB},
              {"b_replaces_a", r.bReplacesA},
              {"reason", r.reason}};
    if (r.kind == SceneRuleKind::Resets) e["value"] = r.value;
    rules.push_back(e);
  }
  return {{"keys", keys}, {"rules", rules}};
}

}  // namespace voxbrick::render
