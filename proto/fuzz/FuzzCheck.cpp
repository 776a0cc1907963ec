// The fuzzer's check: decode a stream of messages and require each one to re-encode byte for byte.
#include "proto/fuzz/FuzzCheck.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace voxbrick::proto::fuzz {

CheckResult checkStream(std::span<const uint8_t> bytes, const Limits& limits) {
  CheckResult result;
  while (bytes.size() >= kHeaderBytes) {
    Header header;
    try {
      header = decodeHeader(bytes.first<kHeaderBytes>(), limits);
    } catch (const ProtocolError& e) {
      result.errors.push_back(e.code());
      break;
    }
    if (bytes.size() - kHeaderBytes < header.bodyBytes) break;
    const std::span<const uint8_t> wire = bytes.first(kHeaderBytes + header.bodyBytes);
    bytes = bytes.subspan(wire.size());
    Message message;
    try {
      message = decodeBody(header, wire.subspan(kHeaderBytes), limits);
    } catch (const ProtocolError& e) {
      result.errors.push_back(e.code());
      continue;
    }
    result.decoded.push_back(messageType(message));
    const std::vector<uint8_t> again = encode(message, header.requestId, header.version);
    if (!std::equal(again.begin(), again.end(), wire.begin(), wire.end()))
      throw std::logic_error(std::string("checkStream: a decoded ") + messageTypeName(messageType(message)) +
                             " does not encode back to its " + std::to_string(wire.size()) + " bytes");
  }
  return result;
}

}  // namespace voxbrick::proto::fuzz
