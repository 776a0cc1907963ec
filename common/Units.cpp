#include "common/Units.h"

#include <algorithm>
#include <cstdio>

namespace voxbrick::common {

std::string formatBytes(double bytes) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB"};
  int u = 0;
  while (bytes >= 1000 && u < 4) bytes /= 1000, ++u;
  char text[32];
  std::snprintf(text, sizeof text, u == 0 ? "%.0f %s" : "%.1f %s", bytes, units[u]);
  return text;
}

std::string textTable(const std::vector<std::vector<std::string>>& rows, size_t firstNumber) {
  std::vector<size_t> width;
  for (const auto& row : rows) {
    if (width.size() < row.size()) width.resize(row.size());
    for (size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
  }
  std::string text;
  for (const auto& row : rows) {
    std::string line;
    for (size_t c = 0; c < row.size(); ++c) {
      const std::string pad(width[c] - row[c].size(), ' ');
      line += (c ? "  " : "") + (c >= firstNumber ? pad + row[c] : row[c] + (c + 1 < row.size() ? pad : ""));
    }
    text += "\n" + line;
  }
  return text;
}

}  // namespace voxbrick::common
