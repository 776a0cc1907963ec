// The time-versus-error sweep of tetrahedral meshes behind `voxbrick bench --mesh`: GPU frames of each mesh
// setting against the exact reference (render/reference/TetReference.h) of the same views, with the Pareto front, the
// default it implies and a plot.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "render/core/Scene.h"
#include "render/gl/GlContext.h"

namespace voxbrick::quality {

/// The mesh renderer's own choices (render::Scene::visibility, skipEmpty and, for the ray caster, ert): what a default
/// can fix.
struct MeshSetting {
  render::TetSort visibility = render::TetSort::Mpvo;
  bool skipEmpty = true;
  double ert = 0;  ///< render::Scene::ert: the ray caster's termination threshold (0: none); only with Ray
  bool operator==(const MeshSetting&) const = default;
  /// E.g. "mpvo, skip", "centroid, no skip"; "raycast, ert 0.999", "raycast, no ert" (a ray walks every tet it
  /// meets: skipEmpty has no effect).
  std::string label() const;
};

/// What to sweep: meshes (a mesh store, a .vtk or .msh file, or synthetic-mesh:SPEC), the transfer functions to
/// render each with (presets or files), and the views: an orbit of `views` azimuths 360·v/views at `elevation`
/// degrees and `distance` bounding radii, `size`² pixels.
struct MeshSweepSpec {
  std::vector<std::string> meshes;
  std::vector<std::string> transferFunctions = {"hot"};
  std::vector<MeshSetting> settings = {{render::TetSort::Mpvo, true},       {render::TetSort::Mpvo, false},
                                       {render::TetSort::Centroid, true},   {render::TetSort::Centroid, false},
                                       {render::TetSort::Ray, true, 0.999}, {render::TetSort::Ray, true, 0}};
  int views = 4;
  int size = 256;
  double elevation = 20;
  double distance = 2.5;
  double psnrThreshold = 40;  ///< dB: the chosen default is the fastest setting whose every worst view reaches it
};

/// One measured point: a mesh, a transfer function and a setting over every view.
struct MeshPoint {
  std::string mesh;  ///< its name: the input's file name, or the synthetic spec
  std::string transferFunction;
  MeshSetting setting;
  int64_t tets = 0;                           ///< in the mesh
  double msMedian = 0, msMin = 0, msMax = 0;  ///< frame time over the views
  double sortMsMedian = 0;                    ///< the visibility order's part of it
  double fragmentsMedian = 0;                 ///< segments classified per frame: fragments, or the ray caster's steps
  double tetsDrawnMedian = 0;                 ///< tets drawn per frame (skipEmpty leaves some out)
  double psnrMin = 0;                         ///< the worst view's PSNR against the exact reference (dB)
  double psnrPooled = 0;                      ///< PSNR of the RMSE over all views' pixels
  double maxAbs = 0;                          ///< over all views
  bool pareto = false;                        ///< on the front (time, worst PSNR) of its mesh and transfer function
};

struct MeshSweepResult {
  std::string device;
  MeshSweepSpec spec;
  std::vector<MeshPoint> points;
  /// Per mesh and transfer function: the exact reference's median time per view (ms).
  std::vector<std::pair<std::string, double>> referenceMs;
  std::optional<MeshSetting> chosen;  ///< the fastest setting (summed medians) at spec.psnrThreshold everywhere
};

/// Runs the sweep: each mesh is read whole (a store, or a file validated as `prep` does), each view rendered once by
/// the exact reference, then by every setting after a warm-up frame. `log` gets a line per step of progress. Throws
/// what reading a mesh throws (naming it), RenderInputError for an unknown transfer function.
MeshSweepResult runMeshSweep(const MeshSweepSpec& spec, render::GlContext& context,
                             const std::function<void(const std::string&)>& log);

/// Sets MeshPoint::pareto: per mesh and transfer function, the points no other point beats in time and worst PSNR.
void markMeshPareto(std::vector<MeshPoint>& points);

/// Writes mesh-sweep.csv, mesh-sweep.md and mesh-sweep.svg into `out`; throws std::runtime_error naming a file it
/// cannot write.
void writeMeshResults(const MeshSweepResult& result, const std::filesystem::path& out);

}  // namespace voxbrick::quality
