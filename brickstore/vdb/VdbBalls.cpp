// Writing sparse .vdb files of balls.
#include "brickstore/vdb/VdbBalls.h"

#include <cmath>

#include <openvdb/openvdb.h>

#include "brickstore/vdb/OpenVdbInit.h"

namespace voxbrick::store {

void writeBallsVdb(const std::filesystem::path& path, int64_t n, const std::vector<VdbBallsGrid>& grids) {
  initializeOpenVdb();
  openvdb::GridPtrVec out;
  for (const VdbBallsGrid& g : grids) {
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    grid->setName(g.name);
    openvdb::FloatGrid::Accessor acc = grid->getAccessor();
    for (const VdbBall& b : g.balls) {
      const int r = int(std::ceil(b.outer));
      const openvdb::Coord c(int(b.x), int(b.y), int(b.z));
      for (int z = -r; z <= r; ++z)
        for (int y = -r; y <= r; ++y)
          for (int x = -r; x <= r; ++x) {
            const double d = std::sqrt(double(x * x + y * y + z * z));
            if (d >= b.inner && d <= b.outer) acc.setValue(c.offsetBy(x, y, z), b.value);
          }
    }
    acc.setValue(openvdb::Coord(0, 0, 0), 0.01f);
    acc.setValue(openvdb::Coord(int(n - 1), int(n - 1), int(n - 1)), 0.01f);
    out.push_back(grid);
  }
  openvdb::io::File file(path.string());
  file.write(out);
  file.close();
}

}  // namespace voxbrick::store
