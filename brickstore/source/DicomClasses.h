// Which DICOM SOP classes hold no image a volume is made of: one table for the DICOM reader (which skips such files
// in a folder) and the DICOMweb fetch (which skips such series in a study), so both judge a series alike.
#pragma once

#include <string>
#include <string_view>

namespace voxbrick::store {

/// What an instance of SOP class `sopClassUid` is when it holds no image ("RT plan", "structured report", ...); ""
/// for an image, or a class not known here (read as an image).
std::string dicomNonImageKind(std::string_view sopClassUid);

}  // namespace voxbrick::store
