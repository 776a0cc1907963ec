// The scene schema: the shipped examples parse, every rule has an error naming it, and toJson round-trips.
#include <gtest/gtest.h>

#include <filesystem>

#include "render/RenderErrors.h"
#include "render/Scene.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

std::string text(const std::filesystem::path& p) {
  auto bytes = test::readFile(p);
  return std::string(bytes.begin(), bytes.end());
}

TEST(SceneJson, ShippedExamplesParse) {
  int parsed = 0;
  for (auto& e : std::filesystem::directory_iterator(std::filesystem::path(VOXBRICK_SOURCE_DIR) / "config/scenes")) {
    EXPECT_NO_THROW(Scene::fromJson(text(e.path()), e.path().string())) << e.path();
    ++parsed;
  }
  EXPECT_GE(parsed, 2);
  const Scene mri = Scene::fromJson(text(std::filesystem::path(VOXBRICK_SOURCE_DIR) / "config/scenes/mri-lateral.json"),
                                    "mri-lateral");
  EXPECT_FALSE(mri.camera.orbit);
  EXPECT_EQ(mri.camera.up, glm::dvec3(0, 0, 1));
  EXPECT_TRUE(mri.shading);
  EXPECT_EQ(mri.transferFunctionName, "mri");
}

TEST(SceneJson, ErrorsNameTheKey) {
  auto expectError = [](const std::string& json, const std::string& words) {
    try {
      Scene::fromJson(json, "scene.json");
      ADD_FAILURE() << "accepted " << json;
    } catch (const RenderInputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expectError("[1, 2]", "object");
  expectError("{\"sise\": [1, 2]}", "unknown key 'sise'");
  expectError("{\"camera\": {\"orbit\": [0, 0, 2], \"zoom\": 2}}", "unknown key 'camera.zoom'");
  expectError(std::string("{\"size\": [32, 32]}") + '\0' + "garbage", "NUL byte at offset 18");
  expectError("{\"size\": [32, 32]} {}", "not valid JSON");
  expectError("{\"size\": [0, 10]}", "image size");
  expectError("{\"size\": [100000, 10]}", "image size");
  expectError("{\"size\": [10]}", "size");
  expectError("{\"step\": 0}", "step");
  expectError("{\"step\": \"fine\"}", "'step'");
  expectError("{\"background\": [2, 0, 0]}", "background");
  expectError("{\"window\": [5, 1]}", "window");
  expectError("{\"camera\": {\"orbit\": [0, 0, 2], \"eye\": [1, 2, 3]}}", "both");
  expectError("{\"camera\": {\"fov\": 200}}", "fov");
  expectError("{\"slicer\": \"gpu\"}", "slicer");
  // An unknown slicer is refused with the valid names.
  expectError("{\"slicer\": \"gpu\"}",
              "unknown slicer 'gpu' (one of \"vertex\", \"cpu\", \"vertex-lean\", \"geometry\", \"vertex-geometry\")");
  expectError("{\"slicer\": 2}", "'slicer' must be one of \"vertex\"");
  expectError("{\"transfer_function\": {\"points\": []}}", "transfer_function");
  expectError("{\"transfer_function\": 7}", "transfer_function");
  expectError("not json", "not valid JSON");
}

TEST(SceneJson, EverySlicerByName) {
  for (Slicer slicer : kSlicers) {
    const std::string name = slicerName(slicer);
    const Scene s = Scene::fromJson("{\"slicer\": \"" + name + "\"}", "scene.json");
    EXPECT_EQ(s.slicer, slicer) << name;
    EXPECT_EQ(Scene::fromJson(s.toJson(), "round trip").slicer, slicer) << name;
    EXPECT_EQ(parseSlicer(name, "--slicer"), slicer);
  }
  EXPECT_EQ(std::string(slicerName(Slicer::VertexGeometry)), "vertex-geometry");
  EXPECT_THROW(parseSlicer("Vertex", "--slicer"), RenderInputError);
}

TEST(SceneJson, ToJsonRoundTrips) {
  Scene s;
  s.camera.orbit = false;
  s.camera.eye = {1, 2, 3};
  s.camera.up = {0, 0, 1};
  s.camera.orthographic = true;
  s.width = 320;
  s.height = 200;
  s.step = 0.25;
  s.background = {0.1, 0.2, 0.3};
  s.window = std::array<double, 2>{-1, 4};
  s.skipEmpty = false;
  s.slicer = Slicer::Cpu;
  s.shading = true;
  const Scene t = Scene::fromJson(s.toJson(), "round trip");
  EXPECT_EQ(t.camera.eye, s.camera.eye);
  EXPECT_EQ(t.camera.up, s.camera.up);
  EXPECT_TRUE(t.camera.orthographic);
  EXPECT_EQ(t.width, 320);
  EXPECT_EQ(t.height, 200);
  EXPECT_EQ(t.step, 0.25);
  EXPECT_EQ(t.background, s.background);
  EXPECT_EQ(*t.window, *s.window);
  EXPECT_FALSE(t.skipEmpty);
  EXPECT_EQ(t.slicer, Slicer::Cpu);
  EXPECT_TRUE(t.shading);
  EXPECT_EQ(t.transferFunction.evaluate(0.37), s.transferFunction.evaluate(0.37));
}

}  // namespace
}  // namespace voxbrick::render
