// Quality by target: a dataset's table of measured settings (time and worst-view error against the reference, as
// `voxbrick bench --calibrate` measures them and writes them beside the data) and the rule that picks the setting a
// target asks for: "psnr:40", the fastest setting whose worst view reaches 40 dB; "ms:200", the most accurate one
// whose median frame takes at most 200 ms. GL-free.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace voxbrick::render {

struct Scene;
struct GridTechnique;

/// A target a user asks for instead of drawing settings.
struct QualityTarget {
  enum class Kind { Psnr, Ms };
  static constexpr double kMinPsnr = 10, kMaxPsnr = 100;   ///< dB
  static constexpr double kMinMs = 1, kMaxMs = 3'600'000;  ///< milliseconds
  Kind kind = Kind::Psnr;
  double value = 40;

  /// "psnr:40" (dB, in [10, 100]) or "ms:200" (milliseconds, in [1, 3600000]); throws RenderInputError naming
  /// `what` and the accepted forms otherwise.
  static QualityTarget parse(const std::string& text, const std::string& what);
  /// The form parse() reads.
  std::string text() const;
  bool operator==(const QualityTarget&) const = default;
};

/// The drawing settings a target chooses among: the Scene fields of the same names.
struct QualitySetting {
  double step = 0.75;
  bool raycast = true;
  int slab = 0;
  double ert = 0;
  bool preIntegration = false;
  int subBlock = 0;
  double lod = 0;

  /// Sets the scene's fields of the same names (all of them a grid technique's).
  void applyTo(GridTechnique& technique) const;
  /// E.g. "step 0.75, raycast, ert 0.999, sub-block 8, lod 1".
  std::string label() const;
  bool operator==(const QualitySetting&) const = default;
};

/// One measured setting of one transfer function (and shading) on the dataset.
struct QualityEntry {
  std::string transferFunction;  ///< preset name
  bool shading = false;
  QualitySetting setting;
  double msMedian = 0;  ///< median frame time over the views, at the table's image size
  double psnrMin = 0;   ///< the worst view's PSNR against the reference (dB)
};

/// What a target resolved to, and what to expect of it.
struct QualityChoice {
  QualityTarget target;
  QualitySetting setting;
  double expectedPsnr = 0;  ///< the worst view measured with this setting (dB)
  double expectedMs = 0;    ///< its median time scaled to the scene's pixel count
  bool met = false;         ///< false: no setting meets the target; this is the closest (most accurate, or fastest)
  std::string basis;  ///< which entries were used, e.g. "mri, unshaded" or "the worst over every transfer function"

  /// {"target", "setting", "expected_psnr", "expected_ms", "met", "basis"}.
  nlohmann::json toJson() const;
};

/// A dataset's table (quality.json): the measured settings and how they were measured.
struct QualityTable {
  static constexpr int kFormatVersion = 1;
  std::string device;         ///< the GL renderer the times were measured on
  int width = 0, height = 0;  ///< image size of the measurements
  int views = 0;              ///< views per setting (an orbit; the worst is kept)
  std::vector<QualityEntry> entries;

  std::string toJson() const;
  /// Throws RenderInputError naming `what` and the bad key.
  static QualityTable fromJson(const std::string& text, const std::string& what);

  /// Where a dataset's table lives: DIR/quality.json for a store directory, FILE.quality.json beside a file.
  static std::filesystem::path pathFor(const std::filesystem::path& dataset);
  /// The table of the dataset at `dataset` if it has one; throws RenderInputError if it has a malformed one.
  static std::optional<QualityTable> load(const std::filesystem::path& dataset);
  /// Writes the table where pathFor() says, atomically; throws RenderInputError naming the file on failure.
  void save(const std::filesystem::path& dataset) const;

  /// Margins a setting must keep beyond the target, as views and machines the table did not measure vary: its worst
  /// measured view at least kPsnrMargin dB above a PSNR target, its expected time at most kTimeMargin of a time one.
  static constexpr double kPsnrMargin = 1, kTimeMargin = 0.9;

  /// The setting `target` asks for with `scene` (its transfer function by name and its shading; if the table has
  /// no entry for them, each setting counts with its worst PSNR and longest time over every entry; times scale with
  /// the scene's pixel count against the table's). psnr:X: the fastest setting with worst view >= X + kPsnrMargin,
  /// else the most accurate. ms:N: the most accurate setting expected within kTimeMargin * N ms, else the fastest.
  /// Ties go to the faster.
  /// Throws RenderInputError if the table is empty.
  QualityChoice choose(const QualityTarget& target, const Scene& scene) const;
};

}  // namespace voxbrick::render
