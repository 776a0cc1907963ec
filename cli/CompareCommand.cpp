// `voxbrick compare A.png B.png`: the optical model's image error (RMSE, PSNR, max |diff| on RGB in [0, 1]).
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "cli/Commands.h"
#include "image/Image.h"
#include "image/ImageFile.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::cli {
namespace {

struct CompareArgs {
  std::string a, b, heatmap;
  double heatmapScale = 0;
  bool json = false;
};

void runCompare(const CompareArgs& args) {
  const image::ImageF a = image::toImageF(image::readImage(args.a));
  const image::ImageF b = image::toImageF(image::readImage(args.b));
  const image::ImageError e = image::compareImages(a, b);
  // By default the heat map spans the largest difference, so that any difference is visible.
  const double scale = args.heatmapScale > 0 ? args.heatmapScale : (e.maxAbs > 0 ? e.maxAbs : 1.0);
  if (!args.heatmap.empty()) image::writeImage(args.heatmap, image::toImage8(image::differenceHeatmap(a, b, scale)));
  if (args.json) {
    nlohmann::json j = {{"a", args.a},    {"b", args.b},         {"width", a.width},          {"height", a.height},
                        {"rmse", e.rmse}, {"max_abs", e.maxAbs}, {"identical", e.maxAbs == 0}};
    // JSON has no infinity: identical images have "psnr": null.
    j["psnr"] = std::isfinite(e.psnr) ? nlohmann::json(e.psnr) : nlohmann::json(nullptr);
    if (!args.heatmap.empty()) j["heatmap"] = {{"file", args.heatmap}, {"scale", scale}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  char psnr[32] = "inf";
  if (std::isfinite(e.psnr)) std::snprintf(psnr, sizeof(psnr), "%.2f", e.psnr);
  std::printf("compare: %dx%d  rmse %.6g  psnr %s dB  max_abs %.6g\n", a.width, a.height, e.rmse, psnr, e.maxAbs);
  if (!args.heatmap.empty()) std::printf("compare: wrote %s (white = |diff| >= %.6g)\n", args.heatmap.c_str(), scale);
}

}  // namespace

void addCompareCommand(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd =
      app.add_subcommand("compare", "Image error between two PNGs: RMSE, PSNR, max |diff| on RGB in [0, 1]");
  cmd->add_option("a", args->a, "first image (PNG or JPEG)")->required();
  cmd->add_option("b", args->b, "second PNG (same size)")->required();
  cmd->add_option("--heatmap", args->heatmap, "write a PNG of where the images differ (per-pixel max |diff|)");
  cmd->add_option("--heatmap-scale", args->heatmapScale,
                  "the difference shown as white in the heat map (default: the largest difference)")
      ->check(between(1e-6, 1));
  cmd->add_flag("--json", args->json, "print one JSON object instead of a line");
  cmd->callback([args] { runCompare(*args); });
}

}  // namespace voxbrick::cli
