// A DICOMDIR (the index of a DICOM medium, as a CD or a hospital export holds it): the files its directory records
// reference, opened as the DICOM files of a folder (series chosen as for a folder, non-images skipped).
#include <gdcmDataSet.h>
#include <gdcmReader.h>
#include <gdcmSequenceOfItems.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/format/InputErrors.h"
#include "brickstore/ingest/dicom/DicomStructure.h"
#include "brickstore/modules/gdcm/DicomHeader.h"
#include "brickstore/modules/gdcm/GdcmModule.h"

namespace voxbrick::store {
namespace {

/// An item's string value (a CS such as ReferencedFileID), padding removed; "" when absent.
std::string itemText(const gdcm::DataSet& item, uint16_t group, uint16_t element) {
  const gdcm::Tag tag(group, element);
  if (!item.FindDataElement(tag)) return "";
  const gdcm::ByteValue* bv = item.GetDataElement(tag).GetByteValue();
  if (!bv) return "";
  std::string s(bv->GetPointer(), bv->GetLength());
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  return s;
}

/// ReferencedFileID's components (backslash-separated) as a path under `root`; refuses components that leave it.
/// The medium's upper-case names are tried in lower case too (as a copy to a case-sensitive disk may leave them).
std::filesystem::path referencedFile(const std::filesystem::path& root, const std::string& id,
                                     const std::string& dicomdir) {
  std::filesystem::path p = root, lower = root;
  size_t start = 0;
  while (start <= id.size()) {
    const size_t end = std::min(id.find('\\', start), id.size());
    const std::string part = id.substr(start, end - start);
    if (part.empty() || part == "." || part == ".." || part.find('/') != std::string::npos)
      throw InputError(dicomdir + ": ReferencedFileID (0004,1500) '" + id + "' is not a path inside the medium");
    p /= part;
    std::string low = part;
    std::transform(low.begin(), low.end(), low.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    lower /= low;
    start = end + 1;
  }
  std::error_code ec;
  return !std::filesystem::exists(p, ec) && std::filesystem::exists(lower, ec) ? lower : p;
}

/// The files the DICOMDIR's directory records reference, in record order.
std::vector<std::string> referencedFiles(const std::string& path) {
  checkDicomStructure(path);  // before GDCM parses it
  gdcm::Reader reader;
  reader.SetFileName(path.c_str());
  if (!namingInput({path}, [&] { return reader.Read(); }))
    throw InputError(path + ": not a readable DICOMDIR (GDCM could not parse it)");
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  const gdcm::Tag records(0x0004, 0x1220);
  if (!ds.FindDataElement(records))
    throw InputError(path + ": not a DICOMDIR (no DirectoryRecordSequence (0004,1220))");
  const gdcm::SmartPointer<gdcm::SequenceOfItems> sq = ds.GetDataElement(records).GetValueAsSQ();
  const std::filesystem::path root = std::filesystem::path(path).parent_path();
  std::vector<std::string> files;
  for (size_t k = 1; sq && k <= sq->GetNumberOfItems(); ++k) {
    const std::string id = itemText(sq->GetItem(k).GetNestedDataSet(), 0x0004, 0x1500);
    if (id.empty()) continue;  // a patient, study or series record
    const std::filesystem::path file = referencedFile(root, id, path);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec))
      throw InputError(path + ": lists " + id + ", but " + file.string() + " is not a file");
    files.push_back(file.string());
  }
  if (files.empty()) throw InputError(path + ": the DICOMDIR references no files");
  return files;
}

}  // namespace

namespace dicomGdcm {

std::unique_ptr<VolumeSource> openDicomDir(const std::string& path, const SourceOptions& options) {
  quietGdcm();
  return openDicomSeries(referencedFiles(path), options, "", path);
}

}  // namespace dicomGdcm

}  // namespace voxbrick::store
