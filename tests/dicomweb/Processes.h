// The processes the DICOMweb tests run: a real Orthanc (Debian's, with its DICOMweb plugin) on loopback on a free port
// with a generated configuration, a TLS forwarder in front of it, and `voxbrick` started in the background. Each dies
// with the test process (PR_SET_PDEATHSIG) and is killed when its object goes, so none outlives a failed test.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

namespace voxbrick::test {

/// A child process in its own process group, its output in a log file; SIGKILLed (the group) and reaped when
/// destroyed, and killed by the kernel if this process dies first.
class ChildProcess {
 public:
  /// Starts argv[0] (a path, or a name looked up on PATH) with `argv`, in `workDir`, with `env` added to this
  /// process' environment ("NAME=value"). Throws std::runtime_error if it cannot be started.
  ChildProcess(const std::vector<std::string>& argv, const std::filesystem::path& workDir,
               const std::filesystem::path& log, const std::vector<std::string>& env = {});
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return mPid; }
  /// Whether it still runs (reaps it if it has exited).
  bool running();
  /// Sends `signal` to it (not its group).
  void signal(int signal);
  /// SIGKILLs its process group and reaps it; a no-op once reaped.
  void kill();
  /// Waits up to `timeout` for its exit; returns the exit status, 128 + signal if killed by one, -1 on timeout.
  int wait(std::chrono::milliseconds timeout);
  std::string log() const;

 private:
  pid_t mPid = -1;
  int mStatus = -1;
  std::filesystem::path mLog;
};

/// A free TCP port on 127.0.0.1 (bound and released: another process may take it before it is used).
int freePort();

/// A real Orthanc with the DICOMweb plugin, its storage in `scratch`, HTTP on a free loopback port, authentication
/// on with one user, the DICOM port off. Uploads go through its REST API (POST /instances).
class OrthancServer {
 public:
  /// Starts it and waits (up to 30 s) until its REST API answers. Throws std::runtime_error with its log otherwise.
  /// `settings`: more members of its configuration, as JSON ("\"LimitFindInstances\": 100").
  explicit OrthancServer(const std::filesystem::path& scratch, const std::string& settings = "");

  int port() const { return mPort; }
  /// "dicomweb://127.0.0.1:PORT/dicom-web"
  std::string dicomWeb() const;
  /// "basic USER:PASSWORD": what --auth-file or VOXBRICK_DICOMWEB_AUTH holds for it.
  std::string credentials() const;
  /// POSTs every *.dcm file under `dir` (recursively) to /instances; throws unless each is accepted.
  void upload(const std::filesystem::path& dir);
  /// SIGKILL, now.
  void kill() { mProcess.kill(); }
  bool running() { return mProcess.running(); }
  std::string log() const { return mProcess.log(); }

 private:
  int mPort = 0;
  std::string mUser = "voxbrick", mPassword;
  ChildProcess mProcess;
};

/// A TLS endpoint on a free loopback port that forwards each connection to 127.0.0.1:`target` (tls_forward.py, in
/// Python's standard library): HTTPS in front of an Orthanc, with a self-signed certificate for 127.0.0.1 made by
/// `openssl req` in `scratch`.
class TlsForwarder {
 public:
  TlsForwarder(const std::filesystem::path& scratch, int target);
  int port() const { return mPort; }
  /// The certificate (PEM) a client must trust.
  const std::filesystem::path& certificate() const { return mCertificate; }

 private:
  int mPort = 0;
  std::filesystem::path mCertificate;
  ChildProcess mProcess;
};

}  // namespace voxbrick::test
