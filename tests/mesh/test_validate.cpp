// validateMesh: what it refuses (naming the tet or vertex) and what it repairs (counted).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "mesh/SyntheticMesh.h"
#include "mesh/Validate.h"

using namespace voxbrick::mesh;

namespace {

std::string errorOf(TetMesh mesh) {
  try {
    validateMesh(mesh);
  } catch (const MeshError& e) {
    return e.what();
  }
  return "no error";
}

// The unit corner tet (positive) and points for more.
TetMesh cornerMesh() {
  TetMesh mesh;
  mesh.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {0.5f, 0.5f, 0}};
  mesh.scalars = {0, 1, 2, 3, 4, 5};
  mesh.tets = {{0, 1, 2, 3}};
  return mesh;
}

TEST(Validate, InvertedTetsAreFlippedAndCounted) {
  TetMesh mesh = cornerMesh();
  mesh.tets = {{0, 1, 2, 3}, {0, 2, 1, 3}, {1, 2, 3, 4}, {1, 3, 2, 4}};
  EXPECT_GT(orientedVolume6(mesh, mesh.tets[0]), 0);
  EXPECT_LT(orientedVolume6(mesh, mesh.tets[1]), 0);
  const MeshRepairs repairs = validateMesh(mesh);
  EXPECT_EQ(repairs.flipped, 2u);
  EXPECT_EQ(repairs.removedDegenerate, 0u);
  EXPECT_EQ(repairs.unreferencedVertices, 1u);  // vertex 5
  ASSERT_EQ(mesh.tets.size(), 4u);
  for (const Tet& tet : mesh.tets) EXPECT_GT(orientedVolume6(mesh, tet), 0);
  EXPECT_EQ(mesh.tets[1], (Tet{0, 2, 3, 1}));  // the last two indices swapped
}

TEST(Validate, DegenerateTetsAreRemovedKeepingOrder) {
  TetMesh mesh = cornerMesh();
  mesh.tets = {
      {0, 1, 2, 5}, {0, 1, 2, 3}, {1, 1, 2, 3}, {1, 2, 3, 4}, {3, 2, 3, 0}};  // flat, ok, repeated, ok, repeated
  const MeshRepairs repairs = validateMesh(mesh);
  EXPECT_EQ(repairs.removedDegenerate, 3u);
  EXPECT_EQ(mesh.tets, (std::vector<Tet>{{0, 1, 2, 3}, {1, 2, 3, 4}}));
}

TEST(Validate, NearlyFlatTetsAreRemovedRelativeToTheMeshSize) {
  for (float scale : {1e-6f, 1.0f, 1e6f}) {
    TetMesh mesh = cornerMesh();
    for (glm::vec3& p : mesh.points) p *= scale;
    // Vertex 6 lifts the flat tet by 1e-7 of the size: volume ~ 1e-8 L^3, kept; vertex 7 by 1e-13: removed.
    mesh.points.push_back(glm::vec3(0.2f, 0.2f, 1e-7f) * scale);
    mesh.points.push_back(glm::vec3(0.2f, 0.2f, 1e-13f) * scale);
    mesh.scalars.resize(mesh.points.size(), 0.0f);
    mesh.tets = {{0, 1, 2, 6}, {0, 1, 2, 7}};
    const MeshRepairs repairs = validateMesh(mesh);
    EXPECT_EQ(repairs.removedDegenerate, 1u) << scale;
    EXPECT_EQ(mesh.tets, (std::vector<Tet>{{0, 1, 2, 6}})) << scale;
  }
}

TEST(Validate, RefusalsNameTheTetOrVertex) {
  TetMesh mesh = cornerMesh();
  mesh.tets.push_back({1, 2, 3, 6});
  EXPECT_EQ(errorOf(mesh), "validateMesh: tet 1 uses vertex 6, but the mesh has 6 vertices");

  mesh = cornerMesh();
  mesh.points[4].y = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(errorOf(mesh).find("vertex 4 has a non-finite position"), std::string::npos) << errorOf(mesh);

  mesh = cornerMesh();
  mesh.scalars[3] = std::numeric_limits<float>::infinity();
  EXPECT_NE(errorOf(mesh).find("vertex 3 has a non-finite scalar"), std::string::npos) << errorOf(mesh);

  mesh = cornerMesh();
  mesh.scalars.pop_back();
  EXPECT_EQ(errorOf(mesh), "validateMesh: 5 scalars for 6 vertices");

  mesh = cornerMesh();
  mesh.tets = {{0, 1, 2, 5}, {0, 0, 1, 2}};
  EXPECT_EQ(errorOf(mesh), "validateMesh: all 2 tetrahedra are degenerate");

  mesh.tets.clear();
  EXPECT_EQ(errorOf(mesh), "validateMesh: the mesh has no tetrahedra");
}

TEST(Validate, SyntheticMeshesNeedNoRepair) {
  for (const char* spec : {"box,n=3", "ball,n=9"}) {
    TetMesh mesh = syntheticMesh(spec);
    const size_t tets = mesh.tets.size();
    EXPECT_EQ(validateMesh(mesh), MeshRepairs{}) << spec;
    EXPECT_EQ(mesh.tets.size(), tets);
  }
}

}  // namespace
