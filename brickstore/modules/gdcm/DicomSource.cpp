// DICOM series input through GDCM: every file identified first (series, SOP class; what is not an image is skipped),
// then the chosen series' slices (single-frame files, or the frames of an enhanced multi-frame image or an RT dose
// grid) read, sorted along the slice normal and checked; pixels are decoded a file at a time as prep streams.
#include <gdcmImage.h>
#include <gdcmImageReader.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "brickstore/format/Convert.h"
#include "brickstore/format/Errors.h"
#include "brickstore/format/InputErrors.h"
#include "brickstore/ingest/dicom/DicomStructure.h"
#include "brickstore/modules/gdcm/DicomHeader.h"
#include "brickstore/modules/gdcm/GdcmModule.h"
#include "common/Units.h"

namespace voxbrick::store {
namespace {

using Vec = Orientation::Vec;

constexpr double kSpacingTolerance = 0.01;    // slice steps may differ from the series' step by 1 %
constexpr double kDirectionTolerance = 1e-4;  // direction cosines of two slices count as equal within this

Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
/// DICOM's patient frame is LPS; the store's is RAS.
Vec lpsToRas(const Vec& a) { return {-a[0], -a[1], a[2]}; }

std::string number(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

std::string vecText(const Vec& v) { return number(v[0]) + "\\" + number(v[1]) + "\\" + number(v[2]); }

/// Refuses what this reader cannot turn into one scalar slice, by name.
void checkSupported(const SliceHeader& h) {
  const std::string& f = h.file;
  if (!h.decodable) throw InputError(f + ": unsupported transfer syntax " + h.syntaxText);
  if (h.samples != 1 || (h.photometric != "" && h.photometric != "MONOCHROME1" && h.photometric != "MONOCHROME2"))
    throw InputError(f + ": colour images are not supported (SamplesPerPixel " + std::to_string(h.samples) +
                     ", PhotometricInterpretation '" + h.photometric + "'); only greyscale (MONOCHROME1/2)");
  if (h.frames < 1) throw InputError(f + ": NumberOfFrames " + std::to_string(h.frames) + " is not positive");
  if (h.bitsAllocated != 8 && h.bitsAllocated != 16 && h.bitsAllocated != 32)
    throw InputError(f + ": BitsAllocated " + std::to_string(h.bitsAllocated) + " is not supported (8, 16 or 32)");
  if (h.bitsStored < 1 || h.bitsStored > h.bitsAllocated || h.highBit != h.bitsStored - 1)
    throw InputError(f + ": unsupported bit layout (BitsAllocated " + std::to_string(h.bitsAllocated) +
                     ", BitsStored " + std::to_string(h.bitsStored) + ", HighBit " + std::to_string(h.highBit) + ")");
  if (h.rows < 1 || h.columns < 1 || h.rows > 65535 || h.columns > 65535)
    throw InputError(f + ": bad image size " + std::to_string(h.columns) + "x" + std::to_string(h.rows));
  if (!(h.rowSpacing > 0) || !(h.columnSpacing > 0))
    throw InputError(h.name() + ": PixelSpacing must be positive (" + number(h.rowSpacing) + "\\" +
                     number(h.columnSpacing) + ")");
  if (!(std::fabs(h.slope) > 0))
    throw InputError(h.name() + (h.dose ? ": DoseGridScaling is 0" : ": RescaleSlope is 0"));
}

/// The header's pixel format, to check the pixel data's length and encoding against.
DicomPixelFormat pixelFormat(const SliceHeader& h) {
  return {h.rows, h.columns, h.frames, h.samples, h.bitsAllocated, h.encapsulatedSyntax, h.syntaxText, h.syntaxUid};
}

/// The most of a deflated data set inflated before it is refused: 128 MB (a 16-bit slice of 8192 x 8192 with its
/// header), less under a --memory below 512 MB.
uint64_t maxInflatedBytes(const SourceOptions& options) {
  constexpr uint64_t kMax = uint64_t{128} << 20;
  return options.memoryBudgetMB > 0 ? std::min(kMax, uint64_t(options.memoryBudgetMB) << 18) : kMax;
}

/// The image series as a table, one per line under a header: UID, modality, description, image size, slices and
/// files; for the listing that asks for --series (each line starts with a newline).
std::string seriesList(const std::map<std::string, std::vector<DicomFileEntry>>& series) {
  std::vector<std::vector<std::string>> rows = {{"UID", "modality", "description", "size", "slices", "files"}};
  for (const auto& [uid, files] : series) {
    const DicomFileEntry& a = files.front();
    int64_t slices = 0;
    for (const DicomFileEntry& f : files) slices += f.frames;
    std::string description = a.description.empty() ? "-" : a.description;
    if (description.size() > 40) description = description.substr(0, 37) + "...";
    rows.push_back({uid, a.modality.empty() ? "-" : a.modality, description,
                    std::to_string(a.columns) + "x" + std::to_string(a.rows), std::to_string(slices),
                    std::to_string(files.size())});
  }
  return common::textTable(rows, 4);  // slices and files right-aligned
}

/// " (skipped, not images: rtplan.dcm (RT plan), ...)" for the files that are not images; "" when none.
std::string skippedList(const std::vector<DicomFileEntry>& skipped) {
  if (skipped.empty()) return "";
  std::string text;
  for (size_t k = 0; k < skipped.size() && k < 6; ++k)
    text += (k ? ", " : "") + baseName(skipped[k].file) + " (" + skipped[k].notImage + ")";
  if (skipped.size() > 6) text += " and " + std::to_string(skipped.size() - 6) + " more";
  return " (skipped, not images: " + text + ")";
}

/// The files of one image series: options.seriesUid, else the series of `chosenFile`, else the only image series
/// with pixel data. Files that are not images (reports, plans, structure sets, ...) and other series are skipped
/// before any file is validated as an image; several image series and none chosen list them.
std::vector<DicomFileEntry> selectSeries(std::vector<DicomFileEntry> all, const std::string& uid,
                                         const std::string& chosenFile, const std::string& what) {
  std::map<std::string, std::vector<DicomFileEntry>> series;
  std::vector<DicomFileEntry> skipped;
  std::string chosenUid = uid;
  for (DicomFileEntry& e : all) {
    if (uid.empty() && e.file == chosenFile) {
      if (!e.notImage.empty())
        throw InputError(e.file + ": is a DICOM " + e.notImage + ", not an image (give an image file, or the folder)");
      chosenUid = e.seriesUid;
    }
    if (!e.notImage.empty())
      skipped.push_back(std::move(e));
    else
      series[e.seriesUid].push_back(std::move(e));
  }
  if (chosenUid.empty()) {
    std::vector<std::string> withPixels;
    for (const auto& [id, files] : series)
      if (std::any_of(files.begin(), files.end(), [](const DicomFileEntry& f) { return f.layout.hasPixelData; }))
        withPixels.push_back(id);
    if (withPixels.empty()) throw InputError(what + ": holds no DICOM image series" + skippedList(skipped));
    if (withPixels.size() > 1)
      throw InputError(what + ": holds " + std::to_string(withPixels.size()) +
                       " DICOM image series; pick one with --series UID" + skippedList(skipped) + ":" +
                       seriesList(series));
    chosenUid = withPixels.front();
  }
  auto it = series.find(chosenUid);
  if (it != series.end()) return std::move(it->second);
  for (const DicomFileEntry& e : skipped)
    if (e.seriesUid == chosenUid)
      throw InputError(what + ": DICOM series " + chosenUid + " holds no image (" + baseName(e.file) + " is a " +
                       e.notImage + ")");
  throw InputError(what + ": no DICOM image series " + chosenUid + "; found " +
                   (series.empty() ? std::string("none") : std::to_string(series.size()) + ":" + seriesList(series)));
}

/// A multi-frame image or an RT dose grid is a volume of its own: the named file alone when it is one; a series
/// holding one beside other files is refused, asking for a file. Other copies of the named file's instance (its
/// SOPInstanceUID, as another transfer syntax or a second export leaves them) are left out; other duplicates are
/// refused later, by position.
std::vector<DicomFileEntry> oneVolume(std::vector<DicomFileEntry> all, const std::string& chosenFile) {
  std::string chosenInstance;
  for (const DicomFileEntry& e : all)
    if (e.file == chosenFile) chosenInstance = e.sopInstance;
  std::vector<DicomFileEntry> series;
  for (DicomFileEntry& e : all)
    if (chosenInstance.empty() || e.sopInstance != chosenInstance || e.file == chosenFile)
      series.push_back(std::move(e));
  auto own = [](const DicomFileEntry& e) { return e.frames > 1 || e.dose; };
  for (DicomFileEntry& e : series)
    if (e.file == chosenFile && own(e)) return {std::move(e)};
  if (series.size() < 2) return series;
  for (const DicomFileEntry& e : series)
    if (own(e))
      throw InputError(e.file + ": " + (e.dose ? "an RT dose grid" : "a multi-frame image") + " (NumberOfFrames " +
                       std::to_string(e.frames) + "), a volume of its own, beside " +
                       std::to_string(series.size() - 1) + " other file(s) of DICOM series " + e.seriesUid +
                       ": name the file to read");
  return series;
}

bool sameDirection(const Vec& a, const Vec& b) {
  return std::fabs(a[0] - b[0]) <= kDirectionTolerance && std::fabs(a[1] - b[1]) <= kDirectionTolerance &&
         std::fabs(a[2] - b[2]) <= kDirectionTolerance;
}

/// Every slice must match the first in size, pixel format, orientation and pixel spacing.
void checkConsistent(const std::vector<SliceHeader>& slices) {
  const SliceHeader& a = slices.front();
  for (const SliceHeader& b : slices) {
    auto differ = [&](const std::string& what, const std::string& x, const std::string& y) {
      return InputError(b.name() + ": " + what + " " + y + " differs from " + x + " in " + a.name());
    };
    if (b.rows != a.rows || b.columns != a.columns)
      throw differ("size", std::to_string(a.columns) + "x" + std::to_string(a.rows),
                   std::to_string(b.columns) + "x" + std::to_string(b.rows));
    if (b.bitsAllocated != a.bitsAllocated || b.bitsStored != a.bitsStored || b.isSigned != a.isSigned)
      throw differ(
          "pixel format (bits allocated/stored, signed)",
          std::to_string(a.bitsAllocated) + "/" + std::to_string(a.bitsStored) + (a.isSigned ? " signed" : ""),
          std::to_string(b.bitsAllocated) + "/" + std::to_string(b.bitsStored) + (b.isSigned ? " signed" : ""));
    if (!sameDirection(a.row, b.row) || !sameDirection(a.column, b.column))
      throw differ("ImageOrientationPatient", vecText(a.row) + "\\" + vecText(a.column),
                   vecText(b.row) + "\\" + vecText(b.column));
    if (std::fabs(a.rowSpacing - b.rowSpacing) > 1e-4 * a.rowSpacing ||
        std::fabs(a.columnSpacing - b.columnSpacing) > 1e-4 * a.columnSpacing)
      throw differ("PixelSpacing", number(a.rowSpacing) + "\\" + number(a.columnSpacing),
                   number(b.rowSpacing) + "\\" + number(b.columnSpacing));
  }
}

/// Sorts the slices along the normal and returns the slice step; refuses duplicates, gaps, uneven steps and
/// slices not stacked along the normal (a tilted gantry).
double sortAlongNormal(std::vector<SliceHeader>& slices, const Vec& normal, const Vec& row, const Vec& column) {
  for (SliceHeader& s : slices) s.along = dot(s.position, normal);
  std::sort(slices.begin(), slices.end(), [](const SliceHeader& a, const SliceHeader& b) {
    return a.along != b.along ? a.along < b.along : a.file != b.file ? a.file < b.file : a.frame < b.frame;
  });
  if (slices.size() < 2) return 1.0;
  std::vector<double> steps;
  for (size_t k = 1; k < slices.size(); ++k) steps.push_back(slices[k].along - slices[k - 1].along);
  std::vector<double> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
  const double step = sorted[sorted.size() / 2];
  const double inPlaneTolerance = 1e-3 + kSpacingTolerance * std::min(slices[0].rowSpacing, slices[0].columnSpacing);
  for (size_t k = 1; k < slices.size(); ++k) {
    const SliceHeader &a = slices[k - 1], &b = slices[k];
    if (steps[k - 1] <= 1e-3 * std::max(step, 1e-3))
      throw InputError("duplicate slice position: " + a.name() + " and " + b.name() + " both lie at " +
                       number(a.along) + " mm along the slice normal");
    if (std::fabs(steps[k - 1] - step) > kSpacingTolerance * step)
      throw InputError("uneven slice spacing: " + a.name() + " to " + b.name() + " is " + number(steps[k - 1]) +
                       " mm along the slice normal, the series' step is " + number(step) + " mm (a missing slice?)");
    const Vec d = sub(b.position, slices[0].position);
    if (std::fabs(dot(d, row)) > inPlaneTolerance || std::fabs(dot(d, column)) > inPlaneTolerance)
      throw InputError(b.name() + ": slice is shifted in-plane from " + slices[0].name() +
                       " (ImagePositionPatient not along the slice normal: a tilted gantry?); not supported");
  }
  if (!(step > 0)) throw InputError(slices[0].file + ": zero slice step");
  return step;
}

/// The store type: the stored integers when every slice shares an integral rescale whose range fits u8, u16 or i16;
/// else f32 (always for an RT dose grid: Gy).
ValueType outputType(const std::vector<SliceHeader>& slices) {
  const SliceHeader& a = slices.front();
  if (a.dose) return ValueType::F32;
  for (const SliceHeader& s : slices)
    if (s.slope != a.slope || s.intercept != a.intercept) return ValueType::F32;
  if (a.slope != std::round(a.slope) || a.intercept != std::round(a.intercept)) return ValueType::F32;
  const double rawLo = a.isSigned ? -std::ldexp(1.0, a.bitsStored - 1) : 0.0;
  const double rawHi = a.isSigned ? std::ldexp(1.0, a.bitsStored - 1) - 1 : std::ldexp(1.0, a.bitsStored) - 1;
  const double x = a.slope * rawLo + a.intercept, y = a.slope * rawHi + a.intercept;
  const double lo = std::min(x, y), hi = std::max(x, y);
  if (lo >= 0 && hi <= 255) return ValueType::U8;
  if (lo >= 0 && hi <= 65535) return ValueType::U16;
  if (lo >= -32768 && hi <= 32767) return ValueType::I16;
  return ValueType::F32;
}

/// The stored value of a raw sample: the low BitsStored bits, sign-extended for signed pixels.
inline int64_t storedValue(uint32_t bits, int bitsStored, bool isSigned) {
  bits &= bitsStored >= 32 ? ~0u : ((1u << bitsStored) - 1);
  if (isSigned && ((bits >> (bitsStored - 1)) & 1u)) return int64_t(bits) - (int64_t(1) << bitsStored);
  return int64_t(bits);
}

class DicomSource final : public VolumeSource {
 public:
  DicomSource(VolumeInfo info, std::vector<SliceHeader> slices, uint64_t maxInflated)
      : mInfo(std::move(info)), mSlices(std::move(slices)), mMaxInflated(maxInflated) {}

  const VolumeInfo& info() const override { return mInfo; }

  void readSlices(int64_t count, void* dst) override {
    if (count < 0 || mNextZ + count > mInfo.dims.z)
      throw InputError(mSlices.front().file + ": read past the last slice of the series");
    const int64_t plane = mInfo.dims.x * mInfo.dims.y;
    auto* out = static_cast<unsigned char*>(dst);
    for (int64_t k = 0; k < count; ++k, ++mNextZ)
      readSlice(mSlices[size_t(mNextZ)], out + k * plane * int64_t(valueSize(mInfo.type)));
  }

 private:
  /// Decodes the slice's file (GDCM: native or compressed) unless it is the one decoded last (the frames of a
  /// multi-frame file), and writes the slice's rescaled values as the store type.
  void readSlice(const SliceHeader& h, unsigned char* dst) {
    const size_t frameBytes = size_t(mInfo.dims.x * mInfo.dims.y) * size_t(h.bitsAllocated / 8);
    if (mDecoded != h.file) decode(h, frameBytes * size_t(h.frames));
    convert(h, mInfo.dims.x * mInfo.dims.y, mBuffer.data() + frameBytes * size_t(std::max<int64_t>(h.frame, 0)), dst);
  }

  void decode(const SliceHeader& h, size_t bytes) {
    mDecoded.clear();
    // Again: the file may have changed since the source opened.
    checkPixelData(h.file, checkDicomStructure(h.file, mMaxInflated), pixelFormat(h));
    namingInput({h.file}, [&] {
      gdcm::ImageReader reader;
      reader.SetFileName(h.file.c_str());
      if (!reader.Read()) throw InputError(h.file + ": GDCM could not read the image (" + h.syntaxText + ")");
      const gdcm::Image& image = reader.GetImage();
      if (image.GetBufferLength() != bytes)
        throw InputError(h.file + ": decoded pixel data is " + std::to_string(image.GetBufferLength()) +
                         " bytes, expected " + std::to_string(bytes) + " for " + std::to_string(h.frames) + " x " +
                         std::to_string(h.columns) + "x" + std::to_string(h.rows) + " " +
                         std::to_string(h.bitsAllocated) + "-bit pixels");
      mBuffer.resize(bytes);
      if (!image.GetBuffer(mBuffer.data()))
        throw InputError(h.file + ": GDCM could not decode the pixel data (" + h.syntaxText + ")");
    });
    mDecoded = h.file;
  }

  void convert(const SliceHeader& h, int64_t count, const char* src, unsigned char* dst) const {
    dispatchType(mInfo.type, [&](auto zero) {
      using T = decltype(zero);
      T* out = reinterpret_cast<T*>(dst);
      for (int64_t i = 0; i < count; ++i) {
        uint32_t bits;
        if (h.bitsAllocated == 8) {
          bits = uint8_t(src[i]);
        } else if (h.bitsAllocated == 16) {
          uint16_t b;
          std::memcpy(&b, src + 2 * i, 2);
          bits = b;
        } else {
          std::memcpy(&bits, src + 4 * i, 4);
        }
        const double v = h.slope * double(storedValue(bits, h.bitsStored, h.isSigned)) + h.intercept;
        if constexpr (std::is_floating_point_v<T>)
          out[i] = T(v);
        else
          out[i] = T(std::llround(v));
      }
    });
  }

  VolumeInfo mInfo;
  std::vector<SliceHeader> mSlices;
  std::vector<char> mBuffer;  // the decoded pixels of file mDecoded: every frame of it
  std::string mDecoded;
  uint64_t mMaxInflated;
  int64_t mNextZ = 0;
};

/// The volume's dims, spacing, type, orientation and description from the sorted, checked slices.
VolumeInfo volumeInfo(const std::vector<SliceHeader>& slices, const std::array<Vec, 3>& axes, double step,
                      const SourceOptions& options) {
  const SliceHeader& a = slices.front();
  VolumeInfo info;
  info.dims = {a.columns, a.rows, int64_t(slices.size())};
  info.spacing = {a.columnSpacing, a.rowSpacing, step};
  if (options.spacingGiven) info.spacing = options.spacing;
  checkSpacing(info.spacing, a.file);
  info.type = outputType(slices);
  info.orientation.axes = {lpsToRas(axes[0]), lpsToRas(axes[1]), lpsToRas(axes[2])};
  info.orientation.origin = lpsToRas(a.position);
  info.orientation.patient = true;
  const bool rescaled = a.slope != 1 || a.intercept != 0;
  const std::string what = a.dose ? "RT dose grid" : a.frames > 1 ? "multi-frame image" : "series";
  const std::string files = a.frames > 1 ? std::to_string(a.frames) + " frames" : "...";
  info.description = "DICOM " + what + " " + a.seriesUid + (a.description.empty() ? "" : " '" + a.description + "'") +
                     " " + std::to_string(a.bitsStored) + "-bit " + (a.isSigned ? "signed " : "") +
                     dimsText(info.dims) + " " + std::string(valueTypeName(info.type)) +
                     (a.dose     ? " (Gy: DoseGridScaling " + number(a.slope) + ")"
                      : rescaled ? " (rescaled)"
                                 : "") +
                     ", " + a.syntaxText + " (" + baseName(a.file) + ", " + files + ")";
  return info;
}

}  // namespace

namespace dicomGdcm {

std::unique_ptr<VolumeSource> openDicomSeries(const std::vector<std::string>& files, const SourceOptions& options,
                                              const std::string& chosenFile, const std::string& what) {
  if (files.empty()) throw InputError(what + ": no DICOM files");
  quietGdcm();
  std::vector<DicomFileEntry> entries;
  entries.reserve(files.size());
  // With a file or --series named, a damaged file beside them is skipped (and named in the description): it may be
  // of any series. Otherwise, and for the named file itself, it is refused.
  const bool lenient = !chosenFile.empty() || !options.seriesUid.empty();
  std::vector<std::string> unreadable;
  for (const std::string& f : files) {
    try {
      entries.push_back(identifyDicomFile(f, maxInflatedBytes(options)));
    } catch (const InputError&) {
      if (!lenient || f == chosenFile) throw;
      unreadable.push_back(baseName(f));
    }
  }
  std::vector<SliceHeader> slices;
  for (const DicomFileEntry& e :
       oneVolume(selectSeries(std::move(entries), options.seriesUid, chosenFile, what), chosenFile)) {
    std::vector<SliceHeader> frames = readSliceHeaders(e);
    for (const SliceHeader& f : frames) checkSupported(f);
    const SliceHeader& s = frames.front();
    // Before any decoder sizes a buffer from Rows x Columns (x NumberOfFrames): the file's frames must fit --memory,
    // and its pixel data hold them.
    checkSliceFitsMemory(s.columns, s.rows * s.frames, size_t(s.bitsAllocated / 8), options, s.file,
                         s.frames > 1 ? "Rows x Columns x NumberOfFrames" : "Rows x Columns");
    checkPixelData(s.file, s.layout, pixelFormat(s));
    for (SliceHeader& f : frames) slices.push_back(std::move(f));
  }
  checkConsistent(slices);
  const std::array<Vec, 3> axes = directions(slices.front());
  const double step = sortAlongNormal(slices, axes[2], axes[0], axes[1]);
  VolumeInfo info = volumeInfo(slices, axes, step, options);
  if (!unreadable.empty())
    info.description += "; skipped " + std::to_string(unreadable.size()) +
                        " damaged file(s) beside it: " + unreadable.front() + (unreadable.size() > 1 ? ", ..." : "");
  return std::make_unique<DicomSource>(std::move(info), std::move(slices), maxInflatedBytes(options));
}

bool isDicomVolumeFile(const std::string& file, const SourceOptions& options) {
  quietGdcm();
  const DicomFileEntry e = identifyDicomFile(file, maxInflatedBytes(options));
  return e.frames > 1 || e.dose;
}

std::unique_ptr<VolumeSource> openDicomSource(const std::vector<std::string>& files, const SourceOptions& options) {
  return openDicomSeries(files, options, "", files.size() == 1 ? files.front() : "the DICOM input");
}

}  // namespace dicomGdcm

}  // namespace voxbrick::store
