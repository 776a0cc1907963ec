// What the time-versus-error sweep measures: the volumes, the scene variants, the renderer settings and the spec
// that combines them (the committed sweep, the quick one for CI, and the calibration of one store for quality by
// target).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "render/core/Scene.h"

namespace voxbrick::quality {

/// A volume to sweep: a prep input and the transfer-function presets to try on it (the first is its default).
struct Dataset {
  std::string name;   ///< short, for file names and tables ("ml", "sparse", "mri")
  std::string input;  ///< what `voxbrick prep` takes
  std::vector<std::string> transferFunctions;
  /// An opaque transfer function (where early ray termination matters most) on which the texture-slab settings run
  /// too, unshaded; empty: none. Swept like the others if it is not among `transferFunctions`.
  std::string opaque = {};
  /// An existing store (or .vdb) to measure as it is, instead of prepping `input` (SweepSpec::calibrate).
  std::string store = {};
};

/// What the scene asks for besides the renderer's own settings: the transfer function and shading.
struct Variant {
  std::string transferFunction;
  bool shading = false;
  bool operator==(const Variant&) const = default;
  /// E.g. "hot, shaded".
  std::string label() const { return transferFunction + (shading ? ", shaded" : ""); }
};

/// The renderer's own choices, which a default can fix: step, brick size (of the store), skipping, slicer, and the
/// marching settings (render::Scene::slab, raycast, ert, preIntegration).
struct Setting {
  double step = 0.5;
  int brick = 32;
  bool skip = true;
  render::Slicer slicer = render::Slicer::Vertex;
  int slab = 0;  ///< 0 slices; N texture slabs of N planes (render::Scene::kMaxSlab: whole bricks)
  /// The frame ray caster (render::Scene::raycast). Its settings keep slab 0: the ray caster ignores slab, which
  /// only picks the slabs drawn instead where a volume is too large for its cell table (render::FramePlan).
  bool raycast = false;
  double ert = 0;               ///< early ray termination threshold (0 off); slabs and the ray caster only
  bool preIntegration = false;  ///< pre-integrated classification; slabs and the ray caster only
  /// Empty sub-blocks skipped inside bricks (render::Scene::subBlock), the ray caster's cell size; 0 whole bricks.
  int subBlock = 0;
  double lod = 0;  ///< level of detail (render::Scene::lod); 0 level 0 everywhere
  bool operator==(const Setting&) const = default;
  /// E.g. "step 0.5, B=32, skip, vertex"; the marching settings are appended only where not default: "step 1, B=32,
  /// skip, vertex, slab 16, ert 0.99, pre-int" ("slab whole brick" for render::Scene::kMaxSlab), "step 0.5, B=32,
  /// skip, vertex, raycast, ert 0.999, sub-block 8".
  std::string label() const;
};

/// "slab 16", "slab whole brick" (render::Scene::kMaxSlab), or "slicing" for 0.
std::string slabLabel(int slab);

/// The part of Setting::label() after the slicer, for tables of one step, brick size and slicer: "slicing",
/// "slab 16, ert 0.99, pre-int", "raycast, ert 0.999, sub-block 8".
std::string marchingLabel(const Setting& s);

/// The sweep: every step with every variant (the baseline renderer), the slicing alternatives (other brick sizes,
/// no skipping, the CPU slicer) at every step with each dataset's default variant, and the texture-slab settings
/// at every step (of `slabSteps`) with each dataset's slab variants (its default and its opaque variant):
///   1. every slab size of `slabs`, without early ray termination;
///   2. every threshold of `erts` at slab `ertSlab`;
///   3. then, once every dataset has been through 1 and 2: every threshold at the best slab size (bestSlabSize) if
///      that is not `ertSlab`, and pre-integration at `ertSlab` with ERT off and with the best threshold (bestErt).
/// All slab settings use B=32, skipping and the vertex slicer; slab sizes below `ertSlab` skip the steps below
/// `smallSlabMinStep`. The ray-caster settings (`rayCast`) run at the same steps on the same variants, B=32,
/// skipping, vertex slicer:
///   1. ERT off and every threshold of `erts`, each with whole-brick cells and with each of `slabSubBlocks`, and each
///      level of `lods` as for slabs;
///   2. once every dataset has been through 1: pre-integration with whole-brick cells, ERT off and the ray caster's
///      own best threshold (bestRayCastErt), as for slabs.
struct SweepSpec {
  std::vector<Dataset> datasets;
  std::vector<double> steps;
  std::vector<int> alternativeBricks;  ///< brick sizes besides 32
  bool alternativeNoSkip = true;
  bool alternativeCpuSlicer = true;
  bool shadingVariants = true;  ///< each transfer function with shading off and on
  std::vector<int> slabs;       ///< slab sizes swept without ERT; empty: no slab settings at all
  int ertSlab = 16;             ///< the slab size of the ERT thresholds and of pre-integration
  std::vector<double> erts;     ///< ERT thresholds besides 0 (off)
  /// Each threshold of `erts` at `ertSlab` again with each of these sub-block sizes (empty space skipped inside
  /// bricks, which slabs pay no extra ownership cost for).
  std::vector<int> slabSubBlocks;
  /// Levels of detail besides 0 (render::Scene::lod), each with every threshold of `erts` at `ertSlab` and the last
  /// of `slabSubBlocks` (0 if none); the reference stays level 0, so their error is what a user sees.
  std::vector<double> lods;
  bool ertAtBestSlab = true;   ///< also the thresholds at the fastest other slab size
  bool preIntegration = true;  ///< pre-integration at `ertSlab`, with ERT off and with the best threshold
  bool opaqueVariants = true;  ///< slab and ray-caster settings on each dataset's opaque transfer function too
  /// The frame ray caster (render::Scene::raycast) with ERT off and each of `erts`, each with whole-brick cells and
  /// each of `slabSubBlocks`; each of `lods` as for slabs; pre-integration if `preIntegration`. Independent of
  /// `slabs`, on the slab variants.
  bool rayCast = false;
  /// Each view's frame timed as a server sends it, finished on the GPU as 8 bits (render::FrameRenderer::render8),
  /// and its error measured on the float frame of the same view drawn again (the same samples: the 8 bits are
  /// image::toImage8 of those floats). False: the float frame is timed and judged.
  bool frames8 = false;
  std::vector<double> slabSteps;  ///< the steps of the slab settings (each one of `steps`); empty: every step
  /// Slab sizes below `ertSlab` (a fragment per plane or few: the slowest settings) run only at steps at least this.
  double smallSlabMinStep = 0;
  double slabTableStep = 1;               ///< the step of sweep.md's slab table (else the nearest swept one)
  double ertToleranceDb = 1;              ///< bestErt: worst-view PSNR a threshold may cost (below psnrHighThreshold)
  int views = 8;                          ///< orbit: azimuth 360·v/views, elevation elevations[v % size], 2.2 R
  std::vector<double> elevations = {20};  ///< degrees, taken in turn by the views
  int size = 256;                         ///< square images
  double referenceStep = 0.125;           ///< voxels
  double psnrThreshold = 40;              ///< dB, for the chosen default
  double psnrHighThreshold = 50;          ///< dB, for the second answer (the fastest setting at this accuracy)

  /// The steps at which the slab and ray-caster settings run.
  std::vector<double> slabStepsOrAll() const { return slabSteps.empty() ? steps : slabSteps; }
  /// Whether any setting runs on the slab variants (slabs or the ray caster).
  bool marches() const { return !slabs.empty() || rayCast; }
  /// How many points runSweep measures at most (the best slab size's thresholds counted as if it is not `ertSlab`).
  size_t plannedPoints() const;

  /// The committed sweep: Marschner–Lobb 128³, the sparse field 256³ and the MRI at `mriPath`, with the ray caster.
  static SweepSpec full(const std::string& mriPath);
  /// A small sweep for CI (seconds): small synthetic volumes, the MRI, 48² images, two views, two steps, every kind of
  /// slab and ray-caster setting at the coarser one.
  static SweepSpec quick(const std::string& mriPath);
  /// The calibration of one dataset for quality by target (render/core/Quality.h): the store at `store` as it is, one
  /// sweep dataset per transfer function of `transferFunctions` (so that each gets every setting), unshaded; the
  /// ray caster at steps 0.35 to 3 with ERT off and 0.999, whole-brick cells and sub-blocks of 8, levels of detail 1
  /// and 2, pre-integration, and slicing at each step; 6 views at 256², at elevations 20, -30 and 55 in turn.
  static SweepSpec calibrate(const std::string& store, const std::vector<std::string>& transferFunctions);
};

/// A dataset's default variant: its first transfer function, unshaded.
inline Variant defaultVariant(const Dataset& d) { return {d.transferFunctions.front(), false}; }

/// The variants the slab and ray-caster settings run on: the default one and, if the dataset has one and `opaque` is
/// set, the opaque transfer function unshaded.
std::vector<Variant> slabVariants(const Dataset& d, bool opaque);

/// Every variant the sweep renders of `d`: each transfer function unshaded (and shaded with
/// SweepSpec::shadingVariants), then the slab variants not among them when the spec marches.
std::vector<Variant> sweptVariants(const SweepSpec& spec, const Dataset& d);

/// Where the sweep keeps the store of `d` with brick size `brick`: `work`/NAME-bB.vbs, or `d.store` if set.
std::filesystem::path datasetStorePath(const Dataset& d, int brick, const std::filesystem::path& work);

/// A step, threshold or level as "%g" prints it: "0.5", "0.999".
std::string stepText(double step);

}  // namespace voxbrick::quality
