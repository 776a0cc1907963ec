// Is the texture walk view-dependent here? Weiskopf, Weiler & Ertl found the frame rate of a 3D-texture slicer
// varying 1:4.8 as the volume turned, because the texture's fast axis was along or across the rays. This tool turns
// the camera a full circle about each axis in fixed steps and times every frame, for each store (one brick, many
// bricks) and drawing (slicing, slabs, the ray caster), so that the minimum/maximum frame-rate ratio and the shape of
// time against angle can be read off.
//
// Protocol: for each store and drawing, a fresh renderer per run (the texture loaded anew, by an untimed frame), one
// warm-up pass over every angle discarded, then --runs timed passes; per angle the median over the runs. Time per
// sample (ns) is reported beside the frame time, since the samples a view takes change with the angle (a diagonal view
// has longer rays). Writes NAME.csv (one row per store, drawing, axis, angle, run), NAME.md (min, max, ratio, mean,
// standard deviation per axis and over all) and NAME.svg (time against angle, one panel per store and drawing).
//
// A store may be listed twice with different --brickings (single, multi-oriented: AtlasBricking), to compare them.
//
//   bench_orientation --stores A.vbs,B.vbs [--labels a,b] [--brickings single,multi-oriented]
//                     [--drawings raycast,slab,slicing] [--axes x,y,z]
//                     [--degrees-per-step 5] [--runs 3] [--size 256] [--tf hot] [--ert 0] [--distance 2.5]
//                     [--out bench/results/orientation] [--name orientation]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
#include "brickstore/read/OpenAnyStore.h"
#include "quality/Statistics.h"
#include "render/core/Camera.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/VolumeRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;
using voxbrick::quality::median;

namespace {

struct Options {
  std::string stores, labels, brickings, drawings = "raycast,slab,slicing", axes = "x,y,z", tf = "hot",
                                         name = "orientation", out = "bench/results/orientation";
  double step = 5, ert = 0, distance = 2.5;
  int runs = 3, size = 256;
};

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
    svg << "<text x='" << x0 - 38 << "' y='" << y0 + h / 2 << "' transform='rotate(-90 " << x0 - 38 << " " << y0 + h / 2
        << ")' text-anchor='middle'>ms a frame</text>\n";
    int legend = 0;
    for (const Series& s : series) {
      if (s.store != panels[p].first || s.drawing != panels[p].second) continue;
      const std::vector<double> ms = s.medianMs();
      svg << "<polyline fill='none' stroke='" << kAxisColours[s.axis] << "' stroke-width='1.5' points='";
      for (size_t i = 0; i < ms.size(); ++i)
        svg << x0 + w * s.angles[i] / 360.0 << "," << y0 + h - h * (ms[i] - lo) / (hi - lo) << " ";
      svg << "'/>\n<text x='" << x0 + 8 + 70 * legend++ << "' y='" << y0 + h + 30 << "' fill='" << kAxisColours[s.axis]
          << "'>about " << kAxisNames[s.axis] << "</text>\n";
    }
  }
  svg << "</svg>\n";
  return svg.str();
}

void addOptions(CLI::App& app, Options& o) {
  app.add_option("--stores", o.stores, "stores to turn, comma-separated")->required();
  app.add_option("--labels", o.labels, "a label per store, comma-separated (default: the stores' names)");
  app.add_option("--brickings", o.brickings,
                 "a bricking per store, comma-separated: single or multi-oriented (default: single for every store)");
  app.add_option("--drawings", o.drawings, "raycast, slab, slicing, comma-separated");
  app.add_option("--axes", o.axes, "x, y, z, comma-separated");
  app.add_option("--degrees-per-step", o.step, "degrees between views")->check(CLI::Range(0.1, 180.0));
  app.add_option("--runs", o.runs, "timed passes after the warm-up pass")->check(CLI::Range(1, 1000));
  app.add_option("--size", o.size, "frame side in pixels")->check(CLI::Range(8, 8192));
  app.add_option("--tf", o.tf, "transfer function preset");
  app.add_option("--ert", o.ert, "early ray termination threshold (0: off, so every sample is taken)");
  app.add_option("--distance", o.distance, "eye distance in bounding radii");
  app.add_option("--out", o.out, "output directory");
  app.add_option("--name", o.name, "output file name stem");
}

/// What the options name: stores with their labels and brickings, axes, drawings and the angles of a turn.
struct Plan {
  std::vector<std::string> stores, labels, drawings;
  std::vector<render::AtlasBricking> brickings;
  std::vector<int> axes;
  std::vector<double> angles;
};

/// A bricking per store: single for each, or those `text` names; throws std::invalid_argument if they do not match.
std::vector<render::AtlasBricking> brickingsOf(const std::string& text, size_t stores) {
  std::vector<render::AtlasBricking> brickings(stores, render::AtlasBricking::Single);
  if (text.empty()) return brickings;
  const std::vector<std::string> names = split(text);
  if (names.size() != stores)
    throw std::invalid_argument("--brickings names " + std::to_string(names.size()) + " brickings for " +
                                std::to_string(stores) + " stores");
  for (size_t i = 0; i < names.size(); ++i) brickings[i] = render::parseAtlasBricking(names[i]);
  return brickings;
}

/// The plan of the options; throws std::invalid_argument (or what parseAtlasBricking throws) naming what is wrong.
Plan planOf(const Options& o) {
  Plan p;
  p.stores = split(o.stores);
  p.drawings = split(o.drawings);
  p.labels = split(o.labels);
  if (p.stores.empty()) throw std::invalid_argument("--stores names no store");
  if (p.labels.size() != p.stores.size()) {
    p.labels.clear();
    for (const std::string& s : p.stores) p.labels.push_back(fs::path(s).filename().string());
  }
  p.brickings = brickingsOf(o.brickings, p.stores.size());
  for (const std::string& a : split(o.axes)) {
    if (a != "x" && a != "y" && a != "z") throw std::invalid_argument("axis '" + a + "' is not x, y or z");
    p.axes.push_back(a[0] - 'x');
  }
  for (const std::string& d : p.drawings)
    if (d != "raycast" && d != "slab" && d != "slicing")
      throw std::invalid_argument("drawing '" + d + "' is not raycast, slab or slicing");
  for (double a = 0; a < 360 - 1e-9; a += o.step) p.angles.push_back(a);
  return p;
}

render::Scene drawingScene(const Options& o, const std::string& drawing) {
  render::Scene scene;
  scene.width = scene.height = o.size;
  scene.transferFunction = render::TransferFunction::load(o.tf);
  scene.transferFunctionName = o.tf;
  scene.ert = o.ert;
  scene.lod = 0;
  scene.raycast = drawing == "raycast";
  scene.slab = drawing == "slicing" ? 0 : 32;
  return scene;
}

/// Store `si` with `drawing`: a series per axis appended to `series`, each angle timed in every run. A fresh
/// renderer each run (the atlas, the texture, loaded anew, as in the paper's protocol); run -1 is the warm-up pass,
/// discarded.
void measureDrawing(render::GlContext& context, const std::shared_ptr<store::BrickCache>& cache, const Plan& plan,
                    size_t si, const std::string& drawing, const Options& o, std::vector<Series>& series) {
  const render::Box box = render::volumeBox(cache->store()->meta().dims, cache->store()->meta().spacing);
  render::Scene scene = drawingScene(o, drawing);
  const size_t first = series.size();
  for (int axis : plan.axes) {
    Series s;
    s.store = plan.labels[si];
    s.drawing = drawing;
    s.axis = axis;
    s.angles = plan.angles;
    s.runs.resize(plan.angles.size());
    series.push_back(std::move(s));
  }
  for (int run = -1; run < o.runs; ++run) {
    render::VolumeRenderer renderer(context, cache, size_t(2048) << 20, render::AtlasFormat::Float,
                                    render::AtlasUploads::Auto, plan.brickings[si]);
    scene.camera = cameraAbout(plan.axes[0], plan.angles[0], o.distance * box.radius());
    renderer.render(scene);  // untimed: uploads the bricks, so that no timed frame pays for the load
    for (size_t ai = 0; ai < plan.axes.size(); ++ai)
      for (size_t k = 0; k < plan.angles.size(); ++k) {
        scene.camera = cameraAbout(plan.axes[ai], plan.angles[k], o.distance * box.radius());
        render::FrameStats stats;
        renderer.render(scene, &stats);
        if (run >= 0) series[first + ai].runs[k].push_back({stats.msTotal, double(stats.samples)});
      }
    if (run >= 0) std::printf("%s, %s: run %d of %d done\n", plan.labels[si].c_str(), drawing.c_str(), run + 1, o.runs);
    std::fflush(stdout);
  }
}

void writeCsv(const fs::path& path, const std::string& device, const Options& o, const std::vector<Series>& series) {
  std::ofstream csv(path);
  csv << "# " << device << "; " << o.size << "x" << o.size << ", tf " << o.tf << ", ert " << o.ert << ", distance "
      << o.distance << " R, " << o.step << " degrees a step, " << o.runs << " runs after a warm-up pass\n";
  csv << "store,drawing,axis,angle,run,ms_total,samples\n";
  for (const Series& s : series)
    for (size_t k = 0; k < s.angles.size(); ++k)
      for (size_t r = 0; r < s.runs[k].size(); ++r)
        csv << s.store << "," << s.drawing << "," << kAxisNames[s.axis] << "," << s.angles[k] << "," << r << ","
            << s.runs[k][r].ms << "," << s.runs[k][r].samples << "\n";
}

/// A panel's rows: one per axis, then one over all its axes.
void writeSummaryRows(std::ofstream& md, const std::vector<Series>& series, const std::string& store,
                      const std::string& drawing) {
  char line[512];
  std::vector<double> allMs, allNs;
  for (const Series& s : series) {
    if (s.store != store || s.drawing != drawing) continue;
    const std::vector<double> ms = s.medianMs(), ns = s.nsPerSample();
    allMs.insert(allMs.end(), ms.begin(), ms.end());
    allNs.insert(allNs.end(), ns.begin(), ns.end());
    const Summary t = summarise(ms), n = summarise(ns);
    std::snprintf(line, sizeof line, "| %s | %s | %s | %.1f | %.1f | 1:%.2f | %.1f | %.1f | %.2f | %.2f | %.2f |\n",
                  store.c_str(), drawing.c_str(), kAxisNames[s.axis], t.min, t.max, t.max / t.min, t.mean, t.sd, n.min,
                  n.max, n.max / n.min);
    md << line;
  }
  const Summary t = summarise(allMs), n = summarise(allNs);
  std::snprintf(line, sizeof line,
                "| %s | %s | **all** | %.1f | %.1f | **1:%.2f** | %.1f | %.1f | %.2f | %.2f | %.2f |\n", store.c_str(),
                drawing.c_str(), t.min, t.max, t.max / t.min, t.mean, t.sd, n.min, n.max, n.max / n.min);
  md << line;
}

void writeMarkdown(const fs::path& path, const std::string& device, const Options& o, size_t angles,
                   const std::vector<Series>& series, const std::vector<std::pair<std::string, std::string>>& panels) {
  std::ofstream md(path);
  md << "Device: " << device << ". " << o.size << "×" << o.size << ", transfer function `" << o.tf << "`, termination "
     << (o.ert > 0 ? std::to_string(o.ert) : std::string("off")) << ", level 0, the eye at " << o.distance
     << " bounding radii on a circle about each axis (up along the axis), " << o.step << "° a step (" << angles
     << " angles an axis); per store and drawing a fresh renderer each run, a warm-up pass discarded, " << o.runs
     << " timed runs; per angle the median frame time over the runs.\n\n";
  md << "| store | drawing | axis | min ms | max ms | min/max frame rate | mean ms | sd ms | min ns/sample | max "
        "ns/sample | ns/sample ratio |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& [store, drawing] : panels) writeSummaryRows(md, series, store, drawing);
  md << "\n![frame time against angle](" << o.name << ".svg)\n";
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"bench_orientation: frame time against view angle about each axis"};
  addOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  Plan plan;
  try {
    plan = planOf(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_orientation: %s\n", e.what());
    return 2;
  }
  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  std::printf("bench_orientation on %s: %zu stores, %zu drawings, %zu axes, %zu angles, %d runs\n", device.c_str(),
              plan.stores.size(), plan.drawings.size(), plan.axes.size(), plan.angles.size(), o.runs);
  std::vector<Series> series;
  std::vector<std::pair<std::string, std::string>> panels;
  for (size_t si = 0; si < plan.stores.size(); ++si) {
    auto cache = std::make_shared<store::BrickCache>(store::openAnyStore(plan.stores[si]), size_t(4096) << 20, 2);
    for (const std::string& drawing : plan.drawings) {
      panels.push_back({plan.labels[si], drawing});
      measureDrawing(*context, cache, plan, si, drawing, o, series);
    }
  }
  const fs::path out = o.out;
  fs::create_directories(out);
  writeCsv(out / (o.name + ".csv"), device, o, series);
  writeMarkdown(out / (o.name + ".md"), device, o, plan.angles.size(), series, panels);
  std::ofstream(out / (o.name + ".svg")) << plot(series, panels);
  std::printf("wrote %s.{csv,md,svg} in %s\n", o.name.c_str(), out.string().c_str());
  return 0;
}
