// The time-budget planner of interactive frames and the bilinear scale-up.
#include "render/core/Interactive.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>

namespace voxbrick::render {

const std::vector<InteractiveRung>& interactiveLadder() {
  // Each rung is cheaper than the one before in at least one factor and no dearer in any. The order is the one
  // measured on the MRI at 512² (bench_interactive): a step 1.5 and 2 times longer
  // costs the fewest dB for the time it saves (44 dB at 0.7 of the time), then the drawing size (which also coarsens
  // the level of detail, given in pixels of the smaller drawing). The bottom, where a crowd's frames end up, is the
  // Pareto front of bench/run_ladder_bottom.sh (the MRI at 1024² and 512², a 512³ field at 1024²;
  // bench/results/interactive/ladder-bottom-*.md): smaller drawings and longer steps only. A coarser level of detail
  // of its own never paid there: on the MRI at 1024² a drawing of 0.125 at step 6 took 12.4 ms and 22.5 dB at lod 4,
  // 12.4 ms and 25.7 dB at lod 1; on the field, 16.4 ms and 32 dB against 13.1 ms and 57 dB. Below about 0.125 of
  // the sides the time is mostly the frame's fixed cost (planning, read-back, the scale-up); a smaller scene's rungs
  // there meet the 64-pixel floor and are the same drawing.
  static const std::vector<InteractiveRung> kLadder = {
      {1, 1, 1},     {1, 1.5, 1},  {1, 2, 1},   {0.75, 2, 1}, {0.6, 2, 1},   {0.5, 2, 1},
      {0.42, 2, 1},  {0.35, 2, 1}, {0.35, 3, 1}, {0.3, 3, 1},  {0.25, 3, 1},  {0.25, 4, 1},
      {0.18, 4, 1},  {0.125, 4, 1}, {0.125, 6, 1}, {0.09, 6, 1}, {0.0625, 6, 1},
  };
  return kLadder;
}

nlohmann::json InteractiveChoice::toJson() const {
  return {{"budget_ms", budgetMs},
          {"predicted_ms", predictedMs},
          {"rate_samples_per_ms", rate},
          {"scale", scale},
          {"scale_wanted", wantedScale},
          {"width", width},
          {"height", height},
          {"lod", lod},
          {"step", step},
          {"rung", rung},
          {"samples_estimated", samples}};
}

namespace {

/// `scale`, raised where it would take the shorter side below kMinInteractiveSide (both sides by one factor, so that
/// the drawing keeps the scene's aspect: its camera then sees what the scene's does), at most 1.
double reducedScale(const Scene& scene, double scale) {
  const int shorter = std::max(1, std::min(scene.width, scene.height));
  return std::clamp(scale, std::min(1.0, double(kMinInteractiveSide) / shorter), 1.0);
}

/// `choice` (made with a rate, rungs capped at `maxScale`) with its wantedScale: the scale of the first rung that
/// fits without the cap. A rung the cap leaves alone is the same drawing either way, so where the chosen one is such
/// a rung the answer is the choice's own. Otherwise it lies between the chosen rung (its drawing uncapped is dearer
/// than the capped one) and the first rung after it that the cap leaves alone (the same drawing as its capped one,
/// which is no dearer than the chosen one): found by bisection there; the last rung where none fits.
InteractiveChoice withWantedScale(const Scene& scene, const SampleEstimate& estimate, double maxScale,
                                  InteractiveChoice choice) {
  const auto& ladder = interactiveLadder();
  auto capped = [&](size_t i) { return reducedScale(scene, ladder[i].scale) > maxScale; };
  const size_t chosen = size_t(choice.rung);
  choice.wantedScale = choice.scale;
  if (!capped(chosen)) return choice;
  size_t alone = chosen + 1;
  while (alone < ladder.size() && capped(alone)) ++alone;
  auto fits = [&](size_t i) {
    return choice.fixedMs + std::max(estimate(interactiveScene(scene, ladder[i])), 0.0) / choice.rate <=
           choice.budgetMs;
  };
  // hi fits, or is the ladder's end; lo, from the second step on, does not.
  size_t lo = chosen, hi = alone;
  if (fits(chosen)) {
    hi = chosen;
  } else {
    while (hi - lo > 1) {
      const size_t mid = (lo + hi) / 2;
      (fits(mid) ? hi : lo) = mid;
    }
  }
  choice.wantedScale = double(interactiveScene(scene, ladder[std::min(hi, ladder.size() - 1)]).width) / scene.width;
  return choice;
}

}  // namespace

int scaledSide(int side, double scale) { return std::max(1, int(std::lround(side * scale))); }

Scene interactiveScene(const Scene& scene, const InteractiveRung& rung, double maxScale) {
  Scene s = scene;
  s.interactive = false;
  const double scale = reducedScale(scene, std::min(rung.scale, maxScale));
  s.width = scaledSide(scene.width, scale);
  s.height = scaledSide(scene.height, scale);
  s.step = std::min(scene.step * rung.stepFactor, 64.0);
  if (rung.lodFactor > 1)
    s.lod = std::min(scene.lod > 0 ? scene.lod * rung.lodFactor : rung.lodFactor - 1, Scene::kMaxLod);
  // Drawn smaller only because the frame is returned smaller (a video stream's size): the level of detail of the
  // scene's size, where the frame is shown. The drawing's own pixels would pick a level too coarse for it: 2.4 dB
  // less on the MRI at a quarter of 1024² (bench/results/video/stream-drawing.md).
  if (maxScale < rung.scale) s.lod *= scale;
  return s;
}

InteractiveChoice chooseInteractive(const Scene& scene, double rate, double fixedMs, const SampleEstimate& estimate,
                                    double maxScale) {
  const auto& ladder = interactiveLadder();
  // Each drawing estimated once (an estimate plans the frame, brick by brick): rungs capped at maxScale draw the same
  // scene where they differ only in size, the bisection's last rung was estimated on its way, and the wanted scale
  // asks again about rungs the choice tried.
  // (Rung scenes differ from one another only in these.)
  using Drawing = std::tuple<int, int, double, double>;  // width, height, step, lod
  std::vector<std::pair<Drawing, double>> known;
  const SampleEstimate once = [&](const Scene& s) {
    const Drawing drawing{s.width, s.height, s.step, s.lod};
    for (const auto& [seen, samples] : known)
      if (seen == drawing) return samples;
    known.emplace_back(drawing, estimate(s));
    return known.back().second;
  };
  InteractiveChoice choice;
  choice.budgetMs = scene.timeBudgetMs;
  choice.rate = rate > 0 && std::isfinite(rate) ? rate : 0;
  choice.fixedMs = choice.rate > 0 && fixedMs > 0 && std::isfinite(fixedMs) ? fixedMs : 0;
  auto take = [&](size_t i) {
    const Scene s = interactiveScene(scene, ladder[i], maxScale);
    choice.rung = int(i);
    choice.samples = std::max(once(s), 0.0);
    choice.predictedMs = choice.rate > 0 ? choice.fixedMs + choice.samples / choice.rate : 0;
    choice.width = s.width;
    choice.height = s.height;
    choice.scale = double(s.width) / scene.width;
    choice.lod = s.lod;
    choice.step = s.step;
    return choice.rate > 0 && choice.predictedMs <= choice.budgetMs;
  };
  // Without a rate the cheapest rung is drawn: its time measures the device for the next frame.
  if (choice.rate <= 0) {
    take(ladder.size() - 1);
    return choice;
  }
  if (take(0)) return withWantedScale(scene, once, maxScale, choice);
  // Each rung costs no more than the one before (capping their sizes at maxScale keeps that): the first that fits,
  // by bisection (a plan per step, a handful for the whole ladder, so that planning a large volume stays a small
  // part of the budget). lo does not fit.
  size_t lo = 0, hi = ladder.size() - 1;
  if (!take(hi)) return withWantedScale(scene, once, maxScale, choice);
  while (hi - lo > 1) {
    const size_t mid = (lo + hi) / 2;
    (take(mid) ? hi : lo) = mid;
  }
  take(hi);
  return withWantedScale(scene, once, maxScale, choice);
}

void RateGauge::add(double samples, double ms) {
  if (!(samples > 0 && ms > 0) || !std::isfinite(samples) || !std::isfinite(ms)) return;
  if (mFrames.size() == kFrames) mFrames.erase(mFrames.begin());
  mFrames.emplace_back(samples, ms);
  fit();
}

void RateGauge::fit() {
  const double n = double(mFrames.size());
  double sumS = 0, sumMs = 0, lo = mFrames.front().first, hi = lo;
  for (const auto& [s, ms] : mFrames) sumS += s, sumMs += ms, lo = std::min(lo, s), hi = std::max(hi, s);
  mRate = sumS / sumMs;
  mFixedMs = 0;
  if (mFrames.size() < 3 || hi < 1.5 * lo) return;
  const double meanS = sumS / n, meanMs = sumMs / n;
  double cov = 0, var = 0;
  for (const auto& [s, ms] : mFrames) cov += (s - meanS) * (ms - meanMs), var += (s - meanS) * (s - meanS);
  // A noisy frame can tilt the line into a large fixed time that would make every drawing look too dear: the fixed
  // time is held to half the quickest frame's, and the rate is then that of the rest of the time.
  double quickest = mFrames.front().second;
  for (const auto& frame : mFrames) quickest = std::min(quickest, frame.second);
  const double slope = cov / var, fixed = std::min(meanMs - slope * meanS, 0.5 * quickest);
  if (slope > 0 && fixed > 0) mRate = sumS / (sumMs - n * fixed), mFixedMs = fixed;
}

image::ImageF scaleBilinear(const image::ImageF& image, int width, int height) {
  if (image.width == width && image.height == height) return image;
  image::ImageF out;
  out.width = width;
  out.height = height;
  out.rgba.resize(size_t(width) * size_t(height) * 4);
  const double sx = double(image.width) / width, sy = double(image.height) / height;
  for (int y = 0; y < height; ++y) {
    const double fy = std::clamp((y + 0.5) * sy - 0.5, 0.0, double(image.height - 1));
    const int y0 = int(fy), y1 = std::min(y0 + 1, image.height - 1);
    const float ty = float(fy - y0);
    for (int x = 0; x < width; ++x) {
      const double fx = std::clamp((x + 0.5) * sx - 0.5, 0.0, double(image.width - 1));
      const int x0 = int(fx), x1 = std::min(x0 + 1, image.width - 1);
      const float tx = float(fx - x0);
      const float *a = image.pixel(x0, y0), *b = image.pixel(x1, y0), *c = image.pixel(x0, y1),
                  *d = image.pixel(x1, y1);
      float* o = out.pixel(x, y);
      for (int k = 0; k < 4; ++k) o[k] = (1 - ty) * ((1 - tx) * a[k] + tx * b[k]) + ty * ((1 - tx) * c[k] + tx * d[k]);
    }
  }
  return out;
}

}  // namespace voxbrick::render
