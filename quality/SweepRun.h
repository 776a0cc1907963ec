// Running the time-versus-error sweep: GPU frames of each setting against reference frames of the same views,
// then the Pareto front and the default it implies.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include "quality/SweepResult.h"
#include "render/gl/GlContext.h"

namespace voxbrick::quality {

/// Runs the sweep. Stores go to `work`/NAME-bB.vbs (made once, kept), reference frames to `work`/reference (so a
/// rerun only renders the GPU frames). `log` gets one line per step of progress.
SweepResult runSweep(const SweepSpec& spec, const std::filesystem::path& work, render::GlContext& context,
                     const std::function<void(const std::string&)>& log);

}  // namespace voxbrick::quality
