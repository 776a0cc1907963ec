// `voxbrick scene [scene options]`: the scene the scene options make, as JSON (what `render` and `orbit` draw and
// `request` sends); `voxbrick scene --schema`: the scene's schema, every key and the rules between keys.
#include <cstdio>
#include <memory>

#include "cli/Commands.h"
#include "cli/SceneOptions.h"
#include "render/core/RenderErrors.h"
#include "render/core/SceneSchema.h"

namespace voxbrick::cli {
namespace {

struct SceneCommandArgs {
  SceneArgs scene;
  bool schema = false;
};

void runScene(const SceneCommandArgs& a, const CLI::App& cmd) {
  if (!a.schema) {
    std::printf("%s\n", buildScene(a.scene, cmd).toJson().c_str());
    return;
  }
  if (!a.scene.sceneFile.empty() || !sceneOptionKeys(a.scene, cmd).empty())
    throw render::RenderInputError("--schema prints the schema, not a scene: give it without --scene or scene options");
  std::printf("%s\n", render::sceneSchemaJson().dump(2).c_str());
}

}  // namespace

void addSceneCommand(CLI::App& app) {
  auto a = std::make_shared<SceneCommandArgs>();
  CLI::App* cmd = app.add_subcommand(
      "scene", "Print the scene the scene options make, as JSON (what render and orbit draw, request sends)");
  cmd->add_flag("--schema", a->schema,
                "print the scene's schema instead, as JSON: every key with its type, allowed values, default, "
                "concern, help and option, and the rules between keys");
  addSceneOptions(cmd, a->scene);
  cmd->callback([a, cmd] { runScene(*a, *cmd); });
}

}  // namespace voxbrick::cli
