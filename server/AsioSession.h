// The Asio half every transport of a connection shares: the strand its handlers run on, the three deadline timers,
// the render sink that posts frames to the strand, and completion handlers that close the connection instead of
// letting an exception out of Asio. A transport (TcpSession, WebSocketSession) derives from it and adds only
// its stream: readMessage, write and close of Transport. No socket type here.
#pragma once

#include <exception>
#include <memory>
#include <string>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>

#include "server/Connection.h"
#include "server/RenderScheduler.h"
#include "server/Session.h"
#include "server/Transport.h"

namespace voxbrick::server {

/// One connection's rules (a Connection) on a strand. Everything runs on `executor`, which must be a strand; the
/// public calls post there.
class AsioSession : public Session,
                    public Transport,
                    public RenderScheduler::Sink,
                    public std::enable_shared_from_this<AsioSession> {
 public:
  void start() override;
  void end(proto::Error error) override;
  const std::string& peer() const override { return mCore.peer(); }
  ConnectionId id() const override { return mCore.id(); }

  bool wantsReplies() const override { return mCore.alive(); }
  void rendered(RenderJob job, proto::Message reply) override;

  void arm(Deadline deadline, double seconds) override;
  void cancel(Deadline deadline) override;
  void runAside(std::function<void()> work, std::function<void()> then, Aside where = Aside::Encode,
                FrameClass cls = FrameClass::Still) override;
  std::shared_ptr<RenderScheduler::Sink> renderSink() override { return shared_from_this(); }

 protected:
  /// `kind` is the transport's name in the audit trail ("tcp", "tls", "ws", "wss").
  AsioSession(const boost::asio::any_io_executor& executor, const SessionServices& services, ConnectionId id,
              std::string peer, std::string kind);

  /// A completion handler that runs `step(*self, args...)` on this session, keeping it alive, and closes the
  /// connection instead of letting an exception out of Asio. `self` is `this` as the derived transport.
  template <typename Self, typename Step>
  auto guarded(Self* self, Step step) {
    return [keep = std::shared_ptr<Self>(shared_from_this(), self),
            step = std::move(step)](auto&&... args) mutable noexcept {
      try {
        step(*keep, std::forward<decltype(args)>(args)...);
      } catch (...) {
        keep->failed(std::current_exception());
      }
    };
  }

  /// Logs an unexpected failure and closes the connection.
  void failed(const std::exception_ptr& error) noexcept;

  /// The rules this transport carries bytes for; the transport reports its reads and writes here.
  Connection mCore;
  /// The server's statistics: a transport counts the bytes it writes (ServerStats::bytesWritten).
  ServerStats& mStats;

 private:
  boost::asio::steady_timer& timer(Deadline deadline);

  boost::asio::any_io_executor mExecutor;
  boost::asio::steady_timer mHelloTimer, mReadTimer, mWriteTimer, mPaceTimer;
  const std::function<void(FrameClass, std::function<void()>)>& mAside;
  const std::function<void(std::function<void()>)>& mPrepare;
};

}  // namespace voxbrick::server
