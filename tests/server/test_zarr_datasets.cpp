// An OME-Zarr directory among the served datasets: listed under its directory name, opened live (time point 0,
// channel 0), and a broken one listed but failing to open with its own error naming the file; the real server
// process serves it with the frames of its prepped store.
#include <gtest/gtest.h>

#include "ServerProcess.h"
#include "client/Client.h"
#include "image/FrameImage.h"
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

TEST(ServerZarr, ServesAZarrDirectoryWithTheFramesOfItsPreppedStore) {
  test::ScratchDir dir;
  const std::filesystem::path datasets = dir / "datasets";
  std::filesystem::create_directories(datasets);
  const auto zarr = test::writeZarr(datasets / "ball.ome.zarr", nlohmann::json::parse(R"({"shape": [48, 40, 56],
      "levels": 3, "compressor": {"id": "zstd"}})"));
  // The server reads a Zarr with bricks of 32, so the store is prepped likewise.
  const auto r = test::runVoxbrick("prep " + zarr.string() + " --no-vdb -q -o " + (datasets / "ball-prepped").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  test::ServerProcess server("--datasets " + datasets.string() + " --render-threads 2", dir.path());
  client::Client c("127.0.0.1", server.port(), std::chrono::seconds(60));
  c.hello("test");
  EXPECT_EQ(c.listDatasets(), (std::vector<std::string>{"ball-prepped", "ball.ome.zarr"}));
  const char* scene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [80, 64], "transfer_function": "hot"})";
  c.openDataset("ball.ome.zarr");
  const std::vector<uint8_t> live = image::decodeFrameImage(c.render(scene, proto::Encoding::RawRgba8)).rgba;
  c.openDataset("ball-prepped");
  const std::vector<uint8_t> prepped = image::decodeFrameImage(c.render(scene, proto::Encoding::RawRgba8)).rgba;
  ASSERT_EQ(live.size(), prepped.size());
  EXPECT_EQ(live, prepped) << "the Zarr served live differs from its prepped store";
  size_t lit = 0;
  for (size_t i = 0; i < live.size(); i += 4) lit += live[i] > 0 ? 1 : 0;
  EXPECT_GT(lit, 100u) << "an empty frame would prove nothing";
  c.goodbye();
}

}  // namespace
}  // namespace voxbrick::server
