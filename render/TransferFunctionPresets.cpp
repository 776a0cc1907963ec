// Reading a directory of presets once.
#include "render/TransferFunctionPresets.h"

#include "render/RenderErrors.h"

namespace voxbrick::render {

TransferFunctionPresets TransferFunctionPresets::load(const std::filesystem::path& directory) {
  TransferFunctionPresets presets;
  presets.mDirectory = directory;
  for (const std::string& name : TransferFunction::presetNames(directory))
    presets.mPresets.emplace(name, TransferFunction::load((directory / (name + ".json")).string()));
  return presets;
}

const TransferFunction& TransferFunctionPresets::get(const std::string& name) const {
  if (auto it = mPresets.find(name); it != mPresets.end()) return it->second;
  std::string known;
  for (const auto& [n, tf] : mPresets) known += (known.empty() ? "" : ", ") + n;
  throw RenderInputError("no transfer-function preset '" + name + "' in " + mDirectory.string() + " (presets: " +
                         (known.empty() ? "none" : known) + ")");
}

std::vector<std::string> TransferFunctionPresets::names() const {
  std::vector<std::string> out;
  for (const auto& [n, tf] : mPresets) out.push_back(n);
  return out;
}

}  // namespace voxbrick::render
