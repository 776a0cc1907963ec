// Frames on a time budget (Scene::interactive): the ladder of cheaper drawings an interactive frame chooses from,
// the choice by predicted cost (the frame plan's sample estimate over the rate the device has shown), the rate
// itself, and the bilinear scale-up of a reduced drawing to the requested size. GL-free: the server, the engine and
// `voxbrick orbit --interactive` plan with the same code.
#pragma once

#include <functional>
#include <vector>

#include <nlohmann/json.hpp>

#include "image/Image.h"
#include "render/core/Scene.h"

namespace voxbrick::render {

/// One way of drawing a frame more cheaply than its scene asks: the drawing size as a fraction of the requested
/// sides, and factors on the scene's step and level of detail (pixels).
struct InteractiveRung {
  double scale = 1;
  double stepFactor = 1;
  double lodFactor = 1;
};

/// The rungs, from the exact drawing down, each cheaper than the one before, in the order that loses the least
/// PSNR per ms saved on the MRI (as bench_interactive measures it): the step first, then the drawing size (the
/// rungs' level-of-detail factor is 1: a coarser level measured dominated at every size tried).
const std::vector<InteractiveRung>& interactiveLadder();

/// The shortest side a reduced drawing keeps, in pixels (a requested image smaller than this is never reduced).
inline constexpr int kMinInteractiveSide = 64;

/// What an interactive frame chose and why.
struct InteractiveChoice {
  double budgetMs = 0;        ///< Scene::timeBudgetMs
  double rate = 0;            ///< estimated samples per ms it was predicted with; 0: none known (the cheapest rung)
  double fixedMs = 0;         ///< the time a frame takes whatever its samples, predicted with
  double samples = 0;         ///< the estimate of the chosen drawing
  double predictedMs = 0;     ///< fixedMs + samples / rate (0 when no rate is known)
  int rung = 0;               ///< index into interactiveLadder()
  double scale = 1;           ///< drawn width / requested width
  /// The scale the ladder would draw at were the frame not returned smaller (chooseInteractive's `maxScale`): the
  /// first rung that fits without the cap, as a fraction of the requested width. `scale` where the cap did not bind;
  /// 0 where no rate is known. What a video stream sent smaller may follow the drawing down by (server/VideoStream.h).
  double wantedScale = 0;
  int width = 0, height = 0;  ///< the drawing's size
  double lod = 0, step = 0;   ///< the drawing's Scene::lod and Scene::step

  /// {"budget_ms", "predicted_ms", "rate_samples_per_ms", "fixed_ms", "scale", "scale_wanted", "width", "height",
  /// "lod", "step", "rung", "samples_estimated"}.
  nlohmann::json toJson() const;
};

/// A side of `side` pixels at `scale` of it: rounded, at least 1. The size an interactive frame is returned at
/// (FrameOptions::outputScale) and a video stream is sent at (server/VideoStream.h) alike.
int scaledSide(int side, double scale);

/// The scene an interactive frame of `scene` draws at `rung`: its sides times the smaller of rung.scale and
/// `maxScale`, a factor raised as far as the shorter side needs to keep kMinInteractiveSide pixels (or its own, if
/// fewer), so that the drawing keeps the scene's aspect; its step and level of detail times the rung's factors (a
/// scene with lod 0 gets lod = lodFactor - 1 beyond the first factor, 0 otherwise); interactive off. A rung capped
/// by `maxScale` keeps the level of detail of the scene's size (its lod times the drawing's scale).
Scene interactiveScene(const Scene& scene, const InteractiveRung& rung, double maxScale = 1);

/// The estimated samples of drawing a scene (FramePlan::estimatedSamples for grids, the mesh's cost model for
/// meshes).
using SampleEstimate = std::function<double(const Scene&)>;

/// The first rung of interactiveLadder() whose predicted time, fixedMs + estimate / rate, is within
/// scene.timeBudgetMs; the last rung when none is, or when `rate` is 0 (no frame measured yet: the cheapest drawing
/// measures the device). Found by bisection, since every rung costs no more than the one before (about log2 of the
/// ladder's length estimates). Deterministic: the same scene, rate and estimates give the same choice. `maxScale`:
/// no rung draws more than this fraction of the scene's sides (interactiveScene), a frame that is returned smaller
/// than its scene (FrameOptions::outputScale). Where the chosen rung was capped, the rungs from it to the first the cap
/// leaves alone are estimated again without the cap, for InteractiveChoice::wantedScale (a few more estimates). No
/// drawing is estimated twice in one choice (rungs the cap makes the same drawing share one estimate).
InteractiveChoice chooseInteractive(const Scene& scene, double rate, double fixedMs, const SampleEstimate& estimate,
                                    double maxScale = 1);

/// What this device has shown: a frame of s estimated samples takes fixedMs() + s / rate() ms, fitted by least
/// squares to the last kFrames frames added (a line through their (samples, ms), its fixed time at most half the
/// quickest frame's and the rate that of the rest; with too little spread in samples, or a fit that is not a rising
/// line above 0, the ratio of their sums and no fixed time). Not thread-safe.
class RateGauge {
 public:
  static constexpr size_t kFrames = 8;
  /// Adds a frame of `samples` estimated samples that took `ms`; frames of no samples or no time are ignored.
  void add(double samples, double ms);
  /// Samples per ms of the time that grows with the samples; 0 before any frame.
  double rate() const { return mRate; }
  /// The time a frame takes besides its samples, ms.
  double fixedMs() const { return mFixedMs; }

 private:
  void fit();
  std::vector<std::pair<double, double>> mFrames;  // (samples, ms), oldest first
  double mRate = 0, mFixedMs = 0;
};

/// `image` resampled bilinearly (pixel centres aligned, edges clamped) to width x height; the same image when the
/// size is already that.
image::ImageF scaleBilinear(const image::ImageF& image, int width, int height);

}  // namespace voxbrick::render
