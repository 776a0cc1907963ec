// `voxbrick info DATASET [--json]`: what a dataset holds (a store level by level, a .vdb or an OME-Zarr as it would
// be read live, a mesh store), as the driver of its kind describes it (render/engine).
#include <cstdio>

#include "brickstore/format/InputErrors.h"
#include "cli/Commands.h"
#include "render/engine/Datasets.h"

namespace voxbrick::cli {
namespace {

struct InfoArgs {
  std::string store, grid;
  int brick = 32;
  int64_t time = 0, channel = 0;
  bool json = false;
};

void runInfo(const InfoArgs& a) {
  const render::DatasetReport report = render::describeDataset(a.store, {a.grid, a.brick, a.time, a.channel});
  if (a.json)
    std::printf("%s\n", report.json.dump(2).c_str());
  else
    std::printf("%s", report.text.c_str());
}

}  // namespace

void addInfoCommand(CLI::App& app) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "info", "Describe a dataset: a brick store, a .vdb or an OME-Zarr as it would be read live, or a mesh store");
  cmd->add_option("dataset", args->store, "store directory, a .vdb file, an OME-Zarr directory or a mesh store")
      ->required();
  cmd->add_option("--grid", args->grid, ".vdb: the float grid to read (default: the first float grid)");
  cmd->add_option("--brick", args->brick, ".vdb: brick size B, a power of two in [8, 256]")
      ->capture_default_str()
      ->check(between(8, 256, "voxels"));
  addZarrIndexOptions(cmd, args->time, args->channel);
  cmd->add_flag("--json", args->json, "print one JSON object");
  cmd->callback([args] { store::namingInput({args->store}, [&] { runInfo(*args); }); });
}

}  // namespace voxbrick::cli
