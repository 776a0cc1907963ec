// NRRD input: attached (.nrrd) and detached (.nhdr) headers, raw or gzip encoding, 3D scalar volumes.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "brickstore/format/Convert.h"
#include "brickstore/format/Errors.h"
#include "brickstore/format/Orientation.h"
#include "brickstore/format/StoreMeta.h"
#include "brickstore/ingest/raw/DenseSource.h"
#include "brickstore/ingest/raw/RawSources.h"
#include "brickstore/source/ByteStream.h"

namespace voxbrick::store {
namespace {

constexpr size_t kMaxHeaderBytes = size_t(1) << 20;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string trim(const std::string& s) {
  size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  size_t e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> tokens(const std::string& s) {
  std::vector<std::string> out;
  size_t i = 0;
  while (true) {
    i = s.find_first_not_of(" \t", i);
    if (i == std::string::npos) break;
    size_t e = s.find_first_of(" \t", i);
    out.push_back(s.substr(i, e == std::string::npos ? std::string::npos : e - i));
    if (e == std::string::npos) break;
    i = e;
  }
  return out;
}

// Type spellings of the NRRD spec (lowercased, single spaces); int64 and block are known but unsupported.
std::optional<FileValueType> parseNrrdType(const std::string& text) {
  std::string t;
  for (const std::string& word : tokens(lower(text))) t += (t.empty() ? "" : " ") + word;
  static const std::map<std::string, FileValueType> kTypes = {
      {"signed char", FileValueType::I8},
      {"int8", FileValueType::I8},
      {"int8_t", FileValueType::I8},
      {"uchar", FileValueType::U8},
      {"unsigned char", FileValueType::U8},
      {"uint8", FileValueType::U8},
      {"uint8_t", FileValueType::U8},
      {"short", FileValueType::I16},
      {"short int", FileValueType::I16},
      {"signed short", FileValueType::I16},
      {"signed short int", FileValueType::I16},
      {"int16", FileValueType::I16},
      {"int16_t", FileValueType::I16},
      {"ushort", FileValueType::U16},
      {"unsigned short", FileValueType::U16},
      {"unsigned short int", FileValueType::U16},
      {"uint16", FileValueType::U16},
      {"uint16_t", FileValueType::U16},
      {"int", FileValueType::I32},
      {"signed int", FileValueType::I32},
      {"int32", FileValueType::I32},
      {"int32_t", FileValueType::I32},
      {"uint", FileValueType::U32},
      {"unsigned int", FileValueType::U32},
      {"uint32", FileValueType::U32},
      {"uint32_t", FileValueType::U32},
      {"float", FileValueType::F32},
      {"double", FileValueType::F64},
  };
  auto it = kTypes.find(t);
  if (it == kTypes.end()) return std::nullopt;
  return it->second;
}

// from_chars over the whole text; a leading '+' is allowed as in strtod.
template <typename T>
bool parseWhole(const std::string& text, T& value) {
  const char* begin = text.data();
  const char* end = begin + text.size();
  if (begin != end && *begin == '+') ++begin;
  auto [stop, ec] = std::from_chars(begin, end, value);
  return ec == std::errc() && stop == end && begin != end;
}

// The header's fields by canonical (lowercase) name, and where the data starts in an attached file.
struct NrrdHeader {
  std::map<std::string, std::string> fields;
  int64_t dataOffset = -1;  // byte after the blank line; -1 when the header ends at the end of the file
};

std::string canonicalField(const std::string& key) {
  if (key == "datafile") return "data file";
  if (key == "byteskip") return "byte skip";
  if (key == "lineskip") return "line skip";
  return key;
}

NrrdHeader parseHeader(const std::string& path) {
  std::vector<char> prefix(kMaxHeaderBytes);
  {
    ByteStream stream(path, 0, ByteStream::Compression::None);
    prefix.resize(stream.readUpTo(prefix.data(), prefix.size()));
  }
  const std::string text(prefix.begin(), prefix.end());
  if (text.size() < 8 || text.compare(0, 7, "NRRD000") != 0 || !std::isdigit(static_cast<unsigned char>(text[7]))) {
    throw InputError(path + ": not a NRRD file (the first line is not the NRRD000N magic)");
  }
  const bool wholeFile = text.size() < kMaxHeaderBytes || fileSize(path) == static_cast<int64_t>(text.size());

  NrrdHeader header;
  size_t pos = text.find('\n');
  int lineNumber = 1;
  if (pos == std::string::npos) throw InputError(path + ": truncated or corrupt header (nothing after the magic)");
  ++pos;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos && !wholeFile) break;
    const std::string line = trim(text.substr(pos, end == std::string::npos ? std::string::npos : end - pos));
    ++lineNumber;
    if (line.empty()) {
      if (end == std::string::npos) break;
      header.dataOffset = static_cast<int64_t>(end + 1);
      return header;
    }
    pos = end == std::string::npos ? text.size() : end + 1;
    if (line[0] == '#') continue;
    size_t colon = line.find(':');
    if (colon == std::string::npos) {
      throw InputError(path + ": malformed header line " + std::to_string(lineNumber) + ": '" + line + "'");
    }
    if (colon + 1 < line.size() && line[colon + 1] == '=') continue;  // key:=value pairs carry no geometry
    std::string key = canonicalField(lower(trim(line.substr(0, colon))));
    std::string value = trim(line.substr(colon + 1));
    // The file names of "data file: LIST" follow as header lines, so this must be caught before parsing on.
    if (key == "data file" && value.rfind("LIST", 0) == 0) {
      throw InputError(path + ": 'data file: " + value +
                       "' names several data files; only a single data file is "
                       "supported");
    }
    if (!header.fields.emplace(key, std::move(value)).second) {
      throw InputError(path + ": header field '" + key + "' is given twice");
    }
  }
  if (!wholeFile) throw InputError(path + ": truncated or corrupt header (no blank line within the first 1 MiB)");
  return header;
}

// Typed access to the fields, with errors that name the file and the field.
class FieldReader {
 public:
  FieldReader(const std::string& path, const NrrdHeader& header) : mPath(path), mHeader(header) {}

  const std::string* find(const std::string& name) const {
    auto it = mHeader.fields.find(name);
    return it == mHeader.fields.end() ? nullptr : &it->second;
  }

  const std::string& required(const std::string& name) const {
    if (const std::string* value = find(name)) return *value;
    throw InputError(mPath + ": missing required header field '" + name + "'");
  }

  [[noreturn]] void bad(const std::string& name, const std::string& value, const std::string& why = "") const {
    throw InputError(mPath + ": header field '" + name + "' has a bad value '" + value + "'" +
                     (why.empty() ? "" : " (" + why + ")"));
  }

  int64_t integer(const std::string& name, const std::string& text) const {
    int64_t v = 0;
    if (!parseWhole(text, v)) bad(name, text, "expected an integer");
    return v;
  }

  double real(const std::string& name, const std::string& text) const {
    double v = 0;
    if (!parseWhole(text, v)) bad(name, text, "expected a number");
    return v;
  }

  int64_t optionalInteger(const std::string& name, int64_t fallback) const {
    const std::string* value = find(name);
    return value ? integer(name, *value) : fallback;
  }

  const std::string& path() const { return mPath; }

 private:
  const std::string& mPath;
  const NrrdHeader& mHeader;
};

// A "(x,y,z)" vector starting at value[i]; i is moved past the ')'.
std::vector<double> parseVector(const FieldReader& fields, const std::string& name, const std::string& value,
                                size_t& i) {
  if (value[i] != '(') fields.bad(name, value, "expected '(x,y,z)'");
  size_t close = value.find(')', i);
  if (close == std::string::npos) fields.bad(name, value, "missing ')'");
  std::string inner = value.substr(i + 1, close - i - 1);
  std::vector<double> out;
  size_t start = 0;
  while (true) {
    size_t comma = inner.find(',', start);
    double c = fields.real(name, trim(inner.substr(start, comma == std::string::npos ? comma : comma - start)));
    if (!std::isfinite(c)) fields.bad(name, value, "components must be finite");
    out.push_back(c);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  i = close + 1;
  return out;
}

// Each "space directions" vector; empty for a "none" axis.
std::vector<std::vector<double>> directionVectors(const FieldReader& fields, const std::string& value) {
  const std::string name = "space directions";
  std::vector<std::vector<double>> vectors;
  size_t i = 0;
  while ((i = value.find_first_not_of(" \t", i)) != std::string::npos) {
    if (value.compare(i, 4, "none") == 0) {
      vectors.emplace_back();
      i += 4;
      continue;
    }
    if (value[i] != '(') fields.bad(name, value, "expected '(x,y,z)' or 'none' per axis");
    vectors.push_back(parseVector(fields, name, value, i));
  }
  return vectors;
}

// The length of each "space directions" vector; NaN for a "none" axis.
std::vector<double> directionLengths(const FieldReader& fields, const std::string& value) {
  std::vector<double> lengths;
  for (const std::vector<double>& v : directionVectors(fields, value)) {
    double sum = 0;
    for (double c : v) sum += c * c;
    lengths.push_back(v.empty() ? std::nan("") : std::sqrt(sum));
  }
  return lengths;
}

// The signs that turn the "space" field's coordinates into RAS, and whether it is a patient frame. Spaces without
// anatomy (scanner-xyz, 3D-right-handed, 3D-left-handed) keep their coordinates and are not patient frames.
struct SpaceFrame {
  double sign[3] = {1, 1, 1};
  bool patient = false;
};

SpaceFrame parseSpace(const FieldReader& fields, const std::string& value) {
  const std::string v = lower(value);
  SpaceFrame f;
  f.patient = true;
  if (v == "right-anterior-superior" || v == "ras") return f;
  if (v == "left-anterior-superior" || v == "las") {
    f.sign[0] = -1;
    return f;
  }
  if (v == "left-posterior-superior" || v == "lps") {
    f.sign[0] = -1, f.sign[1] = -1;
    return f;
  }
  f.patient = false;
  if (v == "scanner-xyz" || v == "3d-right-handed" || v == "3d-left-handed") return f;
  fields.bad("space", value,
             "supported: right-anterior-superior (RAS), left-anterior-superior (LAS), left-posterior-superior (LPS), "
             "scanner-xyz, 3D-right-handed, 3D-left-handed; time-varying spaces are not");
}

// The orientation from "space", "space directions" and "space origin"; the identity without "space directions" (or
// with a 'none' spatial axis). `spacing` becomes the directions' lengths.
Orientation parseOrientation(const FieldReader& fields, int64_t dimension, Vec3d& spacing) {
  const std::string* dirs = fields.find("space directions");
  if (!dirs) return Orientation{};
  const SpaceFrame space = fields.find("space") ? parseSpace(fields, *fields.find("space")) : SpaceFrame{};
  if (const std::string* sd = fields.find("space dimension"); sd && fields.integer("space dimension", *sd) != 3)
    fields.bad("space dimension", *sd, "only 3 is supported");
  const std::vector<std::vector<double>> vectors = directionVectors(fields, *dirs);
  Directions d;
  d.patient = space.patient;
  for (int a = 0; a < 3; ++a) {
    const std::vector<double>& v = vectors.at(size_t(dimension - 3 + a));
    if (v.empty()) return Orientation{};
    if (v.size() != 3) fields.bad("space directions", *dirs, "each vector needs 3 components");
    for (int b = 0; b < 3; ++b) d.columns[a][b] = space.sign[b] * v[size_t(b)];
  }
  if (const std::string* origin = fields.find("space origin")) {
    size_t i = origin->find_first_not_of(" \t");
    if (i == std::string::npos) fields.bad("space origin", *origin, "expected '(x,y,z)'");
    const std::vector<double> o = parseVector(fields, "space origin", *origin, i);
    if (o.size() != 3) fields.bad("space origin", *origin, "expected 3 components");
    for (int b = 0; b < 3; ++b) d.origin[b] = space.sign[b] * o[size_t(b)];
  }
  return fromDirections(d, fields.path() + ": space directions", spacing);
}

// Spacing of the three spatial axes (the last three), from "space directions" or else "spacings"; 1 where neither is
// given. A spatial axis's spacing must be in range: "nan", a negative or absurd value, or a 'none' direction is
// refused rather than guessed.
Vec3d parseSpacing(const FieldReader& fields, int64_t dimension) {
  std::vector<double> perAxis;
  std::string name;
  if (const std::string* dirs = fields.find("space directions")) {
    name = "space directions";
    perAxis = directionLengths(fields, *dirs);
  } else if (const std::string* spacings = fields.find("spacings")) {
    name = "spacings";
    for (const std::string& t : tokens(*spacings)) perAxis.push_back(fields.real(name, t));
  } else {
    return Vec3d{1, 1, 1};
  }
  if (static_cast<int64_t>(perAxis.size()) != dimension) {
    throw InputError(fields.path() + ": header field '" + name + "' has " + std::to_string(perAxis.size()) +
                     " values, expected " + std::to_string(dimension));
  }
  const double* spatial = perAxis.data() + (dimension - 3);
  for (int a = 0; a < 3; ++a)
    checkSpacingInRange(spatial[a],
                        fields.path() + ": header field '" + name + "' of spatial axis " + std::to_string(a));
  return Vec3d{spatial[0], spatial[1], spatial[2]};
}

std::string resolveDataFile(const FieldReader& fields, const std::string& value) {
  if (value.find('%') != std::string::npos && tokens(value).size() >= 4) {
    throw InputError(fields.path() + ": 'data file: " + value +
                     "' names several data files; only a single data file is supported");
  }
  std::filesystem::path file(value);
  if (file.is_relative()) file = std::filesystem::path(fields.path()).parent_path() / file;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    throw InputError(fields.path() + ": data file '" + value + "' not found (looked for " + file.string() + ")");
  }
  return file.string();
}

/// The volume's size from 'sizes': `dimension` positive values, a leading 1 when there are four.
Vec3i nrrdDims(const FieldReader& fields, int64_t dimension) {
  const std::string& path = fields.path();
  const std::string& sizesText = fields.required("sizes");
  const std::vector<std::string> sizeTokens = tokens(sizesText);
  if (dimension != 3 && dimension != 4) {
    throw InputError(path + ": only 3D scalar volumes are supported (dimension " + std::to_string(dimension) + ")");
  }
  if (static_cast<int64_t>(sizeTokens.size()) != dimension) {
    throw InputError(path + ": header field 'sizes' has " + std::to_string(sizeTokens.size()) + " values, expected " +
                     std::to_string(dimension));
  }
  std::vector<int64_t> sizes;
  for (const std::string& t : sizeTokens) {
    sizes.push_back(fields.integer("sizes", t));
    if (sizes.back() <= 0) fields.bad("sizes", sizesText, "sizes must be positive");
  }
  if (dimension == 4 && sizes[0] != 1) {
    throw InputError(path + ": only 3D scalar volumes are supported (dimension 4 with sizes " + sizesText + ")");
  }
  return {sizes[dimension - 3], sizes[dimension - 2], sizes[dimension - 1]};
}

/// Whether 'encoding' is gzip; raw is the only other one read.
bool nrrdGzip(const FieldReader& fields) {
  const std::string encodingText = lower(fields.required("encoding"));
  if (encodingText == "gzip" || encodingText == "gz") return true;
  if (encodingText != "raw")
    throw InputError(fields.path() + ": unsupported NRRD encoding '" + encodingText + "' (supported: raw, gzip)");
  return false;
}

/// Whether 'endian' is big; required for values wider than a byte.
bool nrrdBigEndian(const FieldReader& fields, FileValueType fileType, const std::string& typeText) {
  if (const std::string* endian = fields.find("endian")) {
    const std::string e = lower(*endian);
    if (e != "little" && e != "big") fields.bad("endian", *endian, "expected little or big");
    return e == "big";
  }
  if (fileValueSize(fileType) > 1) {
    throw InputError(fields.path() + ": missing required header field 'endian' (needed for type '" + typeText + "')");
  }
  return false;
}

/// The voxel data: in the header's file after the blank line or in 'data file', after 'line skip' lines and
/// 'byte skip' bytes. Sets `dataPath` to the file it is in.
std::unique_ptr<ByteStream> openNrrdData(const FieldReader& fields, const NrrdHeader& header, bool gzip,
                                         int64_t dataBytes, std::string& dataPath) {
  const int64_t lineSkip = fields.optionalInteger("line skip", 0);
  if (lineSkip < 0) fields.bad("line skip", std::to_string(lineSkip), "must be >= 0");
  const int64_t byteSkip = fields.optionalInteger("byte skip", 0);
  if (byteSkip < -1) fields.bad("byte skip", std::to_string(byteSkip), "must be >= -1");
  if (byteSkip == -1 && gzip) fields.bad("byte skip", "-1", "-1 is only allowed with raw encoding");
  dataPath = fields.path();
  int64_t start = header.dataOffset;
  if (const std::string* dataFile = fields.find("data file")) {
    dataPath = resolveDataFile(fields, *dataFile);
    start = 0;
  }
  // A detached data file's errors name it; the header that points at it is named too.
  try {
    start = offsetAfterLines(dataPath, start, lineSkip);
    return openVoxelData(dataPath, start, byteSkip, gzip, dataBytes);
  } catch (const InputError& e) {
    if (dataPath == fields.path()) throw;
    throw InputError(fields.path() + ": data file: " + e.what());
  } catch (const IoError& e) {
    if (dataPath == fields.path()) throw;
    throw IoError(fields.path() + ": data file: " + e.what());
  }
}

}  // namespace

std::unique_ptr<VolumeSource> openNrrdSource(const std::string& path, const SourceOptions& options) {
  const NrrdHeader header = parseHeader(path);
  const FieldReader fields(path, header);
  // Without a blank line the data can only be elsewhere; otherwise the header was cut short.
  if (header.dataOffset < 0 && !fields.find("data file")) {
    throw InputError(path + ": truncated or corrupt header (no blank line after it and no 'data file' field)");
  }

  const std::string& typeText = fields.required("type");
  const std::optional<FileValueType> fileType = parseNrrdType(typeText);
  if (!fileType) throw InputError(path + ": unsupported NRRD type '" + typeText + "'");
  const int64_t dimension = fields.integer("dimension", fields.required("dimension"));
  const Vec3i dims = nrrdDims(fields, dimension);
  const int64_t dataBytes = checkedVolumeBytes(dims, fileValueSize(*fileType), path);
  checkSliceFitsMemory(dims.x, dims.y, fileValueSize(*fileType), options, path, "'sizes'");
  const bool gzip = nrrdGzip(fields);
  const bool bigEndian = nrrdBigEndian(fields, *fileType, typeText);

  // The header's spacing is checked only where it is used: --spacing replaces it.
  Vec3d spacing = options.spacingGiven ? options.spacing : parseSpacing(fields, dimension);
  const Orientation orientation = parseOrientation(fields, dimension, spacing);
  if (options.spacingGiven) spacing = options.spacing;
  checkSpacing(spacing, path);

  std::string dataPath;
  std::unique_ptr<ByteStream> stream = openNrrdData(fields, header, gzip, dataBytes, dataPath);
  Conversion conversion;
  conversion.from = *fileType;
  conversion.swapBytes = fileValueSize(*fileType) > 1 && needsSwap(bigEndian);

  VolumeInfo info;
  info.dims = dims;
  info.spacing = spacing;
  info.orientation = orientation;
  info.type = conversion.to();
  info.background = 0.0;
  info.description = "NRRD " + std::string(fileValueTypeName(*fileType)) + (gzip ? " gzip " : " raw ") +
                     dimsText(dims) + " (" + baseName(path) + ")";
  return std::make_unique<DenseSource>(std::move(info), std::move(stream), conversion, dataPath);
}

}  // namespace voxbrick::store
