// Checks of numeric options whose errors name readable bounds ("must be between 16 and 1048576 MB, not 0"), in
// place of CLI11's ranges, which print the limits of double (a 309-digit number for PositiveNumber).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "cli/Commands.h"

namespace voxbrick::cli {
std::string formatNumber(double v) {
  char text[64];
  if (v == std::floor(v) && std::fabs(v) < 1e15)
    std::snprintf(text, sizeof text, "%.0f", v);
  else
    std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

CLI::Validator between(double lo, double hi, const std::string& unit) {
  const std::string range = formatNumber(lo) + " and " + formatNumber(hi) + (unit.empty() ? "" : " " + unit);
  CLI::Validator check(
      [lo, hi, range](std::string& input) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(input.c_str(), &end);
        if (input.empty() || end != input.c_str() + input.size() || !(v >= lo && v <= hi))
          return "must be between " + range + ", not '" + input + "'";
        return {};
      },
      "in [" + formatNumber(lo) + ", " + formatNumber(hi) + "]" + (unit.empty() ? "" : " " + unit));
  return check;
}

void addZarrIndexOptions(CLI::App* cmd, int64_t& time, int64_t& channel) {
  cmd->add_option("--time", time, "OME-Zarr: the index along its 't' axis")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--channel", channel, "OME-Zarr: the index along its 'c' axis")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
}

void defaultsInText(CLI::App& app) {
  for (CLI::App* sub : app.get_subcommands({})) defaultsInText(*sub);
  for (CLI::Option* option : app.get_options()) {
    const std::string value = option->get_default_str();
    if (value.empty() || option->get_type_size() == 0) continue;  // no captured default, or a flag
    const std::string text = option->get_description();
    const size_t said = text.find("(default ");
    if (said != std::string::npos) {
      // A default written by hand must be the one the parser holds.
      const std::string written = text.substr(said + 9);
      if (written.compare(0, value.size(), value) != 0 ||
          (written.size() > value.size() && std::string(");, ").find(written[value.size()]) == std::string::npos))
        throw std::logic_error("voxbrick " + app.get_name() + " " + option->get_name() + ": its help says '" +
                               text.substr(said) + "' but its default is " + value);
    } else {
      option->description(text + " (default " + value + ")");
    }
    option->default_str("");
  }
}

}  // namespace voxbrick::cli
