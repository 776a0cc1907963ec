// syntheticMesh: the Kuhn box and the ball, their fields, and the errors for bad specs.
#include <gtest/gtest.h>

#include <numbers>

#include "mesh/SyntheticMesh.h"
#include "mesh/Validate.h"

using namespace voxbrick::mesh;

namespace {

double totalVolume(const TetMesh& mesh) {
  double volume = 0;
  for (const Tet& tet : mesh.tets) volume += orientedVolume6(mesh, tet) / 6.0;
  return volume;
}

std::string specError(const std::string& spec) {
  try {
    syntheticMesh(spec);
  } catch (const MeshError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SyntheticMesh, BoxIsTheCubeInPositiveKuhnTets) {
  const TetMesh mesh = syntheticMesh("box,n=2");
  EXPECT_EQ(mesh.points.size(), 27u);
  EXPECT_EQ(mesh.tets.size(), 48u);
  EXPECT_EQ(mesh.bounds(), std::make_pair(glm::vec3(-1), glm::vec3(1)));
  for (const Tet& tet : mesh.tets) EXPECT_NEAR(orientedVolume6(mesh, tet), 1.0, 1e-12);  // (2/2)^3 / 6 each
  EXPECT_NEAR(totalVolume(mesh), 8.0, 1e-9);
  EXPECT_EQ(mesh.field, "blobs");
  EXPECT_EQ(mesh.scalars.size(), mesh.points.size());
}

TEST(SyntheticMesh, BallKeepsTetsInsideTheUnitBall) {
  const TetMesh mesh = syntheticMesh("ball,n=16");
  const TetMesh box = syntheticMesh("box,n=16");
  EXPECT_LT(mesh.tets.size(), box.tets.size());
  for (const glm::vec3& p : mesh.points) EXPECT_LE(glm::length(p), 1.0f + 1e-6f);
  std::vector<uint8_t> used(mesh.points.size(), 0);
  for (const Tet& tet : mesh.tets)
    for (uint32_t v : tet) used[v] = 1;
  EXPECT_EQ(std::count(used.begin(), used.end(), uint8_t{0}), 0);  // unused vertices are dropped
  // Inscribed in the ball, and most of it at this resolution.
  const double ball = 4.0 / 3.0 * std::numbers::pi;
  EXPECT_LT(totalVolume(mesh), ball);
  EXPECT_GT(totalVolume(mesh), 0.6 * ball);
  EXPECT_THROW(syntheticMesh("ball,n=2"), MeshError);  // every tet of the 2-cell grid reaches a corner outside
}

TEST(SyntheticMesh, Fields) {
  const TetMesh blobs = syntheticMesh("box,n=8");
  const auto [lo, hi] = blobs.scalarRange();
  EXPECT_GE(lo, 0.0f);
  EXPECT_LE(hi, 1.0f);
  EXPECT_GT(hi - lo, 0.5f);  // not flat
  for (size_t v = 0; v < blobs.points.size(); ++v) EXPECT_EQ(blobs.scalars[v], blobsField(blobs.points[v]));
  const TetMesh linear = syntheticMesh("box,field=linear,n=4");
  EXPECT_EQ(linear.field, "linear");
  for (size_t v = 0; v < linear.points.size(); ++v)
    EXPECT_FLOAT_EQ(linear.scalars[v], (linear.points[v].x + 1.0f) / 2.0f);
}

TEST(SyntheticMesh, BadSpecsNameTheKey) {
  EXPECT_EQ(specError("cylinder,n=4"),
            "synthetic mesh 'cylinder,n=4': unknown shape 'cylinder' (known: box, ball; form "
            "SHAPE[,n=N][,field=NAME])");
  EXPECT_EQ(specError("box,m=4"), "synthetic mesh 'box,m=4': unknown key 'm' (known: n, field)");
  EXPECT_EQ(specError("box,n=x"), "synthetic mesh 'box,n=x': key 'n': expected an integer in [1, 256], got 'x'");
  EXPECT_EQ(specError("box,n=0"), "synthetic mesh 'box,n=0': key 'n': expected an integer in [1, 256], got '0'");
  EXPECT_EQ(specError("box,n=257"), "synthetic mesh 'box,n=257': key 'n': expected an integer in [1, 256], got '257'");
  EXPECT_EQ(specError("box,n=4,n=5"), "synthetic mesh 'box,n=4,n=5': key 'n' is given twice");
  EXPECT_EQ(specError("box,n"), "synthetic mesh 'box,n': expected key=value, got 'n'");
  EXPECT_EQ(specError("box,field=noise"),
            "synthetic mesh 'box,field=noise': key 'field': unknown field 'noise' (known: blobs, linear)");
}

}  // namespace
