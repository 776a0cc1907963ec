// What the server holds of each open connection, whatever its transport: start it, end it, name it. The server's
// bookkeeping (the registry of connections, admission, shutdown) sees only this; TcpSession is one implementation.
#pragma once

#include <memory>
#include <string>

#include "proto/Messages.h"
#include "server/AccessTokens.h"
#include "server/Admission.h"

namespace voxbrick::server {

class Session {
 public:
  virtual ~Session() = default;
  /// Starts the Hello deadline and reading messages. Safe from any thread.
  virtual void start() = 0;
  /// Sends `error` with request id 0, then closes once the replies queued before it are written (a refused
  /// connection, the server stopping). Safe from any thread.
  virtual void end(proto::Error error) = 0;
  /// The client's address and port, for logs.
  virtual const std::string& peer() const = 0;
  /// The server's number for the connection.
  virtual ConnectionId id() const = 0;
  /// The grant of the access token the client was admitted with (a browser's /ws ?token=), for the per-token
  /// quotas; null for none (a TCP session presents its token later, with Authenticate). Read on the connection's own
  /// serial context.
  virtual std::shared_ptr<const TokenGrant> accessGrant() const { return nullptr; }
};

}  // namespace voxbrick::server
