// The DICOM reader's functions (DicomSources.h): the GDCM module's (brickstore/modules/gdcm), loaded on first use.
#include "brickstore/ingest/dicom/DicomSources.h"
#include "common/Modules.h"

VOXBRICK_MODULE_ENTRY_DECLARE(VOXBRICK_DICOM_ENTRY);

namespace voxbrick::store {
namespace {

const DicomModule& dicomModule() {
  static const DicomModule& module = VOXBRICK_MODULE_TABLE(DicomModule, "gdcm", VOXBRICK_DICOM_ENTRY);
  return module;
}

}  // namespace

std::unique_ptr<VolumeSource> openDicomSource(const std::vector<std::string>& files, const SourceOptions& options) {
  return dicomModule().openDicomSource(files, options);
}

std::unique_ptr<VolumeSource> openDicomSeries(const std::vector<std::string>& files, const SourceOptions& options,
                                              const std::string& chosenFile, const std::string& what) {
  return dicomModule().openDicomSeries(files, options, chosenFile, what);
}

bool isDicomVolumeFile(const std::string& file, const SourceOptions& options) {
  return dicomModule().isDicomVolumeFile(file, options);
}

std::unique_ptr<VolumeSource> openDicomDir(const std::string& path, const SourceOptions& options) {
  return dicomModule().openDicomDir(path, options);
}

}  // namespace voxbrick::store
