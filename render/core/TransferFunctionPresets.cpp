// Reading the built-in presets and a directory of presets once.
#include "render/core/TransferFunctionPresets.h"

#include "render/core/BuiltInPresets.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::render {

TransferFunctionPresets TransferFunctionPresets::load(const std::filesystem::path& directory) {
  TransferFunctionPresets presets;
  presets.mDirectory = directory;
  for (const BuiltInPreset& p : builtInPresets()) {
    const std::string name(p.name);
    presets.mPresets.insert_or_assign(
        name, Entry{TransferFunction::parse(std::string(p.json), "built-in preset '" + name + "'"), std::nullopt});
  }
  // A file replaces the built-in preset of its name, so a site can retune a shipped preset without a rebuild.
  for (const std::string& name : TransferFunction::presetNames(directory)) {
    const std::filesystem::path path = directory / (name + ".json");
    presets.mPresets.insert_or_assign(name, Entry{TransferFunction::load(path.string()), path});
  }
  return presets;
}

const TransferFunctionPresets::Entry& TransferFunctionPresets::entry(const std::string& name) const {
  if (auto it = mPresets.find(name); it != mPresets.end()) return it->second;
  std::string known;
  for (const auto& [n, e] : mPresets) known += (known.empty() ? "" : ", ") + n;
  throw RenderInputError("no transfer-function preset '" + name + "' built in or in " + mDirectory.string() +
                         " (presets: " + (known.empty() ? "none" : known) + ")");
}

const TransferFunction& TransferFunctionPresets::get(const std::string& name) const { return entry(name).tf; }

const std::optional<std::filesystem::path>& TransferFunctionPresets::file(const std::string& name) const {
  return entry(name).file;
}

std::vector<std::string> TransferFunctionPresets::names() const {
  std::vector<std::string> out;
  for (const auto& [n, e] : mPresets) out.push_back(n);
  return out;
}

}  // namespace voxbrick::render
