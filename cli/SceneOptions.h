// The scene options shared by `render` and `request`: a scene JSON file and command-line options on top of it.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "render/core/Scene.h"

namespace voxbrick::cli {

struct SceneArgs {
  std::string sceneFile, orbit, eye, center, up, upAxis, view, size, tf, background, window, slicer, visibility,
      quality;
  double fov = 0, step = 0;
  bool fit = false, ortho = false, noSkip = false, noCull = false, shading = false, preIntegration = false, ess = false,
       progressive = false, raycast = false;
  int subBlock = -1;
  int slab = -1;
  double ert = 0;
  double lod = 0;
};

/// Registers the scene options on `cmd`, storing into `args` (which must outlive the app).
void addSceneOptions(CLI::App* cmd, SceneArgs& args);
/// Refuses an output the scene's frame cannot go to: a transparent frame (--background none) as JPEG, which has no
/// alpha. Throws RenderInputError naming the file.
void checkOutputFormat(const render::Scene& scene, const std::string& output);
/// The scene: --scene first, then every option given on the command line on top of it. Throws RenderInputError.
/// Camera: --orbit, --view and --eye each replace the scene's camera placement (one of them at most); --eye keeps the
/// scene's center and up unless --center/--up are given; --center/--up without --eye apply to a scene whose camera
/// is explicit (eye) and are refused otherwise; --up-axis and --fit apply to an orbit (--fit alone: the scene's
/// orbit at the fitted distance).
render::Scene buildScene(const SceneArgs& args, const CLI::App& cmd);

}  // namespace voxbrick::cli
