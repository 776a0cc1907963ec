// The audit trail's lines, appends and rotation.
#include "server/AuditLog.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <stdexcept>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

namespace voxbrick::server {
namespace {

std::string utcText(AuditLog::Clock::time_point when) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(when.time_since_epoch()).count();
  const std::time_t seconds = std::time_t(ms / 1000);
  std::tm utc{};
  ::gmtime_r(&seconds, &utc);
  char text[40];
  const size_t n = std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &utc);
  std::snprintf(text + n, sizeof text - n, ".%03dZ", int(ms % 1000));
  return text;
}

std::filesystem::path numbered(const std::filesystem::path& path, int n) {
  return path.string() + "." + std::to_string(n);
}

}  // namespace

AuditLog::AuditLog(std::filesystem::path path, uint64_t maxBytes, int keep)
    : mPath(std::move(path)), mMaxBytes(maxBytes), mKeep(keep) {
  open();
  if (mFd < 0)
    throw std::runtime_error("audit.path '" + mPath.string() + "' cannot be opened for appending: " +
                             std::strerror(errno));
}

AuditLog::~AuditLog() {
  if (mFd >= 0) ::close(mFd);
}

void AuditLog::open() {
  mFd = ::open(mPath.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0600);
  struct stat s {};
  mBytes = mFd >= 0 && ::fstat(mFd, &s) == 0 ? uint64_t(s.st_size) : 0;
}

void AuditLog::rotate() {
  ::close(mFd);
  std::error_code ec;
  std::filesystem::remove(numbered(mPath, mKeep), ec);
  for (int n = mKeep - 1; n >= 1; --n)
    if (std::filesystem::exists(numbered(mPath, n), ec)) std::filesystem::rename(numbered(mPath, n), numbered(mPath, n + 1), ec);
  if (mKeep >= 1)
    std::filesystem::rename(mPath, numbered(mPath, 1), ec);
  else
    std::filesystem::remove(mPath, ec);
  open();
}

std::string AuditLog::line(const AuditEvent& event, Clock::time_point when) {
  // An ordered object: the keys in the order a person reads them.
  nlohmann::ordered_json line;
  line["time"] = utcText(when);
  line["event"] = event.event;
  line["client"] = event.client;
  line["transport"] = event.transport;
  line["token"] = event.token.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(event.token);
  if (!event.dataset.empty()) line["dataset"] = event.dataset;
  if (!event.reason.empty()) line["reason"] = event.reason;
  // Whatever a client sent (a dataset name) goes through as valid JSON: bytes that are not UTF-8 are replaced.
  return line.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

void AuditLog::record(const AuditEvent& event, Clock::time_point when) {
  if (!enabled()) return;
  try {
    const std::string text = line(event, when);
    std::lock_guard lock(mMutex);
    if (mFd >= 0 && mBytes > 0 && mBytes + text.size() > mMaxBytes) rotate();
    if (mFd < 0) open();
    const ssize_t written = mFd >= 0 ? ::write(mFd, text.data(), text.size()) : -1;
    if (written == ssize_t(text.size())) {
      mBytes += text.size();
      mFailed = false;
    } else if (!mFailed) {
      mFailed = true;
      spdlog::error("audit: cannot append to {}: {}", mPath.string(), std::strerror(errno));
    }
  } catch (const std::exception& e) {  // no memory for a line: the session goes on, the log says so
    spdlog::error("audit: {}", e.what());
  }
}

}  // namespace voxbrick::server
