// Quantities as people read them.
#pragma once

#include <string>
#include <vector>

namespace voxbrick::common {

/// A byte count in decimal units, "12.3 MB" ("512 B" below a kilobyte).
std::string formatBytes(double bytes);

/// `rows` (the first a header) as a table of columns two spaces apart, each line after a newline ("\nA  B\n1  2"):
/// columns from `firstNumber` on right-aligned, the others left-aligned (the last without trailing blanks).
std::string textTable(const std::vector<std::vector<std::string>>& rows, size_t firstNumber);

}  // namespace voxbrick::common
