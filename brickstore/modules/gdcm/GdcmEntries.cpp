// The GDCM module's entry: the DICOM reader's table, as brickstore/ingest/dicom/DicomSources.h declares it.
#include "brickstore/ingest/dicom/DicomSources.h"
#include "brickstore/modules/gdcm/GdcmModule.h"
#include "common/Modules.h"

VOXBRICK_MODULE_ENTRY_DEFINE(VOXBRICK_DICOM_ENTRY) {
  namespace d = voxbrick::store::dicomGdcm;
  static const voxbrick::store::DicomModule table{&d::openDicomSource, &d::openDicomSeries, &d::isDicomVolumeFile,
                                                  &d::openDicomDir};
  return &table;
}
