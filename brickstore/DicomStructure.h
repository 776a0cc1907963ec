// A bounds check of a DICOM file's element structure, made before GDCM parses it: Debian's GDCM is built with
// assertions, which abort the process on a truncated file instead of returning false.
#pragma once

#include <string>

namespace voxbrick::store {

/// Walks the file's elements (the Part 10 meta header, then the data set in its transfer syntax; sequences and
/// encapsulated pixel data item by item) and throws InputError naming the file when one runs past the end of the
/// file or a sequence is not closed. A deflated data set is not walked (only its meta header). Throws IoError when
/// the file cannot be read.
void checkDicomStructure(const std::string& path);

}  // namespace voxbrick::store
