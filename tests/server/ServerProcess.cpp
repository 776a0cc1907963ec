// Starting and stopping the server process for the server tests.
#include "ServerProcess.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace voxbrick::test {

ServerProcess::ServerProcess(const std::string& args, const std::filesystem::path& scratch) {
  static int serial = 0;
  const std::string tag = std::to_string(::getpid()) + "-" + std::to_string(serial++);
  const std::filesystem::path portFile = scratch / ("port-" + tag);
  mLog = scratch / ("serve-" + tag + ".log");
  const std::filesystem::path httpPortFile = scratch / ("http-port-" + tag);
  const bool http = (" " + args + " ").find(" --http ") != std::string::npos;
  const std::string command = std::string("exec '") + VOXBRICK_EXE + "' serve --port 0 --port-file '" +
                              portFile.string() + "' " +
                              (http ? "--http-port-file '" + httpPortFile.string() + "' " : std::string()) + args +
                              " > '" + mLog.string() + "' 2>&1";
  const char* argv[] = {"/bin/sh", "-c", command.c_str(), nullptr};
  if (posix_spawn(&mPid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0)
    throw std::runtime_error("cannot start the server");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    std::ifstream in(portFile), httpIn(httpPortFile);
    if (in >> mPort && mPort > 0 && (!http || (httpIn >> mHttpPort && mHttpPort > 0))) return;
    if (!running()) throw std::runtime_error("the server exited (status " + std::to_string(mStatus) + "): " + log());
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  stop(SIGKILL);
  throw std::runtime_error("the server did not listen within 60 s: " + log());
}

ServerProcess::~ServerProcess() {
  if (running()) stop(SIGKILL);
}

bool ServerProcess::running() {
  if (mPid <= 0) return false;
  int status = 0;
  const pid_t r = ::waitpid(mPid, &status, WNOHANG);
  if (r == 0) return true;
  mStatus = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  mPid = -1;
  return false;
}

int ServerProcess::stop(int signal, std::chrono::milliseconds timeout) {
  if (!running()) return mStatus;
  ::kill(mPid, signal);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (!running()) return mStatus;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ::kill(mPid, SIGKILL);
  ::waitpid(mPid, nullptr, 0);
  mPid = -1;
  return -1;
}

uint64_t ServerProcess::residentBytes() const {
  if (mPid <= 0) return 0;
  std::ifstream status("/proc/" + std::to_string(mPid) + "/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stoull(line.substr(6)) * 1024;
  return 0;
}

std::string ServerProcess::log() const {
  std::ifstream in(mLog);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace voxbrick::test
