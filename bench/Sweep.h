// The time-versus-error sweep behind `voxbrick bench`: GPU frames of each setting against reference frames of the
// same views, with the Pareto front and the default it implies.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "render/GlContext.h"
#include "render/Scene.h"

namespace voxbrick::bench {

/// A volume to sweep: a prep input and the transfer-function presets to try on it (the first is its default).
struct Dataset {
  std::string name;   ///< short, for file names and tables ("ml", "sparse", "mri")
  std::string input;  ///< what `voxbrick prep` takes
  std::vector<std::string> transferFunctions;
};

/// What the scene asks for besides the renderer's own settings: the transfer function and shading.
struct Variant {
  std::string transferFunction;
  bool shading = false;
  bool operator==(const Variant&) const = default;
  /// E.g. "hot, shaded".
  std::string label() const { return transferFunction + (shading ? ", shaded" : ""); }
};

/// The renderer's own choices, which a default can fix: step, brick size (of the store), skipping, slicer.
struct Setting {
  double step = 0.5;
  int brick = 32;
  bool skip = true;
  render::Slicer slicer = render::Slicer::Vertex;
  bool operator==(const Setting&) const = default;
  /// E.g. "step 0.5, B=32, skip, vertex".
  std::string label() const;
};

/// The sweep: every step with every variant (the baseline renderer), and the renderer alternatives (other brick
/// sizes, no skipping, the CPU slicer) at every step with each dataset's default variant.
struct SweepSpec {
  std::vector<Dataset> datasets;
  std::vector<double> steps;
  std::vector<int> alternativeBricks;  ///< brick sizes besides 32
  bool alternativeNoSkip = true;
  bool alternativeCpuSlicer = true;
  bool shadingVariants = true;        ///< each transfer function with shading off and on
  int views = 8;                       ///< orbit: azimuth 360·v/views, elevation 20°, distance 2.2 R
  int size = 256;                      ///< square images
  double referenceStep = 0.125;        ///< voxels
  double psnrThreshold = 40;           ///< dB, for the chosen default

  /// The committed sweep: Marschner–Lobb 128³, the sparse field 256³ and the MRI at `mriPath`.
  static SweepSpec full(const std::string& mriPath);
  /// A small sweep for CI (seconds): small synthetic volumes, the MRI, 48² images, two views, two steps.
  static SweepSpec quick(const std::string& mriPath);
};

/// One measured point: a dataset, a variant and a setting over every view.
struct Point {
  std::string dataset;
  Variant variant;
  Setting setting;
  double msMedian = 0, msMin = 0, msMax = 0;  ///< frame time over the views
  double samplesMedian = 0;                    ///< fragments shaded per frame
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
  std::optional<Setting> chosen;  ///< chooseDefault's answer
};

/// Runs the sweep. Stores go to `work`/NAME-bB.vbs (made once, kept), reference frames to `work`/reference (so a
/// rerun only renders the GPU frames). `log` gets one line per step of progress.
SweepResult runSweep(const SweepSpec& spec, const std::filesystem::path& work, render::GlContext& context,
                     const std::function<void(const std::string&)>& log);

/// Sets Point::pareto: per dataset and variant, the points no other point beats in both time and worst PSNR.
void markPareto(std::vector<Point>& points);

/// A dataset's default variant: its first transfer function, unshaded.
inline Variant defaultVariant(const Dataset& d) { return {d.transferFunctions.front(), false}; }

/// The fastest setting (sum of the median times over the datasets) whose worst view reaches `psnrThreshold` on every
/// dataset's default variant; none if no setting does.
std::optional<Setting> chooseDefault(const std::vector<Point>& points, const std::vector<Dataset>& datasets,
                                     double psnrThreshold);

/// The coarsest step at which the baseline renderer (B=32, skipping, vertex slicer) keeps the worst view of
/// `variant` on `dataset` at or above `psnrThreshold`; none if no swept step does.
std::optional<double> coarsestStep(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                   double psnrThreshold);

/// Writes sweep.csv, sweep.md and sweep.svg into `out`; throws std::runtime_error naming a file it cannot write.
void writeResults(const SweepResult& result, const std::filesystem::path& out);

}  // namespace voxbrick::bench
