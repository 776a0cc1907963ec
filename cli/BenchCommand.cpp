// `voxbrick bench`: the time-versus-error sweep (bench/Sweep.h) with its files and the default it picks.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <set>

#include "bench/Sweep.h"
#include "brickstore/Errors.h"
#include "cli/Commands.h"
#include "render/GlContext.h"

namespace voxbrick::cli {
namespace {

struct BenchArgs {
  std::string out = "bench/results", work = "bench/work", datasets, steps, backend = "auto";
  std::string mri = "/usr/share/mricron/templates/ch2better.nii.gz";
  bool quick = false, quiet = false;
  int views = 0, size = 0;
  double referenceStep = 0, threshold = 40;
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

void runBench(const BenchArgs& a) {
  bench::SweepSpec spec = a.quick ? bench::SweepSpec::quick(a.mri) : bench::SweepSpec::full(a.mri);
  if (!a.datasets.empty()) {
    std::set<std::string> known;
    for (const bench::Dataset& d : spec.datasets) known.insert(d.name);
    const std::vector<std::string> wanted = splitList(a.datasets);
    for (const std::string& name : wanted)
      if (!known.count(name)) throw store::InputError("--datasets: unknown dataset '" + name + "' (ml, sparse, mri)");
    std::erase_if(spec.datasets, [&](const bench::Dataset& d) {
      return std::find(wanted.begin(), wanted.end(), d.name) == wanted.end();
    });
  }
  if (!a.steps.empty()) {
    spec.steps.clear();
    for (const std::string& s : splitList(a.steps)) {
      char* end = nullptr;
      const double step = std::strtod(s.c_str(), &end);
      if (end != s.c_str() + s.size() || !(step >= 1e-3 && step <= 64))
        throw store::InputError("--steps: '" + s + "' is not a step in [0.001, 64] voxels");
      spec.steps.push_back(step);
    }
  }
  if (a.views > 0) spec.views = a.views;
  if (a.size > 0) spec.size = a.size;
  if (a.referenceStep > 0) spec.referenceStep = a.referenceStep;
  spec.psnrThreshold = a.threshold;

  auto context = render::createContext(render::parseBackend(a.backend));
  if (!a.quiet) std::fprintf(stderr, "bench: %s\n", context->describe().c_str());
  const bench::SweepResult result = bench::runSweep(spec, a.work, *context, [&](const std::string& line) {
    if (!a.quiet) std::fprintf(stderr, "bench: %s\n", line.c_str());
  });
  bench::writeResults(result, a.out);
  std::printf("bench: %zu points; wrote %s/sweep.csv, sweep.md, sweep.svg\n", result.points.size(), a.out.c_str());
  if (result.chosen)
    std::printf("bench: default: %s (fastest keeping every dataset at >= %g dB)\n", result.chosen->label().c_str(),
                spec.psnrThreshold);
  else
    std::printf("bench: no setting keeps every dataset at >= %g dB\n", spec.psnrThreshold);
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
  cmd->add_option("--datasets", args->datasets, "a subset of ml,sparse,mri (default all)");
  cmd->add_option("--steps", args->steps, "steps in voxels, comma-separated (default 0.25,0.5,0.75,1,1.5,2)");
  cmd->add_option("--views", args->views, "views of the orbit (default 8)")->check(CLI::Range(1, 360));
  cmd->add_option("--size", args->size, "image side in pixels (default 256)")->check(CLI::Range(8, 4096));
  cmd->add_option("--reference-step", args->referenceStep, "reference step in voxels (default 0.125)")
      ->check(CLI::Range(1e-4, 64.0));
  cmd->add_option("--threshold", args->threshold, "PSNR (dB) the chosen default must keep")->capture_default_str();
  cmd->add_option("--mri", args->mri, "the MRI volume (Debian's mricron-data)")->capture_default_str();
  cmd->add_option("--backend", args->backend, "auto, egl or osmesa")->capture_default_str();
  cmd->add_flag("-q,--quiet", args->quiet, "no progress lines");
  cmd->callback([args] { runBench(*args); });
}

}  // namespace voxbrick::cli
