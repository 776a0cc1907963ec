// Framing, deadlines and the reply queue of one TCP connection.
#include "server/Session.h"

#include <chrono>
#include <optional>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "server/ErrorReply.h"

namespace voxbrick::server {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

/// Capacity of a session's read buffer kept between messages.
constexpr size_t kKeptBodyBytes = 64 << 10;

std::chrono::milliseconds seconds(double s) { return std::chrono::milliseconds(int64_t(s * 1000)); }

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

/// The first reply's error, for logs.
std::string describeError(const Outcome& outcome) {
  if (outcome.replies.empty()) return "?";
  const auto* error = std::get_if<proto::Error>(&outcome.replies.front().message);
  return error ? error->message + " (" + proto::errorCodeName(error->code) + ")" : "?";
}

}  // namespace

Session::Session(tcp::socket socket, const SessionServices& services, ConnectionId id)
    : mServices(services),
      mId(id),
      mSocket(std::move(socket)),
      mHelloTimer(mSocket.get_executor()),
      mReadTimer(mSocket.get_executor()),
      mWriteTimer(mSocket.get_executor()) {
  boost::system::error_code ec;
  const auto endpoint = mSocket.remote_endpoint(ec);
  mPeer = ec ? "?" : endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
}

Session::~Session() {
  // The buffers are freed here, not in close(): an aborted write may still refer to them until its handler ran.
  const bool large = mPeakOutboxBytes > mServices.config.pauseReadingBytes;
  mOutbox.clear();
  mOutbox.shrink_to_fit();
  if (large) releaseFreedMemory();
}

template <typename Step>
auto Session::guarded(Step step) {
  return [self = shared_from_this(), step = std::move(step)](auto&&... args) mutable noexcept {
    try {
      step(*self, std::forward<decltype(args)>(args)...);
    } catch (...) {
      self->failed(std::current_exception());
    }
  };
}

void Session::failed(const std::exception_ptr& error) noexcept {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    spdlog::error("{}: closing after an unexpected failure: {}", mPeer, e.what());
  } catch (...) {
    spdlog::error("{}: closing after an unexpected failure", mPeer);
  }
  try {
    close();
  } catch (...) {  // nothing more can be done for this connection; the others go on
  }
}

void Session::start() {
  asio::post(mSocket.get_executor(), guarded([](Session& s) {
               // A connection that has not said Hello is not a session yet: it gets a short deadline of its own, so
               // sockets that never speak (or trickle bytes) hold a pending slot for seconds, not the idle timeout.
               s.mHelloTimer.expires_after(seconds(s.mServices.config.helloTimeoutS));
               s.mHelloTimer.async_wait(s.guarded([](Session& self, boost::system::error_code ec) {
                 if (!ec) self.onHelloTimeout();
               }));
               s.readHeader();
             }));
}

void Session::onHelloTimeout() {
  if (mState.greeted || mClosing || mClosed) return;
  mServices.stats.add(ServerEvent::Timeout);
  const std::string what = "no Hello within " + std::to_string(mServices.config.helloTimeoutS) + " s";
  spdlog::info("{}: closing: {}", mPeer, what);
  send(errorMessage(proto::ErrorCode::Timeout, what), 0);
  closeAfterFlush();
}

void Session::end(proto::Error error) {
  asio::post(mSocket.get_executor(), guarded([error = std::move(error)](Session& s) {
               s.send(error, 0);
               s.closeAfterFlush();
             }));
}

void Session::rendered(RenderJob job, proto::Message reply) {
  asio::post(mSocket.get_executor(),
             guarded([job = std::move(job), reply = std::move(reply)](Session& s) mutable {
               if (s.mClosing || s.mClosed) return;  // PROTOCOL.md: a session's end drops its renders unanswered
               if (!s.withinOutputBudget(job, reply)) return;
               s.apply(s.mServices.handler.rendered(s.mState, job, std::move(reply)));
             }));
}

bool Session::withinOutputBudget(const RenderJob& job, proto::Message& reply) {
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
  reply = errorMessage(proto::ErrorCode::LimitExceeded,
                       "frame of " + std::to_string(bytes) + " bytes not sent: the server holds " +
                           std::to_string(mServices.output.queued()) + " bytes of replies its clients have not read " +
                           "(limit " + std::to_string(mServices.output.limit()) + "); try again");
  return true;
}

void Session::armReadTimer(double s) {
  mReadTimer.expires_after(seconds(s));
  mReadTimer.async_wait(guarded([](Session& self, boost::system::error_code ec) {
    if (!ec) self.onReadTimeout();
  }));
}

void Session::onReadTimeout() {
  if (mClosed || mClosing) return;
  const SessionServices& sv = mServices;
  if (!mReadingMessage && mState.awaitingFrames()) {  // the client is waiting for us, not idle
    armReadTimer(sv.config.idleTimeoutS);
    return;
  }
  sv.stats.add(ServerEvent::Timeout);
  const std::string what = mReadingMessage ? "message not completed within " + std::to_string(sv.config.readTimeoutS) +
                                                 " s of its first byte"
                                           : "idle for " + std::to_string(sv.config.idleTimeoutS) + " s";
  spdlog::info("{}: closing: {}", mPeer, what);
  send(errorMessage(proto::ErrorCode::Timeout, what), 0);
  closeAfterFlush();
}

void Session::readNext() {
  if (mOutboxBytes > mServices.config.pauseReadingBytes) {
    // The client is not taking its replies: reading its next request would only queue more of them. Its requests
    // wait in the socket buffers (and then its own) until onWritten resumes; the write timeout closes it if it
    // never reads.
    mPaused = true;
    mServices.stats.add(ServerEvent::ReadingPaused);
    spdlog::debug("{}: {} bytes of replies not read, reading paused", mPeer, mOutboxBytes);
    return;
  }
  readHeader();
}

void Session::readHeader() {
  if (mClosing || mClosed) return;
  mReadingMessage = false;
  mHeaderFill = 0;
  armReadTimer(mServices.config.idleTimeoutS);
  readHeaderBytes();
}

void Session::readHeaderBytes() {
  mSocket.async_read_some(
      asio::buffer(mHeaderBytes.data() + mHeaderFill, mHeaderBytes.size() - mHeaderFill),
      guarded([](Session& s, boost::system::error_code ec, size_t bytes) { s.onHeaderBytes(ec, bytes); }));
}

void Session::onHeaderBytes(boost::system::error_code ec, size_t bytes) {
  if (ec) return close();
  if (!mReadingMessage) {
    // The whole message, header and body, must arrive within the read timeout of its first byte: a client that
    // trickles bytes cannot stretch the deadline.
    mReadingMessage = true;
    armReadTimer(mServices.config.readTimeoutS);
  }
  mHeaderFill += bytes;
  if (mHeaderFill < mHeaderBytes.size()) return readHeaderBytes();
  onHeader();
}

void Session::onHeader() {
  try {
    mHeader = proto::decodeHeader(std::span<const uint8_t, proto::kHeaderBytes>(mHeaderBytes), mServices.limits);
  } catch (...) {
    mServices.stats.add(ServerEvent::ProtocolError);
    Outcome outcome = MessageHandler::failed(std::current_exception(), 0);
    // Without a trustworthy header the stream cannot be resynchronised, whatever the code.
    outcome.close = true;
    spdlog::info("{}: {}, closing", mPeer, describeError(outcome));
    return apply(std::move(outcome));
  }
  mBody.resize(mHeader.bodyBytes);  // at most limits.maxBodyBytes, checked by decodeHeader
  asio::async_read(mSocket, asio::buffer(mBody),
                   guarded([](Session& s, boost::system::error_code e, size_t) { s.onBody(e); }));
}

void Session::onBody(boost::system::error_code ec) {
  if (ec) return close();
  mReadTimer.cancel();
  mServices.stats.add(ServerEvent::Message);
  std::optional<proto::Message> message;
  Outcome outcome;
  try {
    message = proto::decodeBody(mHeader, mBody, mServices.limits);
  } catch (...) {
    // The length was valid, so the next message starts where this one ended: the session goes on.
    mServices.stats.add(ServerEvent::ProtocolError);
    outcome = MessageHandler::failed(std::current_exception(), mHeader.requestId);
    spdlog::debug("{}: {}", mPeer, describeError(outcome));
  }
  // Requests are small: the buffer is reused across them, and given back only after a large one.
  if (mBody.capacity() > kKeptBodyBytes) mBody = {};
  mBody.clear();
  const bool wasGreeted = mState.greeted;
  if (message) outcome = mServices.handler.handle(mState, *message, mHeader.requestId);
  if (!wasGreeted && mState.greeted) admit(outcome);
  apply(std::move(outcome));
  readNext();
}

void Session::admit(Outcome& outcome) {
  mHelloTimer.cancel();
  if (mServices.greeted(*this)) return;
  // Sessions filled up while this connection waited for its Hello (or it was evicted): refused as on connect.
  mServices.stats.add(ServerEvent::SessionRefused);
  outcome = Outcome{};
  outcome.replies.push_back(
      {errorMessage(proto::ErrorCode::LimitExceeded,
                    "too many sessions (limit " + std::to_string(mServices.config.maxSessions) + ")"),
       0});
  outcome.close = true;
}

void Session::apply(Outcome outcome) {
  for (const Reply& reply : outcome.replies) send(reply.message, reply.requestId);
  if (outcome.render && !mClosed && !mClosing) {
    const uint32_t requestId = outcome.render->requestId;
    Submission submission = mServices.scheduler.submit(shared_from_this(), std::move(*outcome.render));
    apply(mServices.handler.submitted(mState, requestId, std::move(submission)));
  }
  if (outcome.close) closeAfterFlush();
}

void Session::send(const proto::Message& message, uint32_t requestId) {
  if (mClosed) return;
  std::vector<uint8_t> bytes;
  try {
    bytes = proto::encode(message, requestId);
  } catch (...) {  // a reply above 4 GiB, or no memory for it: the request is answered with the failure instead
    bytes = proto::encode(errorReply(std::current_exception(), "reply cannot be encoded"), requestId);
  }
  if (mOutboxBytes + bytes.size() > mServices.config.maxOutputBytes) {
    mServices.stats.add(ServerEvent::SlowClientDropped);
    spdlog::warn("{}: {} bytes of replies not read, dropping the session", mPeer, mOutboxBytes);
    return close();
  }
  mOutboxBytes += bytes.size();
  mPeakOutboxBytes = std::max(mPeakOutboxBytes, mOutboxBytes);
  mServices.output.add(bytes.size());
  mOutbox.push_back(std::move(bytes));
  if (!mWriting) writeNext();
}

void Session::writeNext() {
  mWriting = true;
  mWriteTimer.expires_after(seconds(mServices.config.writeTimeoutS));
  mWriteTimer.async_wait(guarded([](Session& s, boost::system::error_code ec) {
    if (ec || s.mClosed) return;
    s.mServices.stats.add(ServerEvent::SlowClientDropped);
    spdlog::info("{}: a reply was not taken within {} s, closing", s.mPeer, s.mServices.config.writeTimeoutS);
    s.close();
  }));
  asio::async_write(mSocket, asio::buffer(mOutbox.front()),
                    guarded([](Session& s, boost::system::error_code ec, size_t) { s.onWritten(ec); }));
}

void Session::onWritten(boost::system::error_code ec) {
  mWriteTimer.cancel();
  if (ec || mClosed) return close();  // close() has released the queue's bytes already
  mOutboxBytes -= mOutbox.front().size();
  mServices.output.release(mOutbox.front().size());
  mOutbox.pop_front();
  // Resumed once half the threshold is written, so a client reading at its own pace is not paused at every reply.
  if (mPaused && mOutboxBytes <= mServices.config.pauseReadingBytes / 2) {
    mPaused = false;
    readHeader();
  }
  if (!mOutbox.empty()) return writeNext();
  mWriting = false;
  if (mClosing) close();
}

void Session::closeAfterFlush() {
  mClosing = true;
  mAlive = false;  // its waiting renders are dropped unrendered
  if (!mWriting) close();
}

void Session::close() {
  if (mClosed) return;
  mClosed = true;
  mAlive = false;
  mHelloTimer.cancel();
  mReadTimer.cancel();
  mWriteTimer.cancel();
  mServices.output.release(mOutboxBytes);
  mOutboxBytes = 0;
  boost::system::error_code ignored;
  mSocket.shutdown(tcp::socket::shutdown_both, ignored);
  mSocket.close(ignored);
  mServices.ended(shared_from_this());
}

}  // namespace voxbrick::server
