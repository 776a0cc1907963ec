// What a Connection (the transport-independent rules of one client connection) asks of the transport under it:
// read one message, write one encoded message, run three deadlines, close. No Asio here: the TCP session
// (TcpSession) implements it with framing and socket I/O, WebSocketSession with one binary message per
// protocol message, a test with a recording fake.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>

#include "server/RenderScheduler.h"

namespace voxbrick::server {

/// The deadlines a Connection runs; each is armed and cancelled by the Connection, and reported back through
/// Connection::expired when it passes.
enum class Deadline {
  Hello,  ///< the connection's Hello must arrive (hello_timeout_s)
  Read,   ///< between messages the idle timeout, once a message has started the read timeout
  Write,  ///< the reply being written must be taken (write_timeout_s)
  Pace,   ///< a Frame held back for the client's reports may go (LinkPacer::releaseAt)
};

/// Where Transport::runAside runs its work.
enum class Aside {
  Encode,   ///< the server's encoder threads (video frames: short tasks)
  Prepare,  ///< the server's upload threads (an upload's prep: a child process waited for, seconds to minutes)
};

/// Every call is made on the connection's serial context (its strand), and every report back to the Connection
/// (Connection::received, written, expired, closed by the peer) must be made there too.
class Transport {
 public:
  virtual ~Transport() = default;

  /// Reads the next message and hands it to the Connection (Connection::received, or headerReceived then
  /// bodyReceived), or reports Connection::readFailed. Called once per message, only when the Connection is ready
  /// for one: not calling it is how reading pauses (back-pressure), calling it again how it resumes.
  virtual void readMessage() = 0;
  /// Writes one whole encoded message (header and body); reports Connection::written once it is written or failed.
  /// At most one write is in flight; `message` stays valid until written() is called.
  virtual void write(std::span<const uint8_t> message) = 0;
  /// Runs `deadline` for `seconds` from now (replacing a running one); Connection::expired reports that it passed.
  virtual void arm(Deadline deadline, double seconds) = 0;
  /// Stops `deadline`; it is not reported, unless it had passed already.
  virtual void cancel(Deadline deadline) = 0;
  /// Closes the stream at once. A read or write in flight may still report its failure afterwards.
  virtual void close() = 0;
  /// Runs `work` on a thread aside (the server's encoder or upload threads, as `where` says; never the serial
  /// context), then `then` on the serial context, keeping the connection alive in between. `work` must not touch the
  /// Connection. An encoding is served by the class of its frame, `cls` (EncoderQueue).
  virtual void runAside(std::function<void()> work, std::function<void()> then, Aside where = Aside::Encode,
                        FrameClass cls = FrameClass::Still) = 0;
  /// The object render threads hand this connection's frames to (RenderScheduler::submit keeps it while a job of
  /// the connection waits); it must pass them to Connection::rendered on the serial context.
  virtual std::shared_ptr<RenderScheduler::Sink> renderSink() = 0;
};

}  // namespace voxbrick::server
