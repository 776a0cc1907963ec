// The subcommands of `voxbrick`: each registers its options on the app and runs when selected.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

#include "common/Units.h"

namespace voxbrick::cli {

/// Adds `prep` to the app.
void addPrepCommand(CLI::App& app);
/// Adds `info` to the app.
void addInfoCommand(CLI::App& app);
/// Adds `render` to the app.
void addRenderCommand(CLI::App& app);
/// Adds `orbit` (a turntable of frames) to the app.
void addOrbitCommand(CLI::App& app);
/// Adds `serve` to the app.
void addServeCommand(CLI::App& app);
/// Adds `request` to the app.
void addRequestCommand(CLI::App& app);
/// Adds `load` to the app.
void addLoadCommand(CLI::App& app);
/// Adds `compare` to the app.
void addCompareCommand(CLI::App& app);
/// Adds `bench` to the app.
void addBenchCommand(CLI::App& app);
/// Adds `presets` (the transfer-function presets) to the app.
void addPresetsCommand(CLI::App& app);
/// Adds `scene` (the scene the scene options make, or the scene's schema) to the app.
void addSceneCommand(CLI::App& app);
/// Adds `token` (a new access token: its secret and its [[tokens]] entry for server.toml) to the app.
void addTokenCommand(CLI::App& app);

/// Parses "a,b,c" into three numbers; throws store::InputError naming the option, the text and `example`, a valid
/// value.
template <typename T>
void parseTriple(const std::string& text, const std::string& option, T out[3], const std::string& example);

/// A number as a person writes it in help and errors: integers without a fraction or an exponent, others to six
/// digits.
std::string formatNumber(double v);
/// A check for a numeric option: accepts numbers in [lo, hi] (inclusive); its error reads "must be between LO and HI
/// UNIT, not 'VALUE'", which CLI11 prefixes with the option's name.
CLI::Validator between(double lo, double hi, const std::string& unit = "");
/// Every option of `app` and its subcommands whose default the parser holds (capture_default_str) says it in one
/// form, at the end of its help text: "(default VALUE)", in place of CLI11's "=VALUE" after the type. A help text
/// that already says "(default ...)" must name the same value: otherwise throws std::logic_error, so a help text
/// that disagrees with its parser fails every run (and every test) at once.
void defaultsInText(CLI::App& app);
/// --time and --channel: the index along an OME-Zarr array's 't' and 'c' axes (default 0 each).
void addZarrIndexOptions(CLI::App* cmd, int64_t& time, int64_t& channel);

/// Writes `text` to the file at `path`, replacing it atomically (a temporary renamed over it); throws
/// image::ImageFailure naming the file on failure.
void writeText(const std::string& path, const std::string& text);

/// Where the provisional frame of a progressive render goes beside `output`: "dir/f.png" -> "dir/f.provisional.png".
std::string provisionalPath(const std::string& output);

/// Parses "WIDTHxHEIGHT" into two integers; throws store::InputError naming the option.
void parseSize(const std::string& text, const std::string& option, int& width, int& height);

using common::formatBytes;  ///< "12.3 MB"

/// For `render`, `serve` and `bench`: keeps freed memory of up to 32 MB a block (frames, read-backs, bricks) in the
/// process for the next frame instead of returning it to the system (cli/Allocator.cpp says why).
void keepFreedMemoryForFrames();

/// For `serve`, first thing (before any thread): where the kernel grants transparent huge pages only on request
/// (its mode "madvise", Debian's default), runs this program again, the same arguments, with glibc's malloc asking
/// for them (GLIBC_TUNABLES glibc.malloc.hugetlb=1); returns where it does not: GLIBC_TUNABLES names the setting
/// already (the operator's choice, or this process is that run), VOXBRICK_MALLOC_HUGE_PAGES=0, another mode, or the
/// exec failed. A video stream's encoder (libvpx: about 70 MiB for a VP9 stream at 1024², 130 at 1920x1080)
/// otherwise faults its memory in 4 KiB at a time whenever a stream starts (cli/Allocator.cpp,
/// bench/results/video/stream-start.md).
void askHugePagesForMalloc(char** argv);
/// What askHugePagesForMalloc did, for the server's log.
std::string hugePagesForMallocNote();

/// For `prep`: one heap for every thread, grown (and trimmed) 64 MB at a time, so that building the OpenVDB grid
/// leaf by leaf does not make a system call and page faults per page (cli/Allocator.cpp).
void growHeapInLargeSteps();

}  // namespace voxbrick::cli
