// The session state machine of PROTOCOL.md section 5: each client message in a state, to its replies.
#include "server/MessageHandler.h"

#include <algorithm>
#include <string>
#include <type_traits>
#include <utility>

#include <spdlog/spdlog.h>

#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"
#include "render/engine/Datasets.h"
#include "image/Video.h"
#include "server/ErrorReply.h"

namespace voxbrick::server {
namespace {

using proto::ErrorCode;
using Clock = std::chrono::steady_clock;

Outcome replyWith(proto::Message message, uint32_t requestId) {
  Outcome outcome;
  outcome.replies.push_back({std::move(message), requestId});
  return outcome;
}

/// What an Internal error says the server was doing.
std::string failureContext(const proto::Message& message) {
  if (const auto* open = std::get_if<proto::OpenDataset>(&message))
    return "dataset '" + open->name + "' cannot be opened";
  return std::string(proto::messageTypeName(proto::messageType(message))) + " failed";
}

/// Which dataset names a session in `state` may see (none: every one).
DatasetRegistry::Visible visibleTo(const ConnectionState& state) {
  if (!state.access) return {};
  return [access = state.access](const std::string& name) { return access->mayOpen(name); };
}

/// Sets job.provisionalEncoding from the scene and refuses what the session cannot be sent: an encoding its version
/// lacks, a video encoding for anything but provisional frames (a video frame belongs to the session's stream of
/// moving frames; the exact frame is a still), and jpeg or video (which have no alpha) for a transparent frame.
void checkEncodings(RenderJob& job, uint16_t version) {
  if (image::isVideoEncoding(job.encoding))
    throw render::RenderInputError(std::string("Render.encoding ") + proto::encodingName(job.encoding) +
                                   " is a video stream of moving frames: ask for it as the scene's "
                                   "'provisional_encoding' (with 'interactive' or 'progressive'), and for the exact "
                                   "frame as png, webp, jpeg, zstd_rgba8 or raw_rgba8");
  if (job.scene.provisionalEncoding) {
    // Scene::fromJson accepted only render::Scene::kEncodingNames, the short names proto knows.
    const auto named = proto::encodingFromShortName(*job.scene.provisionalEncoding);
    if (!named) throw render::RenderInputError("scene: 'provisional_encoding' names no encoding");
    const proto::Encoding provisional = *named;
    if (!proto::encodingInVersion(provisional, version))
      throw render::RenderInputError("scene: 'provisional_encoding' \"" + *job.scene.provisionalEncoding +
                                     "\" needs protocol version " + std::to_string(proto::firstVersionOf(provisional)) +
                                     "; this session speaks version " + std::to_string(version));
    job.provisionalEncoding = provisional;
  }
  if (job.scene.acceptsWebp && !proto::encodingInVersion(proto::Encoding::Webp, version))
    throw render::RenderInputError("scene: 'accepts_webp' needs protocol version " +
                                   std::to_string(proto::firstVersionOf(proto::Encoding::Webp)) +
                                   "; this session speaks version " + std::to_string(version));
  if (job.scene.acceptsVp9_444 && version < proto::kVp9FullChromaVersion)
    throw render::RenderInputError("scene: 'accepts_vp9_444' needs protocol version " +
                                   std::to_string(proto::kVp9FullChromaVersion) + "; this session speaks version " +
                                   std::to_string(version));
  if (job.scene.transparent) {
    if (job.encoding == proto::Encoding::Jpeg)
      throw render::RenderInputError(
          "scene: 'background': \"none\" asks for alpha, which a jpeg frame cannot carry; give a background colour or "
          "ask for png or zstd_rgba8");
    if (job.provisionalEncoding == proto::Encoding::Jpeg ||
        (job.provisionalEncoding && image::isVideoEncoding(*job.provisionalEncoding)))
      throw render::RenderInputError("scene: 'background': \"none\" asks for alpha, which 'provisional_encoding' \"" +
                                     *job.scene.provisionalEncoding + "\" cannot carry");
  }
}

}  // namespace

MessageHandler::MessageHandler(const ServerConfig& config, DatasetRegistry& datasets,
                               const render::TransferFunctionPresets& presets, ServerStats& stats,
                               std::function<nlohmann::json()> statsJson, std::shared_ptr<const AccessTokens> tokens,
                               AuditLog* audit, Uploads* uploads)
    : mConfig(config),
      mDatasets(datasets),
      mPresets(presets),
      mStats(stats),
      mStatsJson(std::move(statsJson)),
      mTokens(std::move(tokens)),
      mAudit(audit),
      mUploads(uploads) {}

AuditEvent auditEvent(const ConnectionState& state, std::string event, std::string dataset, std::string reason) {
  AuditEvent e;
  e.event = std::move(event);
  e.client = state.client;
  e.transport = state.transport;
  e.token = state.authenticated && state.access ? state.access->id : "";
  e.dataset = std::move(dataset);
  e.reason = std::move(reason);
  return e;
}

Outcome MessageHandler::handle(ConnectionState& state, const proto::Message& message, uint32_t requestId) {
  try {
    return dispatch(state, message, requestId);
  } catch (...) {
    return failed(std::current_exception(), requestId, failureContext(message));
  }
}

Outcome MessageHandler::failed(const std::exception_ptr& error, uint32_t requestId, const std::string& context) {
  proto::Error reply = errorReply(error, context);
  Outcome outcome;
  outcome.close = closesSession(reply.code);
  outcome.replies.push_back({std::move(reply), requestId});
  return outcome;
}

Outcome MessageHandler::dispatch(ConnectionState& state, const proto::Message& message, uint32_t requestId) {
  // Failures are thrown as the typed exceptions errorReply maps, so that this reads as the state machine only.
  if (const auto* h = std::get_if<proto::Hello>(&message)) return hello(state, *h, requestId);
  if (std::holds_alternative<proto::Goodbye>(message)) return Outcome{{}, true, std::nullopt, std::nullopt};
  if (!state.greeted) throw proto::ProtocolError(ErrorCode::UnexpectedMessage, "send Hello first");
  // A message of a later version than the session's (FrameReceived, Authenticate, Upload...) is not known there,
  // whatever version its header said.
  if (const proto::MessageType type = proto::messageType(message); !proto::messageTypeInVersion(type, state.version))
    throw proto::ProtocolError(ErrorCode::UnknownType, std::string(proto::messageTypeName(type)) +
                                                           " is not known in protocol version " +
                                                           std::to_string(state.version));
  return std::visit(
      [&](const auto& m) -> Outcome {
        using M = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<M, proto::ListDatasets>) {
          return replyWith(proto::DatasetList{mDatasets.names(visibleTo(state))}, requestId);
        } else if constexpr (std::is_same_v<M, proto::OpenDataset>) {
          return openDataset(state, m, requestId);
        } else if constexpr (std::is_same_v<M, proto::RenderRequest>) {
          return render(state, m, requestId);
        } else if constexpr (std::is_same_v<M, proto::GetStats>) {
          return replyWith(proto::Stats{statsFor(state).dump(2)}, requestId);
        } else if constexpr (std::is_same_v<M, proto::Authenticate>) {
          return authenticate(state, m, requestId);
        } else if constexpr (std::is_same_v<M, proto::FrameReceived>) {
          return Outcome{};  // read by the Connection (its link's pace); nothing answers it
        } else if constexpr (std::is_same_v<M, proto::Upload>) {
          return upload(state, m, requestId);
        } else if constexpr (std::is_same_v<M, proto::UploadChunk>) {
          return uploadChunk(state, m, requestId);
        } else {
          throw proto::ProtocolError(
              ErrorCode::UnexpectedMessage,
              std::string(proto::messageTypeName(proto::messageType(message))) + " is sent by servers, not clients");
        }
      },
      message);
}

Outcome MessageHandler::hello(ConnectionState& state, const proto::Hello& hello, uint32_t requestId) {
  if (state.greeted) throw proto::ProtocolError(ErrorCode::UnexpectedMessage, "Hello was already received");
  // The highest version both speak.
  const uint16_t version = std::min(hello.maxVersion, proto::kMaxVersion);
  if (version < hello.minVersion || version < proto::kMinVersion)
    throw proto::ProtocolError(ErrorCode::UnsupportedVersion,
                               "client speaks versions " + std::to_string(hello.minVersion) + ".." +
                                   std::to_string(hello.maxVersion) + ", server speaks " +
                                   std::to_string(proto::kMinVersion) + ".." + std::to_string(proto::kMaxVersion));
  state.greeted = true;
  state.version = version;
  spdlog::debug("hello from '{}'", hello.client);
  proto::Capabilities caps;
  caps.server = "voxbrick 0.1.0";
  caps.maxMessageBytes = mConfig.maxMessageBytes;
  caps.maxImageSide = uint32_t(mConfig.maxImageSide);
  caps.maxQueuedPerSession = uint32_t(mConfig.maxQueuedPerSession());
  caps.version = version;
  caps.encodings = proto::encodingsOf(version);
  return replyWith(std::move(caps), requestId);
}

Outcome MessageHandler::openDataset(ConnectionState& state, const proto::OpenDataset& open, uint32_t requestId) {
  std::shared_ptr<const render::Dataset> dataset;
  try {
    dataset = mDatasets.open(open.name, visibleTo(state));
  } catch (const DatasetNotFound&) {
    // The client hears the same for both; the trail says which it was.
    if (mAudit)
      mAudit->record(auditEvent(state, "refused", open.name,
                                state.access && !state.access->mayOpen(open.name)
                                    ? "not among the datasets of the session's token"
                                    : "no such dataset"));
    throw;
  }
  if (mAudit) mAudit->record(auditEvent(state, "dataset", dataset->name()));
  state.dataset = dataset;
  state.lastCamera.reset();
  return replyWith(proto::DatasetInfo{dataset->name(), dataset->infoJson()}, requestId);
}

Outcome MessageHandler::authenticate(ConnectionState& state, const proto::Authenticate& message, uint32_t requestId) {
  if (state.authenticated)
    throw proto::ProtocolError(ErrorCode::UnexpectedMessage, "this session presented its access token already");
  if (state.dataset)
    throw proto::ProtocolError(ErrorCode::UnexpectedMessage,
                               "Authenticate comes before OpenDataset: the token decides what the session may open");
  std::shared_ptr<const TokenGrant> grant = mTokens ? mTokens->match(message.token) : nullptr;
  if (!grant) {
    mStats.refused(Refusal::Forbidden);
    if (mAudit) mAudit->record(auditEvent(state, "refused", "", "wrong access token"));
    // Never the token itself: it goes nowhere, the log included.
    throw proto::ProtocolError(ErrorCode::Forbidden, mTokens && mTokens->configured()
                                                         ? "wrong access token"
                                                         : "wrong access token: this server has no access tokens");
  }
  state.access = grant;
  state.authenticated = true;
  return replyWith(proto::Authenticated{grant->id}, requestId);
}

Outcome MessageHandler::upload(ConnectionState& state, const proto::Upload& request, uint32_t requestId) {
  if (state.upload)
    throw proto::ProtocolError(ErrorCode::UnexpectedMessage,
                               "this session's upload of '" + state.upload->name() + "' is not finished (" +
                                   std::to_string(state.upload->received()) + " of " +
                                   std::to_string(state.upload->expected()) + " bytes sent)");
  try {
    if (!mUploads) throw proto::ProtocolError(ErrorCode::Forbidden, "this server takes no uploads");
    state.upload = mUploads->begin(request, state.authenticated ? state.access.get() : nullptr);
  } catch (...) {
    Outcome refused = failed(std::current_exception(), requestId, "upload '" + request.name + "'");
    const auto& error = std::get<proto::Error>(refused.replies.front().message);
    mStats.add(ServerEvent::UploadRefused);
    if (mAudit) mAudit->record(auditEvent(state, "refused", request.name, "upload: " + error.message));
    // A refused upload leaves the session as it was (Forbidden closes a session only for a wrong token).
    refused.close = false;
    return refused;
  }
  return replyWith(proto::UploadReady{mUploads->chunkBytes()}, requestId);
}

Outcome MessageHandler::uploadChunk(ConnectionState& state, const proto::UploadChunk& chunk, uint32_t requestId) {
  if (!state.upload) throw proto::ProtocolError(ErrorCode::UnexpectedMessage, "no upload in progress: send Upload first");
  if (state.preparing)
    throw proto::ProtocolError(ErrorCode::UnexpectedMessage,
                               "upload '" + state.upload->name() + "' has all its bytes: its store is being prepped");
  bool last;
  try {
    last = state.upload->append(chunk.data);
  } catch (...) {
    mStats.add(ServerEvent::UploadRefused);
    if (mAudit) mAudit->record(auditEvent(state, "refused", state.upload->name(), "upload: a chunk was refused"));
    state.upload.reset();  // its scratch goes with it
    throw;
  }
  if (!last) return {};
  state.preparing = true;
  Outcome outcome;
  outcome.prepare = PrepareJob{state.upload, requestId};
  return outcome;
}

Outcome MessageHandler::prepared(ConnectionState& state, const PrepareJob& job, const std::exception_ptr& error) {
  if (state.upload == job.upload) {
    state.upload.reset();
    state.preparing = false;
  }
  job.upload->release();  // its scratch and its place go before the answer: the client may upload again at once
  const std::string& name = job.upload->name();
  if (error) {
    mStats.add(ServerEvent::UploadRefused);
    Outcome outcome = failed(error, job.requestId, "upload '" + name + "'");
    if (mAudit)
      mAudit->record(auditEvent(state, "refused", name,
                                "upload: " + std::get<proto::Error>(outcome.replies.front().message).message));
    return outcome;
  }
  mStats.add(ServerEvent::Uploaded);
  if (mAudit) mAudit->record(auditEvent(state, "uploaded", name));
  // Its DatasetInfo, as OpenDataset answers, without making it the session's open dataset.
  try {
    const auto dataset = mDatasets.open(name, visibleTo(state));
    return replyWith(proto::DatasetInfo{dataset->name(), dataset->infoJson()}, job.requestId);
  } catch (...) {
    return failed(std::current_exception(), job.requestId, "dataset '" + name + "' cannot be opened");
  }
}

nlohmann::json MessageHandler::statsFor(const ConnectionState& state) const {
  nlohmann::json stats = mStatsJson();
  if (!state.access || state.access->everything() || !stats.contains("datasets")) return stats;
  nlohmann::json visible = nlohmann::json::array();
  for (const nlohmann::json& dataset : stats["datasets"])
    if (dataset.is_object() && state.access->mayOpen(dataset.value("name", std::string()))) visible.push_back(dataset);
  stats["datasets"] = std::move(visible);
  // A PACS' series as the token sees them: only those it may open.
  if (stats.contains("pacs") && stats["pacs"].is_array())
    for (nlohmann::json& pacs : stats["pacs"]) {
      nlohmann::json series = nlohmann::json::array();
      for (const nlohmann::json& s : pacs.value("series", nlohmann::json::array()))
        if (state.access->mayOpen(s.value("name", std::string()))) series.push_back(s);
      pacs["series"] = std::move(series);
    }
  return stats;
}

Outcome MessageHandler::render(ConnectionState& state, const proto::RenderRequest& request, uint32_t requestId) {
  mStats.add(ServerEvent::RenderRequest);
  if (!state.dataset) throw proto::ProtocolError(ErrorCode::UnexpectedMessage, "open a dataset before rendering");
  // Replaced on disk since it was opened (two stat calls tell)? Then the session draws the new files. A quarantined
  // dataset that was not replaced is refused without drawing.
  state.dataset = mDatasets.open(state.dataset->name());
  if (const auto why = state.dataset->quarantined())
    throw DatasetUnavailable("dataset '" + state.dataset->name() + "' is quarantined until it is replaced: " + *why);
  RenderJob job;
  job.requestId = requestId;
  // An encoding the session's version lacks is refused as the decoder refuses it in a header of that version, so a
  // version-1 session never gets jpeg, whatever version its Render's header said.
  if (!proto::encodingInVersion(request.encoding, state.version))
    throw proto::ProtocolError(ErrorCode::Malformed, "Render.encoding: unknown value " +
                                                         std::to_string(int(request.encoding)) +
                                                         " in protocol version " + std::to_string(state.version));
  job.encoding = request.encoding;
  job.provisionalAsDrawn = state.version >= proto::kProvisionalAsDrawnVersion;
  job.dataset = state.dataset;
  job.received = Clock::now();
  // Presets were read at start: parsing a scene reads no file on an I/O thread.
  job.scene = render::Scene::fromJson(request.sceneJson, "scene", mPresets);
  checkEncodings(job, state.version);
  if (job.scene.width > mConfig.maxImageSide || job.scene.height > mConfig.maxImageSide)
    throw LimitExceededError("image " + std::to_string(job.scene.width) + "x" + std::to_string(job.scene.height) +
                             " exceeds this server's limit of " + std::to_string(mConfig.maxImageSide) + " per side");
  // A raw frame's size is known now: one the session could not receive is refused before it is drawn (the stats
  // take a few hundred bytes; 4 KiB is kept for them). Other encodings are checked once encoded (renderReply).
  job.maxBodyBytes = mConfig.maxMessageBytes;
  job.encodeAside = mConfig.encodeAside;
  job.maxSamples = mConfig.maxRenderMSamples * 1e6;
  if (job.encoding == proto::Encoding::RawRgba8) {
    const uint64_t body = frameBodyBytes(4096, uint64_t(job.scene.width) * uint64_t(job.scene.height) * 4);
    if (body > job.maxBodyBytes)
      throw LimitExceededError("a raw_rgba8 frame of " + std::to_string(job.scene.width) + "x" +
                               std::to_string(job.scene.height) + " takes about " + std::to_string(body) +
                               " bytes, above this server's message limit of " + std::to_string(job.maxBodyBytes) +
                               "; ask for png or zstd_rgba8, or a smaller image");
  }
  job.previousCamera = state.lastCamera;
  state.lastCamera = job.scene.camera;
  mStats.renderAccepted(frameClassOf(job));
  Outcome outcome;
  outcome.render = std::move(job);
  return outcome;
}

Outcome MessageHandler::submitted(ConnectionState& state, uint32_t requestId, Submission submission) {
  switch (submission.result) {
    case Submission::Result::Stopped:
      return {};  // the session is being closed with ShuttingDown; the request gets no other reply
    case Submission::Result::Full:
      return replyWith(
          errorMessage(ErrorCode::LimitExceeded,
                       "more than " + std::to_string(ServerConfig::kMaxQueuedWithoutCoalescing) + " renders queued"),
          requestId);
    case Submission::Result::Busy:
      mStats.refused(submission.quota ? Refusal::Quota : Refusal::Busy);
      return replyWith(errorMessage(ErrorCode::Busy, proto::busyMessage(submission.why, submission.retryAfterMs)),
                       requestId);
    case Submission::Result::Queued: break;
  }
  ++state.outstandingRenders;
  // A refinement the client never asked for (its request already had a provisional Frame) goes without a word.
  if (!submission.replaced || submission.replaced->refinement) return {};
  --state.outstandingRenders;
  mStats.add(ServerEvent::Superseded);
  const uint32_t replaced = submission.replaced->requestId;
  return replyWith(
      errorMessage(ErrorCode::Superseded, "request " + std::to_string(replaced) + " was replaced by request " +
                                              std::to_string(requestId) + " before it started"),
      replaced);
}

Outcome MessageHandler::dropped(ConnectionState& state, const RenderJob& job, bool answered) {
  if (!job.refinement) --state.outstandingRenders;
  if (answered) return {};
  mStats.add(ServerEvent::Superseded);
  return replyWith(errorMessage(ErrorCode::Superseded, "a newer frame of this session was ready before this one was "
                                                       "encoded"),
                   job.requestId);
}

Outcome MessageHandler::rendered(ConnectionState& state, const RenderJob& job, proto::Message reply) {
  // A provisional Frame answers its request as any Frame does; the refinement after it was not counted.
  if (job.refinement)
    mStats.add(ServerEvent::Refined);
  else
    --state.outstandingRenders;
  if (job.shared && std::holds_alternative<proto::Frame>(reply)) mStats.frameShared();
  if (const auto* frame = std::get_if<proto::Frame>(&reply); !frame)
    mStats.add(ServerEvent::RenderError);
  else if (!job.refinement)
    mStats.frameDelivered(frameClassOf(job), frame->encoding,
                          proto::kHeaderBytes + frameBodyBytes(frame->statsJson.size(), frame->payload.size()),
                          std::chrono::duration<double, std::milli>(Clock::now() - job.received).count());
  return replyWith(std::move(reply), job.requestId);
}

}  // namespace voxbrick::server
