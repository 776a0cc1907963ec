// The Pareto front and the settings chosen from a sweep's points.
#include "quality/SettingChoice.h"

#include <algorithm>
#include <functional>
#include <limits>
#include <map>

namespace voxbrick::quality {

void markPareto(std::vector<Point>& points) {
  for (Point& p : points) {
    p.pareto = std::none_of(points.begin(), points.end(), [&](const Point& q) {
      return q.dataset == p.dataset && q.variant == p.variant && q.msMedian <= p.msMedian && q.psnrMin >= p.psnrMin &&
             (q.msMedian < p.msMedian || q.psnrMin > p.psnrMin);
    });
  }
}

std::optional<Setting> chooseDefault(const std::vector<Point>& points, const std::vector<Dataset>& datasets,
                                     double psnrThreshold) {
  std::optional<Setting> best;
  double bestCost = std::numeric_limits<double>::infinity();
  for (const Point& candidate : points) {
    double cost = 0;
    for (const Dataset& d : datasets) {
      const auto p = std::find_if(points.begin(), points.end(), [&](const Point& q) {
        return q.dataset == d.name && q.setting == candidate.setting && q.variant == defaultVariant(d);
      });
      cost += p != points.end() && p->psnrMin >= psnrThreshold ? p->msMedian : std::numeric_limits<double>::infinity();
    }
    if (cost < bestCost) {
      best = candidate.setting;
      bestCost = cost;
    }
  }
  return best;
}

std::optional<int> bestSlabSize(const std::vector<Point>& points, int exclude) {
  // Per slab size, the (dataset, variant, step) it was measured at and its median time there.
  std::map<int, std::map<std::string, double>> times;
  for (const Point& p : points) {
    const Setting& s = p.setting;
    if (s.slab <= 0 || s.raycast || s.slab == exclude || s.ert > 0 || s.preIntegration || s.brick != 32 || !s.skip ||
        s.slicer != render::Slicer::Vertex)
      continue;
    times[s.slab][p.dataset + "\n" + p.variant.label() + "\n" + stepText(s.step)] = p.msMedian;
  }
  std::map<std::string, size_t> sizesAt;  // how many sizes were measured at each (dataset, variant, step)
  for (const auto& [slab, where] : times)
    for (const auto& [key, ms] : where) ++sizesAt[key];
  if (std::none_of(sizesAt.begin(), sizesAt.end(), [&](const auto& at) { return at.second == times.size(); }))
    return std::nullopt;
  std::optional<int> best;
  double bestTotal = std::numeric_limits<double>::infinity();
  for (const auto& [slab, where] : times) {
    double total = 0;
    for (const auto& [key, ms] : where)
      if (sizesAt[key] == times.size()) total += ms;
    if (total < bestTotal) best = slab, bestTotal = total;
  }
  return best;
}

namespace {

/// bestErt's rule over the points whose setting is `plain` (one renderer, without pre-integration).
std::optional<double> lowestKeepingErt(const std::vector<Point>& points,
                                       const std::function<bool(const Setting&)>& plain, double toleranceDb,
                                       double highThreshold) {
  std::map<double, bool> keeps;  // threshold -> keeps the accuracy everywhere
  for (const Point& p : points) {
    if (!plain(p.setting) || p.setting.ert <= 0) continue;
    bool& ok = keeps.try_emplace(p.setting.ert, true).first->second;
    const auto off = std::find_if(points.begin(), points.end(), [&](const Point& q) {
      return q.dataset == p.dataset && q.variant == p.variant && plain(q.setting) && q.setting.ert == 0 &&
             q.setting.step == p.setting.step;
    });
    if (off != points.end() && p.psnrMin < std::min(off->psnrMin - toleranceDb, highThreshold)) ok = false;
  }
  for (const auto& [ert, ok] : keeps)
    if (ok) return ert;
  if (keeps.empty()) return std::nullopt;
  return keeps.rbegin()->first;
}

}  // namespace

std::optional<double> bestErt(const std::vector<Point>& points, int slab, double toleranceDb, double highThreshold) {
  return lowestKeepingErt(
      points,
      [&](const Setting& s) {
        return s.slab == slab && !s.raycast && !s.preIntegration && s.brick == 32 && s.skip &&
               s.slicer == render::Slicer::Vertex;
      },
      toleranceDb, highThreshold);
}

std::optional<double> bestRayCastErt(const std::vector<Point>& points, double toleranceDb, double highThreshold) {
  return lowestKeepingErt(
      points,
      [](const Setting& s) {
        return s.raycast && !s.preIntegration && s.brick == 32 && s.skip && s.slicer == render::Slicer::Vertex;
      },
      toleranceDb, highThreshold);
}

std::optional<Point> fastestPoint(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                  double psnrThreshold) {
  std::optional<Point> best;
  for (const Point& p : points)
    if (p.dataset == dataset && p.variant == variant && p.psnrMin >= psnrThreshold &&
        (!best || p.msMedian < best->msMedian))
      best = p;
  return best;
}

std::optional<double> coarsestStep(const std::vector<Point>& points, const std::string& dataset, const Variant& variant,
                                   double psnrThreshold) {
  std::optional<double> step;
  for (const Point& p : points)
    if (p.dataset == dataset && p.variant == variant && p.setting == Setting{p.setting.step} &&
        p.psnrMin >= psnrThreshold && (!step || p.setting.step > *step))
      step = p.setting.step;
  return step;
}

}  // namespace voxbrick::quality
