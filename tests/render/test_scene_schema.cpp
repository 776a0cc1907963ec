// The scene's schema as parsing, validation and writing use it: every key reads back what it was given, refuses
// what its range or names exclude with an error naming the key, the value and what it may be, lives in its
// concern's struct; the rules between keys refuse, reset and lay options over a file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"
#include "render/core/SceneSchema.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using nlohmann::json;

/// `key` ("camera.fov") at its place in a scene object.
void putKey(json& scene, const std::string& key, const json& value) {
  std::string pointer = "/" + key;
  std::replace(pointer.begin(), pointer.end(), '.', '/');
  scene[json::json_pointer(pointer)] = value;
}

/// The object of `key` set to `value`, with what the key needs (center and up need an eye) and, where the key
/// resets another, that one at its default (slab's raycast).
json sceneWith(const SceneKey& k, const json& value) {
  json scene = json::object();
  for (const SceneRule& r : sceneRules()) {
    if (r.kind == SceneRuleKind::Needs && r.a == k.key) putKey(scene, r.b, findSceneKey(r.b)->example);
    if (r.kind == SceneRuleKind::Resets && r.a == k.key) putKey(scene, r.b, findSceneKey(r.b)->defaultValue());
  }
  putKey(scene, k.key, value);
  return scene;
}

/// The error reading `scene` gives, or "" when it is read.
std::string readError(const json& scene) {
  try {
    Scene::fromJson(scene.dump(), "scene.json");
  } catch (const RenderInputError& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_MENTIONS(text, words) EXPECT_NE(std::string(text).find(words), std::string::npos) << (text)

TEST(SceneSchema, KeysAreUniqueAndEveryRuleNamesThem) {
  std::set<std::string> seen;
  for (const SceneKey& k : sceneSchema()) {
    EXPECT_TRUE(seen.insert(k.key).second) << k.key;
    EXPECT_FALSE(k.help.empty()) << k.key;
    EXPECT_TRUE(k.value && k.set) << k.key;
    // A group's keys follow the group.
    if (const size_t dot = k.key.find('.'); dot != std::string::npos) {
      EXPECT_TRUE(seen.count(k.key.substr(0, dot))) << k.key;
    }
  }
  for (const SceneRule& r : sceneRules()) {
    EXPECT_TRUE(findSceneKey(r.a)) << r.a;
    EXPECT_TRUE(findSceneKey(r.b)) << r.b;
  }
  EXPECT_EQ(findSceneKey("nonsense"), nullptr);
}

TEST(SceneSchema, EveryKeyReadsBackItsExampleAndItsDefault) {
  const std::string plain = Scene::fromJson("{}", "scene").toJson();
  for (const SceneKey& k : sceneSchema()) {
    if (k.type == SceneType::Object) continue;
    SCOPED_TRACE(k.key);
    // Its default given explicitly changes nothing.
    if (const json d = k.defaultValue(); !d.is_null()) {
      EXPECT_EQ(Scene::fromJson(sceneWith(k, d).dump(), "scene").toJson(), plain);
      EXPECT_EQ(k.problem(d), "");
    }
    if (k.example.is_null()) continue;
    EXPECT_NE(k.example, k.defaultValue());
    EXPECT_EQ(k.problem(k.example), "");
    const Scene s = Scene::fromJson(sceneWith(k, k.example).dump(), "scene");
    const json read = k.value(s);
    if (k.written == SceneWritten::Never) {
      // A way of giving other keys (a view is an orbit): the scene is not the default one.
      EXPECT_NE(s.toJson(), plain);
      continue;
    }
    if (k.type == SceneType::TransferFunction) {
      EXPECT_NE(read, k.defaultValue());
    } else {
      EXPECT_EQ(read, k.example);
    }
    // And through toJson.
    EXPECT_EQ(k.value(Scene::fromJson(s.toJson(), "again")), read);
  }
}

TEST(SceneSchema, EveryNameIsAccepted) {
  for (const SceneKey& k : sceneSchema())
    for (const std::string& name : k.names) EXPECT_EQ(readError(sceneWith(k, name)), "") << k.key << " " << name;
}

TEST(SceneSchema, ErrorsNameTheKeyTheValueAndWhatItMayBe) {
  int checked = 0;
  for (const SceneKey& k : sceneSchema()) {
    SCOPED_TRACE(k.key);
    std::vector<json> bad;
    if (k.type == SceneType::Number || k.type == SceneType::Integer) {
      const SceneRange& r = k.range;
      if (std::isfinite(r.hi)) bad.push_back(r.hi * 2 + 1);
      if (std::isfinite(r.lo)) bad.push_back(r.loOpen ? r.lo : r.lo - 1);
      if (r.zeroToo) bad.push_back(r.lo / 2);
      if (r.powerOfTwo) bad.push_back(3);
      if (k.type == SceneType::Integer) bad.push_back(r.lo + 0.5);
      bad.push_back("1");
    } else if (k.type == SceneType::Name) {
      bad = {"nope", 1};
    } else if (k.type == SceneType::Numbers) {
      bad = {json::array({1}), json::array({1, 2, 3, 4}), "nope"};
      if (std::isfinite(k.range.hi)) bad.push_back(json(std::vector<double>(size_t(k.minCount), k.range.hi + 1)));
      if (k.increasing) bad.push_back({5, 1});
    } else if (k.type == SceneType::Bool) {
      bad = {1, "true"};
    }
    for (const json& v : bad) {
      const std::string error = readError(sceneWith(k, v));
      EXPECT_MENTIONS(error, "scene.json: '" + k.key + "' must be " + k.allowed() + ", not ") << v.dump();
      if (v.is_number()) {
        EXPECT_MENTIONS(error, ", not " + numberText(v.get<double>()));
      }
      for (const std::string& name : k.names) EXPECT_MENTIONS(error, "\"" + name + "\"");
      ++checked;
    }
  }
  EXPECT_GT(checked, 60);
  // The words of one key in full, and a value of the wrong type.
  EXPECT_EQ(readError({{"ert", 0.3}}), "scene.json: 'ert' must be 0 or between 0.5 and 1, not 0.3");
  EXPECT_EQ(readError({{"step", "fine"}}), "scene.json: 'step' must be between 0.001 and 64 voxels, not \"fine\"");
  EXPECT_EQ(readError({{"slicer", "gpu"}}),
            "scene.json: 'slicer' must be one of \"vertex\", \"cpu\", \"vertex-lean\", \"geometry\", "
            "\"vertex-geometry\", not \"gpu\"; did you mean \"cpu\"?");
  EXPECT_EQ(
      readError({{"size", {512}}}),
      "scene.json: 'size' must be [width, height], integers between 1 and 8192 pixels, not [512]; e.g. [320,200]");
}

TEST(SceneSchema, ValidateHoldsEveryNumberToItsRange) {
  for (const SceneKey& k : sceneSchema()) {
    if (k.type != SceneType::Number && k.type != SceneType::Integer) continue;
    if (!std::isfinite(k.range.hi)) continue;
    SCOPED_TRACE(k.key);
    Scene s;
    k.set(s, k.range.hi + 1, {});  // set without the checks reading does: what code building a scene could do
    try {
      s.validate();
      ADD_FAILURE() << "validated " << k.key << " " << k.range.hi + 1;
    } catch (const RenderInputError& e) {
      EXPECT_MENTIONS(e.what(), "'" + k.key + "' must be " + k.allowed());
    }
  }
  Scene s;
  s.window = std::array<double, 2>{4, 4};
  EXPECT_THROW(s.validate(), RenderInputError);
  s.window.reset();
  s.provisionalEncoding = "gif";
  EXPECT_THROW(s.validate(), RenderInputError);
}

/// `dst`'s struct of `concern` copied from `src`.
void copyConcern(Scene& dst, const Scene& src, SceneConcern concern) {
  switch (concern) {
    case SceneConcern::View: static_cast<SceneView&>(dst) = src; break;
    case SceneConcern::Classification: static_cast<SceneClassification&>(dst) = src; break;
    case SceneConcern::Grid: static_cast<GridTechnique&>(dst) = src; break;
    case SceneConcern::Mesh: static_cast<MeshTechnique&>(dst) = src; break;
    case SceneConcern::Delivery: static_cast<SceneDelivery&>(dst) = src; break;
  }
}

TEST(SceneSchema, EveryKeyLivesInItsConcernsStruct) {
  const SceneConcern kConcerns[] = {SceneConcern::View, SceneConcern::Classification, SceneConcern::Grid,
                                    SceneConcern::Mesh, SceneConcern::Delivery};
  int checked = 0;
  for (const SceneKey& k : sceneSchema()) {
    if (k.example.is_null()) continue;
    const Scene given = Scene::fromJson(sceneWith(k, k.example).dump(), "scene");
    const json value = k.value(given);
    if (value.is_null() || value == k.defaultValue()) continue;
    SCOPED_TRACE(k.key);
    for (SceneConcern c : kConcerns) {
      Scene s;
      copyConcern(s, given, c);
      // Only the struct of the key's concern carries its value.
      if (c == k.concern) {
        EXPECT_EQ(k.value(s), value) << sceneConcernName(c);
      } else {
        EXPECT_EQ(k.value(s), k.defaultValue()) << sceneConcernName(c);
      }
    }
    ++checked;
  }
  EXPECT_GT(checked, 25);
}

TEST(SceneSchema, RulesRefuseKeysTogetherAndResetOthers) {
  for (const SceneRule& r : sceneRules()) {
    const SceneKey& a = *findSceneKey(r.a);
    const SceneKey& b = *findSceneKey(r.b);
    const json va = a.example.is_null() ? json(true) : a.example;
    const json vb = b.example.is_null() ? json(true) : b.example;
    SCOPED_TRACE(r.a + " " + r.b);
    if (r.kind == SceneRuleKind::Excludes) {
      json scene = json::object();
      putKey(scene, r.a, va);
      putKey(scene, r.b, vb);
      EXPECT_EQ(readError(scene), "scene.json: '" + r.a + "' cannot be combined with '" + r.b + "': " + r.reason);
    } else if (r.kind == SceneRuleKind::Needs) {
      json scene = json::object();
      putKey(scene, r.a, va);
      EXPECT_EQ(readError(scene), "scene.json: '" + r.a + "' needs '" + r.b + "': " + r.reason);
    }
  }
  // A slab size asks for slabs unless raycast is given.
  EXPECT_FALSE(Scene::fromJson(R"({"slab": 8})", "s").raycast);
  EXPECT_TRUE(Scene::fromJson(R"({"slab": 8, "raycast": true})", "s").raycast);
  EXPECT_TRUE(Scene::fromJson(R"({"step": 1})", "s").raycast);
}

TEST(SceneSchema, KeysLaidOverAFileReplaceWhatTheyExclude) {
  const SceneNames names = SceneNames::of("layers");
  const SceneKeys eye = sceneKeysOf(R"({"camera": {"eye": [0, -300, 0], "center": [0, 0, 10], "up": [0, 0, 1]}})", "f");
  // An orbit above replaces the eye, and the center and up that need it go too.
  SceneKeys laid = layerSceneKeys(eye, {{"camera.orbit", {10, 20}}}, names);
  EXPECT_FALSE(laid.count("camera.eye") || laid.count("camera.center") || laid.count("camera.up"));
  const Scene orbit = sceneFromKeys(laid, names);
  EXPECT_TRUE(orbit.camera.orbit);
  EXPECT_EQ(orbit.camera.azimuth, 10);
  // A center above keeps the file's eye and up.
  const Scene moved = sceneFromKeys(layerSceneKeys(eye, {{"camera.center", {1, 2, 3}}}, names), names);
  EXPECT_EQ(moved.camera.eye, glm::dvec3(0, -300, 0));
  EXPECT_EQ(moved.camera.center, glm::dvec3(1, 2, 3));
  EXPECT_EQ(moved.camera.up, glm::dvec3(0, 0, 1));
  // fit does not replace an eye: refused, naming both.
  try {
    layerSceneKeys(eye, {{"camera.fit", true}}, names);
    ADD_FAILURE() << "fit laid over an eye";
  } catch (const RenderInputError& e) {
    EXPECT_MENTIONS(e.what(), "layers: 'camera.fit' cannot be combined with 'camera.eye'");
  }
  // ... unless the same layer replaces the eye.
  EXPECT_NO_THROW(layerSceneKeys(eye, {{"camera.fit", true}, {"camera.orbit", {1, 2, 3}}}, names));
  // A quality target and the settings it chooses replace each other.
  const SceneKeys quality = sceneKeysOf(R"({"quality": "psnr:40"})", "f");
  const Scene stepped = sceneFromKeys(layerSceneKeys(quality, {{"step", 0.5}}, names), names);
  EXPECT_FALSE(stepped.quality);
  EXPECT_EQ(stepped.step, 0.5);
  const SceneKeys step = sceneKeysOf(R"({"step": 0.5, "lod": 2, "shading": true})", "f");
  const Scene targeted = sceneFromKeys(layerSceneKeys(step, {{"quality", "ms:100"}}, names), names);
  EXPECT_TRUE(targeted.quality);
  EXPECT_TRUE(targeted.shading);
  // A slab size above resets the file's raycast.
  const SceneKeys raycast = sceneKeysOf(R"({"raycast": true})", "f");
  EXPECT_FALSE(sceneFromKeys(layerSceneKeys(raycast, {{"slab", 8}}, names), names).raycast);
  EXPECT_TRUE(sceneFromKeys(layerSceneKeys(raycast, {{"slab", 8}, {"raycast", true}}, names), names).raycast);
}

TEST(SceneSchema, ToJsonWritesSchemaKeysAndAQualityTargetForItsSettings) {
  const json written = json::parse(Scene::fromJson(R"({"quality": "psnr:40", "interactive": true})", "s").toJson());
  for (const auto& [key, value] : written.items()) {
    ASSERT_TRUE(findSceneKey(key)) << key;
    if (value.is_object() && key == "camera") {
      for (const auto& [member, v] : value.items()) EXPECT_TRUE(findSceneKey(key + "." + member)) << member;
    }
  }
  for (const char* key : kQualityChosenKeys) EXPECT_FALSE(written.contains(key)) << key;
  EXPECT_EQ(written["quality"], "psnr:40");
  // Keys written only when changed: interactive is, its budget is not.
  EXPECT_EQ(written["interactive"], true);
  EXPECT_FALSE(written.contains("time_budget_ms"));
  EXPECT_FALSE(json::parse(Scene{}.toJson()).contains("interactive"));
}

TEST(SceneSchema, TheSchemaAsJsonCarriesEveryKeyAndRule) {
  const json j = sceneSchemaJson();
  ASSERT_EQ(j["keys"].size(), sceneSchema().size());
  ASSERT_EQ(j["rules"].size(), sceneRules().size());
  for (size_t i = 0; i < sceneSchema().size(); ++i) {
    const SceneKey& k = sceneSchema()[i];
    const json& e = j["keys"][i];
    EXPECT_EQ(e["key"], k.key);
    EXPECT_EQ(e["default"], k.defaultValue());
    EXPECT_EQ(e["default_text"], k.defaultText());
    EXPECT_EQ(e["option"].is_null(), k.option.empty());
  }
  // Defaults are the struct's: a few read directly.
  EXPECT_EQ(findSceneKey("step")->defaultText(), numberText(Scene{}.step));
  EXPECT_EQ(findSceneKey("size")->defaultText(), "512x512");
  EXPECT_EQ(findSceneKey("transfer_function")->defaultText(), Scene{}.transferFunctionName);
  EXPECT_EQ(findSceneKey("window")->defaultText(), "the dataset's value range");
}

TEST(SceneSchema, TheProtocolDocumentsEveryKey) {
  const auto bytes = test::readFile(std::string(VOXBRICK_SOURCE_DIR) + "/proto/PROTOCOL.md");
  const std::string text(bytes.begin(), bytes.end());
  const size_t start = text.find("## 6. Scene JSON"), end = text.find("## 7.");
  ASSERT_LT(start, end);
  const std::string section = text.substr(start, end - start);
  for (const SceneKey& k : sceneSchema())
    EXPECT_NE(section.find("| `" + k.key + "` |"), std::string::npos) << k.key << " is missing from PROTOCOL.md";
}

}  // namespace
}  // namespace voxbrick::render
