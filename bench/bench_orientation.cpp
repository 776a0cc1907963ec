// Is the texture walk view-dependent here? Weiskopf, Weiler & Ertl found the frame rate of a 3D-texture slicer
// varying 1:4.8 as the volume turned, because the texture's fast axis was along or across the rays. This tool turns
// the camera a full circle about each axis in fixed steps and times every frame, for each store (one brick, many
// bricks) and drawing (slicing, slabs, the ray caster), so that the minimum/maximum frame-rate ratio and the shape of
// time against angle can be read off.
//
// Protocol: for each store and drawing, a fresh renderer per run (the texture loaded anew, by an untimed frame), one
// warm-up pass over every angle discarded, then --runs timed passes; per angle the median over the runs. Time per sample (ns) is
// reported beside the frame time, since the samples a view takes change with the angle (a diagonal view has longer
// rays). Writes NAME.csv (one row per store, drawing, axis, angle, run), NAME.md (min, max, ratio, mean, standard
// deviation per axis and over all) and NAME.svg (time against angle, one panel per store and drawing).
//
// A store may be listed twice with different --brickings (single, multi-oriented: AtlasBricking), to compare them.
//
//   bench_orientation --stores A.vbs,B.vbs [--labels a,b] [--brickings single,multi-oriented]
//                     [--drawings raycast,slab,slicing] [--axes x,y,z]
//                     [--degrees-per-step 5] [--runs 3] [--size 256] [--tf hot] [--ert 0] [--distance 2.5]
//                     [--out bench/results] [--name orientation]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/BrickCache.h"
#include "brickstore/BrickStore.h"
#include "quality/Statistics.h"
#include "render/Camera.h"
#include "render/GlContext.h"
#include "render/VolumeRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;
using voxbrick::quality::median;

namespace {

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

/// The eye on a circle of `radius` about world axis `axis` (0, 1, 2) through the volume's centre (the origin), at
/// `degrees` from the first of the other two axes, and an up vector along the axis (always perpendicular to the view).
render::CameraSpec cameraAbout(int axis, double degrees, double radius) {
  const double a = degrees * M_PI / 180;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  render::CameraSpec c;
  c.orbit = false;
  c.eye = glm::dvec3(0);
  c.eye[u] = radius * std::cos(a);
  c.eye[v] = radius * std::sin(a);
  c.center = glm::dvec3(0);
  c.up = glm::dvec3(0);
  c.up[axis] = 1;
  return c;
}

struct Sample {
  double ms = 0;       // frame total
  double samples = 0;  // volume samples taken
};

struct Series {
  std::string store, drawing;
  int axis = 0;
  std::vector<double> angles;
  std::vector<std::vector<Sample>> runs;  // [angle][run]
  std::vector<double> medianMs() const {
    std::vector<double> out;
    for (const auto& r : runs) {
      std::vector<double> ms;
      for (const Sample& s : r) ms.push_back(s.ms);
      out.push_back(median(ms));
    }
    return out;
  }
  std::vector<double> nsPerSample() const {
    std::vector<double> out;
    const std::vector<double> ms = medianMs();
    for (size_t i = 0; i < runs.size(); ++i)
      out.push_back(runs[i].empty() || runs[i][0].samples <= 0 ? 0 : ms[i] * 1e6 / runs[i][0].samples);
    return out;
  }
};

struct Summary {
  double min = 0, max = 0, mean = 0, sd = 0;
};

Summary summarise(const std::vector<double>& v) {
  Summary s;
  if (v.empty()) return s;
  s.min = *std::min_element(v.begin(), v.end());
  s.max = *std::max_element(v.begin(), v.end());
  for (double x : v) s.mean += x;
  s.mean /= double(v.size());
  for (double x : v) s.sd += (x - s.mean) * (x - s.mean);
  s.sd = std::sqrt(s.sd / double(v.size()));
  return s;
}

const char* kAxisNames[3] = {"x", "y", "z"};
const char* kAxisColours[3] = {"#c0392b", "#27ae60", "#2e6fd8"};

/// One panel per (store, drawing): median frame time against angle, a line per axis.
std::string plot(const std::vector<Series>& series, const std::vector<std::pair<std::string, std::string>>& panels) {
  const int pw = 420, ph = 260, margin = 50, cols = 2;
  const int rows = int((panels.size() + cols - 1) / cols);
  std::ostringstream svg;
  svg << "<svg xmlns='http://www.w3.org/2000/svg' width='" << cols * pw << "' height='" << rows * ph
      << "' font-family='sans-serif' font-size='11'>\n<rect width='100%' height='100%' fill='white'/>\n";
  for (size_t p = 0; p < panels.size(); ++p) {
    const int x0 = int(p % cols) * pw + margin, y0 = int(p / cols) * ph + 25;
    const int w = pw - margin - 15, h = ph - 70;
    double lo = 1e300, hi = 0;
    for (const Series& s : series)
      if (s.store == panels[p].first && s.drawing == panels[p].second)
        for (double ms : s.medianMs()) lo = std::min(lo, ms), hi = std::max(hi, ms);
    if (hi <= 0) continue;
    lo = 0;
    hi *= 1.1;
    svg << "<text x='" << x0 << "' y='" << y0 - 8 << "' font-weight='bold'>" << panels[p].first << ", "
        << panels[p].second << "</text>\n";
    svg << "<rect x='" << x0 << "' y='" << y0 << "' width='" << w << "' height='" << h
        << "' fill='none' stroke='#888'/>\n";
    for (int t = 0; t <= 4; ++t) {
      const double ms = lo + (hi - lo) * t / 4;
      const double y = y0 + h - h * t / 4.0;
      svg << "<text x='" << x0 - 5 << "' y='" << y + 4 << "' text-anchor='end'>" << std::lround(ms) << "</text>\n";
      const double angle = 360.0 * t / 4;
      svg << "<text x='" << x0 + w * t / 4.0 << "' y='" << y0 + h + 14 << "' text-anchor='middle'>" << angle
          << "°</text>\n";
    }
    svg << "<text x='" << x0 - 38 << "' y='" << y0 + h / 2 << "' transform='rotate(-90 " << x0 - 38 << " "
        << y0 + h / 2 << ")' text-anchor='middle'>ms a frame</text>\n";
    int legend = 0;
    for (const Series& s : series) {
      if (s.store != panels[p].first || s.drawing != panels[p].second) continue;
      const std::vector<double> ms = s.medianMs();
      svg << "<polyline fill='none' stroke='" << kAxisColours[s.axis] << "' stroke-width='1.5' points='";
      for (size_t i = 0; i < ms.size(); ++i)
        svg << x0 + w * s.angles[i] / 360.0 << "," << y0 + h - h * (ms[i] - lo) / (hi - lo) << " ";
      svg << "'/>\n<text x='" << x0 + 8 + 70 * legend++ << "' y='" << y0 + h + 30 << "' fill='"
          << kAxisColours[s.axis] << "'>about " << kAxisNames[s.axis] << "</text>\n";
    }
  }
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace

int main(int argc, char** argv) {
  std::string storesText, labelsText, brickingsText, drawingsText = "raycast,slab,slicing", axesText = "x,y,z",
              tf = "hot", name = "orientation", outText = "bench/results";
  double step = 5, ert = 0, distance = 2.5;
  int runs = 3, size = 256;
  CLI::App app{"bench_orientation: frame time against view angle about each axis"};
  app.add_option("--stores", storesText, "stores to turn, comma-separated")->required();
  app.add_option("--labels", labelsText, "a label per store, comma-separated (default: the stores' names)");
  app.add_option("--brickings", brickingsText,
                 "a bricking per store, comma-separated: single or multi-oriented (default: single for every store)");
  app.add_option("--drawings", drawingsText, "raycast, slab, slicing, comma-separated");
  app.add_option("--axes", axesText, "x, y, z, comma-separated");
  app.add_option("--degrees-per-step", step, "degrees between views")->check(CLI::Range(0.1, 180.0));
  app.add_option("--runs", runs, "timed passes after the warm-up pass")->check(CLI::Range(1, 1000));
  app.add_option("--size", size, "frame side in pixels")->check(CLI::Range(8, 8192));
  app.add_option("--tf", tf, "transfer function preset");
  app.add_option("--ert", ert, "early ray termination threshold (0: off, so every sample is taken)");
  app.add_option("--distance", distance, "eye distance in bounding radii");
  app.add_option("--out", outText, "output directory");
  app.add_option("--name", name, "output file name stem");
  CLI11_PARSE(app, argc, argv);
  const fs::path out = outText;
  const std::vector<std::string> stores = split(storesText), drawings = split(drawingsText);
  std::vector<std::string> labels = split(labelsText);
  if (stores.empty()) {
    std::fprintf(stderr, "bench_orientation: --stores names no store\n");
    return 2;
  }
  if (labels.size() != stores.size()) {
    labels.clear();
    for (const std::string& s : stores) labels.push_back(fs::path(s).filename().string());
  }
  std::vector<render::AtlasBricking> brickings(stores.size(), render::AtlasBricking::Single);
  if (!brickingsText.empty()) {
    const std::vector<std::string> names = split(brickingsText);
    if (names.size() != stores.size()) {
      std::fprintf(stderr, "bench_orientation: --brickings names %zu brickings for %zu stores\n", names.size(),
                   stores.size());
      return 2;
    }
    try {
      for (size_t i = 0; i < names.size(); ++i) brickings[i] = render::parseAtlasBricking(names[i]);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_orientation: %s\n", e.what());
      return 2;
    }
  }
  std::vector<int> axes;
  for (const std::string& a : split(axesText)) {
    if (a != "x" && a != "y" && a != "z") {
      std::fprintf(stderr, "bench_orientation: axis '%s' is not x, y or z\n", a.c_str());
      return 2;
    }
    axes.push_back(a[0] - 'x');
  }
  for (const std::string& d : drawings)
    if (d != "raycast" && d != "slab" && d != "slicing") {
      std::fprintf(stderr, "bench_orientation: drawing '%s' is not raycast, slab or slicing\n", d.c_str());
      return 2;
    }
  std::vector<double> angles;
  for (double a = 0; a < 360 - 1e-9; a += step) angles.push_back(a);

  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  std::printf("bench_orientation on %s: %zu stores, %zu drawings, %zu axes, %zu angles, %d runs\n", device.c_str(),
              stores.size(), drawings.size(), axes.size(), angles.size(), runs);
  std::vector<Series> series;
  std::vector<std::pair<std::string, std::string>> panels;
  for (size_t si = 0; si < stores.size(); ++si) {
    auto store = store::BrickStore::openAny(stores[si]);
    const render::Box box = render::volumeBox(store->meta().dims, store->meta().spacing);
    auto cache = std::make_shared<store::BrickCache>(store, size_t(4096) << 20, 2);
    for (const std::string& drawing : drawings) {
      panels.push_back({labels[si], drawing});
      render::Scene scene;
      scene.width = scene.height = size;
      scene.transferFunction = render::TransferFunction::load(tf);
      scene.transferFunctionName = tf;
      scene.ert = ert;
      scene.lod = 0;
      scene.raycast = drawing == "raycast";
      scene.slab = drawing == "slicing" ? 0 : 32;
      const size_t first = series.size();
      for (int axis : axes) {
        Series s;
        s.store = labels[si];
        s.drawing = drawing;
        s.axis = axis;
        s.angles = angles;
        s.runs.resize(angles.size());
        series.push_back(std::move(s));
      }
      for (int run = -1; run < runs; ++run) {  // run -1: the warm-up pass, discarded
        // A fresh renderer each run: the atlas (the texture) is loaded anew, as in the paper's protocol.
        render::VolumeRenderer renderer(*context, cache, size_t(2048) << 20, render::AtlasFormat::Float,
                                        render::AtlasUploads::Auto, brickings[si]);
        scene.camera = cameraAbout(axes[0], angles[0], distance * box.radius());
        renderer.render(scene);  // untimed: uploads the bricks, so that no timed frame pays for the load
        for (size_t ai = 0; ai < axes.size(); ++ai)
          for (size_t k = 0; k < angles.size(); ++k) {
            scene.camera = cameraAbout(axes[ai], angles[k], distance * box.radius());
            render::FrameStats stats;
            renderer.render(scene, &stats);
            if (run >= 0) series[first + ai].runs[k].push_back({stats.msTotal, double(stats.samples)});
          }
        if (run >= 0)
          std::printf("%s, %s: run %d of %d done\n", labels[si].c_str(), drawing.c_str(), run + 1, runs);
        std::fflush(stdout);
      }
    }
  }

  fs::create_directories(out);
  std::ofstream csv(out / (name + ".csv"));
  csv << "# " << device << "; " << size << "x" << size << ", tf " << tf << ", ert " << ert << ", distance " << distance
      << " R, " << step << " degrees a step, " << runs << " runs after a warm-up pass\n";
  csv << "store,drawing,axis,angle,run,ms_total,samples\n";
  for (const Series& s : series)
    for (size_t k = 0; k < s.angles.size(); ++k)
      for (size_t r = 0; r < s.runs[k].size(); ++r)
        csv << s.store << "," << s.drawing << "," << kAxisNames[s.axis] << "," << s.angles[k] << "," << r << ","
            << s.runs[k][r].ms << "," << s.runs[k][r].samples << "\n";

  std::ofstream md(out / (name + ".md"));
  md << "Device: " << device << ". " << size << "×" << size << ", transfer function `" << tf << "`, termination "
     << (ert > 0 ? std::to_string(ert) : std::string("off")) << ", level 0, the eye at " << distance
     << " bounding radii on a circle about each axis (up along the axis), " << step << "° a step (" << angles.size()
     << " angles an axis); per store and drawing a fresh renderer each run, a warm-up pass discarded, " << runs
     << " timed runs; per angle the median frame time over the runs.\n\n";
  md << "| store | drawing | axis | min ms | max ms | min/max frame rate | mean ms | sd ms | min ns/sample | max "
        "ns/sample | ns/sample ratio |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  char line[512];
  for (const auto& [store, drawing] : panels) {
    std::vector<double> allMs, allNs;
    for (const Series& s : series) {
      if (s.store != store || s.drawing != drawing) continue;
      const std::vector<double> ms = s.medianMs(), ns = s.nsPerSample();
      allMs.insert(allMs.end(), ms.begin(), ms.end());
      allNs.insert(allNs.end(), ns.begin(), ns.end());
      const Summary t = summarise(ms), n = summarise(ns);
      std::snprintf(line, sizeof line, "| %s | %s | %s | %.1f | %.1f | 1:%.2f | %.1f | %.1f | %.2f | %.2f | %.2f |\n",
                    store.c_str(), drawing.c_str(), kAxisNames[s.axis], t.min, t.max, t.max / t.min, t.mean, t.sd,
                    n.min, n.max, n.max / n.min);
      md << line;
    }
    const Summary t = summarise(allMs), n = summarise(allNs);
    std::snprintf(line, sizeof line,
                  "| %s | %s | **all** | %.1f | %.1f | **1:%.2f** | %.1f | %.1f | %.2f | %.2f | %.2f |\n",
                  store.c_str(), drawing.c_str(), t.min, t.max, t.max / t.min, t.mean, t.sd, n.min, n.max,
                  n.max / n.min);
    md << line;
  }
  md << "\n![frame time against angle](" << name << ".svg)\n";
  std::ofstream(out / (name + ".svg")) << plot(series, panels);
  std::printf("wrote %s.{csv,md,svg} in %s\n", name.c_str(), out.string().c_str());
  return 0;
}
