// The child process: fork, the few async-signal-safe calls before exec, the wait, the cancel.
#include "server/PrepProcess.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace voxbrick::server {

std::string lastLine(const std::filesystem::path& path, const std::string& otherwise) {
  std::ifstream in(path);
  std::string line, last;
  while (std::getline(in, line))
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  return last.empty() ? otherwise : last;
}

void PrepProcess::run(const std::filesystem::path& executable, const std::vector<std::string>& args,
                      const std::filesystem::path& log, const std::string& what) {
  const std::string exe = executable.string(), logPath = log.string();
  std::vector<const char*> argv = {exe.c_str()};
  for (const std::string& arg : args) argv.push_back(arg.c_str());
  argv.push_back(nullptr);
  pid_t child;
  {
    std::lock_guard lock(mMutex);
    if (mCancelled) throw std::runtime_error(what + " was abandoned");
    const pid_t parent = ::getpid();
    child = ::fork();
    if (child == 0) {
      // Only async-signal-safe calls between fork and exec: the server has many threads.
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // the child ends with the server
      if (::getppid() != parent) ::_exit(127);
      const int fd = ::open(logPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
      }
      ::close_range(3, ~0u, 0);  // nothing of the server's (its sockets) goes with it
      ::execv(argv[0], const_cast<char* const*>(argv.data()));
      ::_exit(127);
    }
    if (child < 0) throw std::runtime_error(what + ": cannot start voxbrick prep: " + std::strerror(errno));
    mChild = child;
  }
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  {
    std::lock_guard lock(mMutex);
    mChild = 0;
    if (mCancelled) throw std::runtime_error(what + " was abandoned");
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("voxbrick prep failed on " + what + " (" +
                             (WIFEXITED(status) ? "exit " + std::to_string(WEXITSTATUS(status))
                                                : "signal " + std::to_string(WIFSIGNALED(status) ? WTERMSIG(status) : 0)) +
                             "): " + lastLine(log, "no message"));
}

void PrepProcess::cancel() {
  std::lock_guard lock(mMutex);
  mCancelled = true;
  if (mChild > 0) ::kill(mChild, SIGKILL);
}

bool PrepProcess::cancelled() const {
  std::lock_guard lock(mMutex);
  return mCancelled;
}

}  // namespace voxbrick::server
