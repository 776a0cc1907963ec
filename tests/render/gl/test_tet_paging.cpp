// A mesh store larger than its host budget, paged by view (TetMeshSource): each frame reads only the chunks its view
// reaches (and, when they do not all fit, only those the transfer function shows), within the budget, and draws the
// frame the whole mesh gives; a view that cannot fit is refused naming the sizes; a corrupt chunk is a corrupt store.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include <nlohmann/json.hpp>

#include "brickstore/format/Errors.h"
#include "image/Image.h"
#include "mesh/MeshFormat.h"
#include "mesh/MeshStore.h"
#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"
#include "render/core/Dataset.h"
#include "render/core/RenderErrors.h"
#include "render/engine/Datasets.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/tets/TetRenderer.h"
#include "render/reference/TetReference.h"
#include "render/tets/TetMeshDataset.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

/// The "blobs" box of n cells a side, stored in chunks of `tetsPerChunk` tets.
std::filesystem::path writeBox(const std::filesystem::path& dir, int n, uint32_t tetsPerChunk) {
  const mesh::TetMesh m = mesh::syntheticMesh("box,n=" + std::to_string(n));
  mesh::MeshStoreOptions options;
  options.tetsPerChunk = tetsPerChunk;
  mesh::writeMeshStore(m, mesh::buildTopology(m), dir / "box", options);
  return dir / "box";
}

/// The bytes the whole mesh at `path` takes held in memory.
size_t wholeBytes(const std::filesystem::path& path) {
  const mesh::MeshStoreInfo info = mesh::MeshStore::open(path).info();
  return TetMeshData::hostBytes(info.tetCount, info.vertexCount, info.boundaryFaceCount);
}

/// A transfer function transparent below half the value window, the blobs' peaks shown above it.
TransferFunction peaks() {
  return TransferFunction({{0, {1, 0.5, 0, 0}}, {0.5, {1, 0.5, 0, 0}}, {1, {1, 1, 0.6, 0.8}}});
}

/// A 96x80 ray cast frame (ert off) of the orbit at `azimuth`; `narrow`: a 10-degree view along +y near the box's
/// (+x, +z) edge, which sees about a quarter of its chunks.
Scene sceneOf(const TransferFunction& tf, double azimuth, bool narrow = false) {
  Scene scene;
  scene.width = 96;
  scene.height = 80;
  scene.camera.azimuth = azimuth;
  scene.camera.elevation = 20;
  if (narrow) {
    scene.camera.orbit = false;
    scene.camera.eye = {0.6, -3, 0.6};
    scene.camera.center = {0.6, 0, 0.6};
    scene.camera.up = {0, 0, 1};
    scene.camera.fovY = 10;
  }
  scene.transferFunction = tf;
  scene.visibility = TetSort::Ray;
  scene.ert = 0;
  return scene;
}

const TetMeshDataset& meshOf(const std::shared_ptr<const Dataset>& d) {
  return dynamic_cast<const TetMeshDataset&>(*d);
}

TEST(TetPaging, AFrameReadsOnlyWhatItsViewNeedsAndEqualsTheWholeMeshsFrame) {
  test::ScratchDir dir;
  const auto path = writeBox(dir.path(), 20, 256);  // 48000 tets in 188 chunks
  const size_t whole = wholeBytes(path);
  const auto wholeSet = openDataset("box", path, whole);
  ASSERT_FALSE(meshOf(wholeSet).source()->paged()) << "a mesh that fits is held whole";
  // Four fifths of the whole: the points and three quarters of the tets.
  const size_t budget = whole * 4 / 5;
  const auto paged = openDataset("box", path, budget);
  const TetMeshSource& source = *meshOf(paged).source();
  ASSERT_TRUE(source.paged());
  EXPECT_EQ(meshOf(paged).infoJson(), [&] {
    // Everything a client is told but the paging itself is the same.
    nlohmann::json j = nlohmann::json::parse(meshOf(wholeSet).infoJson());
    j["paged"] = true;
    j["chunks"] = source.chunkCount();
    return j.dump();
  }());
  EXPECT_DOUBLE_EQ(source.constants().meanEdgeLength, meshOf(wholeSet).source()->constants().meanEdgeLength);

  TetRenderer wholeRenderer(test::context(), meshOf(wholeSet).source(), size_t(256) << 20);
  TetRenderer pagedRenderer(test::context(), meshOf(paged).source(), size_t(256) << 20);
  struct Case {
    std::string name;
    Scene scene;
    bool culls, skips, reads;
  };
  // Narrow: most of the box is outside the frustum. Peaks: transparent over the low half of the values, so the
  // chunks in view do not all fit and the transparent ones are left out (the ray caster then re-enters beyond them).
  const std::vector<Case> cases = {{"narrow", sceneOf(TransferFunction::load("hot"), 30, true), true, false, true},
                                   {"peaks", sceneOf(peaks(), 30), false, true, true},
                                   // The same chunks as the last view: its working set is kept.
                                   {"peaks projected", sceneOf(peaks(), 120), false, true, false}};
  for (Case c : cases) {
    SCOPED_TRACE(c.name);
    if (c.name == "peaks projected") c.scene.visibility = TetSort::Mpvo;
    FrameStats stats, again, wholeStats;
    const image::ImageF fromPages = pagedRenderer.render(c.scene, &stats);
    const image::ImageF fromWhole = wholeRenderer.render(c.scene, &wholeStats);
    ASSERT_GT(test::meanBrightness(fromWhole), 0.01);
    // The same tets along every ray, composited by the same programs: equal up to the order of float sums where a
    // ray re-enters beyond a gap.
    test::expectClose(fromPages, fromWhole, 1e-4, "tet-paging-" + c.name);
    EXPECT_EQ(stats.tetChunksCulled > 0, c.culls) << stats.tetChunksCulled;
    EXPECT_EQ(stats.tetChunksSkippedEmpty > 0, c.skips) << stats.tetChunksSkippedEmpty;
    EXPECT_EQ(stats.tetChunksRead > 0, c.reads);
    if (c.reads) {
      EXPECT_EQ(stats.tetChunksRead + stats.tetChunksCulled + stats.tetChunksSkippedEmpty,
                int64_t(source.chunkCount()));
    }
    EXPECT_EQ(wholeStats.tetChunksRead + wholeStats.tetChunksCulled + wholeStats.tetChunksSkippedEmpty, 0);
    if (c.scene.visibility == TetSort::Ray) {
      EXPECT_GT(stats.tetRayPasses, 1);
    } else {
      EXPECT_EQ(stats.tetsDrawn, wholeStats.tetsDrawn) << "every tet the transfer function shows";
    }
    // The next frame of the same view finds its working set kept: nothing is read, the same image.
    const image::ImageF second = pagedRenderer.render(c.scene, &again);
    EXPECT_EQ(again.tetChunksRead, 0);
    EXPECT_EQ(image::compareImages(second, fromPages).maxAbs, 0.0);
  }
  const store::CacheStats cache = paged->cacheStats();
  EXPECT_EQ(cache.budgetBytes, budget);
  EXPECT_LE(cache.peakResidentBytes, budget) << "the host budget held";
  EXPECT_EQ(cache.hits, 4u);  // the second frame of each view, and the peaks' second view
  EXPECT_EQ(cache.misses, 2u);
  EXPECT_EQ(wholeSet->cacheStats().misses, 0u);
}

TEST(TetPaging, TheExactReferenceOfAPagedFrameIsTheWholeMeshs) {
  test::ScratchDir dir;
  const auto path = writeBox(dir.path(), 16, 256);
  const auto paged = openDataset("box", path, wholeBytes(path) * 4 / 5);
  const TetMeshSource& source = *meshOf(paged).source();
  ASSERT_TRUE(source.paged());
  const mesh::MeshStore store = mesh::MeshStore::open(path);
  const mesh::TetMesh all = store.readAll();
  const Scene scene = sceneOf(peaks(), 50);
  FrameStats stats;
  const auto part = source.frameData(scene, TetView::of(scene, source.constants()), &stats);
  ASSERT_TRUE(part);
  EXPECT_GT(stats.tetChunksSkippedEmpty, 0);
  EXPECT_LT(part->mesh.tets.size(), all.tets.size());
  EXPECT_LT(part->mesh.points.size(), all.points.size()) << "the part holds only the points its tets use";
  const image::ImageF ofPart =
      TetReference(part->mesh).render(TetReferenceParams::fromScene(scene, source.constants()));
  const image::ImageF ofWhole =
      TetReference(all).render(TetReferenceParams::fromScene(scene, all, source.constants().meanEdgeLength));
  ASSERT_GT(test::meanBrightness(ofWhole), 0.005);
  // The chunks left out are transparent: every ray integrates to the same colour (double precision, summed in the
  // same order along the ray).
  EXPECT_LT(image::compareImages(ofPart, ofWhole).maxAbs, 1e-9);
  // And the GPU frame of the part is within the ray caster's bound of it.
  TetRenderer renderer(test::context(), meshOf(paged).source(), size_t(256) << 20);
  test::expectClose(renderer.render(scene), ofWhole, 2.0 / 255, "tet-paging-reference");
}

TEST(TetPaging, AViewThatCannotFitIsRefusedNamingTheSizesAndOthersStillDraw) {
  test::ScratchDir dir;
  const auto path = writeBox(dir.path(), 16, 512);
  const size_t budget = wholeBytes(path) / 2;
  const auto paged = openDataset("box", path, budget);
  TetRenderer renderer(test::context(), meshOf(paged).source(), size_t(256) << 20);
  // "hot" shows every value: the whole box in view needs every chunk.
  try {
    renderer.render(sceneOf(TransferFunction::load("hot"), 30));
    ADD_FAILURE() << "a view needing more than the budget was drawn";
  } catch (const RenderLimitError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("this view needs"), std::string::npos) << what;
    EXPECT_NE(what.find("chunks"), std::string::npos) << what;
    EXPECT_NE(what.find("raise the budget"), std::string::npos) << what;
  }
  EXPECT_LE(paged->cacheStats().peakResidentBytes, budget);
  // A nearer view of the same mesh fits and draws.
  FrameStats stats;
  const image::ImageF close = renderer.render(sceneOf(TransferFunction::load("hot"), 30, true), &stats);
  EXPECT_GT(test::meanBrightness(close), 0.01);
  EXPECT_GT(stats.tetChunksCulled, 0);
  // A view that shows nothing (a transfer function transparent everywhere) reads nothing: the background.
  Scene clear = sceneOf(TransferFunction::load("hot"), 30);
  clear.transferFunction = TransferFunction({{0, {1, 1, 1, 0}}, {1, {1, 1, 1, 0}}});
  FrameStats none;
  EXPECT_EQ(test::meanBrightness(renderer.render(clear, &none)), 0.0);
  EXPECT_EQ(none.tetChunksRead, 0);
  EXPECT_EQ(none.tetChunksSkippedEmpty, int64_t(meshOf(paged).source()->chunkCount()) - none.tetChunksCulled);
  // Even the points above the budget: refused when opened.
  EXPECT_THROW(openDataset("box", path, 1000), RenderLimitError);
}

TEST(TetPaging, ACorruptChunkIsACorruptStoreMetWhenPaged) {
  test::ScratchDir dir;
  const auto path = writeBox(dir.path(), 12, 256);
  // One byte of chunk 0's tets block changed: its checksum no longer matches.
  std::ifstream index(path / mesh::kMeshIndexFile, std::ios::binary);
  mesh::MeshIndexHeader header{};
  mesh::MeshChunkRecord record{};
  index.read(reinterpret_cast<char*>(&header), sizeof header);
  index.read(reinterpret_cast<char*>(&record), sizeof record);
  ASSERT_TRUE(index.good());
  std::fstream data(path / mesh::kMeshDataFile, std::ios::binary | std::ios::in | std::ios::out);
  data.seekg(std::streamoff(record.tets.offset + record.tets.compressedSize / 2));
  char byte = 0;
  data.read(&byte, 1);
  byte = char(byte ^ 0x5a);
  data.seekp(std::streamoff(record.tets.offset + record.tets.compressedSize / 2));
  data.write(&byte, 1);
  data.close();
  const auto paged = openDataset("box", path, wholeBytes(path) - 1);  // opening reads no chunk
  const TetMeshSource& source = *meshOf(paged).source();
  ASSERT_TRUE(source.paged());
  const Scene scene = sceneOf(TransferFunction::load("hot"), 30);
  try {
    source.frameData(scene, TetView::of(scene, source.constants()), nullptr);
    ADD_FAILURE() << "a corrupt chunk was drawn";
  } catch (const store::CorruptStoreError& e) {
    EXPECT_NE(std::string(e.what()).find("chunk 0 tets: checksum mismatch"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxbrick::render
