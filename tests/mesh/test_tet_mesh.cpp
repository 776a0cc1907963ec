#include <gtest/gtest.h>

#include "mesh/TetMesh.h"

using namespace voxbrick::mesh;

TEST(TetMesh, BoundsAndScalarRange) {
  TetMesh m;
  m.points = {{0, 0, 0}, {2, 0, 0}, {0, 3, 0}, {0, 0, -1}};
  m.tets = {{0, 1, 2, 3}};
  m.scalars = {0.5f, -1.0f, 4.0f, 2.0f};
  const auto [lo, hi] = m.bounds();
  EXPECT_EQ(lo, glm::vec3(0, 0, -1));
  EXPECT_EQ(hi, glm::vec3(2, 3, 0));
  const auto [smin, smax] = m.scalarRange();
  EXPECT_EQ(smin, -1.0f);
  EXPECT_EQ(smax, 4.0f);
  EXPECT_EQ(TetMesh{}.scalarRange(), std::make_pair(0.0f, 0.0f));
}
