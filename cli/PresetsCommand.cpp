// `voxbrick presets`: every transfer-function preset, where it comes from, and a swatch of its ramp.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "cli/Commands.h"
#include "render/core/TransferFunction.h"
#include "render/core/TransferFunctionPresets.h"

namespace voxbrick::cli {
namespace {

struct PresetsArgs {
  bool json = false, noColor = false;
};

constexpr int kSwatchWidth = 32;

/// A channel in [0, 1] as 0..255.
int byte(double v) { return int(std::lround(std::clamp(v, 0.0, 1.0) * 255)); }

/// The ramp as kSwatchWidth blocks of ANSI 24-bit background colour (straight colour, over the window) on a
/// terminal; as text, opacity as characters of rising ink, since a pipe shows no colour.
std::string swatch(const render::TransferFunction& tf, bool colour) {
  static const std::string ink = " .:-=+*#%@";
  std::string out;
  for (int i = 0; i < kSwatchWidth; ++i) {
    const glm::dvec4 c = tf.evaluate((i + 0.5) / kSwatchWidth);
    if (colour) {
      out += "\x1b[48;2;" + std::to_string(byte(c.r)) + ";" + std::to_string(byte(c.g)) + ";" +
             std::to_string(byte(c.b)) + "m ";
    } else {
      // Opacity 0.5 (most presets' highest) or more is the darkest character.
      const double ink01 = std::clamp(c.a * 2, 0.0, 1.0);
      out += ink[size_t(std::lround(ink01 * double(ink.size() - 1)))];
    }
  }
  return colour ? out + "\x1b[0m" : "|" + out + "|";
}

/// Where a preset comes from, as printed: "built in" or its file.
std::string source(const render::TransferFunctionPresets& presets, const std::string& name) {
  const auto& file = presets.file(name);
  return file ? file->string() : "built in";
}

void runPresets(const PresetsArgs& args) {
  const std::filesystem::path dir = render::TransferFunction::configDirectory() / "tf";
  const render::TransferFunctionPresets presets = render::TransferFunctionPresets::load(dir);
  if (args.json) return (void)std::printf("%s\n", presets.json(true, 2).c_str());
  // Colour only for a person at a terminal: a pipe or a file gets plain text.
  const bool colour = !args.noColor && isatty(STDOUT_FILENO);
  size_t nameWidth = 4;
  for (const std::string& name : presets.names()) nameWidth = std::max(nameWidth, name.size());
  for (const std::string& name : presets.names()) {
    const render::TransferFunction& tf = presets.get(name);
    char refLength[48] = "-";
    if (tf.referenceLength()) std::snprintf(refLength, sizeof(refLength), "%g", *tf.referenceLength());
    std::printf("%-*s  %s  L_ref %-8s  %s\n", int(nameWidth), name.c_str(), swatch(tf, colour).c_str(), refLength,
                source(presets, name).c_str());
  }
}

}  // namespace

void addPresetsCommand(CLI::App& app) {
  auto args = std::make_shared<PresetsArgs>();
  CLI::App* cmd = app.add_subcommand(
      "presets", "List the transfer-function presets: name, a swatch of the ramp, reference length, source");
  cmd->add_flag("--json", args->json, "print a JSON array (name, built_in, file, reference_length, points)");
  cmd->add_flag("--no-color", args->noColor, "no ANSI colour, even on a terminal (the swatch shows opacity)");
  cmd->callback([args] { runPresets(*args); });
}

}  // namespace voxbrick::cli
