// The sweep's files: sweep.csv (one row per point), sweep.md (the tables and the chosen default), sweep.svg.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "bench/Sweep.h"
#include "bench/SweepPlot.h"

namespace voxbrick::bench {
namespace {

std::string number(const char* format, double value) {
  if (std::isinf(value)) return "inf";
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

void writeFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::string csv(const SweepResult& r) {
  std::string out =
      "dataset,transfer_function,shading,step,brick,skip,slicer,views,size,median_ms,min_ms,max_ms,median_samples,"
      "psnr_worst_db,psnr_pooled_db,rmse_pooled,max_abs,pareto\n";
  for (const Point& p : r.points) {
    out += p.dataset + "," + p.variant.transferFunction + "," + (p.variant.shading ? "1" : "0") + "," +
           number("%g", p.setting.step) + "," + std::to_string(p.setting.brick) + "," + (p.setting.skip ? "1" : "0") +
           "," + (p.setting.slicer == render::Slicer::Cpu ? "cpu" : "vertex") + "," + std::to_string(r.spec.views) +
           "," + std::to_string(r.spec.size) + "," + number("%.2f", p.msMedian) + "," + number("%.2f", p.msMin) +
           "," + number("%.2f", p.msMax) + "," + number("%.0f", p.samplesMedian) + "," + number("%.2f", p.psnrMin) +
           "," + number("%.2f", p.psnrPooled) + "," + number("%.6f", p.rmsePooled) + "," + number("%.6f", p.maxAbs) +
           "," + (p.pareto ? "1" : "0") + "\n";
  }
  return out;
}

std::string markdown(const SweepResult& r) {
  const SweepSpec& s = r.spec;
  std::string md = "# Time against error\n\n";
  md += "GPU renderer on " + r.device + "; " + std::to_string(s.size) + "×" + std::to_string(s.size) + " frames, " +
        std::to_string(s.views) + " views (azimuth 0…360°, elevation 20°, 2.2 bounding radii). Each point: the median "
        "frame time over the views (after a warm-up frame) and the error of the same views against the reference "
        "renderer (step " + number("%g", s.referenceStep) + " voxel): the worst view's PSNR, the PSNR of all views' "
        "pixels together, and the largest pixel difference. Pareto: no other point of the same dataset and variant is "
        "both faster and at least as accurate.\n\n![time against error](sweep.svg)\n\n";

  md += "## Chosen default\n\n";
  if (r.chosen) {
    md += "**" + r.chosen->label() + "**: the fastest setting (sum of the median times over the datasets) that "
          "keeps the worst view at or above " + number("%g", s.psnrThreshold) + " dB against the reference on every "
          "dataset, each with its default transfer function, unshaded. At this setting:\n\n";
    md += "| dataset | variant | median ms | worst view dB | pooled dB |\n|---|---|---:|---:|---:|\n";
    for (const Point& p : r.points)
      if (p.setting == *r.chosen)
        md += "| " + p.dataset + " | " + p.variant.label() + " | " + number("%.1f", p.msMedian) + " | " +
              number("%.1f", p.psnrMin) + " | " + number("%.1f", p.psnrPooled) + " |\n";
  } else {
    md += "No setting keeps " + number("%g", s.psnrThreshold) + " dB on every dataset.\n";
  }
  md += "\nWhat the other variants need: the coarsest swept step at which the baseline renderer keeps the worst "
        "view at or above " + number("%g", s.psnrThreshold) + " dB.\n\n| dataset | variant | coarsest step |\n"
        "|---|---|---:|\n";
  for (const Dataset& d : s.datasets)
    for (const std::string& tf : d.transferFunctions)
      for (bool shading : {false, true}) {
        const Variant v{tf, shading};
        if (std::none_of(r.points.begin(), r.points.end(), [&](const Point& p) { return p.variant == v; })) continue;
        const std::optional<double> step = coarsestStep(r.points, d.name, v, s.psnrThreshold);
        md += "| " + d.name + " | " + v.label() + " | " + (step ? number("%g", *step) : "none swept") + " |\n";
      }

  md += "\n## The reference\n\nTime per view, and its self-check: view 0 at the reference step against half that "
        "step (the bound it must stay far inside is the threshold above).\n\n"
        "| dataset | variant | ms per view | step vs step/2: PSNR | max abs |\n|---|---|---:|---:|---:|\n";
  for (const ReferenceReport& ref : r.references)
    md += "| " + ref.dataset + " | " + ref.variant.label() + " | " +
          (ref.msPerView > 0 ? number("%.0f", ref.msPerView) : "cached") + " | " +
          (ref.halvingMaxAbs > 0 || ref.halvingPsnr > 0 ? number("%.1f", ref.halvingPsnr) + " | " +
                                                              number("%.2g", ref.halvingMaxAbs)
                                                        : "— | —") +
          " |\n";

  for (const Dataset& d : s.datasets) {
    md += "\n## " + d.name + " (`" + d.input + "`)\n\n| variant | setting | median ms | min…max ms | Msamples | "
          "worst view dB | pooled dB | max abs | Pareto |\n|---|---|---:|---:|---:|---:|---:|---:|:-:|\n";
    for (const Point& p : r.points)
      if (p.dataset == d.name)
        md += "| " + p.variant.label() + " | " + p.setting.label() + " | " + number("%.1f", p.msMedian) + " | " +
              number("%.1f", p.msMin) + "…" + number("%.1f", p.msMax) + " | " + number("%.2f", p.samplesMedian / 1e6) +
              " | " + number("%.1f", p.psnrMin) + " | " + number("%.1f", p.psnrPooled) + " | " +
              number("%.4f", p.maxAbs) + " | " + (p.pareto ? "✓" : "") + " |\n";
  }
  return md;
}

}  // namespace

void writeResults(const SweepResult& result, const std::filesystem::path& out) {
  std::filesystem::create_directories(out);
  writeFile(out / "sweep.csv", csv(result));
  writeFile(out / "sweep.md", markdown(result));
  writeFile(out / "sweep.svg", sweepSvg(result));
}

}  // namespace voxbrick::bench
