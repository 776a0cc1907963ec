// Exceptions to protocol errors, in one place.
#include "server/ErrorReply.h"

#include <spdlog/spdlog.h>

#include "render/RenderErrors.h"
#include "server/Datasets.h"

namespace voxbrick::server {
namespace {

constexpr size_t kMaxErrorMessageBytes = 4096;

}  // namespace

proto::Error errorMessage(proto::ErrorCode code, const std::string& message) {
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
    case ErrorCode::ShuttingDown: return true;
    default: return false;
  }
}

}  // namespace voxbrick::server
