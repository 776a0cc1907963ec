// store.json: the metadata of a store, written by prep and checked by every reader.
#include "brickstore/format/StoreMeta.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <type_traits>
#include <utility>

#include <nlohmann/json.hpp>

#include "brickstore/format/Convert.h"
#include "brickstore/format/Errors.h"
#include "brickstore/format/StoreFormat.h"

namespace voxbrick::store {
namespace {

using nlohmann::json;

/// `v` as printf's %g writes it ("1e+12", "nan").
std::string numberText(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

json toJson(const Vec3i& v) { return json::array({v.x, v.y, v.z}); }
json toJson(const Vec3d& v) { return json::array({v.x, v.y, v.z}); }

const json& field(const json& j, const char* key, const std::string& what) {
  auto it = j.find(key);
  if (it == j.end()) throw CorruptStoreError(what + ": missing key '" + key + "'");
  return *it;
}

/// `v`, the value of `key`, as a T: an integer in T's range for an integral T, else a finite number. A value of another
/// JSON type is refused naming the key rather than left to the JSON library's type error.
template <typename T>
T numberValue(const json& v, const std::string& key, const std::string& what) {
  if constexpr (std::is_integral_v<T>) {
    if (!v.is_number_integer()) throw CorruptStoreError(what + ": key '" + key + "' is not an integer");
    const bool fits = v.is_number_unsigned() ? v.get<uint64_t>() <= uint64_t(std::numeric_limits<T>::max())
                                             : v.get<int64_t>() >= int64_t(std::numeric_limits<T>::min()) &&
                                                   v.get<int64_t>() <= int64_t(std::numeric_limits<T>::max());
    if (!fits) throw CorruptStoreError(what + ": key '" + key + "' is out of range");
    return v.get<T>();
  } else {
    if (!v.is_number() || !std::isfinite(v.get<double>()))
      throw CorruptStoreError(what + ": key '" + key + "' is not a finite number");
    return v.get<T>();
  }
}

template <typename T>
T number(const json& j, const char* key, const std::string& what) {
  return numberValue<T>(field(j, key, what), key, what);
}

/// As number(), with `fallback` where the key is absent.
template <typename T>
T optionalNumber(const json& j, const char* key, const std::string& what, T fallback) {
  return j.contains(key) ? number<T>(j, key, what) : fallback;
}

Vec3i vec3i(const json& j, const char* key, const std::string& what) {
  const json& v = field(j, key, what);
  if (!v.is_array() || v.size() != 3 || !v[0].is_number_integer() || !v[1].is_number_integer() ||
      !v[2].is_number_integer())
    throw CorruptStoreError(what + ": key '" + key + "' is not three integers");
  Vec3i r{v[0].get<int64_t>(), v[1].get<int64_t>(), v[2].get<int64_t>()};
  if (r.x <= 0 || r.y <= 0 || r.z <= 0) throw CorruptStoreError(what + ": key '" + key + "' has a value <= 0");
  return r;
}

Vec3d vec3d(const json& j, const char* key, const std::string& what) {
  const json& v = field(j, key, what);
  if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
    throw CorruptStoreError(what + ": key '" + key + "' is not three numbers");
  return {numberValue<double>(v[0], key, what), numberValue<double>(v[1], key, what),
          numberValue<double>(v[2], key, what)};
}

Orientation orientationFromJson(const json& o, const std::string& what) {
  auto bad = [&](const std::string& why) { return CorruptStoreError(what + ": key 'orientation' " + why); };
  if (!o.is_object()) throw bad("is not an object");
  if (o.value("space", "") != "RAS") throw bad("must have space \"RAS\"");
  auto vec = [&](const json& v, const char* name) {
    if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
      throw bad(std::string("has '") + name + "' that is not three numbers");
    Orientation::Vec r{v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
    for (double x : r)
      if (!std::isfinite(x)) throw bad(std::string("has a non-finite '") + name + "'");
    return r;
  };
  Orientation r;
  const json& axes = field(o, "axes", what);
  if (!axes.is_array() || axes.size() != 3) throw bad("has 'axes' that is not three vectors");
  for (int a = 0; a < 3; ++a) r.axes[a] = vec(axes[a], "axes");
  r.origin = vec(field(o, "origin", what), "origin");
  const json& patient = field(o, "patient", what);
  if (!patient.is_boolean()) throw bad("has 'patient' that is not true or false");
  r.patient = patient.get<bool>();
  return r;
}

}  // namespace

std::string StoreMeta::toJson() const {
  json levelsJson = json::array();
  for (const LevelMeta& l : levels) {
    levelsJson.push_back({{"dims", store::toJson(l.dims)},
                          {"bricks", store::toJson(l.bricks)},
                          {"bricks_total", l.bricksTotal()},
                          {"bricks_stored", l.bricksStored},
                          {"bytes_stored", l.bytesStored}});
  }
  json j = {{"format", "voxbrick-store"},
            {"version", kFormatVersion},
            {"dims", store::toJson(dims)},
            {"spacing", store::toJson(spacing)},
            {"type", std::string(valueTypeName(type))},
            {"background", background},
            {"value_range", json::array({valueMin, valueMax})},
            {"histogram", {{"range", json::array({histogram.lo, histogram.hi})}, {"counts", histogram.counts}}},
            {"brick_size", brickSize},
            {"levels", levelsJson},
            {"bytes_raw", bytesRaw},
            {"bytes_stored", bytesStored},
            {"bytes_vdb", bytesVdb},
            {"active_voxels", activeVoxels},
            {"nonfinite_replaced", nonFiniteReplaced},
            {"vdb_files", vdbFiles},
            {"source", source}};
  if (!(orientation == Orientation{}))
    j["orientation"] = {
        {"space", "RAS"}, {"axes", orientation.axes}, {"origin", orientation.origin}, {"patient", orientation.patient}};
  if (quantisation)
    j["quantisation"] = {{"type", std::string(valueTypeName(quantisation->type))},
                         {"range", json::array({quantisation->lo, quantisation->hi})},
                         {"clamped", quantisationClamped}};
  return j.dump(2) + "\n";
}

namespace {

/// store.json's object, once it is known to be a store of the format version this build reads.
json parseStoreJson(const std::string& text, const std::string& what) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw CorruptStoreError(what + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object()) throw CorruptStoreError(what + ": not a JSON object");
  if (j.value("format", "") != "voxbrick-store") throw CorruptStoreError(what + ": not a voxbrick store");
  int version = number<int>(j, "version", what);
  if (version != StoreMeta::kFormatVersion)
    throw CorruptStoreError(what + ": store format version " + std::to_string(version) + ", this build reads " +
                            std::to_string(StoreMeta::kFormatVersion));
  return j;
}

ValueType typeFromJson(const json& j, const std::string& what) {
  const json& type = field(j, "type", what);
  if (!type.is_string()) throw CorruptStoreError(what + ": key 'type' is not a string");
  try {
    return parseValueType(type.get<std::string>());
  } catch (const InputError& e) {
    throw CorruptStoreError(what + ": " + e.what());
  }
}

Histogram histogramFromJson(const json& j, const std::string& what) {
  const json& hist = field(j, "histogram", what);
  if (!hist.is_object()) throw CorruptStoreError(what + ": key 'histogram' is not an object");
  const json& hrange = field(hist, "range", what);
  const json& counts = field(hist, "counts", what);
  if (!hrange.is_array() || hrange.size() != 2 || !counts.is_array())
    throw CorruptStoreError(what + ": key 'histogram' is malformed");
  Histogram histogram;
  histogram.lo = numberValue<double>(hrange[0], "histogram.range", what);
  histogram.hi = numberValue<double>(hrange[1], "histogram.range", what);
  if (histogram.lo > histogram.hi) throw CorruptStoreError(what + ": key 'histogram.range' has lo > hi");
  for (const json& c : counts) {
    if (!c.is_number_unsigned()) throw CorruptStoreError(what + ": histogram counts must be unsigned integers");
    histogram.counts.push_back(c.get<uint64_t>());
  }
  return histogram;
}

std::vector<LevelMeta> levelsFromJson(const json& j, const std::string& what) {
  const json& levels = field(j, "levels", what);
  if (!levels.is_array() || levels.empty()) throw CorruptStoreError(what + ": key 'levels' is not a non-empty array");
  std::vector<LevelMeta> out;
  for (const json& l : levels) {
    LevelMeta lm;
    lm.dims = vec3i(l, "dims", what);
    lm.bricks = vec3i(l, "bricks", what);
    lm.bricksStored = number<int64_t>(l, "bricks_stored", what);
    lm.bytesStored = number<int64_t>(l, "bytes_stored", what);
    out.push_back(lm);
  }
  return out;
}

/// The "quantisation" object `q` into `m`, whose type it must agree with.
void quantisationFromJson(const json& q, StoreMeta& m, const std::string& what) {
  const json& qrange = field(q, "range", what);
  const json& qtype = field(q, "type", what);
  if (!qrange.is_array() || qrange.size() != 2 || !qrange[0].is_number() || !qrange[1].is_number() ||
      !qtype.is_string())
    throw CorruptStoreError(what + ": key 'quantisation' is malformed");
  Quantisation quantisation;
  try {
    quantisation.type = parseQuantiseType(qtype.get<std::string>());
    quantisation.lo = qrange[0].get<double>();
    quantisation.hi = qrange[1].get<double>();
    quantisation.validate();
  } catch (const InputError& e) {
    throw CorruptStoreError(what + ": key 'quantisation': " + e.what());
  }
  if (quantisation.type != m.type)
    throw CorruptStoreError(what + ": quantised to " + qtype.get<std::string>() + " but the store type is " +
                            std::string(valueTypeName(m.type)));
  m.quantisation = quantisation;
  m.quantisationClamped = optionalNumber<int64_t>(q, "clamped", what, 0);
}

/// The strings of the optional array `key`; none when it is absent.
std::vector<std::string> stringsFromJson(const json& j, const char* key, const std::string& what) {
  std::vector<std::string> out;
  if (!j.contains(key)) return out;
  const json& list = j[key];
  if (!list.is_array()) throw CorruptStoreError(what + ": key '" + key + "' is not an array of strings");
  for (const json& s : list) {
    if (!s.is_string()) throw CorruptStoreError(what + ": key '" + key + "' is not an array of strings");
    out.push_back(s.get<std::string>());
  }
  return out;
}

/// The levels against the pyramid that `m.dims` and `m.brickSize` make, and each level's counts against its bricks.
void checkLevels(const StoreMeta& m, const std::string& what) {
  const std::vector<Vec3i> pyramid = pyramidDims(m.dims, m.brickSize);
  if (m.levels.size() != pyramid.size())
    throw CorruptStoreError(what + ": key 'levels' has " + std::to_string(m.levels.size()) + " levels; dims " +
                            dimsText(m.dims) + " in bricks of " + std::to_string(m.brickSize) + " make " +
                            std::to_string(pyramid.size()));
  const int64_t B = m.brickSize;
  for (size_t l = 0; l < pyramid.size(); ++l) {
    const LevelMeta& level = m.levels[l];
    const std::string where = what + ": key 'levels' level " + std::to_string(l);
    if (!(level.dims == pyramid[l]))
      throw CorruptStoreError(where + " has dims " + dimsText(level.dims) + ", expected " + dimsText(pyramid[l]));
    if (!(level.bricks == Vec3i{divUp(level.dims.x, B), divUp(level.dims.y, B), divUp(level.dims.z, B)}))
      throw CorruptStoreError(where + " has bricks " + dimsText(level.bricks) + " that do not cover its dims");
    if (level.bricksStored < 0 || level.bricksStored > level.bricksTotal() || level.bytesStored < 0)
      throw CorruptStoreError(where + " has bricks_stored or bytes_stored out of range");
  }
}

/// What readers size and scale from, each within its range: the spacing (as every input's), the value range, the
/// brick size (as --brick's), the levels, and the counts against the volume.
void checkMetaRanges(const StoreMeta& m, const std::string& what) {
  auto bad = [&](const std::string& key, const std::string& why) {
    return CorruptStoreError(what + ": key '" + key + "' " + why);
  };
  for (int a = 0; a < 3; ++a)
    if (!spacingInRange(m.spacing[a]))
      throw bad("spacing", "has " + numberText(m.spacing[a]) + " (each must be in [" + numberText(kMinSpacing) + ", " +
                               numberText(kMaxSpacing) + "])");
  if (m.valueMin > m.valueMax)
    throw bad("value_range", "is [" + numberText(m.valueMin) + ", " + numberText(m.valueMax) + "]: lo > hi");
  if (m.brickSize < 8 || m.brickSize > int(kMaxBrickSize) || (m.brickSize & (m.brickSize - 1)) != 0)
    throw bad("brick_size", "is " + std::to_string(m.brickSize) + ", not a power of two in [8, " +
                                std::to_string(kMaxBrickSize) + "]");
  int64_t voxels = 0, bytesRaw = 0;
  if (__builtin_mul_overflow(m.dims.x, m.dims.y, &voxels) || __builtin_mul_overflow(voxels, m.dims.z, &voxels) ||
      __builtin_mul_overflow(voxels, int64_t(valueSize(m.type)), &bytesRaw))
    throw bad("dims", "is " + dimsText(m.dims) + ", too large (the byte count overflows)");
  checkLevels(m, what);
  if (m.bytesRaw != bytesRaw)
    throw bad("bytes_raw", "is " + std::to_string(m.bytesRaw) + ", expected " + std::to_string(bytesRaw));
  if (m.bytesStored < 0 || m.bytesVdb < 0) throw bad("bytes_stored", "or 'bytes_vdb' is negative");
  const std::pair<const char*, int64_t> voxelCounts[] = {{"active_voxels", m.activeVoxels},
                                                         {"nonfinite_replaced", m.nonFiniteReplaced},
                                                         {"quantisation.clamped", m.quantisationClamped}};
  for (const auto& [key, count] : voxelCounts)
    if (count < 0 || count > voxels)
      throw bad(key, "is " + std::to_string(count) + ", outside [0, " + std::to_string(voxels) + "] (the voxels)");
}

}  // namespace

StoreMeta StoreMeta::fromJson(const std::string& text, const std::string& what) {
  const json j = parseStoreJson(text, what);
  StoreMeta m;
  m.dims = vec3i(j, "dims", what);
  m.spacing = vec3d(j, "spacing", what);
  if (j.contains("orientation")) m.orientation = orientationFromJson(j["orientation"], what);
  m.type = typeFromJson(j, what);
  m.background = number<double>(j, "background", what);
  const json& range = field(j, "value_range", what);
  if (!range.is_array() || range.size() != 2) throw CorruptStoreError(what + ": key 'value_range' is not two numbers");
  m.valueMin = numberValue<double>(range[0], "value_range", what);
  m.valueMax = numberValue<double>(range[1], "value_range", what);
  m.histogram = histogramFromJson(j, what);
  m.brickSize = number<int>(j, "brick_size", what);
  m.levels = levelsFromJson(j, what);
  m.bytesRaw = number<int64_t>(j, "bytes_raw", what);
  m.bytesStored = number<int64_t>(j, "bytes_stored", what);
  m.bytesVdb = optionalNumber<int64_t>(j, "bytes_vdb", what, 0);
  m.activeVoxels = optionalNumber<int64_t>(j, "active_voxels", what, 0);
  m.nonFiniteReplaced = optionalNumber<int64_t>(j, "nonfinite_replaced", what, 0);
  m.vdbFiles = stringsFromJson(j, "vdb_files", what);
  if (j.contains("source")) {
    if (!j["source"].is_string()) throw CorruptStoreError(what + ": key 'source' is not a string");
    m.source = j["source"].get<std::string>();
  }
  if (j.contains("quantisation")) quantisationFromJson(j["quantisation"], m, what);
  checkMetaRanges(m, what);
  return m;
}

std::vector<Vec3i> pyramidDims(Vec3i dims, int brickSize) {
  std::vector<Vec3i> levels{dims};
  while (dims.x > brickSize || dims.y > brickSize || dims.z > brickSize) {
    dims = {divUp(dims.x, 2), divUp(dims.y, 2), divUp(dims.z, 2)};
    levels.push_back(dims);
  }
  return levels;
}

void checkSpacingInRange(double s, const std::string& what) {
  if (!spacingInRange(s))
    throw InputError(what + " is " + numberText(s) + ", not a spacing in [" + numberText(kMinSpacing) + ", " +
                     numberText(kMaxSpacing) + "] (--spacing overrides it)");
}

void checkBrickSize(int brickSize) {
  if (brickSize < 8 || brickSize > int(kMaxBrickSize) || (brickSize & (brickSize - 1)) != 0)
    throw InputError("--brick " + std::to_string(brickSize) + " is not a power of two in [8, " +
                     std::to_string(kMaxBrickSize) + "]");
}

}  // namespace voxbrick::store
