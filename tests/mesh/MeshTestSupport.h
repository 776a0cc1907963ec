// Helpers the mesh tests share: exact mesh comparison and reading text held in a string.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "mesh/MeshReaders.h"
#include "mesh/TetMesh.h"

namespace voxbrick::mesh::test {

/// Expects `actual` to equal `expected` exactly: points, tets, scalars and field name.
inline void expectSameMesh(const TetMesh& expected, const TetMesh& actual) {
  ASSERT_EQ(actual.points.size(), expected.points.size());
  ASSERT_EQ(actual.tets.size(), expected.tets.size());
  ASSERT_EQ(actual.scalars.size(), expected.scalars.size());
  for (size_t i = 0; i < expected.points.size(); ++i) ASSERT_EQ(actual.points[i], expected.points[i]) << "point " << i;
  for (size_t i = 0; i < expected.tets.size(); ++i) ASSERT_EQ(actual.tets[i], expected.tets[i]) << "tet " << i;
  for (size_t i = 0; i < expected.scalars.size(); ++i)
    ASSERT_EQ(actual.scalars[i], expected.scalars[i]) << "scalar " << i;
  EXPECT_EQ(actual.field, expected.field);
}

/// Reads a mesh from text; `name` decides the format when the content does not.
inline TetMesh readText(const std::string& name, const std::string& text, const std::string& field = "") {
  return readMeshBytes(name, std::vector<char>(text.begin(), text.end()), field);
}

/// The message of the MeshError that reading `text` throws, or "no error".
inline std::string readError(const std::string& name, const std::string& text, const std::string& field = "") {
  try {
    readText(name, text, field);
  } catch (const MeshError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace voxbrick::mesh::test
