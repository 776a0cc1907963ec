// Transfer-function presets read once, so that resolving a preset name later does no I/O (a server reads them at
// start and parses request scenes on its I/O threads).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "render/core/TransferFunction.h"

namespace voxbrick::render {

/// The built-in presets and those of one directory, by name.
class TransferFunctionPresets {
 public:
  TransferFunctionPresets() = default;
  /// The built-in presets (BuiltInPresets.h), then every preset <name>.json of `directory`
  /// (TransferFunction::configDirectory() / "tf"), which replaces a built-in one of the same name. Throws
  /// RenderInputError naming a file that does not parse. A missing directory gives the built-in presets only.
  static TransferFunctionPresets load(const std::filesystem::path& directory);
  /// The preset `name`; throws RenderInputError naming it and listing the known names.
  const TransferFunction& get(const std::string& name) const;
  /// The file preset `name` was read from, or nullopt for a built-in one; throws like get().
  const std::optional<std::filesystem::path>& file(const std::string& name) const;
  /// The names, sorted.
  std::vector<std::string> names() const;
  /// Every preset as a JSON array, by name: {"name", "built_in", "reference_length" (null when unset), "points":
  /// [[x, r, g, b, a], ...]}, and "file" (the path, null for a built-in one) when `withFiles` (the server's copy for
  /// its pages leaves paths out). `indent` as nlohmann::json::dump takes it (-1: one line).
  std::string json(bool withFiles, int indent = -1) const;

 private:
  struct Entry {
    TransferFunction tf;
    std::optional<std::filesystem::path> file;  // nullopt: built in
  };
  const Entry& entry(const std::string& name) const;

  std::filesystem::path mDirectory;
  std::map<std::string, Entry> mPresets;
};

}  // namespace voxbrick::render
