// Transfer functions: validation, JSON and preset loading, evaluation, the per-bin opacity index.
#include "render/core/TransferFunction.h"

#include "common/Names.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <utility>

#include <nlohmann/json.hpp>

#include "render/core/BuiltInPresets.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

using nlohmann::json;

constexpr const char* kComponentNames[5] = {"x", "r", "g", "b", "a"};

void checkPoints(const std::vector<TransferFunction::Point>& points, std::optional<double> referenceLength,
                 const std::string& what) {
  if (points.empty()) throw RenderInputError(what + ": 'points' is empty; a transfer function needs at least one");
  for (size_t i = 0; i < points.size(); ++i) {
    const TransferFunction::Point& p = points[i];
    std::string where = what + ": points[" + std::to_string(i) + "]";
    double values[5] = {p.x, p.rgba.r, p.rgba.g, p.rgba.b, p.rgba.a};
    for (int c = 0; c < 5; ++c)
      if (!(values[c] >= 0 && values[c] <= 1))
        throw RenderInputError(where + ": " + kComponentNames[c] + " = " + numberText(values[c]) +
                               " is outside [0, 1]");
    if (i > 0 && p.x < points[i - 1].x)
      throw RenderInputError(where + ": x = " + numberText(p.x) + " is less than the previous point's x = " +
                             numberText(points[i - 1].x) + " (x must be non-decreasing)");
  }
  if (referenceLength && (!(*referenceLength > 0) || !std::isfinite(*referenceLength)))
    throw RenderInputError(what + ": reference_length = " + numberText(*referenceLength) +
                           " is not finite and positive");
}

}  // namespace

TransferFunction::TransferFunction(std::vector<Point> points, std::optional<double> referenceLength)
    : mPoints(std::move(points)), mReferenceLength(referenceLength) {
  checkPoints(mPoints, mReferenceLength, "TransferFunction");
  // Between control points alpha is linear, so its maximum over a closed bin is at the bin's ends or at a control
  // point inside it; a point exactly on a bin boundary belongs to both bins (it may be the left limit of a step).
  std::vector<double> binMax(kRangeBins);
  for (int b = 0; b < kRangeBins; ++b)
    binMax[static_cast<size_t>(b)] =
        std::max(evaluate(static_cast<double>(b) / kRangeBins).a, evaluate(static_cast<double>(b + 1) / kRangeBins).a);
  for (const Point& p : mPoints) {
    double s = p.x * kRangeBins;
    int first = std::max(static_cast<int>(std::ceil(s)) - 1, 0);
    int last = std::min(static_cast<int>(std::floor(s)), kRangeBins - 1);
    for (int b = first; b <= last; ++b)
      binMax[static_cast<size_t>(b)] = std::max(binMax[static_cast<size_t>(b)], p.rgba.a);
  }
  mOpaqueBinsBefore.assign(kRangeBins + 1, 0);
  for (size_t b = 0; b < binMax.size(); ++b) mOpaqueBinsBefore[b + 1] = mOpaqueBinsBefore[b] + (binMax[b] > 0 ? 1 : 0);
}

TransferFunction TransferFunction::parse(const std::string& text, const std::string& what) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw RenderInputError(what + ": not valid JSON: " + e.what());
  }
  if (!j.is_object()) throw RenderInputError(what + ": expected a JSON object with key 'points'");
  for (const auto& [key, value] : j.items()) {
    if (key == "name" || key == "description") {
      if (!value.is_string()) throw RenderInputError(what + ": key '" + key + "' is not a string");
    } else if (key != "points" && key != "reference_length") {
      throw RenderInputError(what + ": unknown key '" + key +
                             "' (expected points, reference_length, name, description)");
    }
  }
  auto it = j.find("points");
  if (it == j.end()) throw RenderInputError(what + ": missing key 'points'");
  if (!it->is_array()) throw RenderInputError(what + ": 'points' is not an array");
  std::vector<Point> points;
  for (size_t i = 0; i < it->size(); ++i) {
    const json& p = (*it)[i];
    std::string where = what + ": points[" + std::to_string(i) + "]";
    if (!p.is_array() || p.size() != 5) throw RenderInputError(where + " is not an array [x, r, g, b, a] of 5 numbers");
    double values[5];
    for (size_t c = 0; c < 5; ++c) {
      if (!p[c].is_number()) throw RenderInputError(where + ": " + kComponentNames[c] + " is not a number");
      values[c] = p[c].get<double>();
    }
    points.push_back({values[0], {values[1], values[2], values[3], values[4]}});
  }
  std::optional<double> referenceLength;
  if (auto r = j.find("reference_length"); r != j.end()) {
    if (!r->is_number()) throw RenderInputError(what + ": 'reference_length' is not a number");
    referenceLength = r->get<double>();
  }
  checkPoints(points, referenceLength, what);
  return TransferFunction(std::move(points), referenceLength);
}

std::filesystem::path TransferFunction::configDirectory() {
  if (const char* env = std::getenv("VOXBRICK_CONFIG_DIR"); env && *env) return env;
  std::error_code ec;
  std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    // build/voxbrick finds the source tree's config/; an installed PREFIX/bin/voxbrick finds PREFIX/share/voxbrick.
    const std::filesystem::path root = exe.parent_path().parent_path();
    for (const std::filesystem::path& beside : {root / "config", root / "share" / "voxbrick"})
      if (std::filesystem::is_directory(beside, ec)) return beside;
  }
  return "config";
}

std::vector<std::string> TransferFunction::presetNames() {
  std::vector<std::string> names = presetNames(configDirectory() / "tf");
  for (const BuiltInPreset& p : builtInPresets()) names.emplace_back(p.name);
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  return names;
}

std::vector<std::string> TransferFunction::presetNames(const std::filesystem::path& directory) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(directory, ec)) {
    const std::filesystem::path& p = entry.path();
    if (p.extension() == ".json" && isPresetName(p.stem().string()) && entry.is_regular_file(ec))
      names.push_back(p.stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

bool TransferFunction::isPresetName(const std::string& name) {
  if (name.empty()) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
  });
}

TransferFunction TransferFunction::load(const std::string& nameOrPath) {
  bool isPath = nameOrPath.find('/') != std::string::npos ||
                (nameOrPath.size() >= 5 && nameOrPath.compare(nameOrPath.size() - 5, 5, ".json") == 0);
  std::filesystem::path path;
  if (isPath) {
    path = nameOrPath;
  } else {
    if (!isPresetName(nameOrPath))
      throw RenderInputError("transfer function '" + nameOrPath +
                             "' is neither a path (with '/' or ending in .json) nor a preset name (letters, digits, "
                             "'-', '_')");
    path = configDirectory() / "tf" / (nameOrPath + ".json");
    std::error_code ec;
    // A file of the name overrides the built-in preset, so a site can retune one without a rebuild.
    if (!std::filesystem::is_regular_file(path, ec)) {
      if (const BuiltInPreset* builtIn = findBuiltInPreset(nameOrPath))
        return parse(std::string(builtIn->json), "built-in preset '" + nameOrPath + "'");
      // A preset named but for case is the preset (names differ by more than case, or the name stays unsafe).
      const std::vector<std::string> names = presetNames();
      if (const auto same = common::sameButForCase(nameOrPath, names)) return load(*same);
      std::string message = "no preset '" + nameOrPath + "' built in or in " + (configDirectory() / "tf").string();
      if (const auto closest = common::closestName(nameOrPath, names)) message += "; did you mean '" + *closest + "'?";
      std::string known;
      for (const std::string& name : names) known += (known.empty() ? "" : ", ") + name;
      throw RenderInputError(message + " (presets: " + (known.empty() ? "none" : known) +
                             "; a file NAME.json in that directory adds one, and VOXBRICK_CONFIG_DIR chooses the "
                             "directory)");
    }
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw RenderInputError("transfer function file '" + path.string() + "': no such readable file");
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.is_open() || in.bad()) throw RenderInputError("transfer function file '" + path.string() + "': cannot be read");
  return parse(text, path.string());
}

glm::dvec4 TransferFunction::evaluate(double x) const {
  if (std::isnan(x)) x = 0;
  // The first point strictly right of x: the value at a step is the later point's (right-continuous).
  auto right = std::upper_bound(mPoints.begin(), mPoints.end(), x, [](double v, const Point& p) { return v < p.x; });
  if (right == mPoints.begin()) return mPoints.front().rgba;
  if (right == mPoints.end()) return mPoints.back().rgba;
  const Point& a = *(right - 1);
  const Point& b = *right;
  double t = (x - a.x) / (b.x - a.x);
  return a.rgba + t * (b.rgba - a.rgba);
}

double TransferFunction::maxAlpha(double lo, double hi) const {
  lo = std::isnan(lo) ? 0.0 : std::clamp(lo, 0.0, 1.0);
  hi = std::isnan(hi) ? 0.0 : std::clamp(hi, 0.0, 1.0);
  if (hi < lo) std::swap(lo, hi);
  double alpha = std::max(evaluate(lo).a, evaluate(hi).a);
  for (const Point& p : mPoints)
    if (p.x >= lo && p.x <= hi) alpha = std::max(alpha, p.rgba.a);
  return alpha;
}

std::vector<glm::vec4> TransferFunction::table(int n) const {
  if (n < 1) throw RenderInputError("TransferFunction::table: size " + std::to_string(n) + " < 1");
  std::vector<glm::vec4> texels(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) texels[static_cast<size_t>(i)] = glm::vec4(evaluate(n > 1 ? double(i) / (n - 1) : 0.0));
  return texels;
}

bool TransferFunction::tableContributes(double lo, double hi, int n) const {
  if (std::isnan(lo) || std::isnan(hi)) return true;
  const double g = std::max(1, n - 1);
  lo = std::clamp(lo, 0.0, 1.0), hi = std::clamp(hi, 0.0, 1.0);
  const double first = lo >= 1 ? g : std::max(0.0, std::floor(lo * g - 1e-3));
  const double last = hi <= 0 ? 0 : std::min(g, std::ceil(hi * g + 1e-3));
  return first == last ? evaluate(first / g).a > 0 : contributes(first / g, last / g);
}

bool TransferFunction::contributes(double lo, double hi) const {
  if (std::isnan(lo) || std::isnan(hi)) return true;
  if (lo > hi) std::swap(lo, hi);
  auto bin = [](double v) {
    v = std::clamp(v, 0.0, 1.0);
    return std::min(static_cast<int>(v * kRangeBins), kRangeBins - 1);
  };
  return mOpaqueBinsBefore[static_cast<size_t>(bin(hi)) + 1] > mOpaqueBinsBefore[static_cast<size_t>(bin(lo))];
}

double TransferFunction::correctOpacity(double alpha, double stepOverReference) {
  if (!(alpha > 0) || !(stepOverReference > 0)) return 0;
  if (alpha >= 1) return 1;
  // 1 - (1 - a)^r = -expm1(r * log1p(-a)): no cancellation for a near 0 and no pow of a rounded base near 1.
  return std::clamp(-std::expm1(stepOverReference * std::log1p(-alpha)), 0.0, 1.0);
}

}  // namespace voxbrick::render
