// Exceptions to protocol errors, in one place.
#include "server/ErrorReply.h"

#include <algorithm>

#include <spdlog/spdlog.h>

#include "render/core/RenderErrors.h"
#include "server/Datasets.h"

namespace voxbrick::server {
namespace {

constexpr size_t kMaxErrorMessageBytes = 4096;

/// `text` with every byte that starts no well-formed UTF-8 sequence replaced by U+FFFD.
std::string validUtf8(const std::string& text) {
  const auto* p = reinterpret_cast<const uint8_t*>(text.data());
  std::string out;
  size_t at = 0;
  while (at < text.size()) {
    const size_t bad = at + proto::invalidUtf8At(p + at, text.size() - at);
    out.append(text, at, bad - at);
    if (bad == text.size()) break;
    out += "\xEF\xBF\xBD";
    at = bad + 1;
  }
  return out;
}

bool startsPath(const std::string& text, size_t i) {
  if (text[i] != '/') return false;
  if (i == 0) return true;
  const char before = text[i - 1];
  return before == ' ' || before == '\'' || before == '"' || before == '(' || before == '=' || before == ':' ||
         before == '\t' || before == '[';
}

}  // namespace

std::string clientText(const std::string& text) {
  const std::string valid = validUtf8(text);
  std::string out;
  out.reserve(valid.size());
  for (size_t i = 0; i < valid.size();) {
    if (!startsPath(valid, i)) {
      out += valid[i++];
      continue;
    }
    // A path runs to the next space or quote; with two slashes or more it is the server's: keep its last part.
    size_t end = i;
    while (end < valid.size() && valid[end] != ' ' && valid[end] != '\'' && valid[end] != '"' && valid[end] != '\t')
      ++end;
    std::string path = valid.substr(i, end - i);
    while (!path.empty() && (path.back() == ':' || path.back() == ',' || path.back() == ')' || path.back() == '.')) {
      --end;
      path.pop_back();
    }
    const size_t last = path.find_last_of('/');
    if (std::count(path.begin(), path.end(), '/') >= 2 && last + 1 < path.size())
      out += "…/" + path.substr(last + 1);
    else
      out += path;
    i = end;
  }
  return out;
}

proto::Error errorMessage(proto::ErrorCode code, const std::string& text) {
  const std::string message = clientText(text);
  size_t size = std::min(message.size(), kMaxErrorMessageBytes);
  // Never cut inside a UTF-8 sequence: the peer's decoder would refuse the whole reply as Malformed.
  if (size < message.size())
    while (size > 0 && (static_cast<unsigned char>(message[size]) & 0xC0) == 0x80) --size;
  return proto::Error{code, message.substr(0, size)};
}

proto::Error errorReply(const std::exception_ptr& error, const std::string& context) {
  using proto::ErrorCode;
  if (!error) return errorMessage(ErrorCode::Internal, context + ": no exception");
  try {
    std::rethrow_exception(error);
  } catch (const proto::ProtocolError& e) {
    return errorMessage(e.code(), e.what());
  } catch (const DatasetNotFound& e) {
    return errorMessage(ErrorCode::UnknownDataset, e.what());
  } catch (const DatasetUnavailable& e) {
    return errorMessage(ErrorCode::Internal, e.what());
  } catch (const render::RenderLimitError& e) {
    return errorMessage(ErrorCode::LimitExceeded, e.what());
  } catch (const render::RenderInputError& e) {
    return errorMessage(ErrorCode::InvalidScene, e.what());
  } catch (const LimitExceededError& e) {
    return errorMessage(ErrorCode::LimitExceeded, e.what());
  } catch (const std::exception& e) {
    spdlog::error("{}: {}", context, e.what());
    return errorMessage(ErrorCode::Internal, context + ": " + e.what());
  } catch (...) {
    spdlog::error("{}: an exception of unknown type", context);
    return errorMessage(ErrorCode::Internal, context + ": an exception of unknown type");
  }
}

bool closesSession(proto::ErrorCode code) {
  using proto::ErrorCode;
  switch (code) {
    case ErrorCode::BadMagic:
    case ErrorCode::UnsupportedVersion:
    case ErrorCode::TooLarge:
    case ErrorCode::Timeout:
    case ErrorCode::ShuttingDown:
    case ErrorCode::Forbidden: return true;
    default: return false;
  }
}

}  // namespace voxbrick::server
