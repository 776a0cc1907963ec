// A plain TCP connection to the server for clients that misbehave below the message level: never speaking,
// trickling bytes, never reading.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "proto/Messages.h"

namespace voxbrick::test {

class RawSocket {
 public:
  /// Connects to 127.0.0.1:`port`; throws std::runtime_error if it cannot.
  explicit RawSocket(int port);
  ~RawSocket();
  RawSocket(const RawSocket&) = delete;
  RawSocket& operator=(const RawSocket&) = delete;

  /// Sends all of `bytes`, blocking; false if the connection failed (the server closed it).
  bool sendAll(const std::vector<uint8_t>& bytes);
  /// Sends what the socket takes now of `bytes` without blocking; returns the count sent (0 when the buffers are
  /// full), or -1 once the connection failed.
  long sendSome(std::span<const uint8_t> bytes);
  /// The next whole message within `timeout`; nullopt if none came in time or the connection closed (closed()).
  std::optional<proto::Message> receive(std::chrono::milliseconds timeout);
  /// Reads until the server closes the connection or `timeout` passes; returns whether it closed. The codes of the
  /// Errors read on the way are appended to `codes`.
  bool waitClosed(std::chrono::milliseconds timeout, std::vector<proto::ErrorCode>* codes = nullptr);
  /// Whether the server closed the connection (seen by a read).
  bool closed() const { return mClosed; }
  /// The header of the last message receive() returned (its version, its request id).
  const proto::Header& lastHeader() const { return mLastHeader; }

 private:
  /// Reads what arrives within `timeout` into mInput; false once the connection closed or failed.
  bool fill(std::chrono::milliseconds timeout);
  /// The first whole message of mInput, removed from it.
  std::optional<proto::Message> take();

  int mFd = -1;
  bool mClosed = false;
  std::vector<uint8_t> mInput;
  proto::Header mLastHeader;
};

}  // namespace voxbrick::test
