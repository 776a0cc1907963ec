// Runs the binary with each stream redirected to its own file, then reads them back.
#include "cli/CliRun.h"

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <string>

#include "support/TestSupport.h"

namespace voxbrick::test {

SplitResult runSplit(const std::string& args, double timeoutSeconds, const std::string& shellPrefix) {
  return runExe(VOXBRICK_EXE, args, timeoutSeconds, shellPrefix);
}

SplitResult runExe(const std::string& exe, const std::string& args, double timeoutSeconds,
                   const std::string& shellPrefix) {
  ScratchDir dir;
  const std::string out = (dir / "out").string(), err = (dir / "err").string();
  const std::string command = shellPrefix + " timeout " + std::to_string(timeoutSeconds) + " " + exe + " " + args +
                              " </dev/null >" + out + " 2>" + err;
  const int status = std::system(command.c_str());
  SplitResult r;
  if (WIFEXITED(status))
    r.exitCode = WEXITSTATUS(status);
  else if (WIFSIGNALED(status))
    r.exitCode = 128 + WTERMSIG(status);
  const std::vector<char> o = readFile(out), e = readFile(err);
  r.out.assign(o.begin(), o.end());
  r.err.assign(e.begin(), e.end());
  return r;
}

std::string preppedStore(const std::string& spec, const std::string& options) {
  static ScratchDir dir;
  static std::map<std::string, std::string> stores;
  const std::string key = spec + " " + options;
  if (auto it = stores.find(key); it != stores.end()) return it->second;
  const std::string path = (dir / ("store" + std::to_string(stores.size()))).string();
  const SplitResult r = runSplit("prep " + spec + " " + options + " -q -o " + path);
  if (r.exitCode != 0) throw std::runtime_error("prep " + key + " failed: " + r.err);
  return stores[key] = path;
}

int lineCount(const std::string& text) {
  const int n = int(std::count(text.begin(), text.end(), '\n'));
  return n + (!text.empty() && text.back() != '\n' ? 1 : 0);
}

}  // namespace voxbrick::test
