// Cells a mesh reader leaves out on purpose (points, lines, surfaces: boundaries, not volume) are counted by kind, so
// that prep can say what it dropped; a file of tetrahedra alone drops nothing.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "mesh/MeshReaders.h"

namespace voxbrick::mesh {
namespace {

TetMesh readString(const std::string& name, const std::string& text) {
  return readMeshBytes(name, std::vector<char>(text.begin(), text.end()));
}

TEST(MeshDropped, GmshLinesAndTrianglesAreCountedByKind) {
  const std::string head =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n";
  const std::string data = "$NodeData\n1\n\"s\"\n1\n0\n3\n0\n1\n4\n1 0\n2 1\n3 2\n4 3\n$EndNodeData\n";
  const TetMesh mesh = readString(
      "d.msh", head + "4\n1 4 2 0 1 1 2 3 4\n2 2 2 0 1 1 2 3\n3 2 2 0 1 1 2 4\n4 1 2 0 1 1 2\n$EndElements\n" + data);
  EXPECT_EQ(mesh.tets.size(), 1u);
  EXPECT_EQ(mesh.dropped, "1 x line (gmsh type 1), 2 x triangle (gmsh type 2)");
  EXPECT_EQ(readString("t.msh", head + "1\n1 4 2 0 1 1 2 3 4\n$EndElements\n" + data).dropped, "");
}

TEST(MeshDropped, VtkTrianglesAreCounted) {
  const std::string text =
      "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\n"
      "CELLS 3 13\n4 0 1 2 3\n3 0 1 2\n3 0 1 3\nCELL_TYPES 3\n10\n5\n5\nPOINT_DATA 4\nSCALARS s float 1\n"
      "LOOKUP_TABLE default\n0 1 2 3\n";
  EXPECT_EQ(readString("t.vtk", text).dropped, "2 x triangle (VTK type 5)");
}

}  // namespace
}  // namespace voxbrick::mesh
