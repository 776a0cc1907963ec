// `voxbrick bench`: the time-versus-error sweep (quality/SweepRun.h) with its files (quality/SweepReport.h) and the
// default it picks; `--calibrate` writes a store's quality table (quality/Calibration.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>

#include <unistd.h>

#include "brickstore/format/Errors.h"
#include "brickstore/read/BrickStore.h"
#include "brickstore/read/OpenAnyStore.h"
#include "cli/Commands.h"
#include "quality/Calibration.h"
#include "quality/MeshSweep.h"
#include "quality/SettingChoice.h"
#include "quality/SweepReport.h"
#include "quality/SweepRun.h"
#include "render/core/Quality.h"
#include "render/core/Scene.h"
#include "render/core/TransferFunction.h"
#include "render/gl/GlContext.h"

namespace voxbrick::cli {
namespace {

namespace fs = std::filesystem;

struct BenchArgs {
  std::string out = "bench/results/sweep/raycast", work = "bench/work", datasets, steps, backend = "auto";
  std::string mri = "/usr/share/mricron/templates/ch2better.nii.gz";
  std::string slabs, erts, slabSteps, alternatives, slabSubBlocks, lods, calibrate, tfs = "grayscale";
  bool quick = false, quiet = false, dryRun = false, noBestSlab = false, noPreIntegration = false, noOpaque = false,
       noShading = false, rayCast = false, noRayCast = false, frames8 = false;
  std::vector<std::string> meshes;
  int views = 0, size = 0, ertSlab = 0;
  double referenceStep = 0, threshold = 40, thresholdHigh = 50, slabTableStep = 0, smallSlabMinStep = -1;
};

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> parts;
  for (size_t start = 0; start <= text.size();) {
    const size_t comma = std::min(text.find(',', start), text.size());
    if (comma > start) parts.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return parts;
}

/// A comma-separated list of numbers in [lo, hi] (whole ones if `whole`), or "none" for an empty one; throws
/// store::InputError naming the option.
std::vector<double> numberList(const std::string& text, const std::string& option, double lo, double hi,
                               bool whole = false) {
  std::vector<double> values;
  if (text == "none") return values;
  for (const std::string& s : splitList(text)) {
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || !(v >= lo && v <= hi) || (whole && v != std::floor(v))) {
      char range[64];
      std::snprintf(range, sizeof range, "[%g, %g]", lo, hi);
      throw store::InputError(option + ": '" + s + "' is not " + (whole ? "a whole number" : "a number") + " in " +
                              range);
    }
    values.push_back(v);
  }
  if (values.empty()) throw store::InputError(option + ": an empty list (write 'none' for none)");
  return values;
}

/// Writes the quality table of the sweep's measurements on `store` beside it and says what it holds.
void writeQualityTable(const quality::SweepResult& result, const fs::path& work, const fs::path& store) {
  const render::QualityTable table = quality::saveQualityTable(result, work, store);
  if (table.entries.empty()) return;
  std::printf("bench: wrote %s (%zu settings measured at %dx%d, %d views)\n",
              render::QualityTable::pathFor(store).string().c_str(), table.entries.size(), table.width, table.height,
              table.views);
}

/// The sweep spec the options ask for: the committed sweep, the quick one, or the calibration of one dataset.
quality::SweepSpec baseSpec(const BenchArgs& a) {
  if (a.calibrate.empty()) return a.quick ? quality::SweepSpec::quick(a.mri) : quality::SweepSpec::full(a.mri);
  if (a.quick || !a.datasets.empty())
    throw store::InputError("--calibrate measures the dataset it names: not with --quick or --datasets");
  if (!fs::exists(a.calibrate)) throw store::InputError("--calibrate: '" + a.calibrate + "' does not exist");
  if (!fs::exists(fs::path(a.calibrate) / "store.json") && !store::isVdbFile(a.calibrate))
    throw store::InputError("--calibrate: '" + a.calibrate +
                            "' is not a brick store or a .vdb file (quality tables are measured on grids)");
  const std::vector<std::string> tfs = splitList(a.tfs);
  if (tfs.empty()) throw store::InputError("--tf: an empty list");
  for (const std::string& tf : tfs) render::TransferFunction::load(tf);  // refuses an unknown preset now, not later
  return quality::SweepSpec::calibrate(a.calibrate, tfs);
}

/// `bench --mesh INPUT...`: the mesh sweep (quality/MeshSweep.h) with its files and the default it picks.
void runMeshBench(const BenchArgs& a, const CLI::App& cmd) {
  if (a.quick || !a.calibrate.empty() || !a.datasets.empty())
    throw store::InputError("--mesh sweeps the meshes it names: not with --quick, --calibrate or --datasets");
  for (const std::string& m : a.meshes)
    if (m.rfind("synthetic-mesh:", 0) != 0 && !fs::exists(m))
      throw store::InputError("--mesh: '" + m + "' does not exist");
  quality::MeshSweepSpec spec;
  spec.meshes = a.meshes;
  if (cmd.count("--tf") > 0) spec.transferFunctions = splitList(a.tfs);
  if (spec.transferFunctions.empty()) throw store::InputError("--tf: an empty list");
  if (a.views > 0) spec.views = a.views;
  if (a.size > 0) spec.size = a.size;
  spec.psnrThreshold = a.threshold;
  auto context = render::createContext(render::parseBackend(a.backend));
  if (!a.quiet) std::fprintf(stderr, "bench: %s\n", context->describe().c_str());
  const quality::MeshSweepResult result = quality::runMeshSweep(spec, *context, [&](const std::string& line) {
    if (!a.quiet) std::fprintf(stderr, "bench: %s\n", line.c_str());
  });
  quality::writeMeshResults(result, a.out);
  std::printf("bench: wrote %s/mesh-sweep.{csv,md,svg} (%zu points)\n", a.out.c_str(), result.points.size());
  std::printf("bench: default at >= %g dB: %s\n", spec.psnrThreshold,
              result.chosen ? result.chosen->label().c_str() : "none");
}

/// Keeps the datasets --datasets names; throws store::InputError naming an unknown one.
void selectDatasets(const BenchArgs& a, quality::SweepSpec& spec) {
  if (a.datasets.empty()) return;
  std::set<std::string> known;
  for (const quality::Dataset& d : spec.datasets) known.insert(d.name);
  const std::vector<std::string> wanted = splitList(a.datasets);
  for (const std::string& name : wanted)
    if (!known.count(name)) throw store::InputError("--datasets: unknown dataset '" + name + "' (ml, sparse, mri)");
  std::erase_if(spec.datasets, [&](const quality::Dataset& d) {
    return std::find(wanted.begin(), wanted.end(), d.name) == wanted.end();
  });
}

/// A list of whole numbers (numberList with `whole`).
std::vector<int> intList(const std::string& text, const std::string& option, double lo, double hi) {
  std::vector<int> values;
  for (double v : numberList(text, option, lo, hi, true)) values.push_back(int(v));
  return values;
}

/// The values of a list besides 0 (which the sweep always has), each checked by numberList; "none" for none.
std::vector<double> nonZeroList(const std::string& text, const std::string& option, double lo, double hi) {
  std::vector<double> values;
  for (const std::string& t : text == "none" ? std::vector<std::string>{} : splitList(text))
    if (t != "0") values.push_back(numberList(t, option, lo, hi).front());
  return values;
}

/// The steps, slab sizes, thresholds, sub-blocks, levels of detail and slab steps the options list.
void applyLists(const BenchArgs& a, quality::SweepSpec& spec) {
  if (!a.steps.empty()) spec.steps = numberList(a.steps, "--steps", 1e-3, 64);
  if (!a.slabs.empty()) spec.slabs = intList(a.slabs, "--slabs", 1, render::Scene::kMaxSlab);
  if (!a.erts.empty()) spec.erts = nonZeroList(a.erts, "--erts", 0.5, 1);  // off is always swept
  if (a.ertSlab > 0) spec.ertSlab = a.ertSlab;
  if (!a.slabSubBlocks.empty())
    spec.slabSubBlocks = intList(a.slabSubBlocks, "--slab-sub-blocks", 2, render::Scene::kMaxSubBlock);
  if (!a.lods.empty()) spec.lods = nonZeroList(a.lods, "--lods", 0, render::Scene::kMaxLod);
  if (!a.slabSteps.empty()) {
    spec.slabSteps = numberList(a.slabSteps, "--slab-steps", 1e-3, 64);
    for (double step : spec.slabSteps)
      if (std::find(spec.steps.begin(), spec.steps.end(), step) == spec.steps.end())
        throw store::InputError("--slab-steps: " + std::to_string(step) + " is not one of --steps");
  } else if (!a.steps.empty()) {
    spec.slabSteps.clear();  // the quick sweep's coarse step may not be among the steps asked for
  }
}

/// --alternatives: bN (bricks of N), no-skip, cpu-slicer, or none; throws store::InputError naming a bad one.
void applyAlternatives(const std::string& text, quality::SweepSpec& spec) {
  spec.alternativeBricks.clear();
  spec.alternativeNoSkip = spec.alternativeCpuSlicer = false;
  for (const std::string& alt : text == "none" ? std::vector<std::string>{} : splitList(text)) {
    if (alt == "no-skip") {
      spec.alternativeNoSkip = true;
    } else if (alt == "cpu-slicer") {
      spec.alternativeCpuSlicer = true;
    } else if (alt.size() > 1 && alt[0] == 'b' && alt.find_first_not_of("0123456789", 1) == std::string::npos &&
               alt.size() < 5) {
      const int brick = std::stoi(alt.substr(1));
      if (brick < 8 || brick > 256 || (brick & (brick - 1)) || brick == 32)
        throw store::InputError("--alternatives: '" + alt + "': a brick size is a power of two 8…256 besides 32");
      spec.alternativeBricks.push_back(brick);
    } else {
      throw store::InputError("--alternatives: unknown alternative '" + alt + "' (bN, no-skip, cpu-slicer, none)");
    }
  }
}

/// The switches, the frames and the thresholds the options set.
void applySettings(const BenchArgs& a, quality::SweepSpec& spec) {
  if (a.slabTableStep > 0) spec.slabTableStep = a.slabTableStep;
  if (a.smallSlabMinStep >= 0) spec.smallSlabMinStep = a.smallSlabMinStep;
  if (a.noBestSlab) spec.ertAtBestSlab = false;
  if (a.noPreIntegration) spec.preIntegration = false;
  if (a.noOpaque) spec.opaqueVariants = false;
  if (a.noShading) spec.shadingVariants = false;
  if (a.rayCast) spec.rayCast = true;
  if (a.noRayCast) spec.rayCast = false;
  spec.frames8 = a.frames8;
  if (!a.alternatives.empty()) applyAlternatives(a.alternatives, spec);
  if (a.views > 0) spec.views = a.views;
  if (a.size > 0) spec.size = a.size;
  if (a.referenceStep > 0) spec.referenceStep = a.referenceStep;
  spec.psnrThreshold = a.threshold;
  spec.psnrHighThreshold = a.thresholdHigh;
}

/// What the sweep chose: the default, the answer at the higher threshold, and per dataset the fastest setting there.
void printChoices(const quality::SweepSpec& spec, const quality::SweepResult& result) {
  if (result.chosen)
    std::printf("bench: default: %s (fastest keeping every dataset at >= %g dB)\n", result.chosen->label().c_str(),
                spec.psnrThreshold);
  else
    std::printf("bench: no setting keeps every dataset at >= %g dB\n", spec.psnrThreshold);
  if (result.chosenHigh)
    std::printf("bench: fastest keeping every dataset at >= %g dB: %s\n", spec.psnrHighThreshold,
                result.chosenHigh->label().c_str());
  else
    std::printf("bench: no setting keeps every dataset at >= %g dB\n", spec.psnrHighThreshold);
}

void printFastestPerDataset(const quality::SweepSpec& spec, const quality::SweepResult& result) {
  for (const quality::Dataset& d : spec.datasets) {
    const std::optional<quality::Point> p =
        quality::fastestPoint(result.points, d.name, quality::defaultVariant(d), spec.psnrHighThreshold);
    if (p)
      std::printf("bench: %s, %s: fastest at >= %g dB: %s (%.1f ms, %.1f dB)\n", d.name.c_str(),
                  p->variant.label().c_str(), spec.psnrHighThreshold, p->setting.label().c_str(), p->msMedian,
                  p->psnrMin);
  }
}

/// Runs the sweep of `spec`: a calibration writes its store's quality table (and the sweep's files only with
/// --out); otherwise the files, the choices and a quality table beside each dataset's store.
void runGridSweep(const BenchArgs& a, const CLI::App& cmd, const quality::SweepSpec& spec) {
  auto context = render::createContext(render::parseBackend(a.backend));
  if (!a.quiet)
    std::fprintf(stderr, "bench: %s; at most %zu points\n", context->describe().c_str(), spec.plannedPoints());
  // A calibration keeps its reference frames in a temporary directory unless --work names one.
  const bool temporaryWork = !a.calibrate.empty() && !cmd.count("--work");
  const fs::path work =
      temporaryWork ? fs::temp_directory_path() / ("voxbrick-calibrate-" + std::to_string(getpid())) : fs::path(a.work);
  const quality::SweepResult result = quality::runSweep(spec, work, *context, [&](const std::string& line) {
    if (!a.quiet) std::fprintf(stderr, "bench: %s\n", line.c_str());
  });
  if (temporaryWork) fs::remove_all(work);
  if (!a.calibrate.empty()) {
    writeQualityTable(result, work, a.calibrate);
    if (!cmd.count("--out")) return;
  }
  quality::writeResults(result, a.out);
  std::printf("bench: %zu points; wrote %s/sweep.csv, sweep.md, sweep.svg\n", result.points.size(), a.out.c_str());
  printChoices(spec, result);
  if (a.calibrate.empty())
    for (const quality::Dataset& d : spec.datasets)
      writeQualityTable(result, work, quality::datasetStorePath(d, 32, work));
  printFastestPerDataset(spec, result);
}

void runBench(const BenchArgs& a, const CLI::App& cmd) {
  if (!a.meshes.empty()) return runMeshBench(a, cmd);
  quality::SweepSpec spec = baseSpec(a);
  selectDatasets(a, spec);
  applyLists(a, spec);
  applySettings(a, spec);
  if (a.dryRun) {
    std::printf("bench: at most %zu points, %d views each (and a warm-up frame), %dx%d\n", spec.plannedPoints(),
                spec.views, spec.size, spec.size);
    return;
  }
  runGridSweep(a, cmd, spec);
}

}  // namespace

void addBenchCommand(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "bench", "Time against error: GPU frames of each setting against the reference, with a plot and a default");
  cmd->add_option("--out", args->out, "directory for sweep.csv, sweep.md, sweep.svg")->capture_default_str();
  cmd->add_option("--work", args->work, "directory for the stores and the cached reference frames")
      ->capture_default_str();
  cmd->add_flag("--quick", args->quick, "the small sweep CI runs (seconds)");
  cmd->add_option("--calibrate", args->calibrate,
                  "measure this brick store (or .vdb) for quality by target (render --quality): the ray caster at "
                  "steps 0.35-3 with and without ERT, sub-blocks, LOD and pre-integration, and slicing, against the "
                  "reference, written to its quality.json (FILE.quality.json beside a .vdb); the sweep's files only "
                  "with --out");
  cmd->add_option(
      "--mesh", args->meshes,
      "sweep tetrahedral meshes instead of the grids (repeatable): a mesh store, a .vtk or .msh file, or "
      "synthetic-mesh:SPEC; visibility mpvo and centroid, with and without empty-space skipping, and the ray "
      "caster with and without ert 0.999, against the exact reference, into mesh-sweep.{csv,md,svg} "
      "(default --tf hot, 4 views)");
  cmd->add_option("--tf", args->tfs,
                  "--calibrate and --mesh: transfer functions to measure, comma-separated presets or files (default "
                  "grayscale; hot with --mesh)")
      ->capture_default_str();
  cmd->add_option("--datasets", args->datasets, "a subset of ml,sparse,mri (default all)");
  cmd->add_option("--steps", args->steps, "steps in voxels, comma-separated (default 0.25,0.5,0.75,1,1.5,2)");
  cmd->add_option("--alternatives", args->alternatives,
                  "slicing alternatives at every step, comma-separated: bN (bricks of N), no-skip, cpu-slicer, or "
                  "none (default b16,b64,no-skip,cpu-slicer)");
  cmd->add_flag("--no-shading", args->noShading, "no shaded variants");
  cmd->add_option("--slabs", args->slabs,
                  "texture-slab sizes swept at every step without ERT, comma-separated, 4096 = whole brick; none: no "
                  "slab settings at all, the ray caster's stay (default 1,4,16,32,4096)");
  cmd->add_option("--ert-slab", args->ertSlab,
                  "the slab size of the ERT thresholds and of pre-integration (default 32)")
      ->check(between(1, render::Scene::kMaxSlab));
  cmd->add_option("--erts", args->erts,
                  "early-ray-termination thresholds in [0.5, 1], comma-separated, or none; off (0) is always swept "
                  "(default 0.99,0.999,1)");
  cmd->add_option("--slab-sub-blocks", args->slabSubBlocks,
                  "each ERT threshold at --ert-slab (and the ray caster's, off too) again with these sub-block "
                  "sizes, comma-separated, or none (default 8)");
  cmd->add_option("--lods", args->lods,
                  "levels of detail (pixels) besides 0, each with every ERT threshold at --ert-slab (and on the ray "
                  "caster) and the last --slab-sub-blocks size, comma-separated, or none (default none)");
  cmd->add_flag("--no-best-slab", args->noBestSlab,
                "ERT thresholds only at --ert-slab, not also at the fastest other size");
  cmd->add_flag("--no-pre-integration", args->noPreIntegration, "no pre-integrated settings");
  cmd->add_flag("--no-opaque", args->noOpaque,
                "slab and ray-caster settings only with each dataset's default transfer function, not also with its "
                "opaque one");
  CLI::Option* rayCast =
      cmd->add_flag("--raycast", args->rayCast,
                    "ray-caster settings (with or without --slabs) at the slab steps on the slab variants: ERT off "
                    "and each --erts threshold, each with whole-brick cells and each --slab-sub-blocks size; each "
                    "--lods level; pre-integration (default on)");
  cmd->add_flag("--no-raycast", args->noRayCast, "no ray-caster settings")->excludes(rayCast);
  cmd->add_option("--slab-steps", args->slabSteps,
                  "the steps of the slab and ray-caster settings, a subset of --steps (default all)");
  cmd->add_option("--small-slab-min-step", args->smallSlabMinStep,
                  "slab sizes below --ert-slab (the slowest settings) only at steps at least this (default 0.5; 0: "
                  "every step)")
      ->check(between(0.0, 64.0));
  cmd->add_option("--slab-table-step", args->slabTableStep, "the step of sweep.md's slab table (default 1)")
      ->check(between(1e-3, 64.0));
  cmd->add_flag("--frames8", args->frames8,
                "time each grid frame as a server sends it, finished on the GPU as 8 bits; its error is measured on "
                "the float frame of the same view drawn again");
  cmd->add_option("--views", args->views, "views of the orbit (default 8)")->check(between(1, 360));
  cmd->add_option("--size", args->size, "image side in pixels (default 256)")->check(between(8, 4096));
  cmd->add_option("--reference-step", args->referenceStep, "reference step in voxels (default 0.125)")
      ->check(between(1e-4, 64.0));
  cmd->add_option("--threshold", args->threshold, "PSNR (dB) the chosen default must keep")->capture_default_str();
  cmd->add_option("--threshold-high", args->thresholdHigh, "PSNR (dB) of the second answer: the fastest setting there")
      ->capture_default_str();
  cmd->add_option("--mri", args->mri, "the MRI volume (Debian's mricron-data)")->capture_default_str();
  cmd->add_option("--backend", args->backend, "auto, egl or osmesa")->capture_default_str();
  cmd->add_flag("-q,--quiet", args->quiet, "no progress lines");
  cmd->add_flag("--dry-run", args->dryRun, "print how many points the sweep would measure, and exit");
  cmd->callback([args, cmd] {
    keepFreedMemoryForFrames();
    runBench(*args, *cmd);
  });
}

}  // namespace voxbrick::cli
