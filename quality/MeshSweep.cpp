// The mesh sweep: exact reference frames, GPU frames of each setting, the front, the default and the files.
#include "quality/MeshSweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>

#include "mesh/MeshReaders.h"
#include "mesh/MeshStore.h"
#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"
#include "mesh/Validate.h"
#include "quality/Statistics.h"
#include "quality/SweepReport.h"
#include "render/core/TransferFunction.h"
#include "render/gl/tets/TetRenderer.h"
#include "render/reference/TetReference.h"
#include "render/tets/TetMeshDataset.h"

namespace voxbrick::quality {
namespace {

namespace fs = std::filesystem;

constexpr const char* kSynthetic = "synthetic-mesh:";

/// A mesh input read whole: a mesh store, a .vtk or .msh file (validated and repaired as `prep` does), or a
/// synthetic spec.
mesh::TetMesh readMeshInput(const std::string& input) {
  if (input.rfind(kSynthetic, 0) == 0) return mesh::syntheticMesh(input.substr(std::string(kSynthetic).size()));
  if (mesh::looksLikeMeshStore(input)) return mesh::MeshStore::open(input).readAll();
  mesh::TetMesh m = mesh::readMesh(input);
  mesh::validateMesh(m);
  return m;
}

std::string meshName(const std::string& input) {
  if (input.rfind(kSynthetic, 0) == 0) return input;
  std::string name = fs::path(input).filename().string();
  if (name.empty()) name = fs::path(input).parent_path().filename().string();  // "dir/"
  return name;
}

render::Scene viewScene(const MeshSweepSpec& spec, const std::string& tf, int view) {
  render::Scene scene;
  scene.width = scene.height = spec.size;
  scene.camera.azimuth = 360.0 * view / spec.views;
  scene.camera.elevation = spec.elevation;
  scene.camera.distance = spec.distance;
  scene.transferFunction = render::TransferFunction::load(tf);
  scene.transferFunctionName = tf;
  return scene;
}


/// A CSV field: quoted (quotes doubled) where it holds a comma or a quote, as a synthetic spec does.
std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string csv(const MeshSweepResult& r) {
  std::string out =
      "mesh,tets,transfer_function,visibility,skip_empty,ert,views,size,median_ms,min_ms,max_ms,sort_ms_median,"
      "fragments_median,tets_drawn_median,psnr_worst_db,psnr_pooled_db,max_abs,pareto\n";
  for (const MeshPoint& p : r.points)
    out += csvField(p.mesh) + "," + std::to_string(p.tets) + "," + csvField(p.transferFunction) + "," +
           render::tetSortName(p.setting.visibility) + "," + (p.setting.skipEmpty ? "1" : "0") + "," +
           formatNumber("%g", p.setting.visibility == render::TetSort::Ray ? p.setting.ert : 0) + "," +
           std::to_string(r.spec.views) + "," + std::to_string(r.spec.size) + "," + formatNumber("%.2f", p.msMedian) + "," +
           formatNumber("%.2f", p.msMin) + "," + formatNumber("%.2f", p.msMax) + "," + formatNumber("%.2f", p.sortMsMedian) + "," +
           formatNumber("%.0f", p.fragmentsMedian) + "," + formatNumber("%.0f", p.tetsDrawnMedian) + "," +
           formatNumber("%.2f", p.psnrMin) + "," + formatNumber("%.2f", p.psnrPooled) + "," + formatNumber("%.6f", p.maxAbs) + "," +
           (p.pareto ? "1" : "0") + "\n";
  return out;
}

std::string markdown(const MeshSweepResult& r) {
  const MeshSweepSpec& s = r.spec;
  std::string out = "# Mesh sweep: time against error\n\nDevice: " + r.device + ". " + std::to_string(s.views) +
                    " views (azimuth 0…" + formatNumber("%g", 360.0 * (s.views - 1) / s.views) + "°, elevation " +
                    formatNumber("%g", s.elevation) + "°, " + formatNumber("%g", s.distance) + " R), " + std::to_string(s.size) +
                    "², after a warm-up frame; PSNR against the exact reference (render/reference/TetReference.h).\n\n";
  for (const auto& [what, ms] : r.referenceMs)
    out += "- Reference, " + what + ": " + formatNumber("%.0f", ms) + " ms a view\n";
  out +=
      "\n| mesh | tets | transfer function | setting | median ms | sort ms | fragments (M) | tets drawn | worst "
      "view dB | pooled dB | front |\n|---|---:|---|---|---:|---:|---:|---:|---:|---:|:-:|\n";
  for (const MeshPoint& p : r.points)
    out += "| " + p.mesh + " | " + std::to_string(p.tets) + " | " + p.transferFunction + " | " + p.setting.label() +
           " | " + formatNumber("%.1f", p.msMedian) + " | " + formatNumber("%.1f", p.sortMsMedian) + " | " +
           formatNumber("%.2f", p.fragmentsMedian / 1e6) + " | " + formatNumber("%.0f", p.tetsDrawnMedian) + " | " +
           formatNumber("%.1f", p.psnrMin) + " | " + formatNumber("%.1f", p.psnrPooled) + " | " + (p.pareto ? "●" : "") + " |\n";
  out += "\n**Default** (the fastest setting, summed over meshes and transfer functions, whose worst view reaches " +
         formatNumber("%g", s.psnrThreshold) + " dB everywhere): " + (r.chosen ? r.chosen->label() : "none reaches it") +
         ".\n";
  return out;
}

/// One panel per mesh and transfer function: median time (x, logarithmic) against the worst view's PSNR (y), the
/// front's points filled and joined.
std::string svg(const MeshSweepResult& r) {
  std::vector<std::pair<std::string, std::string>> panels;
  for (const MeshPoint& p : r.points)
    if (std::find(panels.begin(), panels.end(), std::pair{p.mesh, p.transferFunction}) == panels.end())
      panels.emplace_back(p.mesh, p.transferFunction);
  constexpr double kW = 420, kH = 320, kL = 56, kR = 14, kT = 32, kB = 44;
  constexpr const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};
  const double width = kW * double(std::max<size_t>(panels.size(), 1)), height = kH;
  std::string out = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + formatNumber("%.0f", width) + "\" height=\"" +
                    formatNumber("%.0f", height) + "\" font-family=\"sans-serif\" font-size=\"11\">\n";
  out += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  for (size_t i = 0; i < panels.size(); ++i) {
    std::vector<const MeshPoint*> pts;
    for (const MeshPoint& p : r.points)
      if (p.mesh == panels[i].first && p.transferFunction == panels[i].second) pts.push_back(&p);
    double t0 = std::numeric_limits<double>::infinity(), t1 = 0, q0 = t0, q1 = 0;
    for (const MeshPoint* p : pts) {
      t0 = std::min(t0, p->msMedian), t1 = std::max(t1, p->msMedian);
      const double q = std::min(p->psnrMin, 100.0);
      q0 = std::min(q0, q), q1 = std::max(q1, q);
    }
    const double lx0 = std::log10(t0 / 1.25), lx1 = std::log10(t1 * 1.25);
    q0 = std::floor(std::min(q0, r.spec.psnrThreshold) - 2), q1 = std::ceil(q1 + 2);
    const double ox = kW * double(i);
    auto X = [&](double ms) { return ox + kL + (std::log10(ms) - lx0) / (lx1 - lx0) * (kW - kL - kR); };
    auto Y = [&](double db) { return kT + (q1 - std::min(db, 100.0)) / (q1 - q0) * (kH - kT - kB); };
    out += "<text x=\"" + formatNumber("%.1f", ox + kL) + "\" y=\"20\" font-weight=\"bold\">" + panels[i].first + ", " +
           panels[i].second + "</text>\n";
    out += "<rect x=\"" + formatNumber("%.1f", ox + kL) + "\" y=\"" + formatNumber("%.1f", kT) + "\" width=\"" +
           formatNumber("%.1f", kW - kL - kR) + "\" height=\"" + formatNumber("%.1f", kH - kT - kB) +
           "\" fill=\"none\" stroke=\"#888\"/>\n";
    out += "<text x=\"" + formatNumber("%.1f", ox + kW / 2) + "\" y=\"" + formatNumber("%.1f", kH - 10) +
           "\" text-anchor=\"middle\">median ms (log) " + formatNumber("%.1f", t0) + " … " + formatNumber("%.1f", t1) +
           "</text>\n<text x=\"" + formatNumber("%.1f", ox + 14) + "\" y=\"" + formatNumber("%.1f", kH / 2) +
           "\" transform=\"rotate(-90 " + formatNumber("%.1f", ox + 14) + " " + formatNumber("%.1f", kH / 2) +
           ")\" text-anchor=\"middle\">worst view PSNR (dB) " + formatNumber("%.0f", q0) + " … " + formatNumber("%.0f", q1) +
           "</text>\n";
    out += "<line x1=\"" + formatNumber("%.1f", ox + kL) + "\" x2=\"" + formatNumber("%.1f", ox + kW - kR) + "\" y1=\"" +
           formatNumber("%.1f", Y(r.spec.psnrThreshold)) + "\" y2=\"" + formatNumber("%.1f", Y(r.spec.psnrThreshold)) +
           "\" stroke=\"#aaa\" stroke-dasharray=\"4 3\"/>\n";
    std::vector<const MeshPoint*> front;
    for (const MeshPoint* p : pts)
      if (p->pareto) front.push_back(p);
    std::sort(front.begin(), front.end(),
              [](const MeshPoint* a, const MeshPoint* b) { return a->msMedian < b->msMedian; });
    if (front.size() > 1) {
      out += "<polyline fill=\"none\" stroke=\"#444\" points=\"";
      for (const MeshPoint* p : front)
        out += formatNumber("%.1f", X(p->msMedian)) + "," + formatNumber("%.1f", Y(p->psnrMin)) + " ";
      out += "\"/>\n";
    }
    for (size_t k = 0; k < pts.size(); ++k) {
      const MeshPoint& p = *pts[k];
      const size_t c =
          size_t(std::find(r.spec.settings.begin(), r.spec.settings.end(), p.setting) - r.spec.settings.begin()) %
          std::size(kColors);
      out += "<circle cx=\"" + formatNumber("%.1f", X(p.msMedian)) + "\" cy=\"" + formatNumber("%.1f", Y(p.psnrMin)) +
             "\" r=\"5\" stroke=\"" + kColors[c] + "\" fill=\"" + (p.pareto ? kColors[c] : "none") + "\"><title>" +
             p.setting.label() + ": " + formatNumber("%.1f", p.msMedian) + " ms, " + formatNumber("%.1f", p.psnrMin) +
             " dB</title></circle>\n";
    }
    for (size_t k = 0; k < r.spec.settings.size() && i == 0; ++k)
      out += "<text x=\"" + formatNumber("%.1f", kL + 4) + "\" y=\"" + formatNumber("%.1f", kT + 14 + 13.0 * double(k)) +
             "\" fill=\"" + kColors[k % std::size(kColors)] + "\">● " + r.spec.settings[k].label() + "</text>\n";
  }
  out += "</svg>\n";
  return out;
}

}  // namespace

std::string MeshSetting::label() const {
  if (visibility == render::TetSort::Ray)
    return std::string(render::tetSortName(visibility)) + (ert > 0 ? ", ert " + formatNumber("%g", ert) : ", no ert");
  return std::string(render::tetSortName(visibility)) + (skipEmpty ? ", skip" : ", no skip");
}

MeshSweepResult runMeshSweep(const MeshSweepSpec& spec, render::GlContext& context,
                             const std::function<void(const std::string&)>& log) {
  MeshSweepResult result;
  result.spec = spec;
  result.device = context.describe();
  for (const std::string& tf : spec.transferFunctions) render::TransferFunction::load(tf);  // unknown ones fail now
  for (const std::string& input : spec.meshes) {
    const std::string name = meshName(input);
    log("mesh " + name + ": reading");
    mesh::TetMesh m = readMeshInput(input);
    mesh::Topology topology = mesh::buildTopology(m);
    const render::TetReference reference(m);
    auto data = std::make_shared<const render::TetMeshData>(std::move(m), std::move(topology));
    render::TetRenderer renderer(context, data, size_t(2) << 30);
    for (const std::string& tf : spec.transferFunctions) {
      // The exact reference of every view.
      std::vector<image::ImageF> truth;
      std::vector<double> referenceMs;
      for (int v = 0; v < spec.views; ++v) {
        render::TetReferenceStats stats;
        truth.push_back(reference.render(
            render::TetReferenceParams::fromScene(viewScene(spec, tf, v), data->mesh, data->meanEdgeLength), &stats));
        referenceMs.push_back(stats.ms);
      }
      result.referenceMs.emplace_back(name + ", " + tf, median(referenceMs));
      log("mesh " + name + ", " + tf + ": reference " + formatNumber("%.0f", median(referenceMs)) + " ms a view");
      for (const MeshSetting& setting : spec.settings) {
        auto sceneOf = [&](int v) {
          render::Scene scene = viewScene(spec, tf, v);
          scene.visibility = setting.visibility;
          scene.skipEmpty = setting.skipEmpty;
          scene.ert = setting.ert;
          return scene;
        };
        renderer.render(sceneOf(0));  // warm-up: the program, the table
        MeshPoint p{name, tf, setting, int64_t(data->mesh.tets.size())};
        std::vector<double> ms, sort, fragments, drawn;
        ErrorTally errors;
        for (int v = 0; v < spec.views; ++v) {
          render::FrameStats stats;
          const image::ImageF image = renderer.render(sceneOf(v), &stats);
          ms.push_back(stats.msTotal);
          sort.push_back(stats.msSorting);
          if (setting.visibility == render::TetSort::Ray && stats.tetRayPasses == 0)
            throw std::runtime_error("mesh " + name + ", view " + std::to_string(v) +
                                     ": the ray caster could not draw it (the camera is within the mesh's box)");
          fragments.push_back(double(stats.tetRayPasses > 0 ? stats.samples : stats.fragments));
          drawn.push_back(double(stats.tetsDrawn));
          errors.add(image::compareImages(image, truth[size_t(v)]));
        }
        p.psnrMin = errors.psnrMin;
        p.maxAbs = errors.maxAbs;
        p.psnrPooled = errors.psnrPooled();
        p.msMedian = median(ms);
        p.msMin = *std::min_element(ms.begin(), ms.end());
        p.msMax = *std::max_element(ms.begin(), ms.end());
        p.sortMsMedian = median(sort);
        p.fragmentsMedian = median(fragments);
        p.tetsDrawnMedian = median(drawn);
        log("mesh " + name + ", " + tf + ", " + setting.label() + ": " + formatNumber("%.1f", p.msMedian) + " ms, " +
            formatNumber("%.1f", p.psnrMin) + " dB worst view");
        result.points.push_back(p);
      }
    }
  }
  markMeshPareto(result.points);
  double bestCost = std::numeric_limits<double>::infinity();
  for (const MeshSetting& setting : spec.settings) {
    double cost = 0;
    for (const MeshPoint& p : result.points)
      if (p.setting == setting)
        cost += p.psnrMin >= spec.psnrThreshold ? p.msMedian : std::numeric_limits<double>::infinity();
    if (cost < bestCost) {
      bestCost = cost;
      result.chosen = setting;
    }
  }
  return result;
}

void markMeshPareto(std::vector<MeshPoint>& points) {
  for (MeshPoint& p : points)
    p.pareto = std::none_of(points.begin(), points.end(), [&](const MeshPoint& q) {
      return q.mesh == p.mesh && q.transferFunction == p.transferFunction && q.msMedian <= p.msMedian &&
             q.psnrMin >= p.psnrMin && (q.msMedian < p.msMedian || q.psnrMin > p.psnrMin);
    });
}

void writeMeshResults(const MeshSweepResult& result, const fs::path& out) {
  fs::create_directories(out);
  writeTextFile(out / "mesh-sweep.csv", csv(result));
  writeTextFile(out / "mesh-sweep.md", markdown(result));
  writeTextFile(out / "mesh-sweep.svg", svg(result));
}

}  // namespace voxbrick::quality
