// Piecewise-linear transfer functions: JSON parsing, presets, GPU tables, O(1) range tests, opacity correction.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace voxbrick::render {

/// Colour (straight, not premultiplied) and opacity per reference length over normalised values in [0, 1].
///
/// JSON: {"points": [[x, r, g, b, a], ...], "reference_length": L, "name": "...", "description": "..."}; only
/// "points" is required. x is non-decreasing (two points at the same x make a step: the value there is the later
/// point's), every number is in [0, 1]. Outside [first x, last x] the function is constant (the first or last point).
class TransferFunction {
 public:
  struct Point {
    double x = 0;
    glm::dvec4 rgba{0.0};
  };

  /// Bins of the range test: contributes() is exact up to this resolution of the normalised range.
  static constexpr int kRangeBins = 4096;

  /// Builds from control points; throws RenderInputError (naming the point index and the problem) on the rules
  /// above, or for a reference length that is not finite and positive.
  explicit TransferFunction(std::vector<Point> points, std::optional<double> referenceLength = std::nullopt);

  /// Parses the JSON text; throws RenderInputError naming `what`, and the point index or key, for any violation.
  static TransferFunction parse(const std::string& json, const std::string& what);
  /// Reads a file when `nameOrPath` contains '/' or ends in ".json"; otherwise loads the preset <name> (letters,
  /// digits, '-', '_'): configDirectory()/tf/<name>.json if that file exists, else the built-in preset of that name
  /// (BuiltInPresets.h). Throws RenderInputError for a missing or unreadable file, an unknown name (listing the
  /// presets) and bad content.
  static TransferFunction load(const std::string& nameOrPath);
  /// Whether `name` is a preset name: non-empty, letters, digits, '-' and '_' only.
  static bool isPresetName(const std::string& name);
  /// Where configuration lives: $VOXBRICK_CONFIG_DIR if set and non-empty; else "config" beside the directory holding
  /// the running executable (build/voxbrick -> config/), if that is a directory; else "share/voxbrick" there (an
  /// installed PREFIX/bin/voxbrick -> PREFIX/share/voxbrick), if that is one; else "./config".
  static std::filesystem::path configDirectory();
  /// Names of the presets load() resolves: the built-in ones and those in configDirectory()/tf, sorted, once each.
  static std::vector<std::string> presetNames();
  /// Names of the presets in `directory` (files <name>.json with a preset name), sorted; empty if it is missing.
  static std::vector<std::string> presetNames(const std::filesystem::path& directory);

  /// Straight RGB and alpha at normalised value x (NaN reads as 0).
  glm::dvec4 evaluate(double x) const;
  /// n samples at i / (n - 1), both ends included, for a GPU 1D texture read at (x (n - 1) + 0.5) / n, so that a
  /// lookup is exact at 0 and 1 and linear in between (no half-texel clamp at the ends: a value at the window's
  /// low end gets exactly tf(0), transparent where the function is); throws RenderInputError for n < 1.
  std::vector<glm::vec4> table(int n) const;
  /// The length the alphas are given for, if the JSON set one (the renderer's default: the smallest level-0
  /// spacing).
  std::optional<double> referenceLength() const { return mReferenceLength; }
  const std::vector<Point>& points() const { return mPoints; }

  /// True iff some value in [lo, hi] (normalised, clamped to [0, 1], either order; NaN gives true) may have alpha
  /// > 0. O(1): two lookups into per-bin maxima that are exact for the piecewise-linear function, so narrow spikes
  /// are never missed. Conservative: it may say true for a range that only shares one of kRangeBins bins with
  /// opacity, never false for a range with opacity.
  bool contributes(double lo, double hi) const;
  /// The same test for what the GPU reads from table(n): a filtered lookup at x reads entries floor(x (n - 1)) and
  /// ceil(x (n - 1)), so the range covers the entries [lo, hi] can read, with a margin for the GPU's float
  /// arithmetic, except at 0 and 1, which read one entry exactly (background at the window's low end is skipped
  /// when tf(0) is transparent). lo <= hi, normalised (clamped to [0, 1]); NaN gives true.
  bool tableContributes(double lo, double hi, int n) const;

  /// The largest alpha of a value in [lo, hi] (normalised, clamped to [0, 1], either order; NaN reads as 0): the
  /// larger end, or a control point between them. O(points).
  double maxAlpha(double lo, double hi) const;

  /// Opacity for a step of stepOverReference reference lengths: 1 - (1 - alpha)^stepOverReference, accurate for
  /// alpha near 0 or 1. alpha is clamped to [0, 1]; alpha 0 gives 0, alpha 1 gives 1 for any step > 0; a step
  /// <= 0 (or NaN input) gives 0.
  static double correctOpacity(double alpha, double stepOverReference);

 private:
  std::vector<Point> mPoints;
  std::optional<double> mReferenceLength;
  std::vector<int> mOpaqueBinsBefore;  // [b]: bins below b whose max alpha is > 0; kRangeBins + 1 entries
};

}  // namespace voxbrick::render
