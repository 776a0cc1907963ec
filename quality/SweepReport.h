// The sweep's report files: sweep.csv (one row per point), sweep.md (the tables and the chosen default), sweep.svg;
// and the number and file helpers the bench reports share.
#pragma once

#include <filesystem>
#include <string>

#include "quality/SweepResult.h"

namespace voxbrick::quality {

/// Writes sweep.csv, sweep.md and sweep.svg into `out`; throws std::runtime_error naming a file it cannot write.
void writeResults(const SweepResult& result, const std::filesystem::path& out);

/// `value` printed with `format` (one double), "inf" for an infinite one (a PSNR of identical images).
std::string formatNumber(const char* format, double value);

/// Writes `text` to `path` (replacing it); throws std::runtime_error naming the file if it cannot.
void writeTextFile(const std::filesystem::path& path, const std::string& text);

}  // namespace voxbrick::quality
