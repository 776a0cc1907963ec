// What the server answers: a function from decoded client messages to replies, with no sockets and no Asio, so it
// can be tested on its own and put behind any transport (through Connection, today under TcpSession).
#pragma once

#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "proto/Messages.h"
#include "render/core/Dataset.h"
#include "render/core/TransferFunctionPresets.h"
#include "render/engine/Datasets.h"
#include "server/AccessTokens.h"
#include "server/AuditLog.h"
#include "server/Datasets.h"
#include "server/RenderJob.h"
#include "server/ServerConfig.h"
#include "server/ServerStats.h"
#include "server/Uploads.h"

namespace voxbrick::server {

/// One connection's place in the session state machine (PROTOCOL.md section 5). Its Connection keeps one per
/// connection and hands it to every call; only the handler changes it.
struct ConnectionState {
  bool greeted = false;                            ///< Hello was accepted
  uint16_t version = proto::kVersion;              ///< the session's protocol version, negotiated by Hello
  std::shared_ptr<const render::Dataset> dataset;  ///< the open one; null before OpenDataset
  int outstandingRenders = 0;                      ///< renders queued or drawing, not answered yet
  std::optional<render::CameraSpec> lastCamera;    ///< of the last Render of the open dataset (paging ahead)
  /// What the session may list and open: its token's grant, or the anonymous one (AccessTokens::anonymous) until it
  /// presents one; null: every dataset (a handler without tokens).
  std::shared_ptr<const TokenGrant> access;
  bool authenticated = false;  ///< a token was presented (at the WebSocket upgrade, or with Authenticate)
  std::string client;           ///< the client's address:port (the audit trail)
  std::string transport = "tcp";  ///< "tcp", "tls", "ws" or "wss" (the audit trail)
  /// The session's upload in progress (Upload taken, not answered yet); null: none.
  std::shared_ptr<Upload> upload;
  bool preparing = false;  ///< its last chunk arrived: its store is being prepped

  /// Whether the client is waiting for a frame or for its upload's store (so a silent client is not idle).
  bool awaitingFrames() const { return outstandingRenders > 0 || preparing; }
};

/// The audit trail's line `event` for the session in `state`: its client, transport and token's id.
AuditEvent auditEvent(const ConnectionState& state, std::string event, std::string dataset = {},
                      std::string reason = {});

/// A message to send and the request id its header carries.
struct Reply {
  proto::Message message;
  uint32_t requestId = 0;  ///< the id of the request it answers; 0 for none
};

/// An upload whose last chunk arrived: its store is to be prepped aside (Upload::prepare), then answered through
/// MessageHandler::prepared.
struct PrepareJob {
  std::shared_ptr<Upload> upload;
  uint32_t requestId = 0;  ///< of the last chunk, which the answer carries
};

/// What the Connection does after a message: send the replies in order, queue the render job if there is one (and
/// report what the queue did through MessageHandler::submitted), start the upload's prep if there is one, then close
/// if asked once the replies are written.
struct Outcome {
  std::vector<Reply> replies;         ///< to send, in this order
  bool close = false;                 ///< end the session once the replies are written
  std::optional<RenderJob> render;    ///< to queue for a render thread
  std::optional<PrepareJob> prepare;  ///< to run aside
};

class MessageHandler {
 public:
  /// `statsJson` gives the server's statistics for a Stats reply; `tokens` are the access tokens Authenticate is
  /// checked against (null: none is configured); `audit` gets a line for each dataset opened or refused and each
  /// token refused (null: none); `uploads` takes Upload (null: the server takes none). Thread-safe: shared by every
  /// session.
  MessageHandler(const ServerConfig& config, DatasetRegistry& datasets, const render::TransferFunctionPresets& presets,
                 ServerStats& stats, std::function<nlohmann::json()> statsJson,
                 std::shared_ptr<const AccessTokens> tokens = nullptr, AuditLog* audit = nullptr,
                 Uploads* uploads = nullptr);

  /// The answer to `message` (request `requestId`) in `state`, which it updates. Throws nothing but std::bad_alloc:
  /// every failure is an Error reply (see errorReply).
  Outcome handle(ConnectionState& state, const proto::Message& message, uint32_t requestId);
  /// The answer once the queue took (or refused) the job of request `requestId`: Superseded for the request it
  /// replaced, LimitExceeded or ShuttingDown if it was refused, nothing if it simply waits.
  Outcome submitted(ConnectionState& state, uint32_t requestId, Submission submission);
  /// The answer once a render thread made `reply` (renderReply) for `job`: the reply itself, counted.
  Outcome rendered(ConnectionState& state, const RenderJob& job, proto::Message reply);
  /// The answer for `job`'s frame when it was dropped before it was sent (a video frame a newer frame replaced
  /// before it was encoded): Superseded, or nothing when `answered` (its request gets its exact frame instead).
  Outcome dropped(ConnectionState& state, const RenderJob& job, bool answered);
  /// The answer once `job`'s store was prepped (`error` null) or was not: the new dataset's DatasetInfo, or the Error.
  Outcome prepared(ConnectionState& state, const PrepareJob& job, const std::exception_ptr& error);
  /// The answer to a message that could not be decoded (or any failure outside handle): the Error of
  /// errorReply(error, context), closing the session when its code says so (closesSession).
  static Outcome failed(const std::exception_ptr& error, uint32_t requestId,
                        const std::string& context = "internal error");

 private:
  Outcome dispatch(ConnectionState& state, const proto::Message& message, uint32_t requestId);
  Outcome hello(ConnectionState& state, const proto::Hello& hello, uint32_t requestId);
  Outcome openDataset(ConnectionState& state, const proto::OpenDataset& open, uint32_t requestId);
  Outcome authenticate(ConnectionState& state, const proto::Authenticate& message, uint32_t requestId);
  /// The server's statistics as the session may see them: only its datasets unless it may see every one.
  nlohmann::json statsFor(const ConnectionState& state) const;
  Outcome render(ConnectionState& state, const proto::RenderRequest& request, uint32_t requestId);
  Outcome upload(ConnectionState& state, const proto::Upload& request, uint32_t requestId);
  Outcome uploadChunk(ConnectionState& state, const proto::UploadChunk& chunk, uint32_t requestId);

  const ServerConfig mConfig;
  DatasetRegistry& mDatasets;
  const render::TransferFunctionPresets& mPresets;
  ServerStats& mStats;
  const std::function<nlohmann::json()> mStatsJson;
  const std::shared_ptr<const AccessTokens> mTokens;
  AuditLog* const mAudit;
  Uploads* const mUploads;
};

}  // namespace voxbrick::server
