// Pins the byte layout of mesh-index.bin (offsets, sizes, magic, version), and shows that every damaged, truncated
// or implausible store gives a MeshError naming the file and the fault, never a crash or a huge allocation.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "MeshStoreFixtures.h"
#include "common/Checksum.h"
#include "mesh/MeshBlocks.h"
#include "mesh/MeshFormat.h"
#include "mesh/MeshStore.h"
#include "support/TestSupport.h"

namespace voxbrick::mesh {
namespace {

namespace fs = std::filesystem;
using voxbrick::test::ScratchDir;

static_assert(offsetof(MeshIndexHeader, points) == 80 && offsetof(MeshChunkRecord, tets) == 48);

TEST(MeshFormat, IndexHeaderLayout) {
  EXPECT_EQ(std::memcmp(kMeshIndexMagic, "VXMESHIX", 8), 0);
  EXPECT_EQ(kMeshIndexVersion, 1u);
  EXPECT_EQ(sizeof(MeshIndexHeader), 192u);
  EXPECT_EQ(offsetof(MeshIndexHeader, magic), 0u);
  EXPECT_EQ(offsetof(MeshIndexHeader, version), 8u);
  EXPECT_EQ(offsetof(MeshIndexHeader, chunkCount), 12u);
  EXPECT_EQ(offsetof(MeshIndexHeader, vertexCount), 16u);
  EXPECT_EQ(offsetof(MeshIndexHeader, tetCount), 24u);
  EXPECT_EQ(offsetof(MeshIndexHeader, boundaryFaceCount), 32u);
  EXPECT_EQ(offsetof(MeshIndexHeader, dataFileSize), 40u);
  EXPECT_EQ(offsetof(MeshIndexHeader, boundsMin), 48u);
  EXPECT_EQ(offsetof(MeshIndexHeader, boundsMax), 60u);
  EXPECT_EQ(offsetof(MeshIndexHeader, scalarMin), 72u);
  EXPECT_EQ(offsetof(MeshIndexHeader, scalarMax), 76u);
  EXPECT_EQ(offsetof(MeshIndexHeader, points), 80u);
  EXPECT_EQ(offsetof(MeshIndexHeader, scalars), 112u);
  EXPECT_EQ(offsetof(MeshIndexHeader, boundary), 144u);
  EXPECT_EQ(offsetof(MeshIndexHeader, tetsPerChunk), 176u);
  EXPECT_EQ(offsetof(MeshIndexHeader, reserved), 180u);
  EXPECT_EQ(offsetof(MeshIndexHeader, bodyCrc32), 184u);
  EXPECT_EQ(offsetof(MeshIndexHeader, headerCrc32), 188u);
}

TEST(MeshFormat, ChunkRecordAndBlockRefLayout) {
  EXPECT_EQ(sizeof(MeshChunkRecord), 112u);
  EXPECT_EQ(offsetof(MeshChunkRecord, firstTet), 0u);
  EXPECT_EQ(offsetof(MeshChunkRecord, tetCount), 8u);
  EXPECT_EQ(offsetof(MeshChunkRecord, reserved), 12u);
  EXPECT_EQ(offsetof(MeshChunkRecord, boundsMin), 16u);
  EXPECT_EQ(offsetof(MeshChunkRecord, boundsMax), 28u);
  EXPECT_EQ(offsetof(MeshChunkRecord, scalarMin), 40u);
  EXPECT_EQ(offsetof(MeshChunkRecord, scalarMax), 44u);
  EXPECT_EQ(offsetof(MeshChunkRecord, tets), 48u);
  EXPECT_EQ(offsetof(MeshChunkRecord, neighbours), 80u);
  EXPECT_EQ(sizeof(BlockRef), 32u);
  EXPECT_EQ(offsetof(BlockRef, offset), 0u);
  EXPECT_EQ(offsetof(BlockRef, compressedSize), 8u);
  EXPECT_EQ(offsetof(BlockRef, rawSize), 16u);
  EXPECT_EQ(offsetof(BlockRef, crc32), 24u);
  EXPECT_EQ(offsetof(BlockRef, reserved), 28u);
}

/// A hand-cube store in three chunks (sizes 1, 2, 2), and ways to damage it.
class DamagedStore : public ::testing::Test {
 protected:
  void SetUp() override {
    MeshStoreOptions options;
    options.tetsPerChunk = 2;
    writeMeshStore(test::handCube(), test::handCubeTopology(), mDir, options);
    mData = voxbrick::test::readFile(mDir / kMeshDataFile);
    std::memcpy(&mHeader, readIndex().data(), sizeof mHeader);
    const std::vector<char> index = readIndex();
    mRecords.resize(mHeader.chunkCount);
    std::memcpy(mRecords.data(), index.data() + sizeof mHeader, mRecords.size() * sizeof(MeshChunkRecord));
  }

  std::vector<char> readIndex() const { return voxbrick::test::readFile(mDir / kMeshIndexFile); }

  /// Writes a header and records, with fresh checksums (so only the values are wrong) unless told not to.
  void writeIndex(MeshIndexHeader h, const std::vector<MeshChunkRecord>& records, bool fixChecksums = true) {
    if (fixChecksums) {
      h.bodyCrc32 = common::crc32Of(records.data(), records.size() * sizeof(MeshChunkRecord));
      h.headerCrc32 = common::crc32Of(&h, offsetof(MeshIndexHeader, headerCrc32));
    }
    std::vector<char> bytes(sizeof h + records.size() * sizeof(MeshChunkRecord));
    std::memcpy(bytes.data(), &h, sizeof h);
    std::memcpy(bytes.data() + sizeof h, records.data(), records.size() * sizeof(MeshChunkRecord));
    voxbrick::test::writeFile(mDir / kMeshIndexFile, bytes.data(), bytes.size());
  }

  /// Appends a well-formed block of `values` to the data file; the header's data size follows.
  template <typename T>
  BlockRef appendBlock(const std::vector<T>& values) {
    const std::vector<char> encoded = encodeBlock(values.data(), values.size() * sizeof(T), 3);
    BlockRef ref{mData.size(), encoded.size(), values.size() * sizeof(T),
                 common::crc32Of(encoded.data(), encoded.size()), 0};
    mData.insert(mData.end(), encoded.begin(), encoded.end());
    voxbrick::test::writeFile(mDir / kMeshDataFile, mData.data(), mData.size());
    mHeader.dataFileSize = mData.size();
    return ref;
  }

  void setJson(const std::string& key, uint64_t value) {
    const std::vector<char> text = voxbrick::test::readFile(mDir / kMeshMetaFile);
    auto j = nlohmann::json::parse(text.begin(), text.end());
    j[key] = value;
    voxbrick::test::writeFile(mDir / kMeshMetaFile, j.dump());
  }

  void flip(const fs::path& file, uint64_t offset) {
    std::vector<char> bytes = voxbrick::test::readFile(file);
    bytes.at(offset) ^= 0x10;
    voxbrick::test::writeFile(file, bytes.data(), bytes.size());
  }

  /// `call` throws a MeshError whose message holds every one of `words`.
  template <typename F>
  void expectError(F&& call, std::initializer_list<const char*> words) {
    try {
      call();
      ADD_FAILURE() << "no error; expected one with \"" << *words.begin() << "\"";
    } catch (const MeshError& e) {
      for (const char* w : words) EXPECT_NE(std::string(e.what()).find(w), std::string::npos) << e.what();
    }
  }

  void expectOpenError(std::initializer_list<const char*> words) {
    expectError([&] { MeshStore::open(mDir); }, words);
  }

  ScratchDir mScratch;
  fs::path mDir = mScratch / "cube";
  std::vector<char> mData;
  MeshIndexHeader mHeader{};
  std::vector<MeshChunkRecord> mRecords;
};

TEST_F(DamagedStore, FlippedChunkByteNamesTheChunk) {
  ASSERT_EQ(mRecords.size(), 3u);
  flip(mDir / kMeshDataFile, mRecords[1].tets.offset + mRecords[1].tets.compressedSize / 2);
  flip(mDir / kMeshDataFile, mRecords[2].neighbours.offset + 1);
  const MeshStore store = MeshStore::open(mDir);  // chunks are checked when they are read
  EXPECT_NO_THROW(store.readChunk(0));
  expectError([&] { store.readChunk(1); }, {"mesh-data.bin", "chunk 1 tets", "checksum mismatch"});
  expectError([&] { store.readChunk(2); }, {"mesh-data.bin", "chunk 2 neighbours", "checksum mismatch"});
  expectError([&] { store.readAll(); }, {"checksum mismatch"});
  expectError([&] { store.readTopology(); }, {"checksum mismatch"});
}

TEST_F(DamagedStore, FlippedVertexOrBoundaryByte) {
  flip(mDir / kMeshDataFile, mHeader.boundary.offset + 2);
  expectError([&] { MeshStore::open(mDir).boundary(); }, {"mesh-data.bin", "boundary", "checksum mismatch"});
  flip(mDir / kMeshDataFile, mHeader.scalars.offset + 3);
  expectOpenError({"mesh-data.bin", "scalars", "checksum mismatch"});
}

TEST_F(DamagedStore, EveryFlippedByteIsCaught) {
  const std::vector<char> index = readIndex();
  for (uint64_t i = 0; i < index.size(); ++i) {
    flip(mDir / kMeshIndexFile, i);
    EXPECT_THROW(MeshStore::open(mDir), MeshError) << "index byte " << i;
    flip(mDir / kMeshIndexFile, i);
  }
  for (uint64_t i = 0; i < mData.size(); ++i) {
    flip(mDir / kMeshDataFile, i);
    EXPECT_THROW(
        {
          const MeshStore store = MeshStore::open(mDir);
          store.readTopology();
        },
        MeshError)
        << "data byte " << i;
    flip(mDir / kMeshDataFile, i);
  }
  EXPECT_NO_THROW(MeshStore::open(mDir).readTopology());
}

TEST_F(DamagedStore, TruncatedOrExtendedFiles) {
  const std::vector<char> index = readIndex();
  for (size_t size : {size_t{0}, size_t{7}, size_t{12}, size_t{100}, sizeof(MeshIndexHeader) - 1,
                      sizeof(MeshIndexHeader), index.size() - 1}) {
    voxbrick::test::writeFile(mDir / kMeshIndexFile, index.data(), size);
    expectOpenError({"mesh-index.bin"});
  }
  std::vector<char> longer = index;
  longer.push_back(0);
  voxbrick::test::writeFile(mDir / kMeshIndexFile, longer.data(), longer.size());
  expectOpenError({"mesh-index.bin", "truncated or corrupt"});
  voxbrick::test::writeFile(mDir / kMeshIndexFile, index.data(), index.size());

  for (size_t size = 0; size < mData.size(); ++size) {
    voxbrick::test::writeFile(mDir / kMeshDataFile, mData.data(), size);
    expectOpenError({"mesh-data.bin", "truncated or replaced"});
  }
}

TEST_F(DamagedStore, BadMagicAndVersion) {
  MeshIndexHeader h = mHeader;
  h.magic[0] = 'X';
  writeIndex(h, mRecords);
  expectOpenError({"mesh-index.bin", "bad magic"});
  h = mHeader;
  h.version = 2;
  writeIndex(h, mRecords, false);  // checked before the checksum: a later version may lay the header out anew
  expectOpenError({"mesh-index.bin", "index version 2, this build reads 1"});
  writeIndex(mHeader, mRecords, false);
  EXPECT_NO_THROW(MeshStore::open(mDir));
}

TEST_F(DamagedStore, AbsurdCountsAreRefusedBeforeAllocating) {
  MeshIndexHeader h = mHeader;
  h.tetCount = uint64_t{1} << 40;
  writeIndex(h, mRecords);
  expectOpenError({"mesh-index.bin", "tet count 1099511627776"});
  h = mHeader;
  h.chunkCount = 0xffffffffu;
  writeIndex(h, mRecords);
  expectOpenError({"mesh-index.bin", "chunk count 4294967295"});
  // Within the limits but not what the file holds: the size check comes before the table is read.
  h = mHeader;
  h.chunkCount = 4;
  writeIndex(h, mRecords);
  setJson("chunks", 4);
  expectOpenError({"mesh-index.bin", "4 chunks need"});
  setJson("chunks", 3);
  // 2^31 vertices (24 GiB of points) that the index and mesh.json agree on: the block's size gives it away.
  h = mHeader;
  h.vertexCount = uint64_t{1} << 31;
  writeIndex(h, mRecords);
  setJson("vertices", h.vertexCount);
  expectOpenError({"mesh-index.bin", "points", "the counts give 25769803776"});
  h.points.rawSize = h.vertexCount * 12;
  writeIndex(h, mRecords);
  expectOpenError({"mesh-index.bin", "points", "compressed bytes cannot decode to 25769803776"});
  setJson("vertices", 8);
  h = mHeader;
  h.boundaryFaceCount = 21;
  writeIndex(h, mRecords);
  setJson("boundaryFaces", 21);
  expectOpenError({"boundary face count 21"});
}

TEST_F(DamagedStore, IndexDisagreeingWithItselfOrTheMetadata) {
  std::vector<MeshChunkRecord> r = mRecords;
  r[1].firstTet += 1;
  writeIndex(mHeader, r);
  expectOpenError({"mesh-index.bin", "chunk 1", "do not follow"});
  r = mRecords;
  r[2].boundsMax[1] = 2.0f;
  writeIndex(mHeader, r);
  expectOpenError({"chunk 2", "outside the mesh's"});
  r = mRecords;
  r[0].tets.offset = mData.size() - 2;
  writeIndex(mHeader, r);
  expectOpenError({"chunk 0 tets", "past the end"});
  MeshIndexHeader h = mHeader;
  h.scalarMax = 100.0f;
  writeIndex(h, mRecords);
  expectOpenError({"mesh-data.bin", "do not match the index"});
  writeIndex(mHeader, mRecords);
  setJson("tets", 6);
  expectOpenError({"mesh-index.bin", "counts do not match", "mesh.json"});
  voxbrick::test::writeFile(mDir / kMeshMetaFile, std::string("{ not json"));
  expectOpenError({"mesh.json", "not a JSON object"});
  fs::remove(mDir / kMeshMetaFile);
  expectOpenError({"mesh.json", "missing"});
  expectError([&] { MeshStore::open(mScratch / "nothing"); }, {"nothing", "not a mesh store directory"});
}

/// Blocks whose checksums are right but whose indices are not: range-checked when read.
TEST_F(DamagedStore, IndicesOutOfRangeInWellFormedBlocks) {
  std::vector<MeshChunkRecord> r = mRecords;
  const MeshChunk chunk = MeshStore::open(mDir).readChunk(1);
  std::vector<Tet> tets = chunk.tets;
  tets[0][1] = 8;  // met before the bad neighbour at tet 0, face 3
  r[1].tets = appendBlock(tets);
  std::vector<std::array<int32_t, 4>> neighbours = chunk.neighbours;
  neighbours[0][3] = 5;
  r[1].neighbours = appendBlock(neighbours);
  std::vector<std::array<uint32_t, 2>> boundary(12, {0, 1});
  boundary[0] = {0, 4};
  mHeader.boundary = appendBlock(boundary);
  writeIndex(mHeader, r);
  const MeshStore store = MeshStore::open(mDir);
  expectError([&] { store.readChunk(1); }, {"chunk 1", "names vertex 8 of 8"});
  expectError([&] { store.boundary(); }, {"boundary face 0", "out of range"});
  r[1].tets = mRecords[1].tets;
  writeIndex(mHeader, r);
  expectError([&] { MeshStore::open(mDir).readChunk(1); }, {"chunk 1", "has neighbour 5 of 5"});
}

}  // namespace
}  // namespace voxbrick::mesh
