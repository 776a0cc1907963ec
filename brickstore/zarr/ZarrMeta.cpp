// Reading and checking OME-Zarr metadata: the multiscales of .zattrs, each level's .zarray, axes and transforms.
#include "brickstore/zarr/ZarrMeta.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "brickstore/format/Convert.h"
#include "brickstore/format/Errors.h"
#include "brickstore/format/StoreMeta.h"

namespace voxbrick::store {
namespace fs = std::filesystem;
using nlohmann::json;
namespace {

constexpr int64_t kMaxJsonBytes = 16 << 20;
constexpr int64_t kMaxDim = int64_t{1} << 30;

json readJson(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw InputError(file.string() + ": missing (not an OME-Zarr v2 group)");
  const auto size = fs::file_size(file, ec);
  if (ec || int64_t(size) > kMaxJsonBytes) throw InputError(file.string() + ": unreadable or larger than 16 MiB");
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return json::parse(text.str());
  } catch (const json::exception& e) {
    throw InputError(file.string() + ": not JSON (" + e.what() + ")");
  }
}

/// A positive integer list of `rank` entries at key `key`.
std::vector<int64_t> intList(const json& j, const char* key, const std::string& file) {
  if (!j.contains(key) || !j[key].is_array()) throw InputError(file + ": field '" + key + "' is missing or not a list");
  std::vector<int64_t> out;
  for (const json& v : j[key]) {
    if (!v.is_number_integer() || v.get<int64_t>() <= 0 || v.get<int64_t>() > kMaxDim)
      throw InputError(file + ": field '" + key + "' has " + v.dump() + ", not an integer in [1, 2^30]");
    out.push_back(v.get<int64_t>());
  }
  return out;
}

/// The dtype text ("<u2", ">f4", "|u1") as a file type and byte order; others refused by name.
void parseDtype(const json& j, ZarrArrayMeta& a, const std::string& file) {
  if (!j.contains("dtype") || !j["dtype"].is_string())
    throw InputError(file + ": field 'dtype' is missing or not a string (structured dtypes are not read)");
  const std::string d = j["dtype"].get<std::string>();
  const std::string body = d.size() == 3 ? d.substr(1) : std::string();
  static const std::pair<const char*, FileValueType> kTypes[] = {
      {"u1", FileValueType::U8},  {"i1", FileValueType::I8},  {"u2", FileValueType::U16}, {"i2", FileValueType::I16},
      {"u4", FileValueType::U32}, {"i4", FileValueType::I32}, {"f4", FileValueType::F32}, {"f8", FileValueType::F64}};
  for (const auto& [name, type] : kTypes)
    if (body == name && (d[0] == '<' || d[0] == '>' || d[0] == '|')) {
      a.fileType = type;
      a.bigEndian = d[0] == '>';
      return;
    }
  throw InputError(file + ": field 'dtype' is \"" + d +
                   "\", not read (u1, i1, u2, i2, u4, i4, f4 and f8 are; 64-bit integers, complex, booleans, "
                   "strings and datetimes are not)");
}

void parseCompressor(const json& j, ZarrArrayMeta& a, const std::string& file) {
  if (j.contains("filters") && !j["filters"].is_null() && !(j["filters"].is_array() && j["filters"].empty())) {
    std::string ids;
    for (const json& f : j["filters"]) ids += (ids.empty() ? "" : ", ") + f.value("id", std::string("?"));
    throw InputError(file + ": field 'filters' names " + ids + "; filters are not read");
  }
  if (!j.contains("compressor") || j["compressor"].is_null()) {
    a.compressor = ZarrCompressor::None;
    a.compressorText = "raw";
    return;
  }
  const json& c = j["compressor"];
  const std::string id = c.is_object() ? c.value("id", std::string()) : std::string();
  const std::optional<ZarrCompressor> compressor = common::valueOf<ZarrCompressor>(id);
  if (!compressor)
    throw InputError(file + ": field 'compressor' id \"" + id + "\" is not read (none, " +
                     common::enumNamesText<ZarrCompressor>(", ", " and ") + " are)");
  a.compressor = *compressor;
  a.compressorText = id;
  if (a.compressor == ZarrCompressor::Blosc) {
    const std::string cname = c.value("cname", std::string());
    if (cname != "lz4" && cname != "lz4hc" && cname != "zstd" && cname != "zlib" && cname != "blosclz")
      throw InputError(file + ": field 'compressor' cname \"" + cname +
                       "\" is not read (blosc with lz4, lz4hc, zstd, zlib and blosclz is)");
    const int shuffle = c.value("shuffle", 1);
    a.compressorText += " " + cname + (shuffle == 2 ? " bitshuffle" : shuffle == 1 ? " shuffle" : "");
  }
}

double parseFill(const json& j, const std::string& file) {
  if (!j.contains("fill_value") || j["fill_value"].is_null()) return 0;
  const json& f = j["fill_value"];
  double v = 0;
  if (f.is_number())
    v = f.get<double>();
  else if (f.is_string() && (f == "NaN" || f == "Infinity" || f == "-Infinity"))
    return 0;  // a non-finite fill reads as 0, as non-finite voxels read as the background
  else
    throw InputError(file + ": field 'fill_value' is " + f.dump() + ", not a number");
  if (!std::isfinite(v)) throw InputError(file + ": field 'fill_value' is not finite");
  return v;
}

ZarrArrayMeta readArray(const fs::path& dir, const std::string& path, size_t rank) {
  const fs::path file = dir / ".zarray";
  const std::string name = file.string();
  if (fs::exists(dir / "zarr.json"))
    throw InputError((dir / "zarr.json").string() + ": Zarr v3 arrays are not read (only Zarr v2: .zarray)");
  const json j = readJson(file);
  if (!j.is_object() || j.value("zarr_format", 0) != 2)
    throw InputError(name + ": field 'zarr_format' is not 2 (only Zarr v2 is read)");
  ZarrArrayMeta a;
  a.dir = dir;
  a.path = path;
  a.shape = intList(j, "shape", name);
  a.chunks = intList(j, "chunks", name);
  if (a.shape.size() != rank)
    throw InputError(name + ": field 'shape' has " + std::to_string(a.shape.size()) + " axes; the multiscales axes " +
                     "name " + std::to_string(rank));
  if (a.chunks.size() != rank)
    throw InputError(name + ": field 'chunks' has " + std::to_string(a.chunks.size()) + " axes, 'shape' has " +
                     std::to_string(rank));
  parseDtype(j, a, name);
  const std::string order = j.value("order", std::string("C"));
  if (order != "C" && order != "F") throw InputError(name + ": field 'order' is \"" + order + "\", not C or F");
  a.fortranOrder = order == "F";
  const std::string sep = j.contains("dimension_separator") && j["dimension_separator"].is_string()
                              ? j["dimension_separator"].get<std::string>()
                              : ".";
  if (sep != "." && sep != "/")
    throw InputError(name + ": field 'dimension_separator' is \"" + sep + "\", not \".\" or \"/\"");
  a.separator = sep[0];
  parseCompressor(j, a, name);
  a.fillValue = parseFill(j, name);
  int64_t chunkBytes = int64_t(fileValueSize(a.fileType));
  for (int64_t c : a.chunks) chunkBytes = c > kMaxZarrChunkBytes / chunkBytes ? kMaxZarrChunkBytes + 1 : chunkBytes * c;
  if (chunkBytes > kMaxZarrChunkBytes)
    throw InputError(name + ": field 'chunks' makes chunks larger than 1 GiB decoded; not read");
  const size_t s = rank - 3;
  a.dims = {a.shape[s + 2], a.shape[s + 1], a.shape[s]};
  a.chunkDims = {a.chunks[s + 2], a.chunks[s + 1], a.chunks[s]};
  a.chunkGrid = {divUp(a.dims.x, a.chunkDims.x), divUp(a.dims.y, a.chunkDims.y), divUp(a.dims.z, a.chunkDims.z)};
  if (a.chunkGrid.volume() > kMaxZarrChunksPerLevel)
    throw InputError(name + ": fields 'shape' and 'chunks' make " + std::to_string(a.chunkGrid.volume()) +
                     " chunks in one volume, more than 2^24");
  checkedVolumeBytes(a.dims, fileValueSize(a.fileType), name);
  return a;
}

/// The scale and translation of one dataset (0.4: a list with one "scale" and at most one "translation").
void readTransforms(const json& list, size_t rank, ZarrArrayMeta& a, const std::string& what) {
  if (!list.is_array()) return;
  for (const json& t : list) {
    const std::string type = t.value("type", std::string());
    if (type == "identity") continue;
    if (type != "scale" && type != "translation")
      throw InputError(what + " coordinateTransformations type \"" + type + "\" is not read (scale, translation are)");
    const char* key = type.c_str();
    if (!t.contains(key) || !t[key].is_array() || t[key].size() != rank)
      throw InputError(what + " coordinateTransformations '" + type + "' needs " + std::to_string(rank) + " numbers");
    std::vector<double> v;
    for (const json& n : t[key]) {
      if (!n.is_number() || !std::isfinite(n.get<double>()))
        throw InputError(what + " coordinateTransformations '" + type + "' has " + n.dump() + ", not a number");
      v.push_back(n.get<double>());
    }
    const size_t s = rank - 3;
    if (type == "scale") {
      a.scale = {v[s + 2], v[s + 1], v[s]};
      for (int d = 0; d < 3; ++d) checkSpacingInRange(a.scale[d], what + " coordinateTransformations scale");
    } else {
      a.translation = {v[s + 2], v[s + 1], v[s]};
    }
  }
}

/// The axes of a multiscales entry: 0.4 objects {name, type}, 0.3 names, or (0.1/0.2) t, c, z, y, x by rank.
void readAxes(const json& ms, ZarrMeta& m, size_t rankHint, const std::string& what) {
  if (ms.contains("axes") && ms["axes"].is_array()) {
    for (const json& ax : ms["axes"]) {
      if (ax.is_string())
        m.axisNames.push_back(ax.get<std::string>());
      else if (ax.is_object() && ax.contains("name") && ax["name"].is_string()) {
        m.axisNames.push_back(ax["name"].get<std::string>());
        if (ax.value("type", std::string()) == "space" && m.unit.empty()) m.unit = ax.value("unit", std::string());
      } else
        throw InputError(what + " 'axes' has " + ax.dump() + ", not an axis");
    }
  } else {
    const std::vector<std::string> all{"t", "c", "z", "y", "x"};
    if (rankHint < 3 || rankHint > 5)
      throw InputError(what + " has no 'axes' and " + std::to_string(rankHint) + " dims");
    m.axisNames.assign(all.end() - long(rankHint), all.end());
  }
  const size_t rank = m.axisNames.size();
  if (rank < 3 || rank > 5) throw InputError(what + " 'axes' names " + std::to_string(rank) + " axes, not 3 to 5");
  if (m.axisNames[rank - 3] != "z" || m.axisNames[rank - 2] != "y" || m.axisNames[rank - 1] != "x")
    throw InputError(what + " 'axes' must end with z, y, x (a volume); 2D images are not read");
  for (size_t d = 0; d + 3 < rank; ++d) {
    const std::string& n = m.axisNames[d];
    int& slot = n == "t" ? m.timeAxis : n == "c" ? m.channelAxis : m.timeAxis;
    if ((n != "t" && n != "c") || slot != -1)
      throw InputError(what + " 'axes' has \"" + n + "\" before z, y, x; only one t and one c are read");
    slot = int(d);
  }
}

/// A pyramid level against the level before it: smaller (not larger along any axis, and not the same shape), the
/// same lengths along t and c, the same dtype.
void checkAgainstFiner(const ZarrArrayMeta& a, const ZarrArrayMeta& prev, const std::vector<std::string>& axisNames,
                       const std::string& where) {
  const std::string& path = a.path;
  const size_t rank = axisNames.size();
  for (int d = 0; d < 3; ++d)
    if (a.dims[d] > prev.dims[d])
      throw InputError(where + " (" + path + ") has shape " + dimsText(a.dims) + ", larger than the level before (" +
                       dimsText(prev.dims) + "): pyramid levels must shrink");
  if (a.dims == prev.dims)
    throw InputError(where + " (" + path + ") has the same shape as the level before: pyramid levels must shrink");
  for (size_t d = 0; d + 3 < rank; ++d)
    if (a.shape[d] != prev.shape[d])
      throw InputError(where + " (" + path + ") has " + std::to_string(a.shape[d]) + " along '" + axisNames[d] +
                       "', the level before " + std::to_string(prev.shape[d]));
  if (a.fileType != prev.fileType) throw InputError(where + " (" + path + ") has another dtype than the level before");
}

}  // namespace

int64_t ZarrArrayMeta::chunkBytes() const {
  int64_t n = int64_t(fileValueSize(fileType));
  for (int64_t c : chunks) n *= c;
  return n;
}

fs::path ZarrArrayMeta::chunkFile(const Vec3i& chunk, const std::vector<int64_t>& fixed) const {
  std::string key;
  const size_t s = shape.size() - 3;
  for (size_t d = 0; d < shape.size(); ++d) {
    const int64_t i = d < s ? fixed[d] : chunk[int(2 - (d - s))];
    key += (d ? std::string(1, separator) : std::string()) + std::to_string(i);
  }
  return dir / key;
}

ValueType ZarrMeta::storeType() const { return storeTypeFor(levels.front().fileType); }

double ZarrMeta::background() const {
  const double v = levels.front().fillValue;
  switch (storeType()) {
    case ValueType::U8: return std::clamp(std::round(v), 0.0, 255.0);
    case ValueType::U16: return std::clamp(std::round(v), 0.0, 65535.0);
    case ValueType::I16: return std::clamp(std::round(v), -32768.0, 32767.0);
    case ValueType::F32: return double(float(v));
  }
  return v;
}

std::vector<int64_t> ZarrMeta::fixedChunkIndex() const {
  std::vector<int64_t> out(axisNames.size(), 0);
  const ZarrArrayMeta& a = levels.front();
  if (timeAxis >= 0) out[size_t(timeAxis)] = selection.time / a.chunks[size_t(timeAxis)];
  if (channelAxis >= 0) out[size_t(channelAxis)] = selection.channel / a.chunks[size_t(channelAxis)];
  return out;
}

std::vector<int64_t> ZarrMeta::fixedInChunk() const {
  std::vector<int64_t> out(axisNames.size(), 0);
  const ZarrArrayMeta& a = levels.front();
  if (timeAxis >= 0) out[size_t(timeAxis)] = selection.time % a.chunks[size_t(timeAxis)];
  if (channelAxis >= 0) out[size_t(channelAxis)] = selection.channel % a.chunks[size_t(channelAxis)];
  return out;
}

std::string ZarrMeta::description() const {
  const ZarrArrayMeta& a = levels.front();
  std::string s = "OME-Zarr " + (version.empty() ? std::string("(no version)") : version) + " " +
                  std::string(fileValueTypeName(a.fileType)) + " " + a.compressorText + " " + dimsText(a.dims) + ", " +
                  std::to_string(levels.size()) + " level(s)";
  if (timeAxis >= 0 || channelAxis >= 0) {
    s += " (";
    if (timeAxis >= 0) s += "t=" + std::to_string(selection.time);
    if (channelAxis >= 0) s += std::string(timeAxis >= 0 ? " " : "") + "c=" + std::to_string(selection.channel);
    s += ")";
  }
  return s;
}

bool isZarrDirectory(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return false;
  if (fs::is_regular_file(dir / "zarr.json", ec)) return true;
  if (!fs::is_regular_file(dir / ".zattrs", ec) || !fs::is_regular_file(dir / ".zgroup", ec)) return false;
  // "multiscales" may follow a long "omero" block: up to 1 MiB is read, no more than the file holds.
  const uintmax_t size = fs::file_size(dir / ".zattrs", ec);
  if (ec) return false;
  std::ifstream in(dir / ".zattrs", std::ios::binary);
  std::string head(size_t(std::min<uintmax_t>(size, uintmax_t{1} << 20)), '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(size_t(in.gcount()));
  return head.find("\"multiscales\"") != std::string::npos;
}

/// The chosen time point and channel against the t and c axes (0 where there is no such axis).
static void checkSelection(const ZarrMeta& m, const std::string& attrsName) {
  const ZarrSelection& selection = m.selection;
  const ZarrArrayMeta& l0 = m.levels.front();
  if (selection.time < 0 || (m.timeAxis < 0 ? selection.time != 0 : selection.time >= l0.shape[size_t(m.timeAxis)]))
    throw InputError(attrsName + ": --time " + std::to_string(selection.time) + " is outside the 't' axis (" +
                     (m.timeAxis < 0 ? std::string("none") : std::to_string(l0.shape[size_t(m.timeAxis)]) + " points") +
                     ")");
  if (selection.channel < 0 ||
      (m.channelAxis < 0 ? selection.channel != 0 : selection.channel >= l0.shape[size_t(m.channelAxis)]))
    throw InputError(
        attrsName + ": --channel " + std::to_string(selection.channel) + " is outside the 'c' axis (" +
        (m.channelAxis < 0 ? std::string("none") : std::to_string(l0.shape[size_t(m.channelAxis)]) + " channels") +
        ")");
}

ZarrMeta readZarrMeta(const fs::path& root, const ZarrSelection& selection) {
  std::error_code ec;
  if (fs::is_regular_file(root / "zarr.json", ec))
    throw InputError(
        (root / "zarr.json").string() +
        ": Zarr v3 (OME-NGFF 0.5) is not read; only OME-NGFF 0.4 over Zarr v2 (.zgroup, .zattrs, .zarray)");
  const json group = readJson(root / ".zgroup");
  if (!group.is_object() || group.value("zarr_format", 0) != 2)
    throw InputError((root / ".zgroup").string() + ": field 'zarr_format' is not 2");
  const std::string attrsName = (root / ".zattrs").string();
  const json attrs = readJson(root / ".zattrs");
  if (!attrs.is_object() || !attrs.contains("multiscales") || !attrs["multiscales"].is_array() ||
      attrs["multiscales"].empty())
    throw InputError(attrsName + ": field 'multiscales' is missing or empty");
  const json& ms = attrs["multiscales"][0];
  const std::string what = attrsName + ": multiscales[0]";
  if (!ms.contains("datasets") || !ms["datasets"].is_array() || ms["datasets"].empty())
    throw InputError(what + " 'datasets' is missing or empty");
  if (ms["datasets"].size() > 32) throw InputError(what + " 'datasets' lists more than 32 levels");
  ZarrMeta m;
  m.root = root;
  m.selection = selection;
  m.version = ms.value("version", std::string());
  const json& first = ms["datasets"][0];
  if (!first.is_object() || !first.contains("path") || !first["path"].is_string())
    throw InputError(what + " 'datasets'[0] has no 'path'");
  size_t rankHint = 0;
  if (!ms.contains("axes")) {  // before 0.3: the rank is the first array's
    const json a0 = readJson(root / first["path"].get<std::string>() / ".zarray");
    rankHint = a0.contains("shape") && a0["shape"].is_array() ? a0["shape"].size() : 0;
  }
  readAxes(ms, m, rankHint, what);
  const size_t rank = m.axisNames.size();
  for (size_t l = 0; l < ms["datasets"].size(); ++l) {
    const json& ds = ms["datasets"][l];
    const std::string where = what + " 'datasets'[" + std::to_string(l) + "]";
    if (!ds.is_object() || !ds.contains("path") || !ds["path"].is_string()) throw InputError(where + " has no 'path'");
    const std::string path = ds["path"].get<std::string>();
    if (path.empty() || path.find("..") != std::string::npos || path.front() == '/')
      throw InputError(where + " 'path' \"" + path + "\" is not a path inside the group");
    ZarrArrayMeta a = readArray(root / path, path, rank);
    if (ds.contains("coordinateTransformations")) readTransforms(ds["coordinateTransformations"], rank, a, where);
    if (ms.contains("coordinateTransformations"))
      throw InputError(what + " has multiscales-level 'coordinateTransformations', which are not read");
    if (!m.levels.empty()) checkAgainstFiner(a, m.levels.back(), m.axisNames, where);
    m.levels.push_back(std::move(a));
  }
  checkSelection(m, attrsName);
  return m;
}

std::vector<bool> zarrOwnLevels(const ZarrMeta& meta, int brickSize) {
  const std::vector<Vec3i> pyramid = pyramidDims(meta.levels.front().dims, brickSize);
  std::vector<bool> own(pyramid.size(), false);
  own[0] = true;
  for (size_t m = 1; m < pyramid.size(); ++m)
    own[m] = own[m - 1] && m < meta.levels.size() && meta.levels[m].dims == pyramid[m];
  return own;
}

}  // namespace voxbrick::store
