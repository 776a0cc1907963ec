// Helpers shared by the test suites: scratch directories, running the real `voxbrick` binary, small files.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace voxbrick::test {

/// A fresh directory under the system temp dir, removed with everything in it when destroyed.
class ScratchDir {
 public:
  ScratchDir();
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return mPath; }
  std::filesystem::path operator/(const std::string& name) const { return mPath / name; }

 private:
  std::filesystem::path mPath;
};

/// What a finished command printed and how it ended.
struct CommandResult {
  int exitCode = -1;   ///< exit status, or 128 + signal number if it was killed
  std::string output;  ///< stdout and stderr together
};

/// Runs `command` through /bin/sh -c and waits for it.
CommandResult runShell(const std::string& command);

/// The `voxbrick` binary runVoxbrick runs: the build's (VOXBRICK_EXE), or VOXBRICK_TEST_EXE where that is set (the
/// sanitizer run sets it to voxbrick_asan: tests/sanitize).
std::string voxbrickExe();

/// Runs that `voxbrick` binary with `args` (already shell-quoted where needed).
CommandResult runVoxbrick(const std::string& args);

/// Writes bytes to a file, replacing it.
void writeFile(const std::filesystem::path& path, const void* data, size_t size);
void writeFile(const std::filesystem::path& path, const std::string& text);

/// Reads a whole file.
std::vector<char> readFile(const std::filesystem::path& path);

/// Gzip-compresses bytes (a .gz member), for NRRD and NIfTI test files.
std::vector<char> gzipBytes(const void* data, size_t size);

}  // namespace voxbrick::test
