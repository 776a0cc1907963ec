// The sweep's files: sweep.csv (one row per point), sweep.md (the tables and the chosen default), sweep.svg.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <tuple>

#include "quality/SettingChoice.h"
#include "quality/SweepPlot.h"
#include "quality/SweepReport.h"

namespace voxbrick::quality {
namespace {


std::string csv(const SweepResult& r) {
  std::string out =
      "dataset,transfer_function,shading,step,brick,skip,slicer,views,size,median_ms,min_ms,max_ms,median_samples,"
      "psnr_worst_db,psnr_pooled_db,rmse_pooled,max_abs,pareto,slab,ert,pre_integration,samples_median,"
      "fragments_median,samples_terminated_median,slab_passes_median,sub_block,lod,raycast\n";
  for (const Point& p : r.points) {
    out += p.dataset + "," + p.variant.transferFunction + "," + (p.variant.shading ? "1" : "0") + "," +
           formatNumber("%g", p.setting.step) + "," + std::to_string(p.setting.brick) + "," + (p.setting.skip ? "1" : "0") +
           "," + render::slicerName(p.setting.slicer) + "," + std::to_string(r.spec.views) + "," +
           std::to_string(r.spec.size) + "," + formatNumber("%.2f", p.msMedian) + "," + formatNumber("%.2f", p.msMin) + "," +
           formatNumber("%.2f", p.msMax) + "," + formatNumber("%.0f", p.samplesMedian) + "," + formatNumber("%.2f", p.psnrMin) + "," +
           formatNumber("%.2f", p.psnrPooled) + "," + formatNumber("%.6f", p.rmsePooled) + "," + formatNumber("%.6f", p.maxAbs) + "," +
           (p.pareto ? "1" : "0") + "," + std::to_string(p.setting.slab) + "," + formatNumber("%g", p.setting.ert) + "," +
           (p.setting.preIntegration ? "1" : "0") + "," + formatNumber("%.0f", p.samplesMedian) + "," +
           formatNumber("%.0f", p.fragmentsMedian) + "," + formatNumber("%.0f", p.samplesTerminatedMedian) + "," +
           formatNumber("%.0f", p.slabPassesMedian) + "," + std::to_string(p.setting.subBlock) + "," +
           formatNumber("%g", p.setting.lod) + "," + (p.setting.raycast ? "1" : "0") + "\n";
  }
  return out;
}

/// The swept slab step nearest to the spec's table step.
std::optional<double> slabTableStep(const SweepSpec& s) {
  std::optional<double> best;
  for (double step : s.slabStepsOrAll())
    if (!best || std::abs(step - s.slabTableStep) < std::abs(*best - s.slabTableStep)) best = step;
  return best;
}

/// Per dataset and slab variant, at one step: slicing, the slab sizes without ERT, with ERT and with
/// pre-integration side by side, then the ray caster's settings.
std::string slabTables(const SweepResult& r) {
  const SweepSpec& s = r.spec;
  const std::optional<double> step = slabTableStep(s);
  if (!s.marches() || !step) return "";
  const bool slabs = !s.slabs.empty();
  const char* title = !slabs      ? "The frame ray caster"
                      : s.rayCast ? "Texture slabs and the frame ray caster"
                                  : "Texture slabs";
  std::string md = "\n## " + std::string(title) + " at step " + formatNumber("%g", *step) + "\n\n";
  if (slabs)
    md +=
        "Slicing (one blended sample per fragment) against texture slabs of N planes (a fragment marches its ray "
        "through N planes and blends once; \"whole brick\": N = " +
        std::to_string(render::Scene::kMaxSlab) +
        ", a brick ray caster), without and with early ray termination (ERT: a slab silhouette map between slabs "
        "and a stop inside the fragment) and pre-integration; B=32, skipping, vertex slicer.";
  if (s.rayCast)
    md += std::string(slabs ? " " : "") +
          "*raycast*: the frame ray caster (a fragment per pixel and atlas batch "
          "marches the pixel's whole ray through a cell table, taking the same samples; ERT stops it in the fragment "
          "and by the silhouette map between batches), with cells of whole bricks or of sub-blocks" +
          (slabs ? "" : "; B=32, skipping, vertex slicer") + ".";
  md +=
      " *Fragments*: started (fragments the silhouette map rejects are not); *samples*: taken; *share of samples*: "
      "samples with ERT over samples of the same setting without it; *speed-up*: slicing's median time over the "
      "setting's.";
  if (r.bestSlab)
    md += " ERT also ran at the fastest other slab size (" + slabLabel(*r.bestSlab) +
          ", least total time without "
          "ERT).";
  if (r.bestErt)
    md += " Pre-integration ran with ERT off and at " + formatNumber("%g", *r.bestErt) +
          " (the lowest threshold costing "
          "no more than " +
          formatNumber("%g", s.ertToleranceDb) + " dB of worst view below " + formatNumber("%g", s.psnrHighThreshold) + " dB).";
  if (r.bestRayCastErt)
    md += " The ray caster's pre-integration ran with ERT off and at " + formatNumber("%g", *r.bestRayCastErt) +
          " (the same rule over its own points).";
  md += "\n";
  for (const Dataset& d : s.datasets)
    for (const Variant& v : slabVariants(d, s.opaqueVariants)) {
      std::vector<const Point*> rows;
      const Point* slicing = nullptr;
      for (const Point& p : r.points) {
        if (p.dataset != d.name || !(p.variant == v) || p.setting.step != *step) continue;
        if (p.setting == Setting{*step})
          slicing = &p;
        else if ((p.setting.slab > 0 || p.setting.raycast) && p.setting.brick == 32 && p.setting.skip &&
                 p.setting.slicer == render::Slicer::Vertex)
          rows.push_back(&p);
      }
      if (rows.empty()) continue;
      // Slab size (the ray caster last), then pre-integration, then threshold (off first).
      std::stable_sort(rows.begin(), rows.end(), [](const Point* a, const Point* b) {
        return std::tuple(a->setting.raycast, a->setting.slab, a->setting.preIntegration, a->setting.ert) <
               std::tuple(b->setting.raycast, b->setting.slab, b->setting.preIntegration, b->setting.ert);
      });
      if (slicing) rows.insert(rows.begin(), slicing);
      md += "\n### " + d.name + ", " + v.label() +
            "\n\n| setting | median ms | speed-up | fragments (M) | "
            "samples (M) | share of samples | worst view dB | max abs |\n|---|---:|---:|---:|---:|---:|---:|---:|\n";
      for (const Point* p : rows) {
        const Setting& t = p->setting;
        std::string share = "—";
        if (t.ert > 0) {
          const auto off = std::find_if(r.points.begin(), r.points.end(), [&](const Point& q) {
            Setting same = t;
            same.ert = 0;
            return q.dataset == p->dataset && q.variant == p->variant && q.setting == same;
          });
          if (off != r.points.end() && off->samplesMedian > 0)
            share = formatNumber("%.0f", 100 * p->samplesMedian / off->samplesMedian) + " %";
        }
        md += "| " + marchingLabel(t) + " | " + formatNumber("%.1f", p->msMedian) + " | " +
              (slicing && p->msMedian > 0 ? formatNumber("%.2f", slicing->msMedian / p->msMedian) + "×" : "—") + " | " +
              formatNumber("%.3g", p->fragmentsMedian / 1e6) + " | " + formatNumber("%.3g", p->samplesMedian / 1e6) + " | " +
              share + " | " + formatNumber("%.1f", p->psnrMin) + " | " + formatNumber("%.4f", p->maxAbs) + " |\n";
      }
    }
  return md;
}

/// The title and what a point is.
std::string introduction(const SweepResult& r) {
  const SweepSpec& s = r.spec;
  std::string md = "# Time against error\n\n";
  md += "GPU renderer on " + r.device + "; " + std::to_string(s.size) + "×" + std::to_string(s.size) + " frames, " +
        std::to_string(s.views) +
        " views (azimuth 0…360°, elevation 20°, 2.2 bounding radii). Each point: the median "
        "frame time over the views (after a warm-up frame) and the error of the same views against the reference "
        "renderer (step " +
        formatNumber("%g", s.referenceStep) +
        " voxel): the worst view's PSNR, the PSNR of all views' "
        "pixels together, and the largest pixel difference. Pareto: no other point of the same dataset and variant is "
        "both faster and at least as accurate.\n\n![time against error](sweep.svg)\n\n";
  return md;
}

/// The chosen default and its frames on every dataset.
std::string chosenDefault(const SweepResult& r) {
  const SweepSpec& s = r.spec;
  std::string md = "## Chosen default\n\n";
  if (r.chosen) {
    md += "**" + r.chosen->label() +
          "**: the fastest setting (sum of the median times over the datasets) that "
          "keeps the worst view at or above " +
          formatNumber("%g", s.psnrThreshold) +
          " dB against the reference on every "
          "dataset, each with its default transfer function, unshaded. At this setting:\n\n";
    md +=
        "| dataset | variant | median ms | slowest view ms | min/max frame rate | worst view dB | pooled dB |\n"
        "|---|---|---:|---:|---:|---:|---:|\n";
    for (const Point& p : r.points)
      if (p.setting == *r.chosen)
        md += "| " + p.dataset + " | " + p.variant.label() + " | " + formatNumber("%.1f", p.msMedian) + " | " +
              formatNumber("%.1f", p.msMax) + " | " + (p.msMin > 0 ? "1:" + formatNumber("%.2f", p.msMax / p.msMin) : "—") + " | " +
              formatNumber("%.1f", p.psnrMin) + " | " + formatNumber("%.1f", p.psnrPooled) + " |\n";
    md +=
        "\n*Slowest view* and *min/max frame rate* (the fastest view's frame time over the slowest's, as 1:x) are "
        "over the orbit's views: what a user turning the volume sees at worst.\n";
  } else {
    md += "No setting keeps " + formatNumber("%g", s.psnrThreshold) + " dB on every dataset.\n";
  }
  return md;
}

/// The same rule at both thresholds, side by side.
std::string bothThresholds(const SweepResult& r) {
  const SweepSpec& s = r.spec;
  std::string md;
  md += "\nThe same rule at " + formatNumber("%g", s.psnrThreshold) + " dB and at " + formatNumber("%g", s.psnrHighThreshold) +
        " dB (each dataset's default transfer function, unshaded; median ms / worst view dB):\n\n| worst view ≥ | "
        "setting |";
  for (const Dataset& d : s.datasets) md += " " + d.name + " |";
  md += " sum ms |\n|---:|---|";
  for (size_t i = 0; i <= s.datasets.size(); ++i) md += "---:|";
  md += "\n";
  for (const auto& row : {std::pair{s.psnrThreshold, r.chosen}, std::pair{s.psnrHighThreshold, r.chosenHigh}}) {
    const double threshold = row.first;
    const std::optional<Setting>& chosen = row.second;
    md += "| " + formatNumber("%g", threshold) + " dB | " + (chosen ? "**" + chosen->label() + "**" : "none") + " |";
    double sum = 0;
    for (const Dataset& d : s.datasets) {
      const auto p = std::find_if(r.points.begin(), r.points.end(), [&](const Point& q) {
        return chosen && q.dataset == d.name && q.variant == defaultVariant(d) && q.setting == *chosen;
      });
      if (p == r.points.end()) {
        md += " — |";
        continue;
      }
      md += " " + formatNumber("%.1f", p->msMedian) + " / " + formatNumber("%.1f", p->psnrMin) + " |";
      sum += p->msMedian;
    }
    md += " " + (chosen ? formatNumber("%.1f", sum) : std::string("—")) + " |\n";
  }
  return md;
}

/// The fastest setting per dataset and variant at each threshold.
std::string fastestPerDataset(const SweepResult& r) {
  const SweepSpec& s = r.spec;
  std::string md;
  md +=
      "\nThe fastest setting per dataset and variant (its default transfer function, and the opaque one of the "
      "slab settings) at each threshold: median ms / worst view dB.\n\n| dataset | variant | fastest ≥ " +
      formatNumber("%g", s.psnrThreshold) + " dB | ms / dB | fastest ≥ " + formatNumber("%g", s.psnrHighThreshold) +
      " dB | ms / dB |\n|---|---|---|---:|---|---:|\n";
  for (const Dataset& d : s.datasets)
    for (const Variant& v : slabVariants(d, s.opaqueVariants && s.marches())) {
      md += "| " + d.name + " | " + v.label() + " |";
      for (double threshold : {s.psnrThreshold, s.psnrHighThreshold}) {
        const std::optional<Point> p = fastestPoint(r.points, d.name, v, threshold);
        md += p ? " " + p->setting.label() + " | " + formatNumber("%.1f", p->msMedian) + " / " + formatNumber("%.1f", p->psnrMin) +
                      " |"
                : std::string(" none | — |");
      }
      md += "\n";
    }
  return md;
}

/// The coarsest step at which the baseline keeps the threshold, per dataset and variant.
std::string coarsestSteps(const SweepResult& r) {
  const SweepSpec& s = r.spec;
  std::string md;
  md +=
      "\nWhat the other variants need: the coarsest swept step at which the baseline renderer keeps the worst "
      "view at or above " +
      formatNumber("%g", s.psnrThreshold) +
      " dB.\n\n| dataset | variant | coarsest step |\n"
      "|---|---|---:|\n";
  for (const Dataset& d : s.datasets) {
    std::vector<std::string> transferFunctions = d.transferFunctions;
    if (!d.opaque.empty() &&
        std::find(transferFunctions.begin(), transferFunctions.end(), d.opaque) == transferFunctions.end())
      transferFunctions.push_back(d.opaque);
    for (const std::string& tf : transferFunctions)
      for (bool shading : {false, true}) {
        const Variant v{tf, shading};
        if (std::none_of(r.points.begin(), r.points.end(), [&](const Point& p) { return p.variant == v; })) continue;
        const std::optional<double> step = coarsestStep(r.points, d.name, v, s.psnrThreshold);
        md += "| " + d.name + " | " + v.label() + " | " + (step ? formatNumber("%g", *step) : "none swept") + " |\n";
      }
  }
  return md;
}

/// The reference's time per view and its self-check.
std::string referenceTable(const SweepResult& r) {
  std::string md;
  md +=
      "\n## The reference\n\nTime per view, and its self-check: view 0 at the reference step against half that "
      "step (the bound it must stay far inside is the threshold above).\n\n"
      "| dataset | variant | ms per view | step vs step/2: PSNR | max abs |\n|---|---|---:|---:|---:|\n";
  for (const ReferenceReport& ref : r.references)
    md += "| " + ref.dataset + " | " + ref.variant.label() + " | " +
          (ref.msPerView > 0 ? formatNumber("%.0f", ref.msPerView) : "cached") + " | " +
          (ref.halvingMaxAbs > 0 || ref.halvingPsnr > 0
               ? formatNumber("%.1f", ref.halvingPsnr) + " | " + formatNumber("%.2g", ref.halvingMaxAbs)
               : "— | —") +
          " |\n";
  return md;
}

/// Every point of each dataset.
std::string datasetTables(const SweepResult& r) {
  const SweepSpec& s = r.spec;
  std::string md;
  for (const Dataset& d : s.datasets) {
    md += "\n## " + d.name + " (`" + d.input +
          "`)\n\n| variant | setting | median ms | min…max ms | Msamples | "
          "Mfragments | worst view dB | pooled dB | max abs | Pareto |\n"
          "|---|---|---:|---:|---:|---:|---:|---:|---:|:-:|\n";
    for (const Point& p : r.points)
      if (p.dataset == d.name)
        md += "| " + p.variant.label() + " | " + p.setting.label() + " | " + formatNumber("%.1f", p.msMedian) + " | " +
              formatNumber("%.1f", p.msMin) + "…" + formatNumber("%.1f", p.msMax) + " | " + formatNumber("%.2f", p.samplesMedian / 1e6) +
              " | " + formatNumber("%.2f", p.fragmentsMedian / 1e6) + " | " + formatNumber("%.1f", p.psnrMin) + " | " +
              formatNumber("%.1f", p.psnrPooled) + " | " + formatNumber("%.4f", p.maxAbs) + " | " + (p.pareto ? "✓" : "") + " |\n";
  }
  return md;
}

std::string markdown(const SweepResult& r) {
  return introduction(r) + chosenDefault(r) + bothThresholds(r) + fastestPerDataset(r) + coarsestSteps(r) +
         referenceTable(r) + slabTables(r) + datasetTables(r);
}

}  // namespace

void writeResults(const SweepResult& result, const std::filesystem::path& out) {
  std::filesystem::create_directories(out);
  writeTextFile(out / "sweep.csv", csv(result));
  writeTextFile(out / "sweep.md", markdown(result));
  writeTextFile(out / "sweep.svg", sweepSvg(result));
}

std::string formatNumber(const char* format, double value) {
  if (std::isinf(value)) return "inf";
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

void writeTextFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace voxbrick::quality
