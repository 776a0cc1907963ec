// The mesh store written and read back: the mesh and topology survive the spatial reordering, chunks are compact
// pieces of space with exact ranges, the bytes do not depend on the run, and replacing a store is atomic.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <stdexcept>

#include "MeshStoreFixtures.h"
#include "mesh/MeshStore.h"
#include "support/TestSupport.h"

namespace voxbrick::mesh {
namespace {

namespace fs = std::filesystem;
using voxbrick::test::readFile;
using voxbrick::test::ScratchDir;

MeshStoreOptions chunksOf(uint32_t tets) {
  MeshStoreOptions o;
  o.tetsPerChunk = tets;
  return o;
}

/// Store order -> input order, found by the tets' vertices (every tet of these meshes is distinct).
std::vector<uint32_t> originalIndex(const TetMesh& input, const TetMesh& stored) {
  std::map<Tet, uint32_t> where;
  for (uint32_t t = 0; t < input.tets.size(); ++t) where[input.tets[t]] = t;
  std::vector<uint32_t> out;
  for (const Tet& t : stored.tets) {
    const auto it = where.find(t);
    EXPECT_NE(it, where.end());
    out.push_back(it == where.end() ? 0 : it->second);
  }
  return out;
}

/// Everything a reader can see of the store at `dir` agrees with `mesh` and `topo` (given in input order).
void expectStoreHolds(const fs::path& dir, const TetMesh& mesh, const Topology& topo) {
  const MeshStore store = MeshStore::open(dir);
  const TetMesh back = store.readAll();
  EXPECT_EQ(back.points, mesh.points);
  EXPECT_EQ(back.scalars, mesh.scalars);
  EXPECT_EQ(back.field, mesh.field);
  ASSERT_EQ(back.tets.size(), mesh.tets.size());
  EXPECT_EQ(std::multiset<Tet>(back.tets.begin(), back.tets.end()),
            std::multiset<Tet>(mesh.tets.begin(), mesh.tets.end()));
  const Topology backTopo = store.readTopology();
  test::expectConsistent(back, backTopo);
  // Renumbered, not merely consistent: the neighbour across each face is the input's neighbour there.
  const std::vector<uint32_t> original = originalIndex(mesh, back);
  for (size_t t = 0; t < back.tets.size(); ++t)
    for (size_t f = 0; f < 4; ++f) {
      const int32_t n = backTopo.neighbours[t][f];
      EXPECT_EQ(n == Topology::kBoundary ? Topology::kBoundary : int32_t(original[size_t(n)]),
                topo.neighbours[original[t]][f]);
    }
  EXPECT_EQ(store.boundary(), backTopo.boundary);
}

TEST(MeshStore, HandCubeRoundTrip) {
  ScratchDir scratch;
  const TetMesh cube = test::handCube();
  const Topology topo = test::handCubeTopology();
  test::expectConsistent(cube, topo);
  EXPECT_EQ(topo.neighbours, test::matchFaces(cube).neighbours);  // the hand-written topology is right

  MeshStoreOptions options = chunksOf(2);
  options.source = "hand-made cube";
  const MeshStoreInfo written = writeMeshStore(cube, topo, scratch / "cube", options);
  expectStoreHolds(scratch / "cube", cube, topo);

  const MeshStore store = MeshStore::open(scratch / "cube");
  const MeshStoreInfo& info = store.info();
  EXPECT_EQ(info.vertexCount, 8u);
  EXPECT_EQ(info.tetCount, 5u);
  EXPECT_EQ(info.boundaryFaceCount, 12u);
  EXPECT_EQ(info.chunkCount, 3u);  // 5 tets in chunks of 2: sizes 1, 2, 2 rather than 2, 2, 1
  EXPECT_EQ(info.field, "corner");
  EXPECT_EQ(info.source, "hand-made cube");
  EXPECT_EQ(info.boundsMin, glm::vec3(0.0f));
  EXPECT_EQ(info.boundsMax, glm::vec3(1.0f));
  EXPECT_EQ(info.scalarMin, -7.5f);
  EXPECT_EQ(info.scalarMax, 6.0f);
  EXPECT_EQ(info.bytesRaw, 8u * 16 + 5u * 32 + 12u * 8);
  EXPECT_EQ(info.bytesStored,
            fs::file_size(scratch / "cube" / kMeshDataFile) + fs::file_size(scratch / "cube" / kMeshIndexFile));
  EXPECT_EQ(written.bytesStored, info.bytesStored);
  EXPECT_EQ(written.boundaryFaceCount, info.boundaryFaceCount);
  ASSERT_EQ(store.chunkCount(), 3u);
  EXPECT_EQ(store.chunk(0).tetCount + store.chunk(1).tetCount + store.chunk(2).tetCount, 5u);
  EXPECT_THROW(store.chunk(3), MeshError);
  EXPECT_THROW(store.readChunk(3), MeshError);

  const std::string text = describeMeshStore(store);
  for (const char* part : {"vertices      8", "tets          5 in 3 chunks", "boundary      12 faces", "corner",
                           "hand-made cube", "[-7.5, 6]"})
    EXPECT_NE(text.find(part), std::string::npos) << part << " not in\n" << text;
}

TEST(MeshStore, GridChunksAreCompactAndExact) {
  ScratchDir scratch;
  // Shuffled, so that any compactness is the writer's doing.
  TetMesh grid = test::kuhnGrid(8, 8, 8);
  std::mt19937 random(7);
  std::shuffle(grid.tets.begin(), grid.tets.end(), random);
  const Topology topo = test::matchFaces(grid);
  test::expectConsistent(grid, topo);
  writeMeshStore(grid, topo, scratch / "grid", chunksOf(96));
  expectStoreHolds(scratch / "grid", grid, topo);

  const MeshStore store = MeshStore::open(scratch / "grid");
  ASSERT_EQ(store.chunkCount(), 32u);  // 3072 tets
  const TetMesh all = store.readAll();
  const Topology allTopo = store.readTopology();
  double chunkVolume = 0;
  uint64_t next = 0;
  for (size_t c = 0; c < store.chunkCount(); ++c) {
    const ChunkInfo& info = store.chunk(c);
    EXPECT_EQ(info.firstTet, next);
    EXPECT_EQ(info.tetCount, 96u);
    next += info.tetCount;
    const MeshChunk chunk = store.readChunk(c);
    ASSERT_EQ(chunk.tets.size(), info.tetCount);
    EXPECT_EQ(chunk.firstTet, info.firstTet);
    glm::vec3 lo(1e30f), hi(-1e30f);
    float smin = 1e30f, smax = -1e30f;
    for (size_t t = 0; t < chunk.tets.size(); ++t) {
      EXPECT_EQ(chunk.tets[t], all.tets[info.firstTet + t]);
      EXPECT_EQ(chunk.neighbours[t], allTopo.neighbours[info.firstTet + t]);
      for (uint32_t v : chunk.tets[t]) {
        lo = glm::min(lo, all.points[v]);
        hi = glm::max(hi, all.points[v]);
        smin = std::min(smin, all.scalars[v]);
        smax = std::max(smax, all.scalars[v]);
      }
    }
    EXPECT_EQ(info.boundsMin, lo);
    EXPECT_EQ(info.boundsMax, hi);
    EXPECT_EQ(info.scalarMin, smin);
    EXPECT_EQ(info.scalarMax, smax);
    const glm::vec3 size = hi - lo;
    chunkVolume += double(size.x) * size.y * size.z;
  }
  EXPECT_EQ(next, 3072u);
  // 96 tets are 16 unit cubes: in Z-order, two 2x2x2 blocks side by side, so the 32 boxes tile the grid (a sum of
  // 512). Chunks of the shuffled input would each span nearly the whole grid (a sum near 32 x 512).
  EXPECT_LT(chunkVolume, 1.25 * 512.0) << "chunk boxes sum to " << chunkVolume << " for a 512 volume";
}

// mesh.json records the mean and longest edge, summed in the store's order; a store written before it did is measured
// chunk by chunk to the same bits, and values that are no mesh's lengths are refused.
TEST(MeshStore, RecordsItsEdgeLengths) {
  ScratchDir scratch;
  TetMesh grid = test::kuhnGrid(6, 5, 4);
  const Topology topo = test::matchFaces(grid);
  writeMeshStore(grid, topo, scratch / "grid", chunksOf(50));
  const MeshStore store = MeshStore::open(scratch / "grid");
  EdgeLengths inStoreOrder;
  for (const Tet& tet : store.readAll().tets) inStoreOrder.add(store.points(), tet);
  EXPECT_EQ(store.info().meanEdgeLength, inStoreOrder.mean());
  EXPECT_EQ(store.info().longestEdge, inStoreOrder.longest);
  EXPECT_EQ(store.edgeLengths(), std::make_pair(inStoreOrder.mean(), inStoreOrder.longest));
  EXPECT_NEAR(inStoreOrder.longest, std::sqrt(3.0), 1e-6);  // a unit Kuhn cell's main diagonal

  const std::vector<char> bytes = readFile(scratch / "grid" / kMeshMetaFile);
  const std::string text(bytes.begin(), bytes.end());
  const size_t at = text.find("\"edgeLengths\"");
  ASSERT_NE(at, std::string::npos) << text;
  const size_t end = text.find('}', at) + 1;
  // Without the key (an older store): measured, the same bits.
  voxbrick::test::writeFile(scratch / "grid" / kMeshMetaFile, text.substr(0, at) + "\"older\": 1" + text.substr(end));
  const MeshStore older = MeshStore::open(scratch / "grid");
  EXPECT_EQ(older.info().meanEdgeLength, 0.0);
  EXPECT_EQ(older.edgeLengths(), store.edgeLengths());
  // Lengths that no mesh has.
  for (const std::string bad : {R"("edgeLengths": {"mean": -1, "longest": 1})",
                                R"("edgeLengths": {"mean": 2, "longest": 1})", R"("edgeLengths": {"mean": 1})"}) {
    voxbrick::test::writeFile(scratch / "grid" / kMeshMetaFile, text.substr(0, at) + bad + text.substr(end));
    EXPECT_THROW(MeshStore::open(scratch / "grid"), MeshError) << bad;
  }
}

TEST(MeshStore, OneTetPerChunkAndOneChunk) {
  ScratchDir scratch;
  const TetMesh cube = test::handCube();
  const Topology topo = test::handCubeTopology();
  writeMeshStore(cube, topo, scratch / "a", chunksOf(1));
  EXPECT_EQ(MeshStore::open(scratch / "a").chunkCount(), 5u);
  expectStoreHolds(scratch / "a", cube, topo);
  writeMeshStore(cube, topo, scratch / "b");
  EXPECT_EQ(MeshStore::open(scratch / "b").chunkCount(), 1u);
  expectStoreHolds(scratch / "b", cube, topo);
}

TEST(MeshStore, SameInputSameBytes) {
  ScratchDir scratch;
  const TetMesh grid = test::kuhnGrid(5, 4, 3);
  const Topology topo = test::matchFaces(grid);
  writeMeshStore(grid, topo, scratch / "a", chunksOf(50));
  writeMeshStore(grid, topo, scratch / "b", chunksOf(50));
  for (const char* file : {kMeshDataFile, kMeshIndexFile, kMeshMetaFile})
    EXPECT_EQ(readFile(scratch / "a" / file), readFile(scratch / "b" / file)) << file;
}

TEST(MeshStore, RefusesBadOptionsAndInputs) {
  ScratchDir scratch;
  const TetMesh cube = test::handCube();
  const Topology topo = test::handCubeTopology();
  auto expectRefused = [&](const TetMesh& m, const Topology& t, const MeshStoreOptions& o, const std::string& words) {
    try {
      writeMeshStore(m, t, scratch / "x", o);
      ADD_FAILURE() << "accepted; expected an error with \"" << words << "\"";
    } catch (const MeshError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(scratch / "x"));
  };
  expectRefused(cube, topo, chunksOf(0), "tetsPerChunk 0");
  expectRefused(cube, topo, chunksOf(kMaxTetsPerChunk + 1), "tetsPerChunk");
  MeshStoreOptions level;
  level.zstdLevel = 23;
  expectRefused(cube, topo, level, "zstd level 23");
  TetMesh m = cube;
  m.scalars.pop_back();
  expectRefused(m, topo, {}, "7 scalars for 8 vertices");
  m = cube;
  m.points[3].y = std::numeric_limits<float>::quiet_NaN();
  expectRefused(m, topo, {}, "vertex 3");
  m = cube;
  m.tets[2][1] = 8;
  expectRefused(m, topo, {}, "tet 2 names vertex 8");
  expectRefused(cube, Topology{}, {}, "the topology has 0 tets");
  Topology t = topo;
  t.neighbours[0][1] = 1;  // tet 1 does not name tet 0 back
  expectRefused(cube, t, {}, "does not name it back");
  t = topo;
  t.boundary.pop_back();
  expectRefused(cube, t, {}, "11 boundary faces");
  expectRefused(TetMesh{}, Topology{}, {}, "no tetrahedra");
}

TEST(MeshStore, ReplacesOnlyMeshStoresAndOnlyWhenAsked) {
  ScratchDir scratch;
  const TetMesh cube = test::handCube();
  const Topology topo = test::handCubeTopology();
  writeMeshStore(cube, topo, scratch / "m");
  EXPECT_THROW(writeMeshStore(cube, topo, scratch / "m"), MeshError);
  fs::create_directory(scratch / "other");
  voxbrick::test::writeFile(scratch / "other" / "keep.txt", std::string("precious"));
  MeshStoreOptions force;
  force.overwrite = true;
  EXPECT_THROW(writeMeshStore(cube, topo, scratch / "other", force), MeshError);
  EXPECT_TRUE(fs::exists(scratch / "other" / "keep.txt"));
  writeMeshStore(cube, topo, scratch / "m/", force);  // a trailing slash names the same store
  expectStoreHolds(scratch / "m", cube, topo);
}

/// A write that fails at any step leaves the old store whole and nothing beside it; the step after the last is the
/// write that succeeds.
TEST(MeshStore, FailedWriteLeavesTheOldStore) {
  ScratchDir scratch;
  const fs::path dir = scratch / "m";
  const TetMesh cube = test::handCube();
  const Topology cubeTopo = test::handCubeTopology();
  writeMeshStore(cube, cubeTopo, dir);
  const TetMesh grid = test::kuhnGrid(3, 3, 2);
  const Topology gridTopo = test::matchFaces(grid);

  struct Injected : std::runtime_error {
    using std::runtime_error::runtime_error;
  };
  int steps = 0;
  for (int failAt = 0;; ++failAt) {
    MeshStoreOptions options = chunksOf(10);
    options.overwrite = true;
    int step = 0;
    options.progress = [&](const MeshWriteProgress&) {
      if (step++ == failAt) throw Injected("injected failure");
    };
    try {
      writeMeshStore(grid, gridTopo, dir, options);
    } catch (const Injected&) {
      expectStoreHolds(dir, cube, cubeTopo);
      std::vector<fs::path> left;
      for (const auto& e : fs::directory_iterator(scratch.path())) left.push_back(e.path().filename());
      EXPECT_EQ(left, std::vector<fs::path>{"m"}) << "after a failure at step " << failAt;
      continue;
    }
    steps = failAt;
    break;
  }
  EXPECT_EQ(steps, 2 + 11 + 4);  // points, scalars, 11 chunks of the 108 tets, boundary, index, metadata, commit
  expectStoreHolds(dir, grid, gridTopo);
  std::vector<fs::path> left;
  for (const auto& e : fs::directory_iterator(scratch.path())) left.push_back(e.path().filename());
  EXPECT_EQ(left, std::vector<fs::path>{"m"});
}

}  // namespace
}  // namespace voxbrick::mesh
