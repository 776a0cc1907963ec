// OME-Zarr test volumes written at test time by Debian's python3-zarr (tests/support/zarr_fixture.py), and small
// edits of their metadata for the refusal tests.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/TestSupport.h"

namespace voxbrick::test {

/// The fixture writer beside this header (the test binary defines VOXBRICK_SOURCE_DIR).
inline std::filesystem::path zarrFixtureScript() {
  return std::filesystem::path(VOXBRICK_SOURCE_DIR) / "tests" / "support" / "zarr_fixture.py";
}

/// Writes an OME-Zarr at `out` from `spec` (zarr_fixture.py's JSON; "out" is set here) with /usr/bin/python3.
inline std::filesystem::path writeZarr(const std::filesystem::path& out, nlohmann::json spec) {
  spec["out"] = out.string();
  const CommandResult r = runShell("/usr/bin/python3 " + zarrFixtureScript().string() + " '" + spec.dump() + "' 2>&1");
  EXPECT_EQ(r.exitCode, 0) << r.output;
  return out;
}

/// What zarr_fixture.py wrote with "dump": level 0's voxels at time 0 and channel 0 as float64, x fastest.
inline std::vector<double> readZarrDump(const std::filesystem::path& file) {
  const std::vector<char> bytes = readFile(file);
  std::vector<double> voxels(bytes.size() / sizeof(double));
  std::memcpy(voxels.data(), bytes.data(), voxels.size() * sizeof(double));
  return voxels;
}

/// The JSON file `file`, parsed.
inline nlohmann::json readJsonFile(const std::filesystem::path& file) {
  const std::vector<char> text = readFile(file);
  return nlohmann::json::parse(text.begin(), text.end());
}

inline void writeJsonFile(const std::filesystem::path& file, const nlohmann::json& j) { writeFile(file, j.dump(2)); }

}  // namespace voxbrick::test
