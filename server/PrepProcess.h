// `voxbrick prep` run by the server in a child process (an upload's voxels, a PACS series): started from its own
// executable, its output in a log file, killed with the server (PR_SET_PDEATHSIG) or when cancelled, nothing of the
// server's (its sockets) passed on. No sockets, no Asio.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

namespace voxbrick::server {

/// One run of a child process that can be cancelled from another thread. Thread-safe.
class PrepProcess {
 public:
  /// Runs `executable` with `args` (argv[1...]), stdout and stderr to `log`, and waits for it. Throws
  /// std::runtime_error saying `what` failed: the exit status (or signal) and the log's last line, or that it was
  /// cancelled ("... was abandoned").
  void run(const std::filesystem::path& executable, const std::vector<std::string>& args,
           const std::filesystem::path& log, const std::string& what);
  /// Kills the child if it runs, and makes run() refuse to start one. Safe from any thread.
  void cancel();
  bool cancelled() const;

 private:
  mutable std::mutex mMutex;
  pid_t mChild = 0;  ///< while it runs
  bool mCancelled = false;
};

/// The last non-empty line of `path` (a child's words when it failed), or `otherwise`.
std::string lastLine(const std::filesystem::path& path, const std::string& otherwise);

}  // namespace voxbrick::server
