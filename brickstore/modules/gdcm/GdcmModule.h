// The GDCM module's own functions (libvoxbrick_gdcm.so; GdcmEntries.cpp gives them through its entry): the DICOM
// reader behind brickstore/ingest/dicom/DicomSources.h, which says what each does.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store::dicomGdcm {

std::unique_ptr<VolumeSource> openDicomSource(const std::vector<std::string>& files, const SourceOptions& options);
std::unique_ptr<VolumeSource> openDicomSeries(const std::vector<std::string>& files, const SourceOptions& options,
                                              const std::string& chosenFile, const std::string& what);
bool isDicomVolumeFile(const std::string& file, const SourceOptions& options);
std::unique_ptr<VolumeSource> openDicomDir(const std::string& path, const SourceOptions& options);

}  // namespace voxbrick::store::dicomGdcm
