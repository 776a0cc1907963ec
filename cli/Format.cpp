// Small text helpers shared by the subcommands: "a,b,c" triples, "WxH" sizes, byte counts, text files.
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "brickstore/format/Errors.h"
#include "cli/Commands.h"
#include "image/ImageFile.h"

namespace voxbrick::cli {

template <typename T>
void parseTriple(const std::string& text, const std::string& option, T out[3], const std::string& example) {
  size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    size_t end = text.find(',', start);
    if ((end == std::string::npos) != (i == 2))
      throw store::InputError(option + ": must be three comma-separated numbers, not '" + text + "'; e.g. " + example);
    std::string part = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
    try {
      size_t used = 0;
      if constexpr (std::is_integral_v<T>)
        out[i] = static_cast<T>(std::stoll(part, &used));
      else
        out[i] = static_cast<T>(std::stod(part, &used));
      if (used != part.size()) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw store::InputError(option + ": '" + part + "' is not a number, in '" + text + "'; e.g. " + example);
    }
    start = end + 1;
  }
}

template void parseTriple<int64_t>(const std::string&, const std::string&, int64_t[3], const std::string&);
template void parseTriple<double>(const std::string&, const std::string&, double[3], const std::string&);

void parseSize(const std::string& text, const std::string& option, int& width, int& height) {
  char extra = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &width, &height, &extra) != 2)
    throw store::InputError(option + ": must be WxH, not '" + text + "'; e.g. 512x512");
}

std::string provisionalPath(const std::string& output) {
  const std::filesystem::path path(output);
  return (path.parent_path() / (path.stem().string() + ".provisional" + path.extension().string())).string();
}

void writeText(const std::string& path, const std::string& text) {
  image::writeFileAtomically(path, {reinterpret_cast<const uint8_t*>(text.data()), text.size()});
}

}  // namespace voxbrick::cli
