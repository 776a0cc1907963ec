// A directory of datasets for the in-process server tests, made once per test process with the real `voxbrick prep`.
#pragma once

#include <filesystem>

namespace voxbrick::test {

/// A datasets directory holding "sparse" (synthetic:sparse,n=32 in bricks of 16: 32^3 voxels, 2 levels). Made on
/// first call, removed at exit; throws std::runtime_error with prep's output if prep fails.
const std::filesystem::path& testDatasets();

/// The transfer-function presets shipped in config/tf of the source tree.
std::filesystem::path shippedPresets();

}  // namespace voxbrick::test
