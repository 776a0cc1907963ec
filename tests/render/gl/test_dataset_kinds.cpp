// Dataset kinds through their drivers: a kind added at run time (a toy that paints the frame one colour) is opened
// by path, drawn by the engine, judged by its reference and summarised, with no code outside its driver knowing it;
// the built-in kinds answer through theirs (opening, renderers, sort-last parts, references), and a kind without a
// driver is refused naming it.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>

#include "mesh/MeshStore.h"
#include "mesh/MeshStoreFixtures.h"
#include "render/core/RenderErrors.h"
#include "render/engine/DatasetDriver.h"
#include "render/engine/Datasets.h"
#include "render/engine/RenderEngine.h"
#include "render/gl/GlFixtures.h"
#include "support/StubDataset.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::ScratchDir;

// The toy kind: a directory holding toy.txt with three numbers, the colour every pixel of its frames gets.
class ToyDataset final : public Dataset {
 public:
  ToyDataset(std::string name, const std::filesystem::path& path, glm::dvec3 colour)
      : Dataset(std::move(name), path), mColour(colour) {}
  std::string_view kind() const override { return "toy"; }
  std::string infoJson() const override { return R"({"kind": "toy"})"; }
  store::CacheStats cacheStats() const override { return {}; }
  void setCacheBudget(size_t) const override {}
  glm::dvec3 colour() const { return mColour; }

 private:
  glm::dvec3 mColour;
};

image::ImageF paint(const Scene& scene, glm::dvec3 colour) {
  image::ImageF image{scene.width, scene.height, {}};
  for (int i = 0; i < scene.width * scene.height; ++i)
    image.rgba.insert(image.rgba.end(), {float(colour.r), float(colour.g), float(colour.b), 1.0f});
  return image;
}

class ToyRenderer final : public FrameRenderer {
 public:
  explicit ToyRenderer(glm::dvec3 colour) : mColour(colour) {}
  image::ImageF render(const Scene& scene, FrameStats* stats, const FrameOptions&) override {
    const auto start = std::chrono::steady_clock::now();
    image::ImageF image = paint(scene, mColour);
    if (stats) {
      *stats = {};
      stats->samplesEstimated = estimateSamples(scene);
      // At least a microsecond: a frame timed at zero feeds no rate.
      stats->msTotal =
          std::max(1e-3, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    return image;
  }
  size_t gpuBytes() const override { return 0; }
  double estimateSamples(const Scene& scene) override { return double(scene.width) * scene.height; }

 private:
  glm::dvec3 mColour;
};

class ToyDriver final : public DatasetDriver {
 public:
  std::string_view kind() const override { return "toy"; }
  bool recognises(const std::filesystem::path& path) const override {
    return std::filesystem::is_regular_file(path / "toy.txt");
  }
  std::vector<std::filesystem::path> files(const std::filesystem::path& path) const override {
    return {path / "toy.txt"};
  }
  std::shared_ptr<const Dataset> open(std::string name, const std::filesystem::path& path, size_t,
                                      const store::StoreOpenOptions&) const override {
    glm::dvec3 colour;
    std::ifstream(path / "toy.txt") >> colour.r >> colour.g >> colour.b;
    return std::make_shared<ToyDataset>(std::move(name), path, colour);
  }
  size_t gpuBytesWanted(const Dataset&, const RendererSetup&) const override { return 0; }
  std::unique_ptr<FrameRenderer> makeRenderer(const Dataset& dataset, const RendererSetup&) const override {
    return std::make_unique<ToyRenderer>(static_cast<const ToyDataset&>(dataset).colour());
  }
  ReferenceFrame reference(const Dataset& dataset, const Scene& scene, const ReferenceSettings&) const override {
    return {paint(scene, static_cast<const ToyDataset&>(dataset).colour()),
            {{"pixels", scene.width * scene.height}},
            "with the toy's reference"};
  }
  std::vector<std::string> summary(const Dataset&, const Scene&, const FrameStats&,
                                   const std::string& written) const override {
    return {written + ": one colour"};
  }
};

// The one registration line a new kind needs (here at run time, once for the whole test program).
void registerToy() {
  static const bool once = (registerDriver(std::make_shared<ToyDriver>()), true);
  (void)once;
}

Scene smallScene() {
  Scene scene;
  scene.width = 24;
  scene.height = 16;
  return scene;
}

TEST(DatasetKinds, AKindAddedAtRunTimeIsOpenedDrawnJudgedAndSummarised) {
  registerToy();
  ScratchDir dir;
  std::filesystem::create_directories(dir / "t");
  test::writeFile(dir / "t" / "toy.txt", std::string("0.25 0.5 0.75\n"));
  ASSERT_TRUE(isDataset(dir / "t"));
  EXPECT_EQ(datasetFiles(dir / "t"), std::vector<std::filesystem::path>{dir / "t" / "toy.txt"});
  const auto dataset = openDataset("t", dir / "t", size_t(1) << 20);
  EXPECT_EQ(dataset->kind(), "toy");
  // `voxbrick info` of it: the default report names its path and kind.
  const DatasetReport report = describeDataset(dir / "t");
  EXPECT_EQ(report.json["kind"], "toy");
  EXPECT_EQ(report.json["path"], (dir / "t").string());
  EXPECT_NE(report.text.find("toy"), std::string::npos) << report.text;

  RenderEngine engine(RenderEngineOptions{});
  FrameStats stats;
  const image::ImageF frame = engine.render(dataset, smallScene(), &stats);
  ASSERT_EQ(frame.width, 24);
  ASSERT_EQ(frame.height, 16);
  for (size_t i = 0; i < frame.rgba.size(); i += 4) {
    ASSERT_FLOAT_EQ(frame.rgba[i], 0.25f);
    ASSERT_FLOAT_EQ(frame.rgba[i + 1], 0.5f);
    ASSERT_FLOAT_EQ(frame.rgba[i + 2], 0.75f);
  }
  EXPECT_EQ(stats.samplesEstimated, 24.0 * 16.0);
  EXPECT_GT(engine.recentRate(*dataset), 0.0) << "the toy's frames are timed like any other kind's";

  const DatasetDriver& driver = driverFor(*dataset);
  const ReferenceFrame reference = driver.reference(*dataset, smallScene(), {});
  EXPECT_EQ(reference.image.rgba, frame.rgba);
  EXPECT_EQ(driver.summary(*dataset, smallScene(), stats, "wrote x"), std::vector<std::string>{"wrote x: one colour"});
  EXPECT_FALSE(driver.sortsLast());
  EXPECT_THROW(driver.partition(*dataset, 2), RenderInputError);
  EXPECT_THROW(registerDriver(std::make_shared<ToyDriver>()), std::invalid_argument) << "a kind is registered once";
}

TEST(DatasetKinds, AKindWithoutADriverIsRefusedNamingIt) {
  const auto stray = std::make_shared<test::StubDataset>("stray", "point-cloud");
  RenderEngine engine(RenderEngineOptions{});
  try {
    engine.render(stray, smallScene());
    FAIL() << "a kind without a driver was drawn";
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find("'point-cloud'"), std::string::npos) << e.what();
  }
  EXPECT_EQ(findDriver("point-cloud"), nullptr);
  EXPECT_FALSE(isDataset("/nowhere"));
}

TEST(DatasetKinds, TheBuiltInKindsAnswerThroughTheirDrivers) {
  ScratchDir dir;
  test::prep("synthetic:blobs,n=32", dir / "grid.vbs", 16);
  mesh::writeMeshStore(mesh::test::kuhnGrid(3, 3, 3), mesh::test::matchFaces(mesh::test::kuhnGrid(3, 3, 3)),
                       dir / "mesh");
  const auto grid = openDataset("grid", dir / "grid.vbs", size_t(64) << 20);
  const auto tets = openDataset("mesh", dir / "mesh", size_t(64) << 20);
  EXPECT_EQ(grid->kind(), "brick-store");
  EXPECT_EQ(tets->kind(), "tet-mesh");
  // `voxbrick info`: each kind's own report, and a path no kind recognises described as a store that lacks its files.
  EXPECT_EQ(describeDataset(dir / "grid.vbs").json["kind"], "brick-store");
  EXPECT_EQ(describeDataset(dir / "grid.vbs").json["dims"], (nlohmann::json{32, 32, 32}));
  EXPECT_EQ(describeDataset(dir / "mesh").json["kind"], "tet-mesh");
  EXPECT_EQ(describeDataset(dir / "mesh").json["tets"], 3 * 3 * 3 * 6);
  EXPECT_NE(describeDataset(dir / "mesh").text.find("mesh store"), std::string::npos);
  std::filesystem::create_directories(dir / "half");
  try {
    describeDataset(dir / "half");
    FAIL() << "an empty directory was described";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("store.json"), std::string::npos) << e.what();
  }
  EXPECT_EQ(datasetFiles(dir / "grid.vbs"),
            (std::vector<std::filesystem::path>{dir / "grid.vbs" / "store.json", dir / "grid.vbs" / "bricks.bin"}));

  // Sort-last: a grid splits into boxes of its voxels (FrameOptions::part), a mesh into world-space boxes
  // (FrameOptions::meshPart).
  const DatasetDriver& gridDriver = driverFor(*grid);
  ASSERT_TRUE(gridDriver.sortsLast());
  const auto parts = gridDriver.partition(*grid, 2);
  ASSERT_EQ(parts->count(), 2);
  const std::vector<int> order = parts->frontToBack(smallScene());
  EXPECT_EQ(order.size(), 2u);
  EXPECT_NE(order[0], order[1]);
  FrameOptions gridPart;
  parts->select(1, gridPart);
  EXPECT_TRUE(gridPart.part.has_value());
  EXPECT_FALSE(gridPart.meshPart.has_value());
  ASSERT_TRUE(driverFor(*tets).sortsLast());
  const auto meshParts = driverFor(*tets).partition(*tets, 3);
  ASSERT_EQ(meshParts->count(), 3);
  EXPECT_EQ(meshParts->frontToBack(smallScene()).size(), 3u);
  FrameOptions meshPart;
  meshParts->select(2, meshPart);
  EXPECT_TRUE(meshPart.meshPart.has_value());
  EXPECT_FALSE(meshPart.part.has_value());

  // A sub-block must cut a grid's bricks; a mesh has none to check.
  EXPECT_NO_THROW(gridDriver.checkSubBlock(*grid, 8));
  EXPECT_THROW(gridDriver.checkSubBlock(*grid, 16), RenderInputError);
  EXPECT_NO_THROW(driverFor(*tets).checkSubBlock(*tets, 16));
  // The mesh's reference takes no analytic field.
  EXPECT_THROW(driverFor(*tets).reference(*tets, smallScene(), {0.125, "sphere"}), RenderInputError);

  // Both drawn by one engine, each by its own renderer, within its budget.
  RenderEngine engine(RenderEngineOptions{});
  Scene scene = smallScene();
  scene.transferFunction = TransferFunction::load("hot");
  FrameStats gridStats, meshStats;
  engine.render(grid, scene, &gridStats);
  engine.render(tets, scene, &meshStats);
  EXPECT_GT(gridStats.bricksDrawn, 0);
  EXPECT_GT(meshStats.tetsDrawn + meshStats.tetRayPasses, 0);
  EXPECT_EQ(driverFor(*grid).summary(*grid, scene, gridStats, "wrote g").size(), 1u);
  EXPECT_EQ(driverFor(*tets).summary(*tets, scene, meshStats, "wrote m").size(), 1u);
}

}  // namespace
}  // namespace voxbrick::render
