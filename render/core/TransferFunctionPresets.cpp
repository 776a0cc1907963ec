// Reading the built-in presets and a directory of presets once.
#include "render/core/TransferFunctionPresets.h"

#include <nlohmann/json.hpp>

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

std::string TransferFunctionPresets::json(bool withFiles, int indent) const {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [name, e] : mPresets) {
    nlohmann::json points = nlohmann::json::array();
    for (const auto& p : e.tf.points()) points.push_back({p.x, p.rgba.r, p.rgba.g, p.rgba.b, p.rgba.a});
    nlohmann::json preset = {
        {"name", name},
        {"built_in", !e.file},
        {"reference_length", e.tf.referenceLength() ? nlohmann::json(*e.tf.referenceLength()) : nlohmann::json()},
        {"points", points}};
    if (withFiles) preset["file"] = e.file ? nlohmann::json(e.file->string()) : nlohmann::json();
    list.push_back(std::move(preset));
  }
  return list.dump(indent);
}

}  // namespace voxbrick::render
