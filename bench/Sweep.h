// The time-versus-error sweep behind `voxbrick bench`: GPU frames of each setting against reference frames of the
// same views, with the Pareto front and the default it implies.
#pragma once

#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "image/Image.h"
#include "render/gl/GlContext.h"
#include "render/core/Scene.h"

namespace voxbrick::bench {

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
  int slab = 0;                 ///< 0 slices; N texture slabs of N planes (render::Scene::kMaxSlab: whole bricks)
  /// The frame ray caster (render::Scene::raycast). Its settings keep slab 0: the ray caster ignores slab, which
  /// only picks the slabs drawn instead where a volume is too large for its cell table (render::FramePlan).
  bool raycast = false;
  double ert = 0;               ///< early ray termination threshold (0 off); slabs and the ray caster only
  bool preIntegration = false;  ///< pre-integrated classification; slabs and the ray caster only
  /// Empty sub-blocks skipped inside bricks (render::Scene::subBlock), the ray caster's cell size; 0 whole bricks.
  int subBlock = 0;
  double lod = 0;               ///< level of detail (render::Scene::lod); 0 level 0 everywhere
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

/// The median of `v` (the mean of the middle two for an even count); 0 when empty.
double median(std::vector<double> v);

/// A setting's frames against their references, view by view: the worst view's PSNR, the largest difference and the
/// pooled error (the RMSE over all views' pixels, each view the same size).
struct ErrorTally {
  double psnrMin = std::numeric_limits<double>::infinity();
  double maxAbs = 0;
  double sumSquares = 0;
  int views = 0;
  void add(const image::ImageError& e);
  double rmsePooled() const;
  double psnrPooled() const;  ///< infinity for identical frames
};

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
  bool shadingVariants = true;        ///< each transfer function with shading off and on
  std::vector<int> slabs;              ///< slab sizes swept without ERT; empty: no slab settings at all
  int ertSlab = 16;                    ///< the slab size of the ERT thresholds and of pre-integration
  std::vector<double> erts;            ///< ERT thresholds besides 0 (off)
  /// Each threshold of `erts` at `ertSlab` again with each of these sub-block sizes (empty space skipped inside
  /// bricks, which slabs pay no extra ownership cost for).
  std::vector<int> slabSubBlocks;
  /// Levels of detail besides 0 (render::Scene::lod), each with every threshold of `erts` at `ertSlab` and the last
  /// of `slabSubBlocks` (0 if none); the reference stays level 0, so their error is what a user sees.
  std::vector<double> lods;
  bool ertAtBestSlab = true;           ///< also the thresholds at the fastest other slab size
  bool preIntegration = true;          ///< pre-integration at `ertSlab`, with ERT off and with the best threshold
  bool opaqueVariants = true;          ///< slab and ray-caster settings on each dataset's opaque transfer function too
  /// The frame ray caster (render::Scene::raycast) with ERT off and each of `erts`, each with whole-brick cells and
  /// each of `slabSubBlocks`; each of `lods` as for slabs; pre-integration if `preIntegration`. Independent of
  /// `slabs`, on the slab variants.
  bool rayCast = false;
  std::vector<double> slabSteps;       ///< the steps of the slab settings (each one of `steps`); empty: every step
  /// Slab sizes below `ertSlab` (a fragment per plane or few: the slowest settings) run only at steps at least this.
  double smallSlabMinStep = 0;
  double slabTableStep = 1;            ///< the step of sweep.md's slab table (else the nearest swept one)
  double ertToleranceDb = 1;           ///< bestErt: worst-view PSNR a threshold may cost (below psnrHighThreshold)
  int views = 8;                       ///< orbit: azimuth 360·v/views, elevation elevations[v % size], 2.2 R
  std::vector<double> elevations = {20};  ///< degrees, taken in turn by the views
  int size = 256;                      ///< square images
  double referenceStep = 0.125;        ///< voxels
  double psnrThreshold = 40;           ///< dB, for the chosen default
  double psnrHighThreshold = 50;       ///< dB, for the second answer (the fastest setting at this accuracy)

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

/// One measured point: a dataset, a variant and a setting over every view.
struct Point {
  std::string dataset;
  Variant variant;
  Setting setting;
  double msMedian = 0, msMin = 0, msMax = 0;  ///< frame time over the views
  double samplesMedian = 0;                    ///< volume samples taken per frame (FrameStats::samples)
  double fragmentsMedian = 0;                  ///< fragments started per frame (slicing: = samples)
  double samplesTerminatedMedian = 0;          ///< samples left by early ray termination inside a fragment
  double slabPassesMedian = 0;                 ///< draws of one slab each (0 when slicing)
  double psnrMin = 0;     ///< the worst view's PSNR against the reference (dB)
  double psnrPooled = 0;  ///< PSNR of the RMSE over all views' pixels
  double rmsePooled = 0;
  double maxAbs = 0;      ///< over all views
  bool pareto = false;    ///< on the Pareto front (time, worst PSNR) of its dataset and variant
};

/// How the reference was made for a dataset, and its self-check: view 0 of each default-transfer-function variant at
/// the reference step against half that step.
struct ReferenceReport {
  std::string dataset;
  Variant variant;
  double msPerView = 0;    ///< median over the views that were not cached (0 if all were)
  double halvingPsnr = 0;  ///< step vs step/2
  double halvingMaxAbs = 0;
};

struct SweepResult {
  std::string device;
  SweepSpec spec;
  std::vector<Point> points;
  std::vector<ReferenceReport> references;
  std::optional<Setting> chosen;      ///< chooseDefault's answer at spec.psnrThreshold
  std::optional<Setting> chosenHigh;  ///< chooseDefault's answer at spec.psnrHighThreshold
  std::optional<int> bestSlab;        ///< bestSlabSize: the other slab size the thresholds also ran at
  std::optional<double> bestErt;      ///< bestErt: the threshold pre-integration also ran with
  std::optional<double> bestRayCastErt;  ///< bestRayCastErt: the threshold the ray caster's pre-integration ran with
};

/// Runs the sweep. Stores go to `work`/NAME-bB.vbs (made once, kept), reference frames to `work`/reference (so a
/// rerun only renders the GPU frames). `log` gets one line per step of progress.
SweepResult runSweep(const SweepSpec& spec, const std::filesystem::path& work, render::GlContext& context,
                     const std::function<void(const std::string&)>& log);

/// Sets Point::pareto: per dataset and variant, the points no other point beats in both time and worst PSNR.
void markPareto(std::vector<Point>& points);

/// A dataset's default variant: its first transfer function, unshaded.
inline Variant defaultVariant(const Dataset& d) { return {d.transferFunctions.front(), false}; }

/// The variants the slab and ray-caster settings run on: the default one and, if the dataset has one and `opaque` is
/// set, the opaque transfer function unshaded.
std::vector<Variant> slabVariants(const Dataset& d, bool opaque);

/// Of the slab sizes measured without ERT or pre-integration other than `exclude`, the one with the least total
/// median time over the datasets, variants and steps at which every such size was measured; none if there is none.
std::optional<int> bestSlabSize(const std::vector<Point>& points, int exclude);

/// The lowest threshold (the most termination) of those measured at slab `slab` without pre-integration whose worst
/// view, at every dataset, variant and step, stays at or above min(the same without ERT − toleranceDb,
/// highThreshold): ERT may cost accuracy only where the frame stays above the higher threshold. If none does, the
/// highest threshold measured; none if no threshold was measured.
std::optional<double> bestErt(const std::vector<Point>& points, int slab, double toleranceDb, double highThreshold);

/// The same rule over the ray caster's points: thresholds measured with it without pre-integration, each against the
/// ray caster without ERT.
std::optional<double> bestRayCastErt(const std::vector<Point>& points, double toleranceDb, double highThreshold);

/// The fastest point of `dataset` and `variant` whose worst view reaches `psnrThreshold`; none if no point does.
std::optional<Point> fastestPoint(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                  double psnrThreshold);

/// The fastest setting (sum of the median times over the datasets) whose worst view reaches `psnrThreshold` on every
/// dataset's default variant; none if no setting does.
std::optional<Setting> chooseDefault(const std::vector<Point>& points, const std::vector<Dataset>& datasets,
                                     double psnrThreshold);

/// The coarsest step at which the baseline renderer (B=32, skipping, vertex slicer) keeps the worst view of
/// `variant` on `dataset` at or above `psnrThreshold`; none if no swept step does.
std::optional<double> coarsestStep(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                   double psnrThreshold);

/// Where runSweep keeps the store of `d` with brick size `brick`: `work`/NAME-bB.vbs, or `d.store` if set.
std::filesystem::path datasetStorePath(const Dataset& d, int brick, const std::filesystem::path& work);

/// The quality table (render/core/Quality.h) of the points measured on `store` (a path, as datasetStorePath gives it):
/// every point of a dataset kept there with bricks of 32 (the store's), skipping and the vertex slicer, one entry per
/// transfer function, shading and setting. `device` names the GL renderer.
render::QualityTable qualityTable(const SweepResult& result, const std::filesystem::path& work,
                                  const std::filesystem::path& store);

/// Writes sweep.csv, sweep.md and sweep.svg into `out`; throws std::runtime_error naming a file it cannot write.
void writeResults(const SweepResult& result, const std::filesystem::path& out);

/// `value` printed with `format` (one double), "inf" for an infinite one (a PSNR of identical images).
std::string formatNumber(const char* format, double value);

/// Writes `text` to `path` (replacing it); throws std::runtime_error naming the file if it cannot.
void writeTextFile(const std::filesystem::path& path, const std::string& text);

}  // namespace voxbrick::bench
