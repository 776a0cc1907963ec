// DICOM series writer for tests: every tag the reader needs, set one by one through gdcm::Writer.
#include "support/DicomSeries.h"

#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gdcmTransferSyntax.h>
#include <gdcmWriter.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>

namespace voxbrick::test {
namespace {

Vec3 normalOf(const DicomSeriesSpec& s) {
  const Vec3 &a = s.rowLps, &b = s.columnLps;
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

Vec3 positionLps(const DicomSeriesSpec& s, double i, double j, double k) {
  const Vec3 n = normalOf(s);
  Vec3 p;
  for (int a = 0; a < 3; ++a)
    p[size_t(a)] = s.originLps[size_t(a)] + i * s.spacing[0] * s.rowLps[size_t(a)] +
                   j * s.spacing[1] * s.columnLps[size_t(a)] + k * s.spacing[2] * n[size_t(a)];
  return p;
}

std::string decimals(std::initializer_list<double> values) {
  std::ostringstream out;
  out.precision(10);
  bool first = true;
  for (double v : values) out << (first ? "" : "\\") << v, first = false;
  return out.str();
}

void putText(gdcm::DataSet& ds, uint16_t group, uint16_t element, gdcm::VR vr, std::string value) {
  if (value.size() % 2) value += vr == gdcm::VR::UI ? '\0' : ' ';
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), uint32_t(value.size()));
  ds.Replace(de);
}

void putUs(gdcm::DataSet& ds, uint16_t group, uint16_t element, uint16_t value) {
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(gdcm::VR::US);
  de.SetByteValue(reinterpret_cast<const char*>(&value), 2);
  ds.Replace(de);
}

/// The stored pixels of slice k, little endian.
std::vector<char> pixels(const DicomSeriesSpec& s, int k, const std::function<double(const Vec3&)>& value) {
  const size_t bytes = size_t(s.bitsAllocated / 8);
  const double lo = s.isSigned ? -std::ldexp(1.0, s.bitsAllocated - 1) : 0.0;
  const double hi = s.isSigned ? std::ldexp(1.0, s.bitsAllocated - 1) - 1 : std::ldexp(1.0, s.bitsAllocated) - 1;
  std::vector<char> out(size_t(s.dims[0]) * size_t(s.dims[1]) * bytes);
  for (int j = 0; j < s.dims[1]; ++j)
    for (int i = 0; i < s.dims[0]; ++i) {
      const double stored = std::clamp(std::round((value(dicomVoxelRas(s, i, j, k)) - s.intercept) / s.slope), lo, hi);
      const auto bits = uint16_t(int64_t(stored));
      std::memcpy(out.data() + (size_t(j) * size_t(s.dims[0]) + size_t(i)) * bytes, &bits, bytes);
    }
  return out;
}

void fillDataSet(gdcm::DataSet& ds, const DicomSeriesSpec& s, int k, const std::vector<char>& px) {
  const Vec3 p = positionLps(s, 0, 0, k);
  putText(ds, 0x0008, 0x0016, gdcm::VR::UI, "1.2.840.10008.5.1.4.1.1.2");  // CT Image Storage
  putText(ds, 0x0008, 0x0018, gdcm::VR::UI, s.seriesUid + "." + std::to_string(k + 1));
  putText(ds, 0x0008, 0x0060, gdcm::VR::CS, "CT");
  putText(ds, 0x0008, 0x103E, gdcm::VR::LO, s.description);
  putText(ds, 0x0020, 0x000D, gdcm::VR::UI, "1.2.826.0.1.3680043.9.7777");
  putText(ds, 0x0020, 0x000E, gdcm::VR::UI, s.seriesUid);
  putText(ds, 0x0020, 0x0013, gdcm::VR::IS, std::to_string(k + 1));
  putText(ds, 0x0020, 0x0032, gdcm::VR::DS, decimals({p[0], p[1], p[2]}));
  putText(ds, 0x0020, 0x0037, gdcm::VR::DS,
          decimals({s.rowLps[0], s.rowLps[1], s.rowLps[2], s.columnLps[0], s.columnLps[1], s.columnLps[2]}));
  putUs(ds, 0x0028, 0x0002, 1);
  putText(ds, 0x0028, 0x0004, gdcm::VR::CS, "MONOCHROME2");
  putUs(ds, 0x0028, 0x0010, uint16_t(s.dims[1]));
  putUs(ds, 0x0028, 0x0011, uint16_t(s.dims[0]));
  putText(ds, 0x0028, 0x0030, gdcm::VR::DS, decimals({s.spacing[1], s.spacing[0]}));  // row spacing \ column spacing
  putUs(ds, 0x0028, 0x0100, uint16_t(s.bitsAllocated));
  putUs(ds, 0x0028, 0x0101, uint16_t(s.bitsAllocated));
  putUs(ds, 0x0028, 0x0102, uint16_t(s.bitsAllocated - 1));
  putUs(ds, 0x0028, 0x0103, s.isSigned ? 1 : 0);
  putText(ds, 0x0028, 0x1052, gdcm::VR::DS, decimals({s.intercept}));
  putText(ds, 0x0028, 0x1053, gdcm::VR::DS, decimals({s.slope}));
  gdcm::DataElement data(gdcm::Tag(0x7FE0, 0x0010));
  data.SetVR(s.bitsAllocated == 8 ? gdcm::VR::OB : gdcm::VR::OW);
  data.SetByteValue(px.data(), uint32_t(px.size()));
  ds.Replace(data);
}

/// Rewrites a written file with compressed pixel data (JPEG-LS lossless or RLE), as gdcmconv does.
void compress(const std::filesystem::path& file, gdcm::TransferSyntax::TSType syntax) {
  gdcm::ImageReader reader;
  reader.SetFileName(file.c_str());
  if (!reader.Read()) throw std::runtime_error("writeDicomSlice: cannot read back " + file.string());
  gdcm::ImageChangeTransferSyntax change;
  change.SetTransferSyntax(syntax);
  change.SetInput(reader.GetImage());
  if (!change.Change()) throw std::runtime_error("writeDicomSlice: GDCM cannot compress " + file.string());
  gdcm::ImageWriter writer;
  writer.SetFileName(file.c_str());
  writer.SetFile(reader.GetFile());
  writer.SetImage(change.GetOutput());
  if (!writer.Write()) throw std::runtime_error("writeDicomSlice: cannot write " + file.string());
}

}  // namespace

Vec3 dicomVoxelRas(const DicomSeriesSpec& spec, int i, int j, int k) {
  const Vec3 p = positionLps(spec, i, j, k);
  return {-p[0], -p[1], p[2]};
}

void writeDicomSlice(const std::filesystem::path& file, const DicomSeriesSpec& spec, int k,
                     const std::function<double(const Vec3& ras)>& value) {
  gdcm::Writer writer;
  writer.SetFileName(file.c_str());
  fillDataSet(writer.GetFile().GetDataSet(), spec, k, pixels(spec, k, value));
  const bool special = !spec.transferSyntax.empty() && spec.transferSyntax != "jpegls" && spec.transferSyntax != "rle";
  gdcm::TransferSyntax ts = gdcm::TransferSyntax::ExplicitVRLittleEndian;
  if (special) ts = gdcm::TransferSyntax::GetTSType(spec.transferSyntax.c_str());
  writer.GetFile().GetHeader().SetDataSetTransferSyntax(ts);
  if (!writer.Write()) throw std::runtime_error("writeDicomSlice: GDCM cannot write " + file.string());
  if (spec.transferSyntax == "jpegls") compress(file, gdcm::TransferSyntax::JPEGLSLossless);
  if (spec.transferSyntax == "rle") compress(file, gdcm::TransferSyntax::RLELossless);
}

std::vector<std::filesystem::path> writeDicomSeries(const std::filesystem::path& dir, const DicomSeriesSpec& spec,
                                                    const std::function<double(const Vec3& ras)>& value) {
  std::filesystem::create_directories(dir);
  std::vector<int> names(size_t(spec.dims[2]));
  std::iota(names.begin(), names.end(), 0);
  if (spec.shuffleSeed != 0) std::shuffle(names.begin(), names.end(), std::mt19937(spec.shuffleSeed));
  std::vector<std::filesystem::path> files;
  for (int k = 0; k < spec.dims[2]; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "%03d.dcm", names[size_t(k)]);
    files.push_back(dir / (spec.prefix + name));
    writeDicomSlice(files.back(), spec, k, value);
  }
  return files;
}

}  // namespace voxbrick::test
