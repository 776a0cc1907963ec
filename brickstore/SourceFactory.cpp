// Chooses the ingest source for an input by its form (prefix or file name ending).
#include <algorithm>
#include <cctype>
#include <filesystem>

#include "brickstore/Errors.h"
#include "brickstore/Sources.h"

namespace voxbrick::store {
namespace {

bool endsWith(std::string s, std::string_view suffix) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

std::unique_ptr<VolumeSource> openSource(const std::string& input, const SourceOptions& options) {
  constexpr std::string_view kSynthetic = "synthetic:";
  if (input.rfind(kSynthetic, 0) == 0) return openSyntheticSource(input.substr(kSynthetic.size()), options);

  std::error_code ec;
  if (!std::filesystem::exists(input, ec)) throw InputError(input + ": no such file");
  if (std::filesystem::is_directory(input, ec)) throw InputError(input + ": is a directory, expected a volume file");

  if (endsWith(input, ".vdb")) return openVdbSource(input, options);
  if (endsWith(input, ".nrrd") || endsWith(input, ".nhdr")) return openNrrdSource(input, options);
  if (endsWith(input, ".nii") || endsWith(input, ".nii.gz")) return openNiftiSource(input, options);
  return openRawSource(input, options);
}

}  // namespace voxbrick::store
