// Scene options of `render` and `request`.
#include "cli/SceneOptions.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

#include "cli/Commands.h"
#include "image/ImageFile.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::cli {
namespace {

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw render::RenderInputError(path + ": cannot read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

glm::dvec3 triple(const std::string& text, const std::string& option) {
  double v[3];
  parseTriple(text, option, v);
  return {v[0], v[1], v[2]};
}

std::vector<std::string> slicerNames() {
  std::vector<std::string> names;
  for (render::Slicer slicer : render::kSlicers) names.emplace_back(render::slicerName(slicer));
  return names;
}

// "AZ,EL" (a fitted orbit) or "AZ,EL,DIST" (DIST in bounding-sphere radii) into `camera`.
void applyOrbit(const std::string& text, render::CameraSpec& camera) {
  const auto commas = std::count(text.begin(), text.end(), ',');
  if (commas != 1 && commas != 2)
    throw render::RenderInputError("--orbit '" + text + "': expected AZ,EL or AZ,EL,DIST");
  const bool withDistance = commas == 2;
  const glm::dvec3 o = triple(withDistance ? text : text + ",1", "--orbit");
  camera.orbit = true;
  camera.azimuth = o.x, camera.elevation = o.y;
  camera.distance = std::nullopt;
  if (withDistance) camera.distance = o.z;
}

// The camera options on top of the scene's camera (buildScene in SceneOptions.h says what each does).
void applyCamera(const SceneArgs& a, render::CameraSpec& camera) {
  if (int(!a.orbit.empty()) + int(!a.view.empty()) + int(!a.eye.empty()) > 1)
    throw render::RenderInputError("give at most one of --orbit, --view and --eye");
  if ((!a.center.empty() || !a.up.empty()) && a.eye.empty() && camera.orbit)
    throw render::RenderInputError(
        "--center and --up need --eye (or a --scene with an explicit 'eye'): an orbit or "
        "view looks at the volume's centre, with --up-axis as its up");
  if (!a.view.empty() && !a.upAxis.empty())
    throw render::RenderInputError("--view sets the up axis (+z); give --orbit with --up-axis instead");
  if (!a.orbit.empty()) applyOrbit(a.orbit, camera);
  if (!a.view.empty()) camera.setView(a.view, "--view");
  if (!a.upAxis.empty()) {
    camera.upAxis = render::parseUpAxis(a.upAxis, "--up-axis");
  }
  if (!a.eye.empty()) {
    camera.orbit = false;
    camera.eye = triple(a.eye, "--eye");
  }
  if (!a.center.empty()) camera.center = triple(a.center, "--center");
  if (!a.up.empty()) camera.up = triple(a.up, "--up");
  if ((a.fit || !a.upAxis.empty()) && !camera.orbit)
    throw render::RenderInputError("--fit and --up-axis apply to an orbit or view, not to an explicit eye");
  if (a.fit) camera.distance = std::nullopt;
}

}  // namespace

render::Scene buildScene(const SceneArgs& a, const CLI::App& cmd) {
  render::Scene s = a.sceneFile.empty() ? render::Scene{} : render::Scene::fromJson(readText(a.sceneFile), a.sceneFile);
  applyCamera(a, s.camera);
  if (cmd.count("--fov")) s.camera.fovY = a.fov;
  if (a.ortho) s.camera.orthographic = true;
  if (!a.size.empty()) parseSize(a.size, "--size", s.width, s.height);
  if (!a.tf.empty()) {
    s.transferFunction = render::TransferFunction::load(a.tf);
    s.transferFunctionName = a.tf;
  }
  if (cmd.count("--step")) s.step = a.step;
  if (a.background == "none") {
    s.transparent = true;
  } else if (!a.background.empty()) {
    s.background = triple(a.background, "--background");
    s.transparent = false;
  }
  if (!a.window.empty()) {
    double lo = 0, hi = 0;
    char extra = 0;
    if (std::sscanf(a.window.c_str(), "%lf,%lf%c", &lo, &hi, &extra) != 2)
      throw render::RenderInputError("--window '" + a.window + "': expected LO,HI");
    s.window = std::array<double, 2>{lo, hi};
  }
  if (a.noSkip) s.skipEmpty = false;
  if (a.noCull) s.cullFrustum = false;
  if (a.shading) s.shading = true;
  if (a.subBlock >= 0) s.subBlock = a.subBlock;
  if (a.slab >= 0) {
    s.slab = a.slab;
    s.raycast = false;  // --slab N asks for slicing or slabs
  }
  if (a.raycast) s.raycast = true;
  if (cmd.count("--ert")) s.ert = a.ert;
  if (cmd.count("--lod")) s.lod = a.lod;
  if (a.preIntegration) s.preIntegration = true;
  if (a.ess) s.ess = true;
  if (a.progressive) s.progressive = true;
  if (!a.slicer.empty()) s.slicer = render::parseSlicer(a.slicer, "--slicer");
  if (!a.visibility.empty()) s.visibility = render::parseTetSort(a.visibility, "--visibility");
  if (!a.quality.empty()) {
    for (const char* option : {"--step", "--raycast", "--slab", "--ert", "--pre-integration", "--sub-block", "--lod"})
      if (cmd.count(option))
        throw render::RenderInputError(std::string("--quality chooses what ") + option +
                                       " sets, from the dataset's quality table: give one or the other");
    s.quality = render::QualityTarget::parse(a.quality, "--quality");
  } else if (s.quality && (cmd.count("--step") || cmd.count("--raycast") || cmd.count("--slab") || cmd.count("--ert") ||
                           cmd.count("--pre-integration") || cmd.count("--sub-block") || cmd.count("--lod"))) {
    s.quality.reset();  // drawing settings on the command line replace the scene file's target
  }
  s.validate();
  return s;
}

void checkOutputFormat(const render::Scene& scene, const std::string& output) {
  if (scene.transparent && image::imageFormatFor(output) == image::ImageFormat::Jpeg)
    throw render::RenderInputError("--background none needs a .png output: JPEG has no alpha (" + output + ")");
}

void addSceneOptions(CLI::App* cmd, SceneArgs& args) {
  cmd->add_option("--scene", args.sceneFile, "scene JSON (the options below override it)");
  cmd->add_option("--orbit", args.orbit,
                  "AZ,EL[,DIST]: degrees about the up axis, and bounding-sphere radii (default 30,20 at the fitted "
                  "distance: the whole volume in frame); az 0 looks from +y (anterior), az 90 from -x (the patient's "
                  "left) when the up axis is +z");
  cmd->add_option("--up-axis", args.upAxis,
                  "the orbit's up axis: +z (default; superior for patient data), -z, +y (the Y-up orbit of earlier "
                  "versions: az 0 from +z), -y, +x, -x");
  cmd->add_option("--view", args.view,
                  "a named view about +z: " + render::viewNames() +
                      " (for data without a patient frame: from +y, -y, -x, +x, +z, -z)");
  cmd->add_flag("--fit", args.fit,
                "place the orbit's eye so that the whole volume is in frame (the default unless "
                "--orbit gives a distance)");
  cmd->add_option("--eye", args.eye, "x,y,z eye position (world coordinates: RAS for patient data)");
  cmd->add_option("--center", args.center, "x,y,z look-at point (world; default the scene's, else 0,0,0)");
  cmd->add_option("--up", args.up, "x,y,z up vector (world; default the scene's, else 0,1,0)");
  cmd->add_option("--fov", args.fov, "vertical field of view in degrees (default 30)")
      ->check(between(0.01, 179, "degrees"));
  cmd->add_flag("--ortho", args.ortho, "orthographic projection");
  cmd->add_option("--size", args.size, "WIDTHxHEIGHT (default 512x512)");
  cmd->add_option("--tf", args.tf, "transfer function: preset name (config/tf) or JSON file (default grayscale)");
  cmd->add_option("--step", args.step, "slice spacing in voxels (default 0.75)")->check(between(0.001, 64, "voxels"));
  cmd->add_option(
      "--background", args.background,
      "r,g,b in [0, 1] (default 0,0,0), or none: a transparent frame (RGBA PNG, alpha the accumulated opacity)");
  cmd->add_option("--window", args.window, "LO,HI value window (default: the store's value range)");
  cmd->add_option("--visibility", args.visibility,
                  "how a tetrahedral mesh's cells are put in order: raycast (each pixel's ray walks the adjacency, "
                  "--ert applies; default), mpvo (sorted by the face-adjacency walk), or centroid (sorted by distance)")
      ->check(CLI::IsMember({"mpvo", "centroid", "raycast"}));
  cmd->add_option("--slicer", args.slicer,
                  "where slice polygons are computed when slicing (--slab 0): vertex (the vertex program, default), "
                  "cpu, vertex-lean (paths chosen on the CPU), geometry (a geometry program), vertex-geometry (both)")
      ->check(CLI::IsMember(slicerNames()));
  cmd->add_flag("--no-skip", args.noSkip, "draw bricks the transfer function makes empty");
  cmd->add_flag("--no-cull", args.noCull, "draw bricks outside the view frustum");
  cmd->add_option(
         "--sub-block", args.subBlock,
         "skip empty sub-blocks of N voxels inside bricks (a power of two below the brick size, default 8; 0 draws "
         "whole bricks)")
      ->check(between(0, render::Scene::kMaxSubBlock, "voxels"));
  cmd->add_option("--slab", args.slab,
                  "draw with texture slabs of N planes instead of the ray caster: the fragment program marches N "
                  "samples and blends once (slabs of 32 when a volume is too large for the ray caster's cell table; "
                  "0 slices: one blended sample per fragment)")
      ->check(between(0, render::Scene::kMaxSlab, "planes"));
  cmd->add_flag("--raycast", args.raycast,
                "frame ray casting (the default): one fragment per pixel marches its ray through every brick, each "
                "sample's brick looked up in a table of cells (the same samples as slabs); over a scene's 'slab'");
  cmd->add_option("--ert", args.ert,
                  "early ray termination when marching (slabs, ray casting): stop rays whose opacity reached this "
                  "threshold in [0.5, 1] "
                  "(default 0.999; 0: off)")
      ->check(between(0, 1));
  cmd->add_flag("--pre-integration", args.preIntegration,
                "pre-integrated classification when marching (slabs, ray casting): each segment between samples "
                "classified whole from a table");
  cmd->add_option("--lod", args.lod,
                  "level of detail: draw a coarser pyramid level where its voxels are at most this many pixels tall "
                  "(0: level 0 everywhere)")
      ->check(between(0, render::Scene::kMaxLod, "pixels"));
  cmd->add_flag("--ess", args.ess,
                "empty-space silhouette maps on slabs: a pass before each slab marks the pixels with anything to draw");
  cmd->add_flag("--progressive", args.progressive,
                "coarse to fine: a provisional frame first, bricks not yet resident drawn from a coarser resident "
                "level while they are read, then the exact frame");
  cmd->add_flag("--shading", args.shading, "gradient (central differences) and Phong headlight shading");
  cmd->add_option("--quality", args.quality,
                  "quality by target: psnr:DB (the fastest setting whose worst view reached DB against the reference) "
                  "or ms:N (the most accurate one measured within N ms, scaled to the image size), from the "
                  "dataset's quality table (made by `voxbrick bench --calibrate DATASET`); replaces --step, "
                  "--raycast, --slab, --ert, --pre-integration, --sub-block and --lod");
}

}  // namespace voxbrick::cli
