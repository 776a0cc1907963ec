// The scene schema: the shipped examples parse, every rule has an error naming it, and toJson round-trips.
#include <gtest/gtest.h>

#include <filesystem>

#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"
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

/// Expects the scene `text` to be refused with `words` in the message.
void expectError(const std::string& text, const std::string& words) {
  try {
    Scene::fromJson(text, "scene.json");
    ADD_FAILURE() << "accepted " << text;
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(SceneJson, ErrorsNameTheKey) {
  expectError("[1, 2]", "object");
  expectError("{\"sise\": [1, 2]}", "unknown key 'sise'");
  expectError("{\"camera\": {\"orbit\": [0, 0, 2], \"zoom\": 2}}", "unknown key 'camera.zoom'");
  expectError(std::string("{\"size\": [32, 32]}") + '\0' + "garbage", "NUL byte at offset 18");
  expectError("{\"size\": [32, 32]} {}", "not valid JSON");
  expectError("{\"size\": [0, 10]}", "'size' must be [width, height], integers between 1 and 8192 pixels, not [0, 10]");
  expectError("{\"size\": [100000, 10]}", "not [100000, 10]");
  expectError("{\"size\": [10]}", "size");
  expectError("{\"step\": 0}", "step");
  expectError("{\"step\": \"fine\"}", "'step'");
  expectError("{\"background\": [2, 0, 0]}", "background");
  expectError("{\"window\": [5, 1]}", "window");
  expectError("{\"camera\": {\"orbit\": [0, 0, 2], \"eye\": [1, 2, 3]}}",
              "'camera.orbit' cannot be combined with 'camera.eye'");
  expectError("{\"camera\": {\"fov\": 200}}", "fov");
  expectError("{\"slicer\": \"gpu\"}", "slicer");
  // An unknown slicer is refused with the valid names.
  expectError("{\"slicer\": \"gpu\"}",
              "'slicer' must be one of \"vertex\", \"cpu\", \"vertex-lean\", \"geometry\", \"vertex-geometry\", "
              "not \"gpu\"");
  expectError("{\"slicer\": 2}", "'slicer' must be one of \"vertex\"");
  expectError("{\"transfer_function\": {\"points\": []}}", "transfer_function");
  expectError("{\"transfer_function\": 7}", "transfer_function");
  expectError("not json", "not valid JSON");
  expectError("{\"jpeg_quality\": 0}", "'jpeg_quality' must be an integer between 1 and 100, not 0");
  expectError("{\"jpeg_quality\": 85.5}", "'jpeg_quality'");
  expectError("{\"provisional_encoding\": \"gif\"}", "'provisional_encoding' must be one of");
  expectError("{\"provisional_encoding\": 3}", "'provisional_encoding'");
}

TEST(SceneJson, FrameEncodingKeys) {
  const Scene plain = Scene::fromJson("{}", "scene");
  EXPECT_FALSE(plain.jpegQuality);
  EXPECT_FALSE(plain.provisionalEncoding);
  const Scene s = Scene::fromJson(R"({"jpeg_quality": 60, "provisional_encoding": "jpeg"})", "scene");
  EXPECT_EQ(s.jpegQuality, 60);
  EXPECT_EQ(s.provisionalEncoding, "jpeg");
  const Scene back = Scene::fromJson(s.toJson(), "scene");
  EXPECT_EQ(back.jpegQuality, 60);
  EXPECT_EQ(back.provisionalEncoding, "jpeg");
  for (const char* name : Scene::kEncodingNames)
    EXPECT_EQ(Scene::fromJson(std::string(R"({"provisional_encoding": ")") + name + "\"}", "scene").provisionalEncoding,
              name);
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

TEST(SceneJson, CameraKeysAndWhatIsRefused) {
  // center and up only mean something beside an eye: an orbit silently dropped them before.
  expectError("{\"camera\": {\"orbit\": [0, 0, 2], \"center\": [1, 2, 3]}}", "'camera.center' needs 'camera.eye'");
  expectError("{\"camera\": {\"up\": [0, 0, 1]}}", "'camera.up' needs 'camera.eye'");
  expectError("{\"camera\": {\"view\": \"anterior\", \"orbit\": [0, 0]}}", "'camera.view' cannot be combined");
  expectError("{\"camera\": {\"view\": \"front\"}}",
              "'camera.view' must be one of \"anterior\", \"posterior\", \"left\", \"right\", \"superior\", "
              "\"inferior\", not \"front\"");
  expectError("{\"camera\": {\"up_axis\": \"z+\"}}", "'camera.up_axis' must be one of \"+x\", \"-x\"");
  expectError("{\"camera\": {\"eye\": [0, 0, 5], \"fit\": true}}",
              "'camera.fit' cannot be combined with 'camera.eye': the fitted distance is an orbit's");
  expectError("{\"camera\": {\"orbit\": [0]}}", "[az, el] or [az, el, dist]");
  expectError("{\"camera\": {\"orbit\": [0, 0], \"fit\": false}}", "'camera.fit' false needs a distance");
  expectError("{\"camera\": {\"orbit\": [0, 0, 2], \"zoom\": 2}}", "(one of orbit, fit, up_axis, view, eye");

  const Scene fitted = Scene::fromJson("{\"camera\": {\"orbit\": [10, 20]}}", "s");
  EXPECT_FALSE(fitted.camera.distance);
  EXPECT_EQ(fitted.camera.upAxis, UpAxis::PosZ);
  const Scene placed = Scene::fromJson("{\"camera\": {\"orbit\": [10, 20, 3], \"up_axis\": \"-y\"}}", "s");
  EXPECT_EQ(placed.camera.distance.value_or(0), 3);
  EXPECT_EQ(placed.camera.upAxis, UpAxis::NegY);
  EXPECT_FALSE(Scene::fromJson("{\"camera\": {\"orbit\": [10, 20, 3], \"fit\": true}}", "s").camera.distance);
  const Scene left = Scene::fromJson("{\"camera\": {\"view\": \"left\"}}", "s");
  EXPECT_EQ(left.camera.azimuth, 90);
  EXPECT_EQ(left.camera.elevation, 0);
  EXPECT_FALSE(left.camera.distance);
  const Scene again = Scene::fromJson(placed.toJson(), "round trip");
  EXPECT_EQ(again.camera.upAxis, UpAxis::NegY);
  EXPECT_EQ(again.camera.distance.value_or(0), 3);
}

// NDC x and y of world point `p` seen by `camera` drawing a square image.
glm::dvec2 project(const Camera& camera, const glm::dvec3& p) {
  const glm::dvec4 c = camera.projection(1, 0.1, 1000) * camera.view() * glm::dvec4(p, 1);
  return glm::dvec2(c) / c.w;
}

TEST(CameraSpecWorld, ResolvedCameraSeesTheWorldAsTheWorldCameraDoes) {
  // A volume whose index axes are permuted and flipped, off the origin: the camera resolved into its local frame
  // sees each point where the same spec resolved in the world sees its world position; a mirrored frame sees it
  // mirrored left to right (which finishImage undoes).
  const Box local = volumeBox({10, 20, 30}, {1, 2, 0.5});
  for (bool mirrored : {false, true}) {
    store::Orientation o;
    o.axes = {{{0, 1, 0}, {mirrored ? 1.0 : -1.0, 0, 0}, {0, 0, 1}}};
    o.origin = {5, -7, 11};
    o.patient = true;
    const WorldFrame frame = WorldFrame::of(o, {10, 20, 30}, {1, 2, 0.5});
    EXPECT_EQ(frame.mirrored(), mirrored);
    const glm::dvec3 half = 0.5 * local.extent();
    const Box worldBox{frame.center - half, frame.center + half};
    for (bool orbit : {true, false}) {
      CameraSpec spec;
      spec.orbit = orbit;
      spec.eye = frame.center + glm::dvec3(30, 40, 50);
      spec.center = frame.center + glm::dvec3(1, 2, 3);
      spec.up = {0, 0, 1};
      const Camera inLocal = spec.resolve(local, frame), inWorld = spec.resolve(worldBox);
      for (const glm::dvec3& p : {glm::dvec3(0.0), glm::dvec3(3, -4, 5), glm::dvec3(-6, 2, -1)}) {
        const glm::dvec2 w = project(inWorld, frame.pointToWorld(p)), l = project(inLocal, p);
        EXPECT_NEAR(l.x, mirrored ? -w.x : w.x, 1e-9) << "orbit " << orbit << " mirrored " << mirrored;
        EXPECT_NEAR(l.y, w.y, 1e-9) << "orbit " << orbit << " mirrored " << mirrored;
      }
    }
  }
  // Voxel (0, 0, 0) of the local box sits at the orientation's origin.
  store::Orientation o;
  o.origin = {1, 2, 3};
  const WorldFrame frame = WorldFrame::of(o, {10, 20, 30}, {1, 2, 0.5});
  const glm::dvec3 voxel0 = local.min + 0.5 * glm::dvec3(1, 2, 0.5);
  const glm::dvec3 world0 = frame.pointToWorld(voxel0);
  EXPECT_NEAR(world0.x, 1, 1e-12);
  EXPECT_NEAR(world0.y, 2, 1e-12);
  EXPECT_NEAR(world0.z, 3, 1e-12);
}

TEST(CameraSpecWorld, FlipHorizontallyMirrorsRows) {
  image::ImageF image{3, 2, std::vector<float>(24)};
  for (size_t i = 0; i < image.rgba.size(); ++i) image.rgba[i] = float(i);
  WorldFrame frame;
  finishImage(frame, image);  // not mirrored: unchanged
  EXPECT_EQ(image.pixel(0, 1)[0], 12.0f);
  frame.rotation[0] = -frame.rotation[0];
  finishImage(frame, image);
  EXPECT_EQ(image.pixel(0, 1)[0], 20.0f);
  EXPECT_EQ(image.pixel(2, 1)[3], 15.0f);
  EXPECT_EQ(image.pixel(1, 0)[1], 5.0f);
  // The 8-bit frame (what render8 returns) the same way, at an odd width (the middle column stays).
  image::Image8 bytes{3, 2, std::vector<uint8_t>(24)};
  for (size_t i = 0; i < bytes.rgba.size(); ++i) bytes.rgba[i] = uint8_t(i);
  finishImage(WorldFrame{}, bytes);
  EXPECT_EQ(bytes.rgba[12], 12);
  finishImage(frame, bytes);
  const std::vector<uint8_t> expected = {8,  9,  10, 11, 4,  5,  6,  7,  0,  1,  2,  3,
                                         20, 21, 22, 23, 16, 17, 18, 19, 12, 13, 14, 15};
  EXPECT_EQ(bytes.rgba, expected);
}

}  // namespace
}  // namespace voxbrick::render
