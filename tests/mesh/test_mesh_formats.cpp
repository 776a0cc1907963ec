// The mesh readers against the writers (every format and byte order), hand-written files of the variants our
// writers do not produce (VTK 5.1 offsets, field arrays, several fields), and truncated or damaged files.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <random>

#include "mesh/MeshReaders.h"
#include "mesh/MeshTestSupport.h"
#include "mesh/MeshWriters.h"
#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"
#include "mesh/Validate.h"
#include "support/TestSupport.h"

using namespace voxbrick::mesh;
using voxbrick::mesh::test::expectSameMesh;
using voxbrick::mesh::test::readError;
using voxbrick::mesh::test::readText;
using voxbrick::test::readFile;
using voxbrick::test::ScratchDir;

namespace {

struct Format {
  const char* name;
  const char* extension;
  void (*write)(const TetMesh&, const std::filesystem::path&);
};

const Format kFormats[] = {
    {"VtkAscii", ".vtk", [](const TetMesh& m, const std::filesystem::path& p) { writeVtk(m, p, false); }},
    {"VtkBinaryBigEndian", ".vtk", [](const TetMesh& m, const std::filesystem::path& p) { writeVtk(m, p, true); }},
    {"VtkBinaryLittleEndian", ".vtk",
     [](const TetMesh& m, const std::filesystem::path& p) { writeVtk(m, p, true, false); }},
    {"Gmsh2Ascii", ".msh", [](const TetMesh& m, const std::filesystem::path& p) { writeGmsh(m, p, 2, false); }},
    {"Gmsh2Binary", ".msh", [](const TetMesh& m, const std::filesystem::path& p) { writeGmsh(m, p, 2, true); }},
    {"Gmsh4Ascii", ".msh", [](const TetMesh& m, const std::filesystem::path& p) { writeGmsh(m, p, 4, false); }},
    {"Gmsh4Binary", ".msh", [](const TetMesh& m, const std::filesystem::path& p) { writeGmsh(m, p, 4, true); }},
};

class MeshFormats : public ::testing::TestWithParam<Format> {};

// A mesh whose values exercise the text formats: coordinates like -1 + 2/7 and scalars from exp() have no short
// decimal form, and a field name with a space needs VTK's %20.
TetMesh sourceMesh() {
  TetMesh mesh = syntheticMesh("ball,n=7");
  mesh.field = "blob density";
  mesh.scalars[0] = 1e-30f;
  mesh.scalars[1] = -3.4e38f;
  return mesh;
}

TEST_P(MeshFormats, RoundTripIsExact) {
  ScratchDir dir;
  const TetMesh source = sourceMesh();
  const auto path = dir / (std::string("mesh") + GetParam().extension);
  GetParam().write(source, path);
  expectSameMesh(source, readMesh(path));
  expectSameMesh(source, readMesh(path, "blob density"));
}

TEST_P(MeshFormats, WritingTwiceGivesTheSameBytes) {
  ScratchDir dir;
  const TetMesh source = syntheticMesh("box,n=2");
  GetParam().write(source, dir / "a");
  GetParam().write(source, dir / "b");
  EXPECT_EQ(readFile(dir / "a"), readFile(dir / "b"));
}

// Every prefix of a file is either an error or, when only trailing whitespace was cut, the whole mesh.
TEST_P(MeshFormats, EveryTruncationIsAnErrorOrTheWholeMesh) {
  ScratchDir dir;
  const TetMesh source = syntheticMesh("box,n=1");
  const auto path = dir / (std::string("mesh") + GetParam().extension);
  GetParam().write(source, path);
  const std::vector<char> bytes = readFile(path);
  size_t errors = 0;
  for (size_t length = 0; length < bytes.size(); ++length) {
    try {
      const TetMesh mesh = readMeshBytes(path.string(), std::vector<char>(bytes.begin(), bytes.begin() + length));
      if (std::all_of(bytes.begin() + static_cast<ptrdiff_t>(length), bytes.end(), [](char c) { return c == '\n'; })) {
        expectSameMesh(source, mesh);
      } else {
        // A text file cut inside its last number reads as a shorter number: only ASCII VTK ends with one.
        ASSERT_STREQ(GetParam().name, "VtkAscii") << "length " << length;
        ASSERT_GT(length + 16, bytes.size());
        EXPECT_EQ(mesh.points, source.points);
        EXPECT_EQ(mesh.tets, source.tets);
      }
    } catch (const MeshError&) {
      ++errors;
    }
  }
  EXPECT_GE(errors + 16, bytes.size());
}

// Damaged bytes give an error or some mesh, never a crash; what reads must then validate or fail cleanly.
TEST_P(MeshFormats, DamagedBytesNeverCrash) {
  ScratchDir dir;
  const auto path = dir / (std::string("mesh") + GetParam().extension);
  GetParam().write(syntheticMesh("box,n=1"), path);
  const std::vector<char> bytes = readFile(path);
  std::mt19937 random(1234);
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<char> damaged = bytes;
    const int hits = 1 + trial % 3;
    for (int h = 0; h < hits; ++h) {
      const size_t at = random() % damaged.size();
      // Digits and bit flips: a changed count or index is the interesting damage, not only garbage.
      damaged[at] =
          trial % 2 ? static_cast<char>('0' + random() % 10) : static_cast<char>(damaged[at] ^ (1 << random() % 8));
    }
    try {
      TetMesh mesh = readMeshBytes(path.string(), damaged);
      validateMesh(mesh);
      buildTopology(mesh);
    } catch (const MeshError&) {
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Mesh, MeshFormats, ::testing::ValuesIn(kFormats),
                         [](const ::testing::TestParamInfo<Format>& param) { return param.param.name; });

TEST(MeshFormats, BinaryVtkIsBigEndianUnlessAskedOtherwise) {
  ScratchDir dir;
  const TetMesh source = syntheticMesh("box,n=1");
  writeVtk(source, dir / "be.vtk", true);
  writeVtk(source, dir / "le.vtk", true, false);
  const std::vector<char> be = readFile(dir / "be.vtk"), le = readFile(dir / "le.vtk");
  ASSERT_EQ(be.size(), le.size());
  EXPECT_NE(be, le);
  // The first cell's point count, 4, right after "CELLS 6 30\n".
  const std::string text(be.begin(), be.end());
  const size_t cells = text.find("CELLS 6 30\n") + 11;
  EXPECT_EQ(std::vector<char>(be.begin() + cells, be.begin() + cells + 4), (std::vector<char>{0, 0, 0, 4}));
  EXPECT_EQ(std::vector<char>(le.begin() + cells, le.begin() + cells + 4), (std::vector<char>{4, 0, 0, 0}));
}

// The VTK >= 5.1 cell layout, as VTK 9 writes it: OFFSETS and CONNECTIVITY arrays of 64-bit ids.
const char* kVtk51 = R"(# vtk DataFile Version 5.1
two tets sharing a face
ASCII
DATASET UNSTRUCTURED_GRID
POINTS 5 double
0 0 0  1 0 0  0 1 0
0 0 1  1 1 1
METADATA
INFORMATION 0

CELLS 4 11
OFFSETS vtktypeint64
0 4 8 11
CONNECTIVITY vtktypeint64
0 1 2 3
1 2 3 4
0 1 2
CELL_TYPES 3
10
10
5
POINT_DATA 5
SCALARS pressure double 1
LOOKUP_TABLE default
0.5 1.5 2.5 3.5 4.5
FIELD FieldData 2
temperature 1 5 int
10 20 30 40 50
METADATA
INFORMATION 0

velocity 3 5 float
0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
CELL_DATA 3
SCALARS material int 1
LOOKUP_TABLE default
1 1 2
)";

TEST(MeshFormats, VtkOffsetsLayoutWithFieldArrays) {
  const TetMesh mesh = readText("tets.vtk", kVtk51);
  TetMesh expected;
  expected.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  expected.tets = {{0, 1, 2, 3}, {1, 2, 3, 4}};  // the triangle is dropped
  expected.scalars = {0.5f, 1.5f, 2.5f, 3.5f, 4.5f};
  expected.field = "pressure";
  expectSameMesh(expected, mesh);

  const TetMesh byField = readText("tets.vtk", kVtk51, "temperature");
  EXPECT_EQ(byField.scalars, (std::vector<float>{10, 20, 30, 40, 50}));
  EXPECT_EQ(byField.field, "temperature");

  const std::string error = readError("tets.vtk", kVtk51, "density");
  EXPECT_NE(error.find("no point scalar field named 'density'"), std::string::npos) << error;
  EXPECT_NE(error.find("available point scalars: pressure, temperature"), std::string::npos) << error;
  EXPECT_NE(error.find("velocity (3 components)"), std::string::npos) << error;
  EXPECT_NE(error.find("material (cell data)"), std::string::npos) << error;
  // Neither field nor vector can stand in for a point scalar.
  EXPECT_NE(readError("tets.vtk", kVtk51, "velocity").find("no point scalar field named 'velocity'"),
            std::string::npos);
}

// Builds a binary VTK 5.1 file by hand (64-bit offsets and connectivity) in either byte order.
std::string binaryVtk51(bool bigEndian) {
  std::string out = "# vtk DataFile Version 5.1\nbinary offsets\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n";
  auto put = [&]<class T>(T value) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (bigEndian != (std::endian::native == std::endian::big))
      for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    out.append(bytes, sizeof(T));
  };
  for (float v : {0.f, 0.f, 0.f, 2.f, 0.f, 0.f, 0.f, 2.f, 0.f, 0.f, 0.f, 2.f}) put(v);
  out += "\nCELLS 2 4\nOFFSETS vtktypeint64\n";
  for (int64_t v : {0, 4}) put(v);
  out += "\nCONNECTIVITY vtktypeint64\n";
  for (int64_t v : {0, 1, 2, 3}) put(v);
  out += "\nCELL_TYPES 1\n";
  put(int32_t{10});
  out += "\nPOINT_DATA 4\nSCALARS s unsigned_short\nLOOKUP_TABLE default\n";
  for (uint16_t v : {7, 8, 9, 300}) put(v);
  return out + "\n";
}

TEST(MeshFormats, BinaryVtkOffsetsLayoutInEitherByteOrder) {
  for (bool bigEndian : {true, false}) {
    const TetMesh mesh = readText("b.vtk", binaryVtk51(bigEndian));
    EXPECT_EQ(mesh.tets, (std::vector<Tet>{{0, 1, 2, 3}})) << bigEndian;
    EXPECT_EQ(mesh.points[3], glm::vec3(0, 0, 2)) << bigEndian;
    EXPECT_EQ(mesh.scalars, (std::vector<float>{7, 8, 9, 300})) << bigEndian;
  }
}

TEST(MeshFormats, GmshViewsAreChosenByName) {
  const std::string text = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
1
3 1 "domain"
$EndPhysicalNames
$Nodes
4
10 0 0 0
20 1 0 0
30 0 1 0
40 0 0 1
$EndNodes
$Elements
3
1 15 2 0 1 10
2 2 2 0 1 10 20 30
3 4 2 1 1 10 20 30 40
$EndElements
$NodeData
1
"velocity"
1
0.0
3
0
3
4
10 0 0 0
20 0 0 0
30 0 0 0
40 0 0 0
$EndNodeData
$NodeData
1
"temperature"
1
0.0
3
0
1
4
40 4.5
30 3.5
20 2.5
10 1.5
$EndNodeData
$NodeData
1
"temperature"
1
1.0
3
1
1
4
10 0
20 0
30 0
40 0
$EndNodeData
$NodeData
1
"pressure"
1
0.0
3
0
1
4
10 -1
20 -2
30 -3
40 -4
$EndNodeData
)";
  const TetMesh first = readText("m.msh", text);
  EXPECT_EQ(first.field, "temperature");
  EXPECT_EQ(first.scalars, (std::vector<float>{1.5f, 2.5f, 3.5f, 4.5f}));  // node order, the first time step
  EXPECT_EQ(first.tets, (std::vector<Tet>{{0, 1, 2, 3}}));                 // the point and triangle are dropped
  EXPECT_EQ(readText("m.msh", text, "pressure").scalars, (std::vector<float>{-1, -2, -3, -4}));
  const std::string error = readError("m.msh", text, "density");
  EXPECT_NE(error.find("available point scalars: temperature, pressure"), std::string::npos) << error;
  EXPECT_NE(error.find("velocity (3 components)"), std::string::npos) << error;
}

// MSH 4.1 as gmsh writes it for a real model: several entity blocks, sparse unordered node tags, parametric
// coordinates on a curve's nodes, surface elements to drop, and sections to skip.
const char* kGmsh41 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
1
3 1 "solid"
$EndPhysicalNames
$Entities
1 0 0 1
1 0 0 0 0
1 0 0 0 1 1 1 1 1 0
$EndEntities
$Nodes
3 5 3 900
0 1 0 1
900
0 0 0
1 4 1 1
3
1 0 0 0.25
3 1 0 3
7
42
100
0 1 0
0 0 1
1 1 1
$EndNodes
$Elements
2 3 1 3
2 1 2 1
5 900 3 7
3 1 4 2
8 900 3 7 42
9 3 7 42 100
$EndElements
$Comments
anything at all, even $Nodes
$EndComments
$NodeData
1
"T"
1
0.0
3
0
1
5
900 0.5
3 1.5
7 2.5
42 3.5
100 4.5
$EndNodeData
)";

TEST(MeshFormats, Gmsh41EntityBlocksAndSparseTags) {
  const TetMesh mesh = readText("model.msh", kGmsh41);
  TetMesh expected;
  expected.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};  // in file order
  expected.tets = {{0, 1, 2, 3}, {1, 2, 3, 4}};
  expected.scalars = {0.5f, 1.5f, 2.5f, 3.5f, 4.5f};
  expected.field = "T";
  expectSameMesh(expected, mesh);
}

// Binary gmsh from a machine of the other byte order: the endianness check reads as 0x01000000.
std::string swappedGmsh(int version) {
  std::string out = version == 2 ? "$MeshFormat\n2.2 1 8\n" : "$MeshFormat\n4.1 1 8\n";
  auto put = [&]<class T>(T value) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    out.append(bytes, sizeof(T));
  };
  const double coordinates[4][3] = {{0, 0, 0}, {3, 0, 0}, {0, 3, 0}, {0, 0, 3}};
  put(int32_t{1});
  out += "\n$EndMeshFormat\n$Nodes\n";
  if (version == 2) {
    out += "4\n";
    for (int i = 0; i < 4; ++i) {
      put(int32_t{10 + i});
      for (double c : coordinates[i]) put(c);
    }
    out += "\n$EndNodes\n$Elements\n1\n";
    for (int32_t v : {4, 1, 2, 77, 0, 1, 10, 11, 12, 13}) put(v);  // run header, then tag, 2 tags, 4 nodes
  } else {
    for (uint64_t v : {1, 4, 10, 13}) put(v);
    for (int32_t v : {3, 1, 0}) put(v);
    put(uint64_t{4});
    for (uint64_t tag : {10, 11, 12, 13}) put(tag);
    for (const auto& point : coordinates)
      for (double c : point) put(c);
    out += "\n$EndNodes\n$Elements\n";
    for (uint64_t v : {1, 1, 77, 77}) put(v);
    for (int32_t v : {3, 1, 4}) put(v);
    for (uint64_t v : {1, 77, 10, 11, 12, 13}) put(v);
  }
  out += "\n$EndElements\n$NodeData\n1\n\"s\"\n1\n0\n3\n0\n1\n4\n";
  for (int i = 0; i < 4; ++i) {
    put(int32_t{10 + i});
    put(0.25 * i);
  }
  return out + "\n$EndNodeData\n";
}

TEST(MeshFormats, BinaryGmshInTheOtherByteOrder) {
  for (int version : {2, 4}) {
    const TetMesh mesh = readText("swapped.msh", swappedGmsh(version));
    EXPECT_EQ(mesh.points, (std::vector<glm::vec3>{{0, 0, 0}, {3, 0, 0}, {0, 3, 0}, {0, 0, 3}})) << version;
    EXPECT_EQ(mesh.tets, (std::vector<Tet>{{0, 1, 2, 3}})) << version;
    EXPECT_EQ(mesh.scalars, (std::vector<float>{0, 0.25f, 0.5f, 0.75f})) << version;
  }
}

TEST(MeshFormats, ContentDecidesOverExtension) {
  ScratchDir dir;
  const TetMesh source = syntheticMesh("box,n=1");
  writeGmsh(source, dir / "looks-like.vtk", 4, false);
  writeVtk(source, dir / "looks-like.msh", true);
  expectSameMesh(source, readMesh(dir / "looks-like.vtk"));
  expectSameMesh(source, readMesh(dir / "looks-like.msh"));
  voxbrick::test::writeFile(dir / "plain.txt", std::string("hello\n"));
  EXPECT_THROW(readMesh(dir / "plain.txt"), MeshError);
  EXPECT_THROW(readMesh(dir / "missing.vtk"), MeshError);
}

}  // namespace
