// The rules of one client connection that hold whatever carries its bytes: the Hello deadline and admission as a
// session, the idle and read deadlines, decoding and handing each message to the MessageHandler, submitting renders,
// the queue of replies with its per-session limit and at most one unsent frame (latest wins), back-pressure (pausing
// reading while too many replies wait) and its share of the server's output budget, the write deadline, and closing
// after the queue is flushed. It owns no socket and no timer: it drives a Transport (TcpSession over TCP,
// WebSocketSession over WebSocket) and is driven by it, one call at a time.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "proto/Messages.h"
#include "server/Admission.h"
#include "server/LinkPacer.h"
#include "server/MessageHandler.h"
#include "server/OutputBudget.h"
#include "server/RenderScheduler.h"
#include "server/ServerConfig.h"
#include "server/ServerStats.h"
#include "server/Transport.h"
#include "server/VideoStream.h"

namespace voxbrick::server {

/// What every connection shares; owned by the server, which outlives its connections.
struct SessionServices {
  const ServerConfig& config;  ///< timeouts and the output limits
  proto::Limits limits;        ///< checked while decoding
  MessageHandler& handler;
  RenderScheduler& scheduler;
  ServerStats& stats;
  OutputBudget& output;  ///< replies queued for every session together
  /// Called once when a connection has closed (on its serial context), so the server can forget it.
  std::function<void(ConnectionId)> ended;
  /// Called once the connection's Hello was accepted: none when it may become a session, else the Error it is
  /// refused with (LimitExceeded when max_sessions are open, it was evicted meanwhile or its quota is full; Busy
  /// when the render threads are over capacity).
  std::function<std::optional<proto::Error>(ConnectionId)> greeted;
  /// Called for each Render before it is queued: none when the session's quotas have room, else the Busy refusal.
  std::function<std::optional<Submission>(ConnectionId)> renderQuota;
  /// Called when a Render renderQuota let through was refused all the same (Busy: a first drag beyond capacity, batch
  /// work over it): the frame it took goes back, so that a session waiting its turn does not spend its quota on it.
  std::function<void(ConnectionId)> renderNotTaken;
  /// Runs a task of a frame of a class on the server's encoder threads (EncoderQueue: video frames, and still frames
  /// with encode_aside; Transport::runAside). Empty: on the calling thread.
  std::function<void(FrameClass, std::function<void()>)> aside;
  /// The access tokens: a session starts with their anonymous grant. Null: every session sees every dataset.
  std::shared_ptr<const AccessTokens> tokens;
  /// Called when a session presented a token with Authenticate: none when its quotas have room, else why not
  /// (LimitExceeded; the session goes on without it).
  std::function<std::optional<std::string>(ConnectionId, const TokenGrant&)> authenticated;
  /// The audit trail: sessions opened, tokens presented and refusals (null: none).
  AuditLog* audit = nullptr;
  /// Runs a task on the server's upload threads (an upload's prep; Transport::runAside with Aside::Prepare). Empty:
  /// on the calling thread.
  std::function<void(std::function<void()>)> prepare = {};
  /// The sessions' video encoders' memory (memory.video_mb). Null: not counted, no limit.
  VideoMemory* video = nullptr;
};

/// One client connection's state machine. Not thread-safe: every call but alive() is made on the connection's
/// serial context (a strand), the Transport's reports included.
class Connection {
 public:
  /// `transport` carries the connection's bytes and outlives it; `peer` names the client in logs (its address:port,
  /// then anything after a space); `kind` is the transport's name in the audit trail ("tcp", "tls", "ws", "wss").
  Connection(Transport& transport, const SessionServices& services, ConnectionId id, std::string peer,
             std::string kind = "tcp");
  /// Gives freed reply buffers back to the system when its queue was large (see the .cpp).
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  /// Starts the Hello deadline and reading messages.
  void start();
  /// The client presented `grant`'s token before its session started (a browser's, at the WebSocket upgrade): what
  /// it may see from its Hello on.
  void presented(std::shared_ptr<const TokenGrant> grant);
  /// Sends `error` with request id 0, then closes once the replies queued before it are written (a refused
  /// connection, the server stopping).
  void end(proto::Error error);

  // What the transport reports.
  /// The first bytes of a message arrived: the whole message must now arrive within the read timeout. A transport
  /// that cannot tell leaves the idle deadline to cover the message.
  void messageStarted();
  /// The header of the next message: its decoded form, whose bodyBytes the transport reads next, or nothing when
  /// it is invalid (the connection then answers and closes: the stream cannot be resynchronised).
  std::optional<proto::Header> headerReceived(std::span<const uint8_t, proto::kHeaderBytes> bytes);
  /// The body of the message whose header was accepted last (exactly its bodyBytes long).
  void bodyReceived(std::span<const uint8_t> body);
  /// A whole message, header and body, from a transport that delimits messages itself (WebSocketSession uses it
  /// for a message shorter than a header).
  void received(std::span<const uint8_t> message);
  /// The transport found the stream unusable (a WebSocket text message, a message longer than its header
  /// announces): answers an Error with `code` and request id 0, and closes.
  void refuse(proto::ErrorCode code, const std::string& why);
  /// The stream ended or failed while reading.
  void readFailed();
  /// The message given to Transport::write was written (`ok`) or could not be.
  void written(bool ok);
  /// `deadline` passed.
  void expired(Deadline deadline);
  /// A render thread's `reply` to `job`, as the render sink received it. A Frame in a video encoding (its payload
  /// still its pixels) waits for the session's video stream: it is encoded aside (Transport::runAside) when the link
  /// has room, the newest such frame first (older ones are Superseded), and frames of the stream are never dropped
  /// once encoded (a decoder needs every one). A still Frame whose job says stillToEncode (its payload still its
  /// pixels) is encoded aside too, in order, one at a time; Frames rendered meanwhile wait for it, a newer still Frame
  /// replacing one waiting (latest wins).
  void rendered(const RenderJob& job, proto::Message reply);
  /// Closes at once, dropping what is queued (also after an unexpected failure). Idempotent.
  void close();
  /// Records `event` for this connection in the audit trail (if there is one).
  void audit(const std::string& event, const std::string& reason = {}) const;

  /// False once the connection is ending: its waiting renders are dropped unrendered. Safe from any thread.
  bool alive() const { return mAlive; }
  ConnectionId id() const { return mId; }
  const std::string& peer() const { return mPeer; }
  const ConnectionState& state() const { return mState; }
  /// Bytes of replies queued and not written yet.
  uint64_t queuedBytes() const { return mOutboxBytes; }
  /// The session's link as its FrameReceived reports show it.
  const LinkPacer& link() const { return mPacer; }
  /// Whether reading waits for the client to take its replies.
  bool readingPaused() const { return mPaused; }
  bool closed() const { return mClosed; }

 private:
  void onHelloTimeout();
  void onReadTimeout();
  void onWriteTimeout();
  /// Reads the next message, unless the client has too many replies waiting (then written() resumes).
  void readNext();
  void readMessage();
  /// Answers a header or a whole message that cannot be trusted, and closes.
  void refuseStream(const std::exception_ptr& error);
  /// The connection's Hello was accepted: it becomes a session, or `outcome` is made its refusal.
  void admit(Outcome& outcome);
  /// The session's token was taken (Authenticate): counted against its quotas, or `outcome` is made the refusal and
  /// the session goes on without it.
  void authenticated(Outcome& outcome);
  /// Whether a render thread's `reply` to `job` is to be answered, turned into Busy (hint kOutputBusyRetryMs) past the
  /// server's output budget.
  bool withinOutputBudget(const RenderJob& job, proto::Message& reply);
  static constexpr uint32_t kOutputBusyRetryMs = 500;
  /// Carries out what the handler decided: replies, the render job, closing. `from`: the job whose still Frame is
  /// among the replies (deliver), which orders it on output.
  void apply(Outcome outcome, const RenderJob* from = nullptr);
  /// One reply waiting to be written.
  struct Outgoing {
    std::vector<uint8_t> bytes;
    uint32_t requestId = 0;
    bool frame = false;  ///< a Frame not of the video stream (at most one is queued unsent: latest wins)
    bool video = false;  ///< a Frame of the video stream: never dropped, at most one queued unsent
    /// A still Frame's: when its Render arrived (RenderJob::received), by which the frame queued unsent is newer
    /// than another.
    std::chrono::steady_clock::time_point asked{};
    /// A still Frame whose request its provisional Frame already answered (an exact frame, RenderJob::refinement):
    /// replaced without a word.
    bool answered = false;
    /// The exact frame of an interactive request: to a client that reports, written only once the camera rests
    /// (writeNext).
    bool afterMotion = false;
  };
  /// A video Frame rendered, waiting to be encoded.
  struct PendingVideo {
    RenderJob job;
    proto::Frame frame;
    std::chrono::steady_clock::time_point drawn;
  };
  /// A video Frame being encoded aside, and what came of it.
  struct EncodingVideo {
    RenderJob job;
    proto::Frame frame;
    VideoFrameInput input;
    VideoEncoded encoded;
    /// The frame as a still JPEG, or its Error, where the stream had no room for its encoder (encoded.noRoom).
    std::optional<proto::Message> still;
    std::exception_ptr error;
    std::chrono::steady_clock::time_point handedAt;  ///< to the encoder
  };
  /// A still Frame being encoded aside (RenderJob::stillToEncode), and what came of it: the Frame or its Error.
  struct EncodingStill {
    RenderJob job;
    proto::Message message;
  };
  /// A video Frame rendered: it waits for the encoder, in the place of the one waiting there (dropPendingVideo). A
  /// frame whose Render arrived before that of the frame waiting or the newest encoded (render threads finish a
  /// session's frames out of order) is dropped instead, its request answered Superseded: the stream never goes back to
  /// an older camera, nor to an older size, which would cost two key frames.
  void videoRendered(const RenderJob& job, proto::Frame frame);
  /// Answers `job` with its still Frame or Error, unless the Frame is older than the one queued unsent (its Render
  /// arrived before that one's: render threads finish a session's frames out of order), which then stays while this
  /// one is dropped (answered Superseded, or nothing for an exact frame whose provisional one answered it).
  void deliver(const RenderJob& job, proto::Message reply);
  /// Encodes a still Frame whose payload is its pixels aside; Frames rendered meanwhile wait (mAfterEncoding).
  void encodeStill(const RenderJob& job, proto::Frame frame);
  void stillEncoded(EncodingStill& done);
  /// An encoding aside finished: the Frames that waited for it, in order, then the pending video frame.
  void renderedAfterEncoding();
  /// A still Frame of request `by` is about to wait for the encoder: the still Frame waiting there, if any, is
  /// dropped (its request answered Superseded, unless it is `by`'s own provisional frame).
  void replaceWaitingStill(uint32_t by);
  /// Encodes the pending video frame if nothing holds it back: no encoding in flight, no encoded frame unsent, room
  /// on the link.
  void pumpVideo();
  void videoEncoded(EncodingVideo& done);
  /// The pending video frame gives way to a newer frame of request `by`: its request is answered Superseded, unless
  /// `by` is its own request (whose exact frame then answers it).
  void dropPendingVideo(uint32_t by);
  /// The first queued reply not yet being written that is a still Frame (`frame`) or a video one (`video`), if any.
  std::deque<Outgoing>::iterator firstUnsent(bool Outgoing::*kind);
  /// Wakes writeNext and pumpVideo at `when` (frames held back for the link, a video frame to encode ahead, the rest
  /// before an exact frame), or at the earliest wake already armed.
  void armPaceAt(std::chrono::steady_clock::time_point when);
  /// The most a video frame may take from write to report for the stream to keep the client's pace (its Renders'
  /// median recent interval, RenderScheduler::renderIntervalMs, as LinkPacer::paceMsFor); none before two.
  std::optional<double> videoPaceMs() const;
  /// A FrameReceived report (frames are reported in order; its frame_bytes is the client's word, unchecked): the link
  /// has room again.
  void frameReceived();
  /// Queues `message` to `requestId`; `from`: the job whose still Frame it is (its Outgoing's asked and answered).
  void send(const proto::Message& message, uint32_t requestId, const RenderJob* from = nullptr);
  void enqueue(Outgoing reply);
  /// Removes the reply at the front of the queue (written, or dropped unsent) and resumes reading below half the
  /// pause threshold.
  void popOutbox();
  /// A Frame to `requestId` is about to be queued: the Frame queued and not yet being written, if any, is removed
  /// (its request answered Superseded instead, unless it is `requestId`'s own provisional frame).
  void replaceUnsentFrame(uint32_t requestId);
  void writeNext();
  /// Stops reading; closes once every queued reply is written.
  void closeAfterFlush();
  /// Runs `job`'s prep aside, then applies its answer.
  void prepare(PrepareJob job);
  /// The session is ending: its upload, if any, is abandoned (a prep running is stopped; its scratch goes with the
  /// last reference).
  void abandonUpload();
  /// Sends a Timeout error naming `what`, then closes.
  void timedOut(const std::string& what);

  Transport& mTransport;
  const SessionServices& mServices;
  const ConnectionId mId;
  const std::string mPeer;
  ConnectionState mState;
  proto::Header mHeader;  ///< of the message being read
  std::deque<Outgoing> mOutbox;
  uint64_t mOutboxBytes = 0, mPeakOutboxBytes = 0;
  /// Requests whose provisional Frame was refused (output budget): their exact frame is dropped, not sent.
  std::set<uint32_t> mRefusedProvisional;
  LinkPacer mPacer;
  /// The session's video stream; used by the encoding aside only while mVideoEncoding.
  std::unique_ptr<VideoStream> mVideo = std::make_unique<VideoStream>(mServices.video);
  std::optional<PendingVideo> mVideoPending;
  /// When the Render of the stream's newest frame handed to the encoder arrived: a frame of an earlier Render is
  /// never encoded after it (videoRendered).
  std::chrono::steady_clock::time_point mVideoAsked{};
  /// When the newest Render the scheduler queued arrived: an exact frame asked for before it is obsolete (writeNext).
  std::chrono::steady_clock::time_point mNewestRender{};
  bool mVideoEncoding = false;
  /// From handing a video frame to the encoder to its encoded frame (the encoder's queue and the encoding), smoothed:
  /// a frame is encoded this long before the link is expected to have room for it (pumpVideo).
  double mVideoEncodeLeadMs = 0;
  /// When the Pace deadline is armed for (none: not armed).
  std::chrono::steady_clock::time_point mPaceArmedAt{};
  bool mVideoNeedsKey = false;  ///< a frame of the stream was encoded but not sent: the next must be a key frame
  bool mStillEncoding = false;  ///< a still Frame is being encoded aside
  /// Frames rendered while a frame was being encoded aside, applied after it so that a request's frames stay in order.
  std::vector<std::pair<RenderJob, proto::Message>> mAfterEncoding;
  bool mWriting = false, mClosing = false, mClosed = false;
  bool mReadingMessage = false;    ///< a message's first byte has arrived (its read deadline runs)
  bool mPaused = false;            ///< not reading until the client takes its replies
  std::atomic<bool> mAlive{true};  ///< read by render threads
};

}  // namespace voxbrick::server
