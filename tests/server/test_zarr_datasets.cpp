// An OME-Zarr directory among the served datasets: listed under its directory name, opened live (time point 0,
// channel 0), and a broken one listed but failing to open with its own error naming the file.
#include <gtest/gtest.h>

#include "render/volume/BrickStoreDataset.h"
#include "server/Datasets.h"
#include "support/TestSupport.h"
#include "support/ZarrFixtures.h"

namespace voxbrick::server {
namespace {

TEST(DatasetRegistryZarr, ListsAndOpensZarrDirectories) {
  test::ScratchDir dir;
  const std::filesystem::path datasets = dir / "datasets";
  std::filesystem::create_directories(datasets);
  test::writeZarr(datasets / "cells.ome.zarr", nlohmann::json::parse(R"({"levels": 2, "axes": "czyx", "c": 2,
      "compressor": {"id": "blosc", "cname": "lz4", "shuffle": 1}})"));
  test::writeZarr(datasets / "broken.ome.zarr", nlohmann::json::parse(R"({"levels": 1})"));
  test::writeFile(datasets / "broken.ome.zarr" / "0" / ".zarray", std::string(R"({"zarr_format": 2})"));
  DatasetRegistry registry(datasets, size_t(16) << 20);
  EXPECT_EQ(registry.names(), (std::vector<std::string>{"broken.ome.zarr", "cells.ome.zarr"}));

  const auto live = registry.open("cells.ome.zarr");
  const auto* grid = dynamic_cast<const render::BrickStoreDataset*>(live.get());
  ASSERT_NE(grid, nullptr);
  EXPECT_EQ(grid->store()->backing(), store::StoreBacking::ZarrDirectory);
  EXPECT_NE(live->infoJson().find("OME-Zarr 0.4"), std::string::npos) << live->infoJson();
  EXPECT_EQ(registry.open("cells.ome.zarr"), live);
  try {
    registry.open("broken.ome.zarr");
    ADD_FAILURE() << "broken.ome.zarr opened";
  } catch (const DatasetNotFound& e) {
    ADD_FAILURE() << "reported as not found: " << e.what();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("0/.zarray: field 'shape' is missing"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxbrick::server
