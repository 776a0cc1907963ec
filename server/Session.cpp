// Framing, deadlines and the reply queue of one TCP connection.
#include "server/Session.h"

#include <chrono>
#include <optional>

#include <spdlog/spdlog.h>

#include "server/ErrorReply.h"

namespace voxbrick::server {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

/// Capacity of a session's read buffer kept between messages.
constexpr size_t kKeptBodyBytes = 64 << 10;

std::chrono::milliseconds seconds(double s) { return std::chrono::milliseconds(int64_t(s * 1000)); }

/// The first reply's error, for logs.
std::string describeError(const Outcome& outcome) {
  if (outcome.replies.empty()) return "?";
  const auto* error = std::get_if<proto::Error>(&outcome.replies.front().message);
  return error ? error->message + " (" + proto::errorCodeName(error->code) + ")" : "?";
}

}  // namespace

Session::Session(tcp::socket socket, const SessionServices& services)
    : mServices(services),
      mSocket(std::move(socket)),
      mReadTimer(mSocket.get_executor()),
      mWriteTimer(mSocket.get_executor()) {
  boost::system::error_code ec;
  const auto endpoint = mSocket.remote_endpoint(ec);
  mPeer = ec ? "?" : endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
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
  asio::post(mSocket.get_executor(), guarded([](Session& s) { s.readHeader(); }));
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
               s.apply(s.mServices.handler.rendered(s.mState, job, std::move(reply)));
             }));
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
  if (!mReadingBody && mState.awaitingFrames()) {  // the client is waiting for us, not idle
    armReadTimer(sv.config.idleTimeoutS);
    return;
  }
  sv.stats.add(ServerEvent::Timeout);
  const std::string what = mReadingBody
                               ? "message not completed within " + std::to_string(sv.config.readTimeoutS) + " s"
                               : "idle for " + std::to_string(sv.config.idleTimeoutS) + " s";
  spdlog::info("{}: closing: {}", mPeer, what);
  send(errorMessage(proto::ErrorCode::Timeout, what), 0);
  closeAfterFlush();
}

void Session::readHeader() {
  if (mClosing || mClosed) return;
  mReadingBody = false;
  armReadTimer(mServices.config.idleTimeoutS);
  asio::async_read(mSocket, asio::buffer(mHeaderBytes),
                   guarded([](Session& s, boost::system::error_code ec, size_t) { s.onHeader(ec); }));
}

void Session::onHeader(boost::system::error_code ec) {
  if (ec) return close();
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
  mReadingBody = true;
  armReadTimer(mServices.config.readTimeoutS);
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
  if (message) outcome = mServices.handler.handle(mState, *message, mHeader.requestId);
  apply(std::move(outcome));
  readHeader();
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
  if (ec) return close();
  mOutboxBytes -= mOutbox.front().size();
  mOutbox.pop_front();
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
  mReadTimer.cancel();
  mWriteTimer.cancel();
  boost::system::error_code ignored;
  mSocket.shutdown(tcp::socket::shutdown_both, ignored);
  mSocket.close(ignored);
  mServices.ended(shared_from_this());
}

}  // namespace voxbrick::server
