// Scene options of `render`, `orbit`, `request` and `scene`, made from the scene's schema.
#include "cli/SceneOptions.h"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>

#include "image/ImageFile.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::cli {
namespace {

using nlohmann::json;

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw render::RenderInputError(path + ": cannot read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// A number written out whole ("0.5", "1e3"), or nothing.
std::optional<double> number(const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) return std::nullopt;
  return v;
}

/// The option's text as the key's JSON value: a number, the numbers between the key's separators ("10,20,3",
/// "512x512") as an array, anything else as a string. Text that is not what the key takes stays a string, which
/// the key's check then refuses.
json optionValue(const render::SceneKey& k, const std::string& text) {
  if (k.type == render::SceneType::Number || k.type == render::SceneType::Integer) {
    const auto v = number(text);
    return v ? json(*v) : json(text);
  }
  if (k.type != render::SceneType::Numbers || std::find(k.names.begin(), k.names.end(), text) != k.names.end())
    return json(text);
  json values = json::array();
  size_t start = 0;
  while (true) {
    const size_t end = text.find(k.separator, start);
    const auto v = number(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (!v) return json(text);
    values.push_back(*v);
    if (end == std::string::npos) return values;
    start = end + 1;
  }
}

/// The option's help: the key, what it does, what it may be and its default, all from the schema.
std::string helpOf(const render::SceneKey& k) {
  const std::string applies =
      k.applies == render::SceneApplies::Both ? "" : std::string(" (") + render::sceneAppliesName(k.applies) + ")";
  if (k.flagValue)
    return "sets '" + k.key + "' " + (*k.flagValue ? "true" : "false") + applies + ": " + k.help + " (default " +
           k.defaultText() + ")";
  return "'" + k.key + "'" + applies + ": " + k.help + "; " + k.allowed(true) + " (default " + k.defaultText() + ")";
}

/// The key's check of an option's text, as a CLI11 check: "must be ..., not 'TEXT'", which CLI11 prefixes with the
/// option's name.
CLI::Validator schemaCheck(const render::SceneKey& k) {
  return CLI::Validator(
      [&k](std::string& input) -> std::string {
        const json value = optionValue(k, input);
        const std::string problem = k.problem(value, true);
        return problem.empty() ? std::string() : problem + ", not '" + input + "'" + k.hint(value, true);
      },
      "");
}

}  // namespace

void addSceneOptions(CLI::App* cmd, SceneArgs& args) {
  cmd->add_option("--scene", args.sceneFile,
                  "scene JSON (`voxbrick scene --schema` lists its keys); the options below are laid over it");
  for (const render::SceneKey& k : render::sceneSchema()) {
    if (k.option.empty()) continue;
    SceneArgs::Given& given = args.given[k.key];
    if (k.flagValue)
      cmd->add_flag(k.option, given.flag, helpOf(k));
    else
      cmd->add_option(k.option, given.text, helpOf(k))->type_name(k.optionForm)->check(schemaCheck(k));
  }
}

render::SceneKeys sceneOptionKeys(const SceneArgs& args, const CLI::App& cmd) {
  render::SceneKeys keys;
  for (const auto& [key, given] : args.given) {
    const render::SceneKey& k = *render::findSceneKey(key);
    if (cmd.count(k.option) == 0) continue;
    keys[key] = k.flagValue ? json(*k.flagValue) : optionValue(k, given.text);
  }
  return keys;
}

render::Scene buildScene(const SceneArgs& a, const CLI::App& cmd) {
  render::SceneKeys file;
  if (!a.sceneFile.empty()) {
    const std::string text = readText(a.sceneFile);
    render::Scene::fromJson(text, a.sceneFile);  // the file is a scene by itself: its errors name the file
    file = render::sceneKeysOf(text, a.sceneFile);
  }
  const render::SceneKeys options = sceneOptionKeys(a, cmd);
  // An option given by its name; a key of the file as the file's; another by the option that would give it.
  const render::SceneNames names{"", [&](const std::string& key) {
                                   const render::SceneKey* k = render::findSceneKey(key);
                                   if (options.count(key) || (!file.count(key) && k && !k->option.empty()))
                                     return k->option;
                                   return (file.count(key) ? a.sceneFile + "'s '" : "'") + key + "'";
                                 }};
  return render::sceneFromKeys(render::layerSceneKeys(file, options, names), names);
}

void checkOutputFormat(const render::SceneView& view, const std::string& output) {
  if (view.transparent && image::imageFormatFor(output) == image::ImageFormat::Jpeg)
    throw render::RenderInputError("--background none needs a .png output: JPEG has no alpha (" + output + ")");
}

}  // namespace voxbrick::cli
