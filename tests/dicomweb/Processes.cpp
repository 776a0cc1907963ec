// Orthanc, the TLS forwarder and background commands for the DICOMweb tests.
#include "Processes.h"

#include <arpa/inet.h>
#include <curl/curl.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "support/TestSupport.h"

namespace voxbrick::test {
namespace {

namespace fs = std::filesystem;

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A GET or POST through libcurl with basic authentication; the HTTP status (0 when no connection).
long request(const std::string& url, const std::string& user, const std::string& password, const std::string* body) {
  CURL* curl = curl_easy_init();
  if (curl == nullptr) throw std::runtime_error("curl_easy_init failed");
  curl_easy_setopt(curl, CURLOPT_URL, url.c_str());
  curl_easy_setopt(curl, CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(curl, CURLOPT_TIMEOUT, 60L);
  curl_easy_setopt(curl, CURLOPT_HTTPAUTH, long(CURLAUTH_BASIC));
  curl_easy_setopt(curl, CURLOPT_USERNAME, user.c_str());
  curl_easy_setopt(curl, CURLOPT_PASSWORD, password.c_str());
  curl_easy_setopt(
      curl, CURLOPT_WRITEFUNCTION, +[](char*, size_t size, size_t count, void*) { return size * count; });
  if (body != nullptr) {
    curl_easy_setopt(curl, CURLOPT_POSTFIELDS, body->data());
    curl_easy_setopt(curl, CURLOPT_POSTFIELDSIZE_LARGE, curl_off_t(body->size()));
  }
  long status = 0;
  if (curl_easy_perform(curl) == CURLE_OK) curl_easy_getinfo(curl, CURLINFO_RESPONSE_CODE, &status);
  curl_easy_cleanup(curl);
  return status;
}

std::string randomPassword() {
  std::random_device device;
  std::mt19937_64 random(device());
  const char* alphabet = "abcdefghijkmnopqrstuvwxyzABCDEFGHJKLMNPQRSTUVWXYZ23456789";
  std::string p;
  for (int i = 0; i < 20; ++i) p += alphabet[random() % 57];
  return p;
}

/// Writes Orthanc's configuration into `scratch` and returns the command that starts it.
std::vector<std::string> orthancCommand(const fs::path& scratch, int port, const std::string& user,
                                        const std::string& password, const std::string& settings) {
  fs::create_directories(scratch / "storage");
  const fs::path config = scratch / "orthanc.json";
  std::ofstream out(config);
  out << "{\n"
      << "  \"Name\": \"voxbrick-test\",\n"
      << "  \"StorageDirectory\": \"" << (scratch / "storage").string() << "\",\n"
      << "  \"IndexDirectory\": \"" << (scratch / "storage").string() << "\",\n"
      << "  \"HttpPort\": " << port << ",\n"
      << "  \"DicomServerEnabled\": false,\n"
      << "  \"RemoteAccessAllowed\": false,\n"  // loopback clients only
      << "  \"AuthenticationEnabled\": true,\n"
      << "  \"RegisteredUsers\": {\"" << user << "\": \"" << password << "\"},\n"
      << "  \"Plugins\": [\"" << VOXBRICK_ORTHANC_DICOMWEB << "\"],\n"
      << "  \"DicomWeb\": {\"Enable\": true, \"Root\": \"/dicom-web/\", \"EnableWado\": false},\n"
      << "  \"ConcurrentJobs\": 1,\n"
      << (settings.empty() ? "" : "  " + settings + ",\n") << "  \"HttpThreadsCount\": 8\n"
      << "}\n";
  if (!out) throw std::runtime_error("cannot write " + config.string());
  return {VOXBRICK_ORTHANC, config.string()};
}

}  // namespace

ChildProcess::ChildProcess(const std::vector<std::string>& argv, const fs::path& workDir, const fs::path& log,
                           const std::vector<std::string>& env)
    : mLog(log) {
  const pid_t parent = ::getpid();
  mPid = ::fork();
  if (mPid < 0) throw std::runtime_error("fork failed");
  if (mPid == 0) {
    // Dies with the test process, whatever ends it; its own group, so that kill() reaches what it starts.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    ::setpgid(0, 0);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::close(fd);
    }
    if (::chdir(workDir.c_str()) != 0) ::_exit(127);
    for (const std::string& e : env) ::putenv(const_cast<char*>(e.c_str()));
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execvp(args[0], args.data());
    ::_exit(127);
  }
  ::setpgid(mPid, mPid);  // also here, so that kill() finds the group even before the child has run
}

ChildProcess::~ChildProcess() { kill(); }

bool ChildProcess::running() {
  if (mPid < 0) return false;
  int status = 0;
  const pid_t r = ::waitpid(mPid, &status, WNOHANG);
  if (r == 0) return true;
  mStatus = WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
  ::kill(-mPid, SIGKILL);  // anything it left in its group
  mPid = -1;
  return false;
}

void ChildProcess::signal(int sig) {
  if (mPid > 0) ::kill(mPid, sig);
}

void ChildProcess::kill() {
  if (mPid < 0) return;
  ::kill(-mPid, SIGKILL);
  ::kill(mPid, SIGKILL);
  int status = 0;
  ::waitpid(mPid, &status, 0);
  mStatus = WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
  mPid = -1;
}

int ChildProcess::wait(std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (running()) {
    if (std::chrono::steady_clock::now() > until) {
      kill();
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return mStatus;
}

std::string ChildProcess::log() const { return readText(mLog); }

int freePort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0)
    throw std::runtime_error("no free port");
  ::close(fd);
  return ntohs(address.sin_port);
}

OrthancServer::OrthancServer(const fs::path& scratch, const std::string& settings)
    : mPort(freePort()),
      mPassword(randomPassword()),
      mProcess(orthancCommand(scratch, mPort, mUser, mPassword, settings), scratch, scratch / "orthanc.log") {
  const std::string url = "http://127.0.0.1:" + std::to_string(mPort) + "/system";
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (request(url, mUser, mPassword, nullptr) != 200) {
    if (!mProcess.running()) throw std::runtime_error(std::string(VOXBRICK_ORTHANC) + " exited:\n" + log());
    if (std::chrono::steady_clock::now() > until) throw std::runtime_error("Orthanc did not answer in 30 s:\n" + log());
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

std::string OrthancServer::dicomWeb() const { return "dicomweb://127.0.0.1:" + std::to_string(mPort) + "/dicom-web"; }

std::string OrthancServer::credentials() const { return "basic " + mUser + ":" + mPassword; }

void OrthancServer::upload(const fs::path& dir) {
  const std::string url = "http://127.0.0.1:" + std::to_string(mPort) + "/instances";
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file() || entry.path().extension() != ".dcm") continue;
    const std::vector<char> bytes = readFile(entry.path());
    const std::string body(bytes.begin(), bytes.end());
    const long status = request(url, mUser, mPassword, &body);
    if (status != 200)
      throw std::runtime_error("POST /instances of " + entry.path().string() + ": HTTP " + std::to_string(status) +
                               "\n" + log());
  }
}

namespace {

/// Makes a self-signed certificate for 127.0.0.1 and returns the command of the forwarder that serves it.
std::vector<std::string> forwarderCommand(const fs::path& scratch, int target) {
  fs::create_directories(scratch);
  const auto r = runShell(
      "openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=127.0.0.1 -addext "
      "subjectAltName=IP:127.0.0.1 -keyout '" +
      (scratch / "key.pem").string() + "' -out '" + (scratch / "cert.pem").string() + "'");
  if (r.exitCode != 0) throw std::runtime_error("openssl req failed:\n" + r.output);
  return {"/usr/bin/python3",
          std::string(VOXBRICK_SOURCE_DIR) + "/tests/dicomweb/tls_forward.py",
          (scratch / "cert.pem").string(),
          (scratch / "key.pem").string(),
          std::to_string(target),
          (scratch / "port").string()};
}

}  // namespace

TlsForwarder::TlsForwarder(const fs::path& scratch, int target)
    : mCertificate(scratch / "cert.pem"), mProcess(forwarderCommand(scratch, target), scratch, scratch / "tls.log") {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (mPort == 0) {
    const std::string text = readText(scratch / "port");
    if (!text.empty() && text.back() == '\n') mPort = std::stoi(text);
    if (mPort != 0) break;
    if (!mProcess.running()) throw std::runtime_error("tls_forward.py exited:\n" + mProcess.log());
    if (std::chrono::steady_clock::now() > until) throw std::runtime_error("tls_forward.py did not start in 20 s");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace voxbrick::test
