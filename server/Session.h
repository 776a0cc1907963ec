// The TCP transport of one client connection: message framing (header, then body), deadlines (Hello, idle, read,
// write), the queue of replies with its back-pressure, and closing after it is flushed. It decodes bytes into
// proto::Message and hands each to the MessageHandler; it never looks at what a message means.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio.hpp>

#include "proto/Messages.h"
#include "server/Admission.h"
#include "server/MessageHandler.h"
#include "server/OutputBudget.h"
#include "server/RenderScheduler.h"
#include "server/ServerConfig.h"
#include "server/ServerStats.h"

namespace voxbrick::server {

class Session;

/// What every session shares; owned by the server, which outlives its sessions.
struct SessionServices {
  const ServerConfig& config;  ///< timeouts and the output limits
  proto::Limits limits;        ///< checked while decoding
  MessageHandler& handler;
  RenderScheduler& scheduler;
  ServerStats& stats;
  OutputBudget& output;        ///< replies queued for every session together
  /// Called once when a session has closed (on its strand), so the server can forget it.
  std::function<void(const std::shared_ptr<Session>&)> ended;
  /// Called on its strand once the connection's Hello was accepted: whether it may become a session (false when
  /// max_sessions are open, or it was evicted meanwhile; it is then refused with LimitExceeded).
  std::function<bool(const Session&)> greeted;
};

/// One client connection. Everything runs on the strand of its socket's executor; the public calls post there.
class Session final : public RenderScheduler::Sink, public std::enable_shared_from_this<Session> {
 public:
  /// `socket` must be connected and bound to a strand executor; `id` is the server's number for it.
  Session(boost::asio::ip::tcp::socket socket, const SessionServices& services, ConnectionId id);
  /// Gives freed reply buffers back to the system when its queue was large (see the .cpp).
  ~Session() override;

  /// Starts the Hello deadline and reading messages. Safe from any thread.
  void start();
  /// Sends `error` with request id 0, then closes once the replies queued before it are written (a refused
  /// connection, the server stopping). Safe from any thread.
  void end(proto::Error error);
  /// The client's address and port, for logs.
  const std::string& peer() const { return mPeer; }
  ConnectionId id() const { return mId; }

  bool wantsReplies() const override { return mAlive; }
  void rendered(RenderJob job, proto::Message reply) override;

 private:
  /// A completion handler that runs `step` on this session and closes the session instead of letting an exception
  /// out of Asio.
  template <typename Step>
  auto guarded(Step step);
  void failed(const std::exception_ptr& error) noexcept;

  void onHelloTimeout();
  /// Reads the next message, unless the client has too many replies waiting (then onWritten resumes).
  void readNext();
  void readHeader();
  void readHeaderBytes();
  void onHeaderBytes(boost::system::error_code ec, size_t bytes);
  void onHeader();
  void onBody(boost::system::error_code ec);
  void armReadTimer(double seconds);
  void onReadTimeout();
  /// The connection's Hello was accepted: it becomes a session, or `outcome` is made its refusal.
  void admit(Outcome& outcome);
  /// Whether a render thread's `reply` to `job` is to be answered, turned into LimitExceeded past the server's
  /// output budget.
  bool withinOutputBudget(const RenderJob& job, proto::Message& reply);
  /// Carries out what the handler decided: replies, the render job, closing.
  void apply(Outcome outcome);
  void send(const proto::Message& message, uint32_t requestId);
  void writeNext();
  void onWritten(boost::system::error_code ec);
  /// Stops reading; closes once every queued reply is written.
  void closeAfterFlush();
  void close();

  const SessionServices& mServices;
  const ConnectionId mId;
  boost::asio::ip::tcp::socket mSocket;
  boost::asio::steady_timer mHelloTimer, mReadTimer, mWriteTimer;
  std::string mPeer;
  ConnectionState mState;
  std::array<uint8_t, proto::kHeaderBytes> mHeaderBytes{};
  size_t mHeaderFill = 0;  ///< bytes of mHeaderBytes read
  proto::Header mHeader;
  std::vector<uint8_t> mBody;
  std::deque<std::vector<uint8_t>> mOutbox;
  uint64_t mOutboxBytes = 0, mPeakOutboxBytes = 0;
  /// Requests whose provisional Frame was refused (output budget): their exact frame is dropped, not sent.
  std::set<uint32_t> mRefusedProvisional;
  bool mWriting = false, mClosing = false, mClosed = false;
  bool mReadingMessage = false;  ///< a message's first byte has arrived (its read deadline runs)
  bool mPaused = false;          ///< not reading until the client takes its replies
  std::atomic<bool> mAlive{true};  ///< read by render threads
};

}  // namespace voxbrick::server
