// The SOP classes that are no images.
#include "brickstore/source/DicomClasses.h"

namespace voxbrick::store {

std::string dicomNonImageKind(std::string_view sop) {
  auto starts = [&](std::string_view prefix) { return sop.substr(0, prefix.size()) == prefix; };
  if (sop == "1.2.840.10008.1.3.10") return "DICOMDIR";
  if (sop == "1.2.840.10008.5.1.4.1.1.481.5" || sop == "1.2.840.10008.5.1.4.1.1.481.8") return "RT plan";
  if (sop == "1.2.840.10008.5.1.4.1.1.481.3") return "RT structure set";
  if (starts("1.2.840.10008.5.1.4.1.1.481.") && sop != "1.2.840.10008.5.1.4.1.1.481.1" &&
      sop != "1.2.840.10008.5.1.4.1.1.481.2")
    return "RT treatment record";
  if (sop == "1.2.840.10008.5.1.4.1.1.88.59") return "key object selection";
  if (starts("1.2.840.10008.5.1.4.1.1.88.")) return "structured report";
  if (starts("1.2.840.10008.5.1.4.1.1.11.")) return "presentation state";
  if (starts("1.2.840.10008.5.1.4.1.1.9.")) return "waveform";
  if (starts("1.2.840.10008.5.1.4.1.1.104.")) return "encapsulated document";
  if (sop == "1.2.840.10008.5.1.4.1.1.66.4") return "segmentation";
  if (starts("1.2.840.10008.5.1.4.1.1.66")) return "raw data or registration";
  return "";
}

}  // namespace voxbrick::store
