// SVG written directly: a small, fixed layout that a browser or an image viewer shows and a test can parse.
#include "quality/SweepPlot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iterator>
#include <numbers>
#include <sstream>

namespace voxbrick::quality {
namespace {

constexpr double kPanelWidth = 430, kPanelHeight = 360;
constexpr double kLeft = 58, kRight = 14, kTop = 34, kBottom = 46;  // margins of a panel's plot area
constexpr double kPsnrCap = 100;
constexpr double kPi = std::numbers::pi;  // identical images have infinite PSNR; they are drawn at the top
constexpr const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};

std::string svgf(const char* format, double a, double b = 0, double c = 0, double d = 0) {
  char text[256];
  std::snprintf(text, sizeof text, format, a, b, c, d);
  return text;
}

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '&')
      out += "&amp;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

/// Which renderer alternative a setting is, for its marker: 0 baseline, 1 smaller bricks, 2 larger, 3 no skip, 4 cpu;
/// texture slabs 5 (1–2 planes), 6 (up to 8), 7 (fewer than whole bricks), 8 (whole bricks), 9 pre-integration; the
/// frame ray caster 10, 11 pre-integrated. Early ray termination is a dot in the marker's middle (hasErtDot).
int shapeOf(const Setting& s) {
  if (s.raycast) return s.preIntegration ? 11 : 10;
  if (s.slab > 0) {
    if (s.preIntegration) return 9;
    if (s.slab <= 2) return 5;
    if (s.slab <= 8) return 6;
    return s.slab < render::Scene::kMaxSlab ? 7 : 8;
  }
  if (s.slicer == render::Slicer::Cpu) return 4;
  if (!s.skip) return 3;
  if (s.brick < 32) return 1;
  if (s.brick > 32) return 2;
  return 0;
}

constexpr int kShapes = 12;
constexpr const char* kShapeNames[kShapes] = {"slicing: B=32, skip, vertex slicer",
                                              "B=16",
                                              "B=64",
                                              "no skipping",
                                              "cpu slicer",
                                              "slab 1",
                                              "slab 4",
                                              "slab 16",
                                              "slab whole brick",
                                              "slab 16, pre-integration",
                                              "raycast",
                                              "raycast, pre-integration"};

bool hasErtDot(const Setting& s) { return (s.slab > 0 || s.raycast) && s.ert > 0; }

std::string ertDot(double x, double y) {
  return svgf("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"1.8\" fill=\"black\"/>", x, y);
}

std::string triangle(double x, double y, double dx, double dy, const std::string& style) {
  // Pointing along (dx, dy): the tip 5.5 from the centre, the base 4 behind it, 5 to each side.
  const double px = -dy, py = dx;
  return svgf("<polygon points=\"%.1f,%.1f %.1f,%.1f ", x + 5.5 * dx, y + 5.5 * dy, x - 4 * dx + 5 * px,
              y - 4 * dy + 5 * py) +
         svgf("%.1f,%.1f\"", x - 4 * dx - 5 * px, y - 4 * dy - 5 * py) + style + "/>";
}

std::string marker(int shape, double x, double y, const std::string& color, bool filled) {
  const std::string style =
      " fill=\"" + (filled ? color : std::string("white")) + "\" stroke=\"" + color + "\" stroke-width=\"1.5\"";
  switch (shape) {
    case 1: return svgf("<rect x=\"%.1f\" y=\"%.1f\" width=\"8\" height=\"8\"", x - 4, y - 4) + style + "/>";
    case 2:
      return svgf("<polygon points=\"%.1f,%.1f %.1f,%.1f ", x, y - 5.5, x + 5.5, y) +
             svgf("%.1f,%.1f %.1f,%.1f\"", x, y + 5.5, x - 5.5, y) + style + "/>";
    case 3:
      return svgf("<polygon points=\"%.1f,%.1f %.1f,%.1f ", x, y - 5.5, x + 5, y + 4) +
             svgf("%.1f,%.1f\"", x - 5, y + 4) + style + "/>";
    case 4:
      return svgf("<path d=\"M%.1f %.1fL%.1f %.1f", x - 4.5, y - 4.5, x + 4.5, y + 4.5) +
             svgf("M%.1f %.1fL%.1f %.1f\" fill=\"none\"", x - 4.5, y + 4.5, x + 4.5, y - 4.5) + " stroke=\"" + color +
             "\" stroke-width=\"2\"/>";
    case 5: return triangle(x, y, -1, 0, style);
    case 6: return triangle(x, y, 0, 1, style);
    case 7: return triangle(x, y, 1, 0, style);
    case 8: {
      std::string points;
      for (int i = 0; i < 6; ++i)
        points += svgf("%.1f,%.1f ", x + 5.5 * std::cos(i * kPi / 3), y + 5.5 * std::sin(i * kPi / 3));
      return "<polygon points=\"" + points + "\"" + style + "/>";
    }
    case 9: {
      std::string points;
      for (int i = 0; i < 10; ++i) {
        const double r = i % 2 ? 2.8 : 6.5, a = -kPi / 2 + i * kPi / 5;
        points += svgf("%.1f,%.1f ", x + r * std::cos(a), y + r * std::sin(a));
      }
      return "<polygon points=\"" + points + "\"" + style + "/>";
    }
    case 10: {
      // A plus as one outline, so that it fills like the other markers and leaves room for the ERT dot.
      constexpr double kPlus[12][2] = {{-2.2, -6}, {2.2, -6}, {2.2, -2.2}, {6, -2.2}, {6, 2.2},   {2.2, 2.2},
                                       {2.2, 6},   {-2.2, 6}, {-2.2, 2.2}, {-6, 2.2}, {-6, -2.2}, {-2.2, -2.2}};
      std::string points;
      for (const auto& corner : kPlus) points += svgf("%.1f,%.1f ", x + corner[0], y + corner[1]);
      return "<polygon points=\"" + points + "\"" + style + "/>";
    }
    case 11: {
      std::string points;
      for (int i = 0; i < 5; ++i) {
        const double a = -kPi / 2 + i * 2 * kPi / 5;
        points += svgf("%.1f,%.1f ", x + 6 * std::cos(a), y + 6 * std::sin(a));
      }
      return "<polygon points=\"" + points + "\"" + style + "/>";
    }
    default: return svgf("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"4\"", x, y) + style + "/>";
  }
}

double cappedPsnr(double psnr) { return std::min(psnr, kPsnrCap); }

/// A panel's scales: log time across, PSNR up, both rounded out to ticks.
struct PanelAxes {
  double lx0, lx1, y0, y1;          ///< log10 of the time, and the PSNR, at the edges
  double left, right, top, bottom;  ///< the plot area in the document
  double px(double ms) const { return left + (std::log10(std::max(ms, 1e-3)) - lx0) / (lx1 - lx0) * (right - left); }
  double py(double psnr) const { return bottom - (cappedPsnr(psnr) - y0) / (y1 - y0) * (bottom - top); }
};

/// The scales that hold every point and the threshold, for the panel at `x0`.
PanelAxes panelAxes(const std::vector<const Point*>& points, double threshold, double x0) {
  double tMin = points[0]->msMedian, tMax = tMin, pMin = cappedPsnr(points[0]->psnrMin), pMax = pMin;
  for (const Point* p : points) {
    tMin = std::min(tMin, p->msMedian), tMax = std::max(tMax, p->msMedian);
    pMin = std::min(pMin, cappedPsnr(p->psnrMin)), pMax = std::max(pMax, cappedPsnr(p->psnrMin));
  }
  pMin = std::min(pMin, threshold);
  const double lx0 = std::floor(std::log10(std::max(tMin, 1e-3)) * 4) / 4;
  const double lx1 = std::max(std::ceil(std::log10(std::max(tMax, 1e-3)) * 4) / 4, lx0 + 0.25);
  const double y0 = std::floor(pMin / 5) * 5, y1 = std::max(std::ceil(pMax / 5) * 5, y0 + 5);
  return {lx0, lx1, y0, y1, x0 + kLeft, x0 + kPanelWidth - kRight, kTop, kPanelHeight - kBottom};
}

/// The panel's box, title, ticks, axis labels and the threshold line.
void drawFrame(std::ostringstream& svg, const PanelAxes& a, const Dataset& d, double x0, double psnrThreshold) {
  const double left = a.left, right = a.right, top = a.top, bottom = a.bottom;
  svg << svgf("<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"none\" stroke=\"#444\"/>\n", left, top,
              right - left, bottom - top);
  svg << "<text x=\"" << (left + right) / 2 << "\" y=\"" << top - 10
      << "\" text-anchor=\"middle\" font-size=\"14\" font-weight=\"bold\">" << escape(d.name) << " ("
      << escape(d.input.substr(d.input.find_last_of('/') + 1)) << ")</text>\n";
  // Time ticks at 1, 2 and 5 times powers of ten; PSNR ticks every 5 dB.
  for (int e = int(std::floor(a.lx0)); e <= int(std::ceil(a.lx1)); ++e)
    for (double m : {1.0, 2.0, 5.0}) {
      const double ms = m * std::pow(10.0, e), l = std::log10(ms);
      if (l < a.lx0 - 1e-9 || l > a.lx1 + 1e-9) continue;
      const double x = a.px(ms);
      svg << svgf("<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>\n", x, top, x, bottom);
      svg << svgf("<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\" font-size=\"11\">%g</text>\n", x, bottom + 14,
                  ms);
    }
  for (double p = a.y0; p <= a.y1 + 1e-9; p += (a.y1 - a.y0 > 40 ? 10 : 5)) {
    const double y = a.py(p);
    svg << svgf("<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>\n", left, y, right, y);
    svg << svgf("<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\" font-size=\"11\">%g</text>\n", left - 5, y + 4, p);
  }
  svg << "<text x=\"" << (left + right) / 2 << "\" y=\"" << bottom + 32
      << "\" text-anchor=\"middle\" font-size=\"12\">median frame time (ms, log) — faster to the left</text>\n";
  svg << svgf("<text transform=\"translate(%.1f,%.1f) rotate(-90)\" text-anchor=\"middle\" font-size=\"12\">", x0 + 16,
              (top + bottom) / 2)
      << "PSNR of the worst view (dB) — better up</text>\n";
  const double threshold = a.py(psnrThreshold);
  svg << svgf("<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#888\" stroke-dasharray=\"6 4\"/>\n",
              left, threshold, right, threshold);
  svg << svgf("<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\" font-size=\"11\" fill=\"#666\">%g dB</text>\n",
              right - 4, threshold - 4, psnrThreshold);
}

/// Variant `v` (the `v`-th the sweep measured): its Pareto front as a line under its points, the points (the chosen
/// settings ringed on the first variant), and its entry in the key.
void drawVariant(std::ostringstream& svg, const PanelAxes& a, const SweepResult& result,
                 const std::vector<const Point*>& points, const Variant& variant, size_t v) {
  const std::string color = kColors[v % std::size(kColors)];
  std::vector<const Point*> front;
  for (const Point* p : points)
    if (p->variant == variant && p->pareto) front.push_back(p);
  std::sort(front.begin(), front.end(), [](const Point* x, const Point* y) { return x->msMedian < y->msMedian; });
  svg << "<polyline fill=\"none\" stroke=\"" << color << "\" stroke-width=\"2\" stroke-opacity=\"0.6\" points=\"";
  for (const Point* p : front) svg << svgf("%.1f,%.1f ", a.px(p->msMedian), a.py(p->psnrMin));
  svg << "\"/>\n";
  for (const Point* p : points) {
    if (!(p->variant == variant)) continue;
    const double x = a.px(p->msMedian), y = a.py(p->psnrMin);
    svg << marker(shapeOf(p->setting), x, y, color, p->pareto) << "\n";
    if (hasErtDot(p->setting)) svg << ertDot(x, y) << "\n";
    if (shapeOf(p->setting) == 0)
      svg << svgf("<text x=\"%.1f\" y=\"%.1f\" font-size=\"9\" fill=\"#333\">%g</text>\n", x + 6, y - 5,
                  p->setting.step);
    if (result.chosen && p->setting == *result.chosen && v == 0)
      svg << svgf("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"9\" fill=\"none\" stroke=\"black\" stroke-width=\"1.5\"/>\n", x,
                  y);
    if (result.chosenHigh && p->setting == *result.chosenHigh && v == 0)
      svg << svgf(
          "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"12\" fill=\"none\" stroke=\"black\" stroke-width=\"1.5\" "
          "stroke-dasharray=\"3 2\"/>\n",
          x, y);
  }
  const double ly = kPanelHeight + 16 + 16 * double(v);
  svg << svgf("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"4\" fill=\"", a.left + 4, ly - 4) << color << "\"/>\n";
  svg << svgf("<text x=\"%.1f\" y=\"%.1f\" font-size=\"11\">", a.left + 14, ly)
      << escape(variant.transferFunction + (variant.shading ? ", shaded" : "")) << "</text>\n";
}

void panel(std::ostringstream& svg, const SweepResult& result, const Dataset& d, double x0) {
  std::vector<const Point*> points;
  for (const Point& p : result.points)
    if (p.dataset == d.name) points.push_back(&p);
  if (points.empty()) return;
  const PanelAxes axes = panelAxes(points, result.spec.psnrThreshold, x0);
  drawFrame(svg, axes, d, x0, result.spec.psnrThreshold);
  // Variants in the order the sweep measured them.
  std::vector<Variant> variants;
  for (const Point* p : points)
    if (std::find(variants.begin(), variants.end(), p->variant) == variants.end()) variants.push_back(p->variant);
  for (size_t v = 0; v < variants.size(); ++v) drawVariant(svg, axes, result, points, variants[v], v);
}

}  // namespace

std::string sweepSvg(const SweepResult& result) {
  const double width = kPanelWidth * double(std::max<size_t>(result.spec.datasets.size(), 1));
  // The marker key, shared by the panels, laid out first (it wraps to the width): each entry a marker drawn at
  // (x, y) and a text.
  struct KeyEntry {
    std::function<std::string(double, double)> marker;
    std::string text;
  };
  std::vector<KeyEntry> entries;
  for (int shape = 0; shape < kShapes; ++shape)
    entries.push_back({[shape](double x, double y) { return marker(shape, x, y, "#333", false); }, kShapeNames[shape]});
  entries.push_back(
      {[](double x, double y) { return marker(7, x, y, "#333", false) + ertDot(x, y); }, "dot: early ray termination"});
  entries.push_back({[](double x, double y) {
                       return svgf(
                           "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"8\" fill=\"none\" stroke=\"black\" "
                           "stroke-width=\"1.5\"/>",
                           x, y);
                     },
                     "chosen default (" + svgf("%g", result.spec.psnrThreshold) + " dB)"});
  entries.push_back({[](double x, double y) {
                       return svgf(
                           "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"8\" fill=\"none\" stroke=\"black\" "
                           "stroke-width=\"1.5\" stroke-dasharray=\"3 2\"/>",
                           x, y);
                     },
                     "fastest at " + svgf("%g", result.spec.psnrHighThreshold) + " dB on every dataset"});
  entries.push_back({nullptr, "filled = on its variant's Pareto front (line)"});
  entries.push_back({nullptr, "labels = step in voxels (slicing, B=32)"});
  std::vector<std::pair<double, int>> places;  // x and row of each entry
  double kx = 20;
  int row = 0;
  for (const KeyEntry& e : entries) {
    const double w = (e.marker ? 30 : 14) + 6.2 * double(e.text.size());
    if (kx > 20 && kx + w > width - 10) kx = 20, ++row;
    places.push_back({kx, row});
    kx += w;
  }
  size_t variants = 1;
  for (const Dataset& d : result.spec.datasets) {
    std::vector<Variant> seen;
    for (const Point& p : result.points)
      if (p.dataset == d.name && std::find(seen.begin(), seen.end(), p.variant) == seen.end())
        seen.push_back(p.variant);
    variants = std::max(variants, seen.size());
  }
  const double keyTop = kPanelHeight + 16 * double(variants) + 34;
  const double height = keyTop + 18 * double(row + 1) + 4;

  std::ostringstream svg;
  svg << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  svg << svgf("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" viewBox=\"0 0 %.0f %.0f\" ",
              width, height, width, height)
      << "font-family=\"sans-serif\">\n";
  svg << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg << "<title>voxbrick bench: time against error, " << escape(result.device) << "</title>\n";
  for (size_t i = 0; i < result.spec.datasets.size(); ++i)
    panel(svg, result, result.spec.datasets[i], kPanelWidth * double(i));
  for (size_t i = 0; i < entries.size(); ++i) {
    const double x = places[i].first, y = keyTop + 18 * double(places[i].second);
    if (entries[i].marker) svg << entries[i].marker(x, y - 4) << "\n";
    svg << svgf("<text x=\"%.1f\" y=\"%.1f\" font-size=\"11\">", entries[i].marker ? x + 10 : x, y)
        << escape(entries[i].text) << "</text>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace voxbrick::quality
