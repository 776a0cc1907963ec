// Chooses the ingest source for an input by its form (prefix, file name ending, directory, glob, DICOM preamble).
#include <glob.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "brickstore/format/Errors.h"
#include "brickstore/format/InputErrors.h"
#include "brickstore/ingest/Sources.h"
#include "brickstore/ingest/dicom/DicomStructure.h"
#include "brickstore/ingest/dicomweb/DicomWebFetch.h"
#include "brickstore/ingest/dicomweb/DicomWebUrl.h"
#include "brickstore/zarr/ZarrMeta.h"

namespace voxbrick::store {
namespace {

bool endsWith(std::string s, std::string_view suffix) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

bool isTiffName(const std::string& path) { return endsWith(path, ".tif") || endsWith(path, ".tiff"); }

/// A DICOM file: named *.dcm, a Part 10 file (the "DICM" magic after its 128-byte preamble), or one without the
/// preamble (a meta header first, or a bare data set without one), whatever its name.
bool isDicomFile(const std::string& path) {
  if (endsWith(path, ".dcm")) return true;
  if (std::filesystem::path(path).filename() == "DICOMDIR") return false;  // an index of a medium, not an image
  char head[132] = {};
  std::ifstream in(path, std::ios::binary);
  return (in.read(head, sizeof head) && std::memcmp(head + 128, "DICM", 4) == 0) || looksLikeDicomDataSet(path);
}

/// Natural order: runs of digits compare as numbers, so "slice2" sorts before "slice10".
bool naturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit((unsigned char)a[i]) && std::isdigit((unsigned char)b[j])) {
      size_t ei = i, ej = j;
      while (ei < a.size() && std::isdigit((unsigned char)a[ei])) ++ei;
      while (ej < b.size() && std::isdigit((unsigned char)b[ej])) ++ej;
      std::string_view x(a.data() + i, ei - i), y(b.data() + j, ej - j);
      while (x.size() > 1 && x.front() == '0') x.remove_prefix(1);
      while (y.size() > 1 && y.front() == '0') y.remove_prefix(1);
      if (x.size() != y.size()) return x.size() < y.size();
      if (x != y) return x < y;
      i = ei, j = ej;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  return a.size() - i < b.size() - j || (a.size() - i == b.size() - j && a < b);
}

void sortNaturally(std::vector<std::string>& files) { std::sort(files.begin(), files.end(), naturalLess); }

/// The paths a shell pattern matches, in natural order; throws InputError when none does.
std::vector<std::string> expandGlob(const std::string& pattern) {
  glob_t g{};
  const int rc = ::glob(pattern.c_str(), 0, nullptr, &g);
  std::vector<std::string> files;
  if (rc == 0)
    for (size_t i = 0; i < g.gl_pathc; ++i) files.emplace_back(g.gl_pathv[i]);
  globfree(&g);
  if (files.empty()) throw InputError(pattern + ": no file matches");
  sortNaturally(files);
  return files;
}

/// The regular, not hidden files of a directory (not its subdirectories), in natural order.
std::vector<std::string> directoryFiles(const std::string& dir) {
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().filename().string().front() != '.') files.push_back(e.path().string());
  if (ec) throw InputError(dir + ": cannot list the directory: " + ec.message());
  sortNaturally(files);
  return files;
}

/// A directory: its DICOMDIR's series, its DICOM series, or its TIFF files as a stack.
std::unique_ptr<VolumeSource> openDirectory(const std::string& dir, const SourceOptions& options) {
  std::vector<std::string> dicom, tiff;
  for (const std::string& f : directoryFiles(dir)) {
    if (isTiffName(f))
      tiff.push_back(f);
    else if (isDicomFile(f))
      dicom.push_back(f);
  }
  if (!dicom.empty() && !tiff.empty())
    throw InputError(dir + ": holds both DICOM (" + std::to_string(dicom.size()) + ") and TIFF (" +
                     std::to_string(tiff.size()) + ") files; name the ones to read with a pattern such as '" + dir +
                     "/*.tif'");
  if (std::filesystem::is_regular_file(dir + "/DICOMDIR")) return openDicomDir(dir + "/DICOMDIR", options);
  if (!dicom.empty()) return openDicomSeries(dicom, options, "", dir);
  if (!tiff.empty()) return openTiffSource(tiff, options);
  throw InputError(dir +
                   ": is a directory without DICOM or TIFF files (expected a volume file, a DICOM series or a "
                   "TIFF stack)");
}

/// The DICOM files beside `file` (its directory), for the series `file` belongs to.
std::vector<std::string> dicomSiblings(const std::string& file) {
  std::filesystem::path dir = std::filesystem::path(file).parent_path();
  std::vector<std::string> files;
  for (const std::string& f : directoryFiles(dir.empty() ? "." : dir.string()))
    if (!isTiffName(f) && isDicomFile(f))
      files.push_back(dir.empty() ? std::filesystem::path(f).filename().string() : f);
  if (std::find(files.begin(), files.end(), file) == files.end()) files.push_back(file);
  return files;
}

/// Runs `fn`, which reads the fetched series' folder, with its errors naming the DICOMweb input and the instances'
/// files by name: the folder is a temporary one, of no use in a message.
template <typename F>
decltype(auto) namingFetched(const FetchedSeries& fetched, F&& fn) {
  try {
    return std::forward<F>(fn)();
  } catch (const InputError& e) {
    std::string message = e.what();
    const std::string dir = fetched.directory().string();
    for (size_t at; (at = message.find(dir + "/")) != std::string::npos;) message.erase(at, dir.size() + 1);
    for (size_t at; (at = message.find(dir)) != std::string::npos;) message.replace(at, dir.size(), fetched.input());
    if (message.find(fetched.input()) == std::string::npos) message = fetched.input() + ": " + message;
    if (dynamic_cast<const CorruptStoreError*>(&e) != nullptr) throw CorruptStoreError(message);
    throw InputError(message);
  }
}

/// A DICOMweb series read from the folder it was fetched into, which lives as long as the source.
class FetchedSource final : public VolumeSource {
 public:
  FetchedSource(std::unique_ptr<FetchedSeries> fetched, std::unique_ptr<VolumeSource> source)
      : mFetched(std::move(fetched)), mSource(std::move(source)) {}
  ~FetchedSource() override { mSource.reset(); }  // closes the files before the folder goes

  const VolumeInfo& info() const override { return mSource->info(); }
  void readSlices(int64_t count, void* dst) override {
    namingFetched(*mFetched, [&] { mSource->readSlices(count, dst); });
  }

 private:
  std::unique_ptr<FetchedSeries> mFetched;
  std::unique_ptr<VolumeSource> mSource;
};

/// dicomweb[s]://...: the series fetched into a folder, then read as that folder (openDirectory) with the fetched
/// series named, as `prep FOLDER --series UID` reads it: the same files give the same store.
std::unique_ptr<VolumeSource> openDicomWebSource(const std::string& input, const SourceOptions& options) {
  std::unique_ptr<FetchedSeries> fetched = fetchDicomWebSeries(input, options);
  SourceOptions folder = options;
  folder.seriesUid = fetched->seriesUid();
  auto source = namingFetched(*fetched, [&] { return openDirectory(fetched->directory().string(), folder); });
  return std::make_unique<FetchedSource>(std::move(fetched), std::move(source));
}

}  // namespace

std::unique_ptr<VolumeSource> openSource(const std::string& input, const SourceOptions& options) {
  constexpr std::string_view kSynthetic = "synthetic:";
  if (input.rfind(kSynthetic, 0) == 0) return openSyntheticSource(input.substr(kSynthetic.size()), options);
  if (isDicomWebInput(input)) return openDicomWebSource(input, options);

  std::error_code ec;
  if (!std::filesystem::exists(input, ec)) {
    if (input.find_first_of("*?[") != std::string::npos) return openSource(expandGlob(input), options);
    requirePath(input);
  }
  if (isZarrDirectory(input)) return openZarrSource(input, options);
  if (options.time != 0 || options.channel != 0)
    throw InputError(input + ": --time and --channel apply to an OME-Zarr directory only");
  if (std::filesystem::is_directory(input, ec)) return openDirectory(input, options);

  if (endsWith(input, ".vdb")) return openVdbSource(input, options);
  if (endsWith(input, ".nrrd") || endsWith(input, ".nhdr")) return openNrrdSource(input, options);
  if (endsWith(input, ".nii") || endsWith(input, ".nii.gz")) return openNiftiSource(input, options);
  if (isTiffName(input)) return openTiffSource({input}, options);
  if (std::filesystem::path(input).filename() == "DICOMDIR") return openDicomDir(input, options);
  // One slice of a series stands for the series: the files of its directory that share its SeriesInstanceUID. A file
  // that is a volume of its own (a multi-frame image, an RT dose grid) is read alone: the files beside it are not.
  if (isDicomFile(input)) {
    if (isDicomVolumeFile(input, options)) return openDicomSeries({input}, options, input, input);
    return openDicomSeries(dicomSiblings(input), options, input, input);
  }
  return openRawSource(input, options);
}

std::unique_ptr<VolumeSource> openSource(const std::vector<std::string>& inputs, const SourceOptions& options) {
  if (inputs.empty()) throw InputError("no input");
  if (inputs.size() == 1) return openSource(inputs.front(), options);
  std::vector<std::string> files = inputs;
  sortNaturally(files);
  size_t tiff = 0, dicom = 0;
  for (const std::string& f : files) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(f, ec)) throw InputError(f + ": no such file (or not a regular file)");
    if (isTiffName(f))
      ++tiff;
    else if (isDicomFile(f))
      ++dicom;
    else
      throw InputError(f +
                       ": neither DICOM nor TIFF; several inputs must be the files of one DICOM series or "
                       "one TIFF stack");
  }
  if (tiff == files.size()) return openTiffSource(files, options);
  if (dicom == files.size())
    return openDicomSeries(files, options, "", std::to_string(files.size()) + " DICOM files from " + files.front());
  throw InputError("the inputs mix DICOM (" + std::to_string(dicom) + ") and TIFF (" + std::to_string(tiff) +
                   ") files");
}

}  // namespace voxbrick::store
