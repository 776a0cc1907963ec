// A connection's strand, deadline timers and render sink, shared by its transports.
#include "server/AsioSession.h"

#include <chrono>

#include <spdlog/spdlog.h>
#include <boost/asio/post.hpp>

namespace voxbrick::server {
namespace {

std::chrono::milliseconds milliseconds(double seconds) { return std::chrono::milliseconds(int64_t(seconds * 1000)); }

}  // namespace

AsioSession::AsioSession(const boost::asio::any_io_executor& executor, const SessionServices& services, ConnectionId id,
                         std::string peer, std::string kind)
    : mCore(*this, services, id, std::move(peer), std::move(kind)),
      mStats(services.stats),
      mExecutor(executor),
      mHelloTimer(executor),
      mReadTimer(executor),
      mWriteTimer(executor),
      mPaceTimer(executor),
      mAside(services.aside),
      mPrepare(services.prepare) {}

void AsioSession::start() {
  boost::asio::post(mExecutor, guarded(this, [](AsioSession& s) { s.mCore.start(); }));
}

void AsioSession::end(proto::Error error) {
  boost::asio::post(mExecutor, guarded(this, [error = std::move(error)](AsioSession& s) { s.mCore.end(error); }));
}

void AsioSession::rendered(RenderJob job, proto::Message reply) {
  boost::asio::post(mExecutor, guarded(this, [job = std::move(job), reply = std::move(reply)](AsioSession& s) mutable {
                      s.mCore.rendered(job, std::move(reply));
                    }));
}

boost::asio::steady_timer& AsioSession::timer(Deadline deadline) {
  switch (deadline) {
    case Deadline::Hello: return mHelloTimer;
    case Deadline::Read: return mReadTimer;
    case Deadline::Pace: return mPaceTimer;
    case Deadline::Write: break;
  }
  return mWriteTimer;
}

void AsioSession::arm(Deadline deadline, double seconds) {
  boost::asio::steady_timer& t = timer(deadline);
  t.expires_after(milliseconds(seconds));
  t.async_wait(guarded(this, [deadline](AsioSession& s, boost::system::error_code ec) {
    if (!ec) s.mCore.expired(deadline);
  }));
}

void AsioSession::cancel(Deadline deadline) { timer(deadline).cancel(); }

void AsioSession::runAside(std::function<void()> work, std::function<void()> then, Aside where, FrameClass cls) {
  auto task = [keep = shared_from_this(), work = std::move(work), then = std::move(then)]() mutable {
    work();
    boost::asio::post(keep->mExecutor,
                      keep->guarded(keep.get(), [then = std::move(then)](AsioSession&) mutable { then(); }));
  };
  if (where == Aside::Prepare && mPrepare)
    mPrepare(std::move(task));
  else if (where == Aside::Encode && mAside)
    mAside(cls, std::move(task));
  else
    task();
}

void AsioSession::failed(const std::exception_ptr& error) noexcept {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    spdlog::error("{}: closing after an unexpected failure: {}", peer(), e.what());
  } catch (...) {
    spdlog::error("{}: closing after an unexpected failure", peer());
  }
  try {
    mCore.close();
  } catch (...) {  // nothing more can be done for this connection; the others go on
  }
}

}  // namespace voxbrick::server
