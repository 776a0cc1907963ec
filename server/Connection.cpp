// The transport-independent rules of one client connection: deadlines, admission, decoding, the reply queue, its
// back-pressure and the output budget.
#include "server/Connection.h"

#include <algorithm>
#include <iterator>
#include <utility>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "image/Video.h"
#include "server/ErrorReply.h"

namespace voxbrick::server {
namespace {

using Clock = std::chrono::steady_clock;

/// Bytes a Frame takes encoded, near enough to weigh it against the output budget before encoding it.
uint64_t encodedBytes(const proto::Frame& frame) {
  return proto::kHeaderBytes + 64 + frame.statsJson.size() + frame.payload.size();
}

/// Hands memory freed by the allocator back to the system. glibc keeps what a large reply queue freed in its
/// arenas (its mmap threshold rises with the sizes it sees), so without this the resident size of the server stays
/// at its peak after the clients that caused it are gone.
void releaseFreedMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

/// A moving frame of a video stream that found no room for its encoder in the server's video memory, as a still JPEG
/// (PROTOCOL.md, Session 11): its pixels encoded as any provisional JPEG frame of the job, its statistics saying why.
proto::Message jpegForWantOfVideoMemory(proto::Frame frame, const RenderJob& job) {
  frame.encoding = proto::Encoding::Jpeg;
  // Drawn at the stream's size (RenderJob::outputScale): a still is the scene's, unless its client shows a
  // provisional frame scaled (RenderJob::provisionalAsDrawn).
  if (const int width = job.scene.width, height = job.scene.height;
      !job.provisionalAsDrawn && (int(frame.width) != width || int(frame.height) != height)) {
    try {
      image::Image8 pixels =
          image::scaleImage({int(frame.width), int(frame.height), std::move(frame.payload)}, width, height);
      frame.payload = std::move(pixels.rgba);
      frame.width = uint32_t(width), frame.height = uint32_t(height);
    } catch (...) {
      return errorReply(std::current_exception(), "the video frame could not be scaled to its scene's size");
    }
  }
  frame.statsJson = withKey(std::move(frame.statsJson), "video_fallback", "\"memory\"");
  return encodeStill(std::move(frame), replyJpegQuality(job, true, int(frame.width), int(frame.height)), job);
}

/// The first reply's error, for logs.
std::string describeError(const Outcome& outcome) {
  if (outcome.replies.empty()) return "?";
  const auto* error = std::get_if<proto::Error>(&outcome.replies.front().message);
  return error ? error->message + " (" + proto::errorCodeName(error->code) + ")" : "?";
}

}  // namespace

Connection::Connection(Transport& transport, const SessionServices& services, ConnectionId id, std::string peer,
                       std::string kind)
    : mTransport(transport), mServices(services), mId(id), mPeer(std::move(peer)) {
  if (services.tokens) mState.access = services.tokens->anonymous();
  mState.client = mPeer.substr(0, mPeer.find(' '));
  mState.transport = std::move(kind);
}

void Connection::audit(const std::string& event, const std::string& reason) const {
  if (mServices.audit) mServices.audit->record(auditEvent(mState, event, {}, reason));
}

void Connection::presented(std::shared_ptr<const TokenGrant> grant) {
  mState.access = std::move(grant);
  mState.authenticated = true;
}

Connection::~Connection() {
  // The buffers are freed here, not in close(): an aborted write may still refer to them until it reported.
  const bool large = mPeakOutboxBytes > mServices.config.pauseReadingBytes;
  mOutbox.clear();
  mOutbox.shrink_to_fit();
  // A video stream's encoder holds tens to hundreds of MiB, in blocks glibc keeps in its arenas once freed (below the
  // mmap threshold keepFreedMemoryForFrames sets): without a trim, a crowd of streams that has gone left the server
  // resident near its peak (bench/run_video_memory.sh reads what is left once the clients have gone).
  const bool encoded = mVideo && mVideo->frames() > 0;
  mVideo.reset();
  if (large || encoded) releaseFreedMemory();
}

void Connection::start() {
  // A connection that has not said Hello is not a session yet: it gets a short deadline of its own, so streams that
  // never speak (or trickle bytes) hold a pending slot for seconds, not the idle timeout.
  mTransport.arm(Deadline::Hello, mServices.config.helloTimeoutS);
  readMessage();
}

void Connection::end(proto::Error error) {
  send(error, 0);
  closeAfterFlush();
}

void Connection::expired(Deadline deadline) {
  switch (deadline) {
    case Deadline::Hello: return onHelloTimeout();
    case Deadline::Read: return onReadTimeout();
    case Deadline::Write: return onWriteTimeout();
    case Deadline::Pace:
      mPaceArmedAt = {};
      if (mClosed) return;
      if (!mWriting && !mOutbox.empty()) writeNext();
      return pumpVideo();
  }
}

void Connection::onHelloTimeout() {
  if (mState.greeted || mClosing || mClosed) return;
  timedOut("no Hello within " + std::to_string(mServices.config.helloTimeoutS) + " s");
}

void Connection::onReadTimeout() {
  if (mClosed || mClosing) return;
  const ServerConfig& config = mServices.config;
  if (!mReadingMessage && mState.awaitingFrames()) {  // the client is waiting for us, not idle
    mTransport.arm(Deadline::Read, config.idleTimeoutS);
    return;
  }
  timedOut(mReadingMessage
               ? "message not completed within " + std::to_string(config.readTimeoutS) + " s of its first byte"
               : "idle for " + std::to_string(config.idleTimeoutS) + " s");
}

void Connection::onWriteTimeout() {
  if (mClosed) return;
  mServices.stats.add(ServerEvent::SlowClientDropped);
  spdlog::info("{}: a reply was not taken within {} s, closing", mPeer, mServices.config.writeTimeoutS);
  close();
}

void Connection::timedOut(const std::string& what) {
  mServices.stats.add(ServerEvent::Timeout);
  spdlog::info("{}: closing: {}", mPeer, what);
  send(errorMessage(proto::ErrorCode::Timeout, what), 0);
  closeAfterFlush();
}

void Connection::rendered(const RenderJob& job, proto::Message reply) {
  if (mClosing || mClosed) return;  // PROTOCOL.md: a session's end drops its renders unanswered
  auto* frame = std::get_if<proto::Frame>(&reply);
  const bool video = frame && image::isVideoEncoding(frame->encoding);
  // After the frame being encoded: a session's frames keep their order (a video frame during a video encoding waits
  // as the stream's pending frame instead, where a newer one replaces it).
  if (frame && (mStillEncoding || (mVideoEncoding && !video))) {
    if (!video) replaceWaitingStill(job.requestId);
    mAfterEncoding.emplace_back(job, std::move(reply));
    return;
  }
  if (video) return videoRendered(job, std::move(*frame));
  if (frame && mVideoPending) dropPendingVideo(job.requestId);  // latest wins
  if (frame && job.stillToEncode) return encodeStill(job, std::move(*frame));
  if (!withinOutputBudget(job, reply)) return;
  deliver(job, std::move(reply));
}

void Connection::deliver(const RenderJob& job, proto::Message reply) {
  if (std::holds_alternative<proto::Frame>(reply)) {
    const auto unsent = firstUnsent(&Outgoing::frame);
    if (unsent != mOutbox.end() && unsent->requestId != job.requestId && job.received < unsent->asked)
      return apply(mServices.handler.dropped(mState, job, job.refinement));
  }
  apply(mServices.handler.rendered(mState, job, std::move(reply)), &job);
}

void Connection::encodeStill(const RenderJob& job, proto::Frame frame) {
  auto task = std::make_shared<EncodingStill>();
  task->job = job;
  task->message = std::move(frame);
  mStillEncoding = true;
  mTransport.runAside(
      [task] {
        task->message =
            server::encodeStill(std::move(std::get<proto::Frame>(task->message)), *task->job.stillToEncode, task->job);
      },
      [this, task] { stillEncoded(*task); }, Aside::Encode, frameClassOf(job));
}

void Connection::stillEncoded(EncodingStill& done) {
  mStillEncoding = false;
  if (mClosing || mClosed) return;
  // A provisional frame that could not be sent (too large, or not encoded) answered its request with the error: the
  // exact frame the scheduler queued after it is dropped when it comes, as for a provisional frame refused output.
  if (done.job.stillProvisional && !done.job.refinement && std::holds_alternative<proto::Error>(done.message))
    mRefusedProvisional.insert(done.job.requestId);
  if (withinOutputBudget(done.job, done.message)) deliver(done.job, std::move(done.message));
  renderedAfterEncoding();
}

void Connection::replaceWaitingStill(uint32_t by) {
  // Latest wins before encoding as after it (replaceUnsentFrame): a still frame waiting for the encoder gives way to
  // the newer one, so that a render thread faster than the encoders never leaves a session a backlog of frames to
  // encode and then replace.
  const auto waiting = std::find_if(mAfterEncoding.rbegin(), mAfterEncoding.rend(), [](const auto& entry) {
    const auto* frame = std::get_if<proto::Frame>(&entry.second);
    return frame && !image::isVideoEncoding(frame->encoding);
  });
  if (waiting == mAfterEncoding.rend()) return;
  const RenderJob dropped = std::move(waiting->first);
  mAfterEncoding.erase(std::next(waiting).base());
  apply(mServices.handler.dropped(mState, dropped, dropped.requestId == by));
}

void Connection::renderedAfterEncoding() {
  std::vector<std::pair<RenderJob, proto::Message>> after;
  after.swap(mAfterEncoding);
  // Each in turn: one that starts an encoding sends the rest back to wait, in their order.
  for (auto& [job, message] : after) rendered(job, std::move(message));
  pumpVideo();
}

void Connection::videoRendered(const RenderJob& job, proto::Frame frame) {
  if (job.received < mVideoAsked || (mVideoPending && job.received < mVideoPending->job.received)) {
    // (A video frame is never a refinement, whose `received` is when it was queued: it is its client's Render's.)
    apply(mServices.handler.dropped(mState, job, false));
    return;
  }
  if (mVideoPending) dropPendingVideo(job.requestId);
  mVideoPending = PendingVideo{job, std::move(frame), Clock::now()};
  pumpVideo();
}

void Connection::dropPendingVideo(uint32_t by) {
  PendingVideo dropped = std::move(*mVideoPending);
  mVideoPending.reset();
  apply(mServices.handler.dropped(mState, dropped.job, dropped.job.requestId == by));
}

std::deque<Connection::Outgoing>::iterator Connection::firstUnsent(bool Outgoing::*kind) {
  return std::find_if(mOutbox.begin() + (mWriting ? 1 : 0), mOutbox.end(),
                      [kind](const Outgoing& reply) { return reply.*kind; });
}

void Connection::pumpVideo() {
  if (mVideoEncoding || mStillEncoding || !mVideoPending || mClosing || mClosed ||
      firstUnsent(&Outgoing::video) != mOutbox.end())
    return;
  const auto now = Clock::now();
  // Encoded ahead: started when the link is expected to have room by the time the encoder is done (the frame then
  // waits in the outbox for LinkPacer::mayWrite), so the encoding is not part of the time between frames.
  const auto lead = std::chrono::microseconds(int64_t(mVideoEncodeLeadMs * 1000));
  const std::optional<Clock::time_point> room = mPacer.roomExpectedAt(now);
  if (!mPacer.mayWrite(now) && !(room && *room <= now + lead))
    return armPaceAt(room ? std::max(now, *room - lead) : mPacer.releaseAt());
  auto task = std::make_shared<EncodingVideo>();
  task->handedAt = now;
  task->job = std::move(mVideoPending->job);
  task->frame = std::move(mVideoPending->frame);
  task->input.drawn = mVideoPending->drawn;
  task->input.received = task->job.received;
  mVideoAsked = task->job.received;
  mVideoPending.reset();
  task->input.dataset = task->job.dataset.get();
  task->input.keyframe = task->job.scene.keyframe || mVideoNeedsKey;
  task->input.fullChroma = task->job.scene.acceptsVp9_444;
  // The scene's size, not the frame's, which may have been drawn at the stream's (RenderJob::outputScale).
  const int width = task->job.scene.width, height = task->job.scene.height;
  task->input.sceneWidth = width, task->input.sceneHeight = height;
  task->input.bitrateKbps = mPacer.videoKbps(VideoStream::startKbps(width, height),
                                             VideoStream::capKbps(width, height), now, videoPaceMs());
  task->input.followDrawing = mServices.config.scheduler.streamFollowsDrawing;
  if (mServices.video && mServices.config.scheduler.encoderLadder)
    task->input.encodeShareMs = frameShareMs(size_t(mServices.config.encodeThreads),
                                             mServices.config.scheduler.interactiveFps, mServices.video->moving(now));
  mVideoNeedsKey = false;
  mVideoEncoding = true;
  mTransport.runAside(
      [stream = mVideo.get(), task] {
        try {
          task->encoded = stream->encode(task->frame, task->input);
          if (task->encoded.noRoom) task->still = jpegForWantOfVideoMemory(std::move(task->frame), task->job);
        } catch (...) {
          task->error = std::current_exception();
        }
      },
      [this, task] { videoEncoded(*task); }, Aside::Encode, frameClassOf(task->job));
}

void Connection::videoEncoded(EncodingVideo& done) {
  mVideoEncoding = false;
  const double leadMs = std::chrono::duration<double, std::milli>(Clock::now() - done.handedAt).count();
  mVideoEncodeLeadMs = mVideoEncodeLeadMs > 0 ? 0.75 * mVideoEncodeLeadMs + 0.25 * leadMs : leadMs;
  if (!done.error && !done.still)
    mServices.stats.videoEncoded(done.frame.encoding, done.encoded.encodeMs,
                                 done.encoded.key ? done.encoded.keyReason : "", done.encoded.scaledFor);
  if (mClosing || mClosed) return;
  proto::Message reply = done.error ? proto::Message(errorReply(done.error, "video frame of request " +
                                                                               std::to_string(done.job.requestId) +
                                                                               " could not be encoded"))
                         : done.still ? std::move(*done.still)
                                      : proto::Message(std::move(done.frame));
  if (const auto* frame = std::get_if<proto::Frame>(&reply);
      frame && frameBodyBytes(frame->statsJson.size(), frame->payload.size()) > done.job.maxBodyBytes)
    reply = errorMessage(proto::ErrorCode::LimitExceeded,
                         "the " + std::to_string(frame->width) + "x" + std::to_string(frame->height) +
                             " video frame is above this server's message limit of " +
                             std::to_string(done.job.maxBodyBytes) + " bytes");
  // A frame the stream encoded but the client will not get: the decoder cannot go on past it.
  const bool sent = withinOutputBudget(done.job, reply);
  if (!sent || !std::holds_alternative<proto::Frame>(reply)) mVideoNeedsKey = true;
  if (sent) apply(mServices.handler.rendered(mState, done.job, std::move(reply)));
  renderedAfterEncoding();
}

void Connection::armPaceAt(Clock::time_point when) {
  const auto now = Clock::now();
  if (mPaceArmedAt > now && mPaceArmedAt <= when) return;  // woken sooner: writeNext and pumpVideo look again then
  mPaceArmedAt = when;
  mTransport.arm(Deadline::Pace, std::max(0.001, std::chrono::duration<double>(when - now).count()));
}

std::optional<double> Connection::videoPaceMs() const {
  const std::optional<double> interval = mServices.scheduler.renderIntervalMs(*mTransport.renderSink());
  if (!interval) return std::nullopt;
  return LinkPacer::paceMsFor(*interval);
}

void Connection::frameReceived() {
  if (!mPacer.received(Clock::now())) return;
  if (!mWriting && !mOutbox.empty()) writeNext();
  pumpVideo();
}

bool Connection::withinOutputBudget(const RenderJob& job, proto::Message& reply) {
  // Each request keeps exactly one answer (PROTOCOL.md 5.4 and 5.8): an exact frame whose provisional one was
  // refused, or one that does not fit when its provisional one already answered the request, is dropped.
  if (job.refinement && mRefusedProvisional.erase(job.requestId) > 0) return false;
  const auto* frame = std::get_if<proto::Frame>(&reply);
  if (!frame) return true;
  const uint64_t bytes = encodedBytes(*frame);
  if (mServices.output.fits(bytes)) return true;
  mServices.stats.add(ServerEvent::OutputRefused);
  if (job.refinement) return false;
  const nlohmann::json stats = nlohmann::json::parse(frame->statsJson, nullptr, false);
  if (stats.is_object() && stats.value("provisional", false)) mRefusedProvisional.insert(job.requestId);
  spdlog::info("{}: frame of {} bytes refused: {} bytes of replies wait for their clients", mPeer, bytes,
               mServices.output.queued());
  // Busy (LimitExceeded before version 3, with the same words): the replies drain as the clients read them, so the
  // same Render asked again after the hint may well fit.
  reply = errorMessage(proto::ErrorCode::Busy,
                       proto::busyMessage("frame of " + std::to_string(bytes) + " bytes not sent: the server holds " +
                                              std::to_string(mServices.output.queued()) +
                                              " bytes of replies its clients have not read (limit " +
                                              std::to_string(mServices.output.limit()) + ", max_total_output_bytes)",
                                          kOutputBusyRetryMs));
  return true;
}

void Connection::readNext() {
  if (mOutboxBytes > mServices.config.pauseReadingBytes) {
    // The client is not taking its replies: reading its next request would only queue more of them. Its requests
    // wait in the transport's buffers (and then its own) until written() resumes; the write deadline closes it if
    // it never reads.
    mPaused = true;
    mServices.stats.add(ServerEvent::ReadingPaused);
    spdlog::debug("{}: {} bytes of replies not read, reading paused", mPeer, mOutboxBytes);
    return;
  }
  readMessage();
}

void Connection::readMessage() {
  if (mClosing || mClosed) return;
  mReadingMessage = false;
  mTransport.arm(Deadline::Read, mServices.config.idleTimeoutS);
  mTransport.readMessage();
}

void Connection::messageStarted() {
  if (mReadingMessage) return;
  // The whole message, header and body, must arrive within the read timeout of its first byte: a client that
  // trickles bytes cannot stretch the deadline.
  mReadingMessage = true;
  mTransport.arm(Deadline::Read, mServices.config.readTimeoutS);
}

void Connection::readFailed() { close(); }

std::optional<proto::Header> Connection::headerReceived(std::span<const uint8_t, proto::kHeaderBytes> bytes) {
  try {
    // Any version the server speaks is read, its body in that version; what the session's version lacks (jpeg in
    // version 1) is refused by the handler whatever the header says.
    mHeader = proto::decodeHeader(bytes, mServices.limits);  // bodyBytes at most limits.maxBodyBytes
  } catch (...) {
    refuseStream(std::current_exception());
    return std::nullopt;
  }
  return mHeader;
}

void Connection::refuseStream(const std::exception_ptr& error) {
  mServices.stats.add(ServerEvent::ProtocolError);
  Outcome outcome = MessageHandler::failed(error, 0);
  // Without a trustworthy header the stream cannot be resynchronised, whatever the code.
  outcome.close = true;
  spdlog::info("{}: {}, closing", mPeer, describeError(outcome));
  apply(std::move(outcome));
}

void Connection::refuse(proto::ErrorCode code, const std::string& why) {
  refuseStream(std::make_exception_ptr(proto::ProtocolError(code, why)));
}

void Connection::received(std::span<const uint8_t> message) {
  if (message.size() < proto::kHeaderBytes)
    return refuseStream(std::make_exception_ptr(proto::ProtocolError(
        proto::ErrorCode::Malformed, "message of " + std::to_string(message.size()) + " bytes has no whole header")));
  if (headerReceived(message.first<proto::kHeaderBytes>())) bodyReceived(message.subspan(proto::kHeaderBytes));
}

void Connection::bodyReceived(std::span<const uint8_t> body) {
  mTransport.cancel(Deadline::Read);
  mServices.stats.add(ServerEvent::Message);
  std::optional<proto::Message> message;
  Outcome outcome;
  try {
    if (body.size() != mHeader.bodyBytes)  // only where the transport delimits messages itself
      throw proto::ProtocolError(proto::ErrorCode::Malformed, "body of " + std::to_string(body.size()) +
                                                                  " bytes where its header announces " +
                                                                  std::to_string(mHeader.bodyBytes));
    message = proto::decodeBody(mHeader, body, mServices.limits);
  } catch (...) {
    // The length was valid, so the next message starts where this one ended: the session goes on.
    mServices.stats.add(ServerEvent::ProtocolError);
    outcome = MessageHandler::failed(std::current_exception(), mHeader.requestId);
    spdlog::debug("{}: {}", mPeer, describeError(outcome));
  }
  const bool wasGreeted = mState.greeted, wasAuthenticated = mState.authenticated;
  if (message) outcome = mServices.handler.handle(mState, *message, mHeader.requestId);
  if (!wasGreeted && mState.greeted) admit(outcome);
  if (!wasAuthenticated && mState.authenticated) authenticated(outcome);
  apply(std::move(outcome));
  // A report the handler accepted (no Error in reply) is the link's news.
  if (message && std::holds_alternative<proto::FrameReceived>(*message) && mState.greeted && outcome.replies.empty())
    frameReceived();
  readNext();
}

void Connection::admit(Outcome& outcome) {
  mTransport.cancel(Deadline::Hello);
  std::optional<proto::Error> refusal = mServices.greeted(mId);
  if (!refusal) return audit("session");
  audit("refused", "at Hello: " + refusal->message);
  // Sessions filled up while this connection waited for its Hello (or it was evicted), its quota is full, or the
  // render threads are over capacity: refused as on connect, with the reason (counted by `greeted`).
  spdlog::info("{}: refused at Hello: {}", mPeer, refusal->message);
  outcome = Outcome{};
  outcome.replies.push_back({std::move(*refusal), 0});
  outcome.close = true;
}

void Connection::authenticated(Outcome& outcome) {
  const std::optional<std::string> refusal =
      mServices.authenticated ? mServices.authenticated(mId, *mState.access) : std::nullopt;
  if (!refusal) {
    spdlog::debug("{}: token '{}' presented", mPeer, mState.access->id);
    return audit("token");
  }
  spdlog::info("{}: token '{}' refused: {}", mPeer, mState.access->id, *refusal);
  audit("refused", "token '" + mState.access->id + "': " + *refusal);
  mState.access = mServices.tokens ? mServices.tokens->anonymous() : nullptr;
  mState.authenticated = false;
  const uint32_t requestId = outcome.replies.empty() ? 0 : outcome.replies.front().requestId;
  outcome = Outcome{};
  outcome.replies.push_back({errorMessage(proto::ErrorCode::LimitExceeded, *refusal), requestId});
}

void Connection::apply(Outcome outcome, const RenderJob* from) {
  for (const Reply& reply : outcome.replies) send(reply.message, reply.requestId, from);
  if (outcome.render && !mClosed && !mClosing) {
    const uint32_t requestId = outcome.render->requestId;
    const std::optional<double> link = mPacer.settledLinkKbps();
    outcome.render->pngSpeed = pngSpeedFor(link);
    outcome.render->webpForPng = outcome.render->scene.acceptsWebp && webpFor(link);
    // A moving frame for the session's video stream is drawn at the stream's size, not drawn larger to be shrunk.
    if (outcome.render->scene.interactive && image::isVideoEncoding(replyEncoding(*outcome.render, true)))
      outcome.render->outputScale = mVideo->scale();
    std::optional<Submission> refused = mServices.renderQuota ? mServices.renderQuota(mId) : std::nullopt;
    const auto received = outcome.render->received;
    Submission submission = refused ? std::move(*refused)
                                    : mServices.scheduler.submit(mTransport.renderSink(), std::move(*outcome.render));
    if (!refused && submission.result == Submission::Result::Busy && mServices.renderNotTaken)
      mServices.renderNotTaken(mId);
    if (submission.result == Submission::Result::Queued) mNewestRender = std::max(mNewestRender, received);
    apply(mServices.handler.submitted(mState, requestId, std::move(submission)));
  }
  if (outcome.prepare && !mClosed && !mClosing) prepare(std::move(*outcome.prepare));
  if (outcome.close) closeAfterFlush();
}

void Connection::prepare(PrepareJob job) {
  auto error = std::make_shared<std::exception_ptr>();
  mTransport.runAside(
      [upload = job.upload, error] {
        try {
          upload->prepare();
        } catch (...) {
          *error = std::current_exception();
        }
      },
      [this, job, error] {
        if (mClosing || mClosed) return;  // abandoned: the upload went with the session
        apply(mServices.handler.prepared(mState, job, *error));
      },
      Aside::Prepare);
}

void Connection::abandonUpload() {
  if (!mState.upload) return;
  spdlog::info("{}: upload '{}' abandoned: the session ended", mPeer, mState.upload->name());
  mState.upload->cancel();
  mState.upload.reset();
  mState.preparing = false;
}

void Connection::send(const proto::Message& message, uint32_t requestId, const RenderJob* from) {
  if (mClosed) return;
  std::vector<uint8_t> bytes;
  try {
    // Busy exists from version 3 on: an older session gets LimitExceeded with the same message (and retry hint).
    if (const auto* error = std::get_if<proto::Error>(&message);
        error && !proto::errorCodeInVersion(error->code, mState.version))
      bytes = proto::encode(proto::Error{proto::ErrorCode::LimitExceeded, error->message}, requestId, mState.version);
    else
      bytes = proto::encode(message, requestId, mState.version);
  } catch (...) {  // a reply above 4 GiB, or no memory for it: the request is answered with the failure instead
    bytes = proto::encode(errorReply(std::current_exception(), "reply cannot be encoded"), requestId, mState.version);
  }
  const auto* sentFrame = std::get_if<proto::Frame>(&message);
  const bool video = sentFrame && image::isVideoEncoding(sentFrame->encoding);
  const bool frame = sentFrame && !video;
  if (sentFrame) replaceUnsentFrame(requestId);
  if (mOutboxBytes + bytes.size() > mServices.config.maxOutputBytes) {
    mServices.stats.add(ServerEvent::SlowClientDropped);
    spdlog::warn("{}: {} bytes of replies not read, dropping the session", mPeer, mOutboxBytes);
    return close();
  }
  const bool ordered = frame && from;
  enqueue(Outgoing{std::move(bytes), requestId, frame, video, ordered ? from->received : Clock::time_point{},
                   ordered && from->refinement, ordered && from->refinement && from->scene.interactive});
  if (!mWriting) writeNext();
}

void Connection::enqueue(Outgoing reply) {
  mOutboxBytes += reply.bytes.size();
  mPeakOutboxBytes = std::max(mPeakOutboxBytes, mOutboxBytes);
  mServices.output.add(reply.bytes.size());
  mOutbox.push_back(std::move(reply));
}

void Connection::replaceUnsentFrame(uint32_t requestId) {
  // Latest wins on output (PROTOCOL.md, session rules): the one frame queued and not yet being written gives way
  // to the newer one, so a client that reads slower than frames come gets the newest, never a growing queue.
  const auto unsent = firstUnsent(&Outgoing::frame);
  if (unsent == mOutbox.end()) return;
  mOutboxBytes -= unsent->bytes.size();
  mServices.output.release(unsent->bytes.size());
  // A provisional frame, its request now answered by the exact one; or an exact frame whose provisional one answered
  // its request (PROTOCOL.md 5.8: a provisional Frame is followed by at most one exact Frame, never an Error).
  if (unsent->requestId == requestId || unsent->answered) {
    mOutbox.erase(unsent);
    return;
  }
  mServices.stats.add(ServerEvent::Superseded);
  unsent->bytes = proto::encode(
      errorMessage(proto::ErrorCode::Superseded, "a newer frame of this session was ready before this one was sent"),
      unsent->requestId, mState.version);
  unsent->frame = false;
  mOutboxBytes += unsent->bytes.size();
  mServices.output.add(unsent->bytes.size());
}

void Connection::writeNext() {
  // An exact frame whose provisional frame answered its request, of a camera that has moved on since (a Render came
  // after it was asked for), goes without a word rather than take the link: the newer request's frames make it
  // obsolete (latest wins), and on a slow link its bytes would hold the moving frames behind it (a 1024² png takes
  // 650 ms at 10 Mbit/s). A rest the client only seemed to take (its next move came late) asks for such frames.
  while (!mOutbox.empty() && mOutbox.front().answered && mOutbox.front().asked < mNewestRender) popOutbox();
  if (mOutbox.empty()) {
    mWriting = false;
    if (mClosing) close();
    return;
  }
  const Outgoing& next = mOutbox.front();
  const auto now = Clock::now();
  if (next.afterMotion && mPacer.reporting() && !mClosing) {
    // The exact frame after a drag, to a client that reports: written once the camera rests, judged from what the
    // client could see. While frames are on their way, or until the scheduler's rest has passed since both the last
    // Render and the last report, it waits; a Render meanwhile makes it obsolete (above). A client that waits for
    // its replies before it moves on (the viewer keeps at most three Renders unanswered) sends nothing while a slow
    // link holds them, and the rest the scheduler saw was then the link's: an exact frame sent on it (650 ms for a
    // 1024² png at 10 Mbit/s) held back the very replies the client waited for, and the next rest it read was the
    // link's again.
    const auto quietSince = std::max(mNewestRender, mPacer.lastReport());
    const auto restEnds = quietSince + std::chrono::microseconds(int64_t(
                                           mServices.scheduler.restMs(*mTransport.renderSink()) * 1000));
    // (A client that stopped reporting, its oldest frame unreported for LinkPacer::kStaleMs, is waited for no more.)
    if (mPacer.inFlight() > 0 && now < mPacer.releaseAt()) {
      mWriting = false;
      return armPaceAt(mPacer.releaseAt());  // a report, or the oldest frame going stale, calls again
    }
    if (now < restEnds) {
      mWriting = false;
      return armPaceAt(restEnds);
    }
  }
  if ((next.frame || next.video) && !mClosing) {
    // A client that reports its frames keeps at most LinkPacer::kFramesInFlight on the link: this one waits here,
    // where a newer frame still replaces it, not in the network's buffers.
    if (!mPacer.mayWrite(now)) {
      mWriting = false;
      return armPaceAt(mPacer.releaseAt());
    }
    mPacer.sent(next.bytes.size(), now, next.video);
  }
  mWriting = true;
  mTransport.arm(Deadline::Write, mServices.config.writeTimeoutS);
  mTransport.write(next.bytes);
}

void Connection::popOutbox() {
  mOutboxBytes -= mOutbox.front().bytes.size();
  mServices.output.release(mOutbox.front().bytes.size());
  mOutbox.pop_front();
  // Resumed once half the threshold is gone, so a client reading at its own pace is not paused at every reply.
  if (mPaused && mOutboxBytes <= mServices.config.pauseReadingBytes / 2) {
    mPaused = false;
    readMessage();
  }
}

void Connection::written(bool ok) {
  mTransport.cancel(Deadline::Write);
  if (!ok || mClosed) return close();  // close() has released the queue's bytes already
  popOutbox();
  mWriting = false;
  if (!mOutbox.empty())
    writeNext();
  else if (mClosing)
    return close();
  pumpVideo();  // the stream's frame just written makes room for its next
}

void Connection::closeAfterFlush() {
  mClosing = true;
  mAlive = false;  // its waiting renders are dropped unrendered
  abandonUpload();
  if (mWriting) return;
  if (mOutbox.empty()) return close();
  writeNext();  // replies held back for the link go now
}

void Connection::close() {
  if (mClosed) return;
  mClosed = true;
  mAlive = false;
  abandonUpload();
  for (const Deadline deadline : {Deadline::Hello, Deadline::Read, Deadline::Write, Deadline::Pace})
    mTransport.cancel(deadline);
  mServices.output.release(mOutboxBytes);
  mOutboxBytes = 0;
  mTransport.close();
  mServices.ended(mId);
}

}  // namespace voxbrick::server
