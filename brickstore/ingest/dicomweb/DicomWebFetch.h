// A DICOMweb series fetched from a PACS into a folder of its own: QIDO-RS lists its instances, WADO-RS retrieves
// them a few at a time, each streamed from its multipart answer into its own file (memory stays bounded whatever the
// series' size). What the folder holds is then read as any folder of DICOM files is (brickstore/ingest).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// The instances of one series in a folder created for them, removed with everything in it when this is destroyed.
class FetchedSeries {
 public:
  FetchedSeries(std::filesystem::path directory, std::string input, std::string seriesUid);
  ~FetchedSeries();
  FetchedSeries(const FetchedSeries&) = delete;
  FetchedSeries& operator=(const FetchedSeries&) = delete;

  /// The folder: one file a fetched instance, named SOPINSTANCEUID.dcm.
  const std::filesystem::path& directory() const { return mDirectory; }
  /// The dicomweb:// input as given.
  const std::string& input() const { return mInput; }
  /// The series fetched (the URL's, or the one --series or the study's listing chose).
  const std::string& seriesUid() const { return mSeriesUid; }
  /// Instances fetched and the bytes received (multipart framing included, retries counted again).
  int64_t instances = 0;
  uint64_t bytesReceived = 0;

 private:
  std::filesystem::path mDirectory;
  std::string mInput, mSeriesUid;
};

/// Fetches the series `input` (dicomweb[s]://HOST[:PORT]/PATH/studies/STUDY/series/SERIES) names, or for a study URL
/// (.../studies/STUDY) the series options.seriesUid names, else its one series whose modality is an image's (SR, KO,
/// PR, RT plans and structures, ... skipped), into a new folder under options.dicomWeb.downloadDir. Throws InputError
/// naming the input and the request's URL: a malformed URL, HTTP errors by status (401 and 403 as credentials refused,
/// 404 as no such series), a connection refused or cut (after the retries), a malformed answer; a study of several
/// image series lists them and asks for --series. StoreError "interrupted" when options.dicomWeb.cancelled says so.
/// Nothing is left on disk when it throws.
std::unique_ptr<FetchedSeries> fetchDicomWebSeries(const std::string& input, const SourceOptions& options);

}  // namespace voxbrick::store
