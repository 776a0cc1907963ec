// Transfer-function presets read once, so that resolving a preset name later does no I/O (a server reads them at
// start and parses request scenes on its I/O threads).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "render/TransferFunction.h"

namespace voxbrick::render {

/// The presets of one directory, by name.
class TransferFunctionPresets {
 public:
  TransferFunctionPresets() = default;
  /// Reads every preset <name>.json of `directory` (TransferFunction::configDirectory() / "tf"); throws
  /// RenderInputError naming a file that does not parse. A missing directory gives no presets.
  static TransferFunctionPresets load(const std::filesystem::path& directory);
  /// The preset `name`; throws RenderInputError naming it and listing the known names.
  const TransferFunction& get(const std::string& name) const;
  /// The names, sorted.
  std::vector<std::string> names() const;

 private:
  std::filesystem::path mDirectory;
  std::map<std::string, TransferFunction> mPresets;
};

}  // namespace voxbrick::render
