// The check the protocol fuzzer runs on every input, shared with the test that replays the seed corpus under GCC.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "proto/Messages.h"

namespace voxbrick::proto::fuzz {

/// Limits far below the defaults, so that short inputs reach the string, list and body limits.
constexpr Limits kFuzzLimits{.maxBodyBytes = 1u << 20, .maxStringBytes = 256, .maxListCount = 16};
/// No limits at all: only the bytes at hand bound a length or count, so a check of those that is missing shows up as
/// a huge allocation.
constexpr Limits kNoLimits{.maxBodyBytes = UINT32_MAX, .maxStringBytes = UINT32_MAX, .maxListCount = UINT32_MAX};

/// What one input decoded to.
struct CheckResult {
  std::vector<MessageType> decoded;  ///< types of the messages that decoded, in stream order
  std::vector<ErrorCode> errors;     ///< codes of the ProtocolErrors the decoder threw, in stream order
};

/// Reads `bytes` as a server reads its stream: a header, then its body, and so on. A header that does not decode
/// ends the stream (the server closes); a body that does not decode is skipped (the session goes on); an incomplete
/// last message is left unread. Every decoded message must encode back to exactly the bytes it came from, otherwise
/// this throws std::logic_error. The decoder may throw nothing but ProtocolError: anything else propagates.
CheckResult checkStream(std::span<const uint8_t> bytes, const Limits& limits);

}  // namespace voxbrick::proto::fuzz
