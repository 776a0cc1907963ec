// Running the real `voxbrick` binary with its standard output and standard error kept apart, for the CLI tests.
#pragma once

#include <string>

namespace voxbrick::test {

/// What a finished command wrote to each stream and how it ended.
struct SplitResult {
  int exitCode = -1;  ///< exit status, or 128 + signal number if it was killed (124: it ran past its time limit)
  std::string out;    ///< standard output
  std::string err;    ///< standard error
};

/// Runs the built `voxbrick` with `args` (shell-quoted where needed) through /bin/sh, stdin from /dev/null, killed
/// after `timeoutSeconds`. `shellPrefix` runs first in the same shell (e.g. "ulimit -f 2;").
SplitResult runSplit(const std::string& args, double timeoutSeconds = 120, const std::string& shellPrefix = "");
/// As runSplit, for the binary at `exe` (a copy moved elsewhere, an installed one).
SplitResult runExe(const std::string& exe, const std::string& args, double timeoutSeconds = 120,
                   const std::string& shellPrefix = "");

/// A store `voxbrick prep SPEC OPTIONS` made once per test program (kept until it ends), e.g.
/// preppedStore("synthetic:blobs,n=64", "--brick 16"). Throws std::runtime_error with prep's errors if it fails.
std::string preppedStore(const std::string& spec, const std::string& options);

/// Lines in `text` (a last line without its newline counts).
int lineCount(const std::string& text);

}  // namespace voxbrick::test
