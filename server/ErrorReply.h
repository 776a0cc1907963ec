// The one place where the server turns an exception into a protocol Error (PROTOCOL.md section 8), and decides
// which error codes end a session.
#pragma once

#include <exception>
#include <stdexcept>
#include <string>

#include "proto/Messages.h"

namespace voxbrick::server {

/// A configured limit was exceeded by a request (image side, renders queued): LimitExceeded.
class LimitExceededError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What a client may be told of `text`: valid UTF-8 (each byte that starts no well-formed sequence becomes U+FFFD)
/// and no path of the server's (an absolute path with two slashes or more becomes "…/" and its last part, e.g.
/// "…/bricks.bin"). The full text goes to the server's log where it matters (errorReply, Internal).
std::string clientText(const std::string& text);

/// An Error reply; `message` goes through clientText and is cut (at a UTF-8 character boundary) to 4096 bytes.
proto::Error errorMessage(proto::ErrorCode code, const std::string& message);

/// The Error reply for `error`: proto::ProtocolError -> its code, DatasetNotFound -> UnknownDataset,
/// render::RenderInputError -> InvalidScene, LimitExceededError -> LimitExceeded, anything else -> Internal with a
/// message "`context`: <what>" (logged, since it is the server's fault). Throws nothing but std::bad_alloc.
proto::Error errorReply(const std::exception_ptr& error, const std::string& context = "internal error");

/// Whether a session ends after sending an Error with `code` (PROTOCOL.md: BadMagic, UnsupportedVersion, TooLarge,
/// Timeout, ShuttingDown and Forbidden close; the others leave the session open).
bool closesSession(proto::ErrorCode code);

}  // namespace voxbrick::server
