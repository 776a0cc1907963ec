// The scene options shared by `render`, `orbit`, `request` and `scene`: a scene JSON file and command-line options on
// top of it, each option one key of the scene's schema (render/core/SceneSchema.h), which gives its name, value
// form, help, default and allowed values.
#pragma once

#include <CLI/CLI.hpp>

#include <map>
#include <string>

#include "render/core/Scene.h"
#include "render/core/SceneSchema.h"

namespace voxbrick::cli {

struct SceneArgs {
  std::string sceneFile;
  /// One scene option as given: its text, or for a flag whether it was given.
  struct Given {
    std::string text;
    bool flag = false;
  };
  /// By scene key, one for each key with an option; CLI11 writes into these nodes, which stay where they are.
  std::map<std::string, Given> given;
};

/// Registers --scene and an option for every schema key that has one on `cmd`, storing into `args` (which must
/// outlive the app). Each option's help is the key's, with what it may be and its default; its check is the key's.
void addSceneOptions(CLI::App* cmd, SceneArgs& args);
/// Refuses an output the scene's frame cannot go to: a transparent frame (--background none) as JPEG, which has no
/// alpha. Throws RenderInputError naming the file.
void checkOutputFormat(const render::SceneView& view, const std::string& output);
/// The scene options given on `cmd`'s command line as scene keys.
render::SceneKeys sceneOptionKeys(const SceneArgs& args, const CLI::App& cmd);
/// The scene: --scene (which must be a scene by itself), then the options given laid over it by the schema's rules
/// (render::layerSceneKeys): an option replaces the file's key and the keys it excludes or resets there (--orbit,
/// --view and --eye each replace the file's placement, --slab its raycast, --quality the settings it chooses and
/// they it), and the file's keys that need a replaced one go with it (center and up with eye); an option that
/// excludes a key of the file it does not replace is refused (--fit or --up-axis over an eye, --up-axis over a
/// view), as are two options that exclude each other. Throws RenderInputError.
render::Scene buildScene(const SceneArgs& args, const CLI::App& cmd);

}  // namespace voxbrick::cli
