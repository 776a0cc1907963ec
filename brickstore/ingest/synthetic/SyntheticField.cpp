// Spec parsing and evaluation of the analytic test fields; the formulas are documented in SyntheticField.h.
#include "brickstore/ingest/synthetic/SyntheticField.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <numbers>
#include <string_view>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

constexpr int64_t kMaxDim = 16384;
constexpr double kPi = std::numbers::pi;
const double kShellFloor = std::exp(-8.0);  // a shell's Gaussian at its 4σ cut-off

/// SplitMix64: tiny, and unlike std::uniform_real_distribution it gives the same numbers on every platform, so a
/// seed names the same field everywhere.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : mState(seed) {}
  uint64_t next() {
    uint64_t z = (mState += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  uint64_t mState;
};

/// The key=value pairs of a spec, consumed as they are read so that leftovers can be reported as unknown keys.
class SpecArgs {
 public:
  SpecArgs(std::string spec, std::string_view name) : mSpec(std::move(spec)), mName(name) {}

  void add(const std::string& key, const std::string& value) {
    if (!mValues.emplace(key, value).second) fail("key '" + key + "' is given twice");
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError("synthetic spec '" + mSpec + "': " + problem);
  }

  /// An integer in [lo, hi], or `fallback` if the key is absent.
  int64_t integer(const std::string& key, int64_t fallback, int64_t lo, int64_t hi) {
    auto it = mValues.find(key);
    if (it == mValues.end()) return fallback;
    const std::string text = take(it);
    int64_t value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || text.empty())
      fail("bad integer '" + text + "' for " + key);
    if (value < lo || value > hi)
      fail(key + "=" + text + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return value;
  }

  /// A finite real that `valid` accepts (described by `range`), or `fallback` if the key is absent.
  template <typename Pred>
  double real(const std::string& key, double fallback, Pred valid, const char* range) {
    auto it = mValues.find(key);
    if (it == mValues.end()) return fallback;
    const std::string text = take(it);
    double value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || text.empty() || !std::isfinite(value))
      fail("bad number '" + text + "' for " + key);
    if (!valid(value)) fail(key + "=" + text + " must be " + range);
    return value;
  }

  /// Fails on a key no reader asked for, listing the keys this field knows.
  void checkAllUsed(const std::string& known) const {
    if (!mValues.empty())
      fail("unknown key '" + mValues.begin()->first + "' for " + std::string(mName) + " (known: " + known + ")");
  }

 private:
  std::string take(std::map<std::string, std::string>::iterator it) {
    std::string value = it->second;
    mValues.erase(it);
    return value;
  }

  std::string mSpec;
  std::string_view mName;
  std::map<std::string, std::string> mValues;
};

struct FieldInfo {
  const char* name;
  int64_t defaultN;
  const char* keys;  // for the unknown-key message
};

constexpr FieldInfo kFields[] = {
    {"marschner-lobb", 64, "n, nx, ny, nz, fm, alpha"},
    {"shells", 128, "n, nx, ny, nz, count, width"},
    {"blobs", 128, "n, nx, ny, nz, count, seed"},
    {"sparse", 128, "n, nx, ny, nz, fill, count, seed"},
    {"hdr", 64, "n, nx, ny, nz"},
};

std::string knownNames() {
  std::string out;
  for (const FieldInfo& f : kFields) out += (out.empty() ? "" : ", ") + std::string(f.name);
  return out;
}

/// The spec's comma-separated parts: the field's name, then key=value pairs.
std::vector<std::string> splitSpec(const std::string& spec) {
  std::vector<std::string> parts;
  for (size_t start = 0;;) {
    size_t comma = spec.find(',', start);
    parts.push_back(spec.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return parts;
}

const FieldInfo& findField(const std::string& spec, const std::string& name) {
  for (const FieldInfo& f : kFields)
    if (name == f.name) return f;
  throw InputError("synthetic spec '" + spec +
                   "': " + (name.empty() ? std::string("no field name") : "unknown field '" + name + "'") +
                   " (known: " + knownNames() + "; form NAME[,key=value...])");
}

}  // namespace

std::vector<std::string> SyntheticField::names() {
  std::vector<std::string> out;
  for (const FieldInfo& f : kFields) out.emplace_back(f.name);
  return out;
}

void SyntheticField::drawBlobs(int64_t count, uint64_t seed) {
  SplitMix64 rng(seed);
  for (int64_t b = 0; b < count; ++b) {
    Bump bump;
    bump.cx = rng.uniform(-0.6, 0.6);
    bump.cy = rng.uniform(-0.6, 0.6);
    bump.cz = rng.uniform(-0.6, 0.6);
    bump.radius = rng.uniform(0.08, 0.2);
    bump.amplitude = rng.uniform(0.5, 1.0);
    mBumps.push_back(bump);
  }
}

bool SyntheticField::drawBalls(double fill, int64_t count, uint64_t seed) {
  SplitMix64 rng(seed);
  // Balls of volume 8 * fill / count each fill `fill` of the cube [-1,1]^3 when disjoint and inside it.
  const double radius = std::cbrt(6.0 * fill / (kPi * static_cast<double>(count)));
  // Greedy rejection sampling can paint itself into a corner with a few large balls, hence the restarts.
  for (int restart = 0; restart < 200 && mBumps.size() < static_cast<size_t>(count); ++restart) {
    mBumps.clear();
    for (int attempt = 0; attempt < 2000 && mBumps.size() < static_cast<size_t>(count); ++attempt) {
      Bump ball;
      ball.cx = rng.uniform(-1 + radius, 1 - radius);
      ball.cy = rng.uniform(-1 + radius, 1 - radius);
      ball.cz = rng.uniform(-1 + radius, 1 - radius);
      ball.radius = radius;
      bool clear = std::all_of(mBumps.begin(), mBumps.end(), [&](const Bump& o) {
        double dx = o.cx - ball.cx, dy = o.cy - ball.cy, dz = o.cz - ball.cz;
        return dx * dx + dy * dy + dz * dz >= 4 * radius * radius;
      });
      if (clear) mBumps.push_back(ball);
    }
  }
  return mBumps.size() >= static_cast<size_t>(count);
}

SyntheticField SyntheticField::parse(const std::string& spec) {
  const std::vector<std::string> parts = splitSpec(spec);
  const FieldInfo& info = findField(spec, parts[0]);
  SyntheticField field;
  field.mName = info.name;
  field.mKind = static_cast<Kind>(&info - kFields);  // kFields lists the fields in Kind's order

  SpecArgs args(spec, field.mName);
  for (size_t p = 1; p < parts.size(); ++p) {
    size_t eq = parts[p].find('=');
    if (eq == std::string::npos || eq == 0) args.fail("expected key=value, got '" + parts[p] + "'");
    args.add(parts[p].substr(0, eq), parts[p].substr(eq + 1));
  }

  const int64_t n = args.integer("n", info.defaultN, 1, kMaxDim);
  field.mDims = {args.integer("nx", n, 1, kMaxDim), args.integer("ny", n, 1, kMaxDim),
                 args.integer("nz", n, 1, kMaxDim)};
  field.mSpacing = {1, 1, 1};

  auto positive = [](double v) { return v > 0; };
  switch (field.mKind) {
    case Kind::MarschnerLobb:
      field.mFm = args.real("fm", 6.0, positive, "> 0");
      field.mAlpha = args.real(
          "alpha", 0.25, [](double v) { return v >= 0; }, ">= 0");
      break;
    case Kind::Shells:
      field.mCount = args.integer("count", 3, 1, 1000);
      field.mWidth = args.real("width", 1.0 / (8.0 * static_cast<double>(field.mCount + 1)), positive, "> 0");
      break;
    case Kind::Blobs: {
      const int64_t count = args.integer("count", 8, 1, 10000);
      field.drawBlobs(count, static_cast<uint64_t>(args.integer("seed", 1, 0, INT64_MAX)));
      break;
    }
    case Kind::Sparse: {
      const double fill = args.real(
          "fill", 0.03, [](double v) { return v > 0 && v <= 0.2; }, "in (0, 0.2]");
      const int64_t count = args.integer("count", 6, 1, 10000);
      if (!field.drawBalls(fill, count, static_cast<uint64_t>(args.integer("seed", 1, 0, INT64_MAX))))
        args.fail("could not place " + std::to_string(count) + " disjoint balls; lower fill or raise count");
      break;
    }
    case Kind::Hdr: break;
  }
  args.checkAllUsed(info.keys);
  field.updateAxes();
  return field;
}

void SyntheticField::setSpacing(const Vec3d& spacing) {
  for (int a = 0; a < 3; ++a)
    if (!(spacing[a] > 0) || !std::isfinite(spacing[a]))
      throw InputError("synthetic " + mName + ": spacing must be positive and finite");
  mSpacing = spacing;
  updateAxes();
}

void SyntheticField::updateAxes() {
  // The same expressions as sample() and evaluate(), so the tables hold the very doubles they compute.
  for (int a = 0; a < 3; ++a) {
    const double n = static_cast<double>(mDims[a]), s = mSpacing[a];
    mAxis[a].resize(static_cast<size_t>(mDims[a]));
    for (int64_t i = 0; i < mDims[a]; ++i) {
      const double p = (static_cast<double>(i) + 0.5 - 0.5 * n) * s;
      mAxis[a][static_cast<size_t>(i)] = 2.0 * p / (n * s);
    }
  }
}

double SyntheticField::evaluate(double x, double y, double z) const {
  return evaluateNormalised(2.0 * x / (static_cast<double>(mDims.x) * mSpacing.x),
                            2.0 * y / (static_cast<double>(mDims.y) * mSpacing.y),
                            2.0 * z / (static_cast<double>(mDims.z) * mSpacing.z));
}

double SyntheticField::sample(int64_t i, int64_t j, int64_t k) const {
  return evaluate((static_cast<double>(i) + 0.5 - 0.5 * static_cast<double>(mDims.x)) * mSpacing.x,
                  (static_cast<double>(j) + 0.5 - 0.5 * static_cast<double>(mDims.y)) * mSpacing.y,
                  (static_cast<double>(k) + 0.5 - 0.5 * static_cast<double>(mDims.z)) * mSpacing.z);
}

template <typename PerVoxel>
void SyntheticField::sampleRowWith(int64_t j, int64_t k, float* out, PerVoxel f) const {
  const double y = mAxis[1][static_cast<size_t>(j)], z = mAxis[2][static_cast<size_t>(k)];
  for (size_t i = 0; i < mAxis[0].size(); ++i) out[i] = static_cast<float>(f(mAxis[0][i], y, z));
}

void SyntheticField::sampleRow(int64_t j, int64_t k, float* out) const {
  switch (mKind) {
    case Kind::MarschnerLobb: {
      // sin(πz/2) is the same for the whole row; the rest is marschnerLobb() term by term.
      const double sinZ = std::sin(kPi * mAxis[2][static_cast<size_t>(k)] / 2.0);
      return sampleRowWith(j, k, out, [&](double x, double y, double) {
        const double rhoR = std::cos(2.0 * kPi * mFm * std::cos(kPi * std::sqrt(x * x + y * y) / 2.0));
        return (1.0 - sinZ + mAlpha * (1.0 + rhoR)) / (2.0 * (1.0 + mAlpha));
      });
    }
    case Kind::Shells: return sampleRowWith(j, k, out, [&](double x, double y, double z) { return shells(x, y, z); });
    case Kind::Blobs: return blobsRow(j, k, out);
    case Kind::Sparse: return sparseRow(j, k, out);
    case Kind::Hdr: return sampleRowWith(j, k, out, [](double x, double y, double z) { return hdr(x, y, z); });
  }
}

void SyntheticField::blobsRow(int64_t j, int64_t k, float* out) const {
  // blobs() voxel by voxel, with each bump's dy², dz² and 2σ² taken once per row; the sum keeps its bump order.
  struct RowBump {
    double cx, dyy, dzz, twoSigma2, amplitude;
  };
  thread_local std::vector<RowBump> row;
  row.clear();
  const double y = mAxis[1][static_cast<size_t>(j)], z = mAxis[2][static_cast<size_t>(k)];
  for (const Bump& b : mBumps) {
    const double dy = y - b.cy, dz = z - b.cz;
    row.push_back({b.cx, dy * dy, dz * dz, 2.0 * b.radius * b.radius, b.amplitude});
  }
  for (size_t i = 0; i < mAxis[0].size(); ++i) {
    const double x = mAxis[0][i];
    double sum = 0.0;
    for (const RowBump& b : row) {
      const double dx = x - b.cx;
      sum += b.amplitude * std::exp(-(dx * dx + b.dyy + b.dzz) / b.twoSigma2);
    }
    out[i] = static_cast<float>(sum);
  }
}

void SyntheticField::sparseRow(int64_t j, int64_t k, float* out) const {
  // A ball with fl(dy² + dz²) / R² >= 1 contains no voxel of the row: rounding is monotonic, so adding dx² >= 0
  // first (as sparse() does) can only make the quotient larger. The others are tried in sparse()'s order.
  struct RowBall {
    double cx, dyy, dzz, r2;
  };
  thread_local std::vector<RowBall> row;
  row.clear();
  const double y = mAxis[1][static_cast<size_t>(j)], z = mAxis[2][static_cast<size_t>(k)];
  for (const Bump& b : mBumps) {
    const double dy = y - b.cy, dz = z - b.cz, r2 = b.radius * b.radius;
    if ((dy * dy + dz * dz) / r2 < 1.0) row.push_back({b.cx, dy * dy, dz * dz, r2});
  }
  for (size_t i = 0; i < mAxis[0].size(); ++i) {
    const double x = mAxis[0][i];
    double value = 0.0;
    for (const RowBall& b : row) {
      const double dx = x - b.cx;
      const double d2 = (dx * dx + b.dyy + b.dzz) / b.r2;
      if (d2 < 1.0) {
        value = 1.0 - d2;
        break;
      }
    }
    out[i] = static_cast<float>(value);
  }
}

double SyntheticField::evaluateNormalised(double x, double y, double z) const {
  switch (mKind) {
    case Kind::MarschnerLobb: return marschnerLobb(x, y, z);
    case Kind::Shells: return shells(x, y, z);
    case Kind::Blobs: return blobs(x, y, z);
    case Kind::Sparse: return sparse(x, y, z);
    case Kind::Hdr: return hdr(x, y, z);
  }
  return 0.0;
}

double SyntheticField::marschnerLobb(double x, double y, double z) const {
  const double rhoR = std::cos(2.0 * kPi * mFm * std::cos(kPi * std::sqrt(x * x + y * y) / 2.0));
  return (1.0 - std::sin(kPi * z / 2.0) + mAlpha * (1.0 + rhoR)) / (2.0 * (1.0 + mAlpha));
}

double SyntheticField::shells(double x, double y, double z) const {
  // Lowering the Gaussian by its value at the 4σ cut-off makes the profile continuous and exactly zero beyond it,
  // so the space between shells produces empty bricks.
  const double r = std::sqrt(x * x + y * y + z * z);
  double best = 0.0;
  for (int64_t k = 1; k <= mCount; ++k) {
    const double t = (r - static_cast<double>(k) / static_cast<double>(mCount + 1)) / mWidth;
    if (std::abs(t) < 4.0) best = std::max(best, (std::exp(-0.5 * t * t) - kShellFloor) / (1.0 - kShellFloor));
  }
  return best;
}

double SyntheticField::blobs(double x, double y, double z) const {
  double sum = 0.0;
  for (const Bump& b : mBumps) {
    const double dx = x - b.cx, dy = y - b.cy, dz = z - b.cz;
    sum += b.amplitude * std::exp(-(dx * dx + dy * dy + dz * dz) / (2.0 * b.radius * b.radius));
  }
  return sum;
}

double SyntheticField::sparse(double x, double y, double z) const {
  for (const Bump& b : mBumps) {
    const double dx = x - b.cx, dy = y - b.cy, dz = z - b.cz;
    const double d2 = (dx * dx + dy * dy + dz * dz) / (b.radius * b.radius);
    if (d2 < 1.0) return 1.0 - d2;  // balls are disjoint, so at most one contains the point
  }
  return 0.0;
}

double SyntheticField::hdr(double x, double y, double z) {
  const double s = std::min(std::sqrt(x * x + y * y + z * z) / std::numbers::sqrt3, 1.0);
  return std::pow(10.0, -6.0 + 12.0 * (1.0 + std::cos(kPi * s)) / 2.0);
}

}  // namespace voxbrick::store
