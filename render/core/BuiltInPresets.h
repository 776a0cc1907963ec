// The transfer-function presets of config/tf/*.json, embedded at build time (cmake/EmbedPresets.cmake), so that a
// preset name resolves with no configuration files present.
#pragma once

#include <string_view>
#include <vector>

namespace voxbrick::render {

/// One embedded preset: its name (the file's stem) and the file's JSON text.
struct BuiltInPreset {
  std::string_view name;
  std::string_view json;
};

/// Every built-in preset, sorted by name (defined in the generated EmbeddedPresets.cpp).
const std::vector<BuiltInPreset>& builtInPresets();
/// The built-in preset `name`, or nullptr if there is none.
const BuiltInPreset* findBuiltInPreset(std::string_view name);

}  // namespace voxbrick::render
