// The shared datasets directory of the in-process server tests.
#include "TestDatasets.h"

#include <stdexcept>

#include "support/TestSupport.h"

namespace voxbrick::test {

const std::filesystem::path& testDatasets() {
  static const ScratchDir scratch;
  static const std::filesystem::path directory = [] {
    const std::filesystem::path d = scratch / "datasets";
    std::filesystem::create_directories(d);
    const CommandResult r =
        runVoxbrick("prep synthetic:sparse,n=32 --brick 16 --no-vdb -q -o '" + (d / "sparse").string() + "'");
    if (r.exitCode != 0) throw std::runtime_error("prep of the test dataset failed: " + r.output);
    return d;
  }();
  return directory;
}

std::filesystem::path shippedPresets() { return std::filesystem::path(VOXBRICK_SOURCE_DIR) / "config" / "tf"; }

}  // namespace voxbrick::test
