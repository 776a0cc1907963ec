// A connection's transport-independent rules, driven through a recording fake transport: no socket, no timer, no
// Asio. Deadlines pass when a test says so; writes complete when a test says so.
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "TestDatasets.h"
#include "image/FrameImage.h"
#include "image/Video.h"
#include "render/core/TransferFunctionPresets.h"
#include "render/engine/NullFrameSource.h"
#include "server/Connection.h"
#include "server/Datasets.h"
#include "server/ErrorReply.h"
#include "server/MessageHandler.h"
#include "server/VideoMemory.h"

namespace voxbrick::server {
namespace {

using proto::ErrorCode;

/// Records what the connection asks of its transport.
class FakeTransport : public Transport,
                      public RenderScheduler::Sink,
                      public std::enable_shared_from_this<FakeTransport> {
 public:
  int reads = 0;                             ///< readMessage calls
  std::vector<std::vector<uint8_t>> writes;  ///< every message given to write, in order
  bool writing = false;                      ///< the last write has not been reported yet
  std::map<Deadline, double> armed;          ///< running deadlines and their seconds
  bool closed = false;

  void readMessage() override { ++reads; }
  void write(std::span<const uint8_t> message) override {
    EXPECT_FALSE(writing) << "one write at a time";
    writes.emplace_back(message.begin(), message.end());
    writing = true;
  }
  void arm(Deadline deadline, double seconds) override { armed[deadline] = seconds; }
  void cancel(Deadline deadline) override { armed.erase(deadline); }
  void close() override { closed = true; }
  std::shared_ptr<RenderScheduler::Sink> renderSink() override { return shared_from_this(); }
  /// Tasks run aside, in order; runAsides() runs them (each `work`, then its `then`).
  std::vector<std::pair<std::function<void()>, std::function<void()>>> asides;
  /// The class each encoding aside was queued in, in order.
  std::vector<FrameClass> asideClasses;
  void runAside(std::function<void()> work, std::function<void()> then, Aside where = Aside::Encode,
                FrameClass cls = FrameClass::Still) override {
    asides.emplace_back(std::move(work), std::move(then));
    if (where == Aside::Encode) asideClasses.push_back(cls);
  }
  void runAsides() {
    while (!asides.empty()) {
      auto [work, then] = std::move(asides.front());
      asides.erase(asides.begin());
      work();
      then();
    }
  }

  bool wantsReplies() const override { return true; }
  /// The jobs a started scheduler rendered (the connection under test never hears of them), from its render thread.
  void rendered(RenderJob job, proto::Message) override {
    const std::lock_guard lock(renderedMutex);
    renderedJobs.push_back(std::move(job));
  }
  std::optional<RenderJob> renderedJob(uint32_t requestId) {
    const std::lock_guard lock(renderedMutex);
    for (const RenderJob& job : renderedJobs)
      if (job.requestId == requestId) return job;
    return std::nullopt;
  }
  std::mutex renderedMutex;
  std::vector<RenderJob> renderedJobs;
};

/// The message `bytes` encode and its request id.
std::pair<proto::Message, uint32_t> decoded(const std::vector<uint8_t>& bytes) {
  const proto::Header header =
      proto::decodeHeader(std::span<const uint8_t, proto::kHeaderBytes>(bytes.data(), proto::kHeaderBytes), {});
  return {proto::decodeBody(header, std::span(bytes).subspan(proto::kHeaderBytes), {}), header.requestId};
}

/// The error code of the Error that `bytes` encode, checking it answers `requestId`.
ErrorCode errorIn(const std::vector<uint8_t>& bytes, uint32_t requestId) {
  const auto [message, id] = decoded(bytes);
  EXPECT_EQ(id, requestId);
  const auto* error = std::get_if<proto::Error>(&message);
  EXPECT_NE(error, nullptr) << proto::messageTypeName(proto::messageType(message));
  return error ? error->code : ErrorCode::Internal;
}

std::unique_ptr<RenderScheduler> idleScheduler() {
  std::vector<std::unique_ptr<render::FrameSource>> sources;
  sources.push_back(std::make_unique<render::NullFrameSource>());
  return std::make_unique<RenderScheduler>(std::move(sources), true);  // never started: jobs only wait
}

const char* kConnectionScene =
    R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [40, 32], "transfer_function": "sparse"})";

class ConnectionTest : public ::testing::Test {
 protected:
  ServerConfig config;
  ServerStats stats;
  DatasetRegistry datasets{test::testDatasets(), size_t(16) << 20};
  render::TransferFunctionPresets presets = render::TransferFunctionPresets::load(test::shippedPresets());
  MessageHandler handler{config, datasets, presets, stats, [] { return nlohmann::json::object(); }};
  std::unique_ptr<RenderScheduler> scheduler = idleScheduler();
  OutputBudget output{1u << 20};
  std::vector<ConnectionId> ended;
  bool sessionsFree = true;
  SessionServices services{config,
                           proto::Limits{},
                           handler,
                           *scheduler,
                           stats,
                           output,
                           [this](ConnectionId id) { ended.push_back(id); },
                           [this](ConnectionId) -> std::optional<proto::Error> {
                             if (sessionsFree) return std::nullopt;
                             return errorMessage(proto::ErrorCode::LimitExceeded, "too many sessions (limit 64)");
                           },
                           {},
                           {},
                           {},
                           {},
                           {}};
  std::shared_ptr<FakeTransport> transport = std::make_shared<FakeTransport>();
  Connection core{*transport, services, ConnectionId{7}, "test:1"};

  /// A client message, written in the session's version (version 1 before Hello).
  void receive(const proto::Message& message, uint32_t requestId) {
    core.received(proto::encode(message, requestId, core.state().greeted ? core.state().version : proto::kVersion));
  }
  /// Reports the write in flight as written.
  void writeOne() {
    ASSERT_TRUE(transport->writing);
    transport->writing = false;
    core.written(true);
  }
  /// Reports every write as written, the queue's included.
  void flush() {
    while (transport->writing) writeOne();
  }
  void greet(uint16_t version = 1) {
    core.start();
    receive(proto::Hello{1, version, "test"}, 1);
    flush();
    ASSERT_TRUE(core.state().greeted);
    ASSERT_EQ(core.state().version, version);
  }
  /// The render thread's reply to request `requestId`: a frame of `side` x `side` in `encoding` (raw pixels of a
  /// moving gradient, as renderReply leaves a video frame), provisional unless `refinement`.
  /// A frame of request `requestId` rendered; the requests arrived in the order of their ids.
  void render(uint32_t requestId, proto::Encoding encoding, uint32_t side = 32, bool refinement = false) {
    RenderJob job;
    job.requestId = requestId;
    job.refinement = refinement;
    job.received = std::chrono::steady_clock::time_point{} + std::chrono::milliseconds(requestId);
    job.scene.width = job.scene.height = int(side);  // drawn at its scene's size
    std::vector<uint8_t> pixels(size_t(side) * side * 4, 255);
    for (size_t i = 0; i < pixels.size(); i += 4) pixels[i] = uint8_t(i / 4 + requestId * 3), pixels[i + 1] = 90;
    core.rendered(job, proto::Frame{side, side, encoding, refinement ? "{}" : R"({"provisional": true})", pixels});
  }
  /// The job the scheduler's render thread took for request `id` (waiting up to 30 s for it), if any.
  std::optional<RenderJob> awaitRenderedJob(uint32_t id) {
    for (int i = 0; i < 3000 && !transport->renderedJob(id); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return transport->renderedJob(id);
  }
  /// Makes the session's reports measure its link slow: two frames of 64 KiB (requests 10 and 11, large enough to
  /// settle the rate on their own: LinkPacer::settledLinkKbps) written back to back, their reports 80 ms apart: the
  /// second took 80 ms to pass, about 6.6 Mbit/s (a slower machine makes the gap longer and the link slower still).
  /// Returns the rate settled.
  std::optional<double> measureASlowLink() {
    render(10, proto::Encoding::RawRgba8, 128);
    render(11, proto::Encoding::RawRgba8, 128);
    flush();
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    receive(proto::FrameReceived{1000}, 10);
    std::this_thread::sleep_for(std::chrono::milliseconds(80));
    receive(proto::FrameReceived{1000}, 11);
    return core.link().settledLinkKbps();
  }
  /// What a session of protocol `version` is sent for its moving VP8 frame of `pixels` (32x32), drawn at half its
  /// 64x64 scene's sides for its stream (RenderJob::outputScale), when no video encoder fits in the server's video
  /// memory; `asDrawn`: the job's RenderJob::provisionalAsDrawn. A session of its own, on a link of its own.
  proto::Frame frameWhereNoEncoderFits(uint16_t version, bool asDrawn, std::vector<uint8_t> pixels) {
    VideoMemory memory(1);  // no encoder fits
    SessionServices withVideo = services;
    withVideo.video = &memory;
    auto link = std::make_shared<FakeTransport>();
    Connection session{*link, withVideo, ConnectionId{8}, "test:2"};
    const auto written = [&] {
      while (!link->asides.empty() || link->writing) {
        link->runAsides();
        while (link->writing) link->writing = false, session.written(true);
      }
    };
    session.start();
    session.received(proto::encode(proto::Hello{1, version, "test"}, 1, proto::kVersion));
    written();
    EXPECT_TRUE(session.state().greeted);
    RenderJob job;
    job.requestId = 3;
    job.scene.width = job.scene.height = 64;
    job.scene.interactive = true;
    job.outputScale = 0.5;
    job.provisionalAsDrawn = asDrawn;
    session.rendered(job, proto::Frame{32, 32, proto::Encoding::Vp8, R"({"provisional": true})", std::move(pixels)});
    written();
    EXPECT_EQ(link->writes.size(), 2u);
    if (link->writes.size() < 2) return {};
    auto [message, id] = decoded(link->writes[1]);
    EXPECT_EQ(id, 3u);
    return std::get<proto::Frame>(std::move(message));
  }
  /// Runs what was set aside and writes what that queued, until neither is left.
  void settle() {
    while (!transport->asides.empty() || transport->writing) {
      transport->runAsides();
      flush();
    }
  }
  /// Reports that `deadline` passed, and checks that the connection answers Timeout and closes once it is written.
  void expectTimedOut(Deadline deadline) {
    const size_t before = transport->writes.size();
    core.expired(deadline);
    ASSERT_EQ(transport->writes.size(), before + 1);
    EXPECT_EQ(errorIn(transport->writes.back(), 0), ErrorCode::Timeout);
    flush();
    EXPECT_TRUE(transport->closed);
  }
  /// The encoded size of the reply to ListDatasets.
  size_t listReplyBytes() {
    ConnectionState greeted;
    greeted.greeted = true;
    return proto::encode(handler.handle(greeted, proto::ListDatasets{}, 2).replies.at(0).message, 2).size();
  }
};

TEST_F(ConnectionTest, TheHelloDeadlineClosesAConnectionThatNeverGreets) {
  core.start();
  EXPECT_EQ(transport->armed.at(Deadline::Hello), config.helloTimeoutS);
  EXPECT_EQ(transport->reads, 1);
  core.expired(Deadline::Hello);
  ASSERT_EQ(transport->writes.size(), 1u);
  EXPECT_EQ(errorIn(transport->writes[0], 0), ErrorCode::Timeout);
  EXPECT_FALSE(core.alive()) << "its renders are dropped at once";
  EXPECT_FALSE(transport->closed) << "closed once its error is written";
  writeOne();
  EXPECT_TRUE(transport->closed);
  EXPECT_TRUE(transport->armed.empty());
  ASSERT_EQ(ended.size(), 1u);
  EXPECT_EQ(ended[0].value, 7u);
  EXPECT_EQ(stats.total(ServerEvent::Timeout), 1u);
  EXPECT_EQ(transport->reads, 1) << "no more reading once closing";
}

TEST_F(ConnectionTest, HelloStopsItsDeadlineAndMakesASession) {
  greet();
  EXPECT_FALSE(transport->armed.contains(Deadline::Hello));
  EXPECT_EQ(transport->armed.at(Deadline::Read), config.idleTimeoutS);
  ASSERT_EQ(transport->writes.size(), 1u);
  EXPECT_TRUE(std::holds_alternative<proto::Capabilities>(decoded(transport->writes[0]).first));
  core.expired(Deadline::Hello);  // a deadline that passed as Hello arrived changes nothing
  EXPECT_EQ(transport->writes.size(), 1u);
  EXPECT_TRUE(core.alive());
  EXPECT_EQ(transport->reads, 2);
}

TEST_F(ConnectionTest, AHelloFindingTheSessionsFullIsRefused) {
  sessionsFree = false;
  core.start();
  receive(proto::Hello{1, 1, "test"}, 1);
  ASSERT_EQ(transport->writes.size(), 1u);
  EXPECT_EQ(errorIn(transport->writes[0], 0), ErrorCode::LimitExceeded);
  writeOne();
  EXPECT_TRUE(transport->closed);
  EXPECT_FALSE(core.state().greeted && core.alive()) << "refused: never a session";
}

TEST_F(ConnectionTest, AnIdleSessionIsClosed) {
  greet();
  expectTimedOut(Deadline::Read);
  EXPECT_EQ(stats.total(ServerEvent::Timeout), 1u);
}

TEST_F(ConnectionTest, AMessageMustCompleteWithinTheReadTimeoutOfItsFirstByte) {
  greet();
  core.messageStarted();
  EXPECT_EQ(transport->armed.at(Deadline::Read), config.readTimeoutS) << "a started message has the read timeout";
  expectTimedOut(Deadline::Read);
}

TEST_F(ConnectionTest, AClientWaitingForAFrameIsNotIdle) {
  greet();
  receive(proto::OpenDataset{"sparse"}, 2);
  receive(proto::RenderRequest{proto::Encoding::RawRgba8, kConnectionScene}, 3);
  flush();
  ASSERT_TRUE(core.state().awaitingFrames());
  transport->armed.erase(Deadline::Read);
  core.expired(Deadline::Read);
  EXPECT_EQ(transport->armed.at(Deadline::Read), config.idleTimeoutS) << "the idle deadline starts again";
  EXPECT_FALSE(transport->writing);
  EXPECT_TRUE(core.alive());
}

TEST_F(ConnectionTest, BackPressurePausesReadingAboveTheLimitAndResumesBelowHalfOfIt) {
  greet();
  const size_t reply = listReplyBytes();
  config.pauseReadingBytes = 2 * reply;
  receive(proto::ListDatasets{}, 2);  // being written
  receive(proto::ListDatasets{}, 2);  // queued: 2 replies, at the limit
  EXPECT_FALSE(core.readingPaused());
  EXPECT_EQ(transport->reads, 4);
  receive(proto::ListDatasets{}, 2);  // 3 replies: above it
  EXPECT_EQ(core.queuedBytes(), 3 * reply);
  EXPECT_TRUE(core.readingPaused());
  EXPECT_EQ(transport->reads, 4) << "the next request is not read";
  EXPECT_EQ(stats.total(ServerEvent::ReadingPaused), 1u);
  writeOne();  // 2 left: above half the limit
  EXPECT_TRUE(core.readingPaused());
  EXPECT_EQ(transport->reads, 4);
  writeOne();  // 1 left: half the limit
  EXPECT_FALSE(core.readingPaused());
  EXPECT_EQ(transport->reads, 5);
  EXPECT_EQ(transport->armed.at(Deadline::Read), config.idleTimeoutS);
}

TEST_F(ConnectionTest, ANewerRenderReplacesAWaitingOlderOne) {
  greet();
  receive(proto::OpenDataset{"sparse"}, 2);
  receive(proto::RenderRequest{proto::Encoding::RawRgba8, kConnectionScene}, 3);
  receive(proto::RenderRequest{proto::Encoding::RawRgba8, kConnectionScene}, 4);
  flush();
  ASSERT_EQ(transport->writes.size(), 3u);  // Capabilities, DatasetInfo, Superseded
  EXPECT_EQ(errorIn(transport->writes[2], 3), ErrorCode::Superseded);
  EXPECT_EQ(core.state().outstandingRenders, 1);
  EXPECT_EQ(scheduler->queuedSessions(), 1u);

  RenderJob job;
  job.requestId = 4;
  core.rendered(job, proto::Frame{40, 32, proto::Encoding::RawRgba8, "{}", std::vector<uint8_t>(40 * 32 * 4)});
  ASSERT_EQ(transport->writes.size(), 4u);
  const auto [frame, id] = decoded(transport->writes[3]);
  EXPECT_EQ(id, 4u);
  EXPECT_TRUE(std::holds_alternative<proto::Frame>(frame));
  EXPECT_EQ(core.state().outstandingRenders, 0);
}

// Latest wins on output: at most one frame waits unsent; a newer one replaces it, and its request is answered
// Superseded, unless it was the provisional frame of the same request, whose exact frame simply takes its place.
TEST_F(ConnectionTest, ANewerFrameReplacesOneQueuedUnsent) {
  greet();
  auto frame = [](uint32_t side, const char* statsJson) {
    return proto::Frame{side, side, proto::Encoding::RawRgba8, statsJson,
                        std::vector<uint8_t>(size_t(side) * side * 4)};
  };
  auto render = [&](uint32_t requestId, bool refinement, proto::Frame f) {
    RenderJob job;
    job.requestId = requestId;
    job.refinement = refinement;
    core.rendered(job, std::move(f));
  };
  receive(proto::ListDatasets{}, 2);  // being written: nothing replaces it
  render(3, false, frame(8, "{}"));   // queued
  const uint64_t oneFrame = core.queuedBytes() - transport->writes.back().size();
  render(4, false, frame(8, "{}"));                        // replaces 3's frame, which becomes Superseded
  render(5, false, frame(8, R"({"provisional": true})"));  // replaces 4's
  render(5, true, frame(8, "{}"));                         // the exact frame of 5 replaces its provisional one
  EXPECT_LT(core.queuedBytes(), transport->writes.back().size() + oneFrame + 200) << "more than one frame waits unsent";
  EXPECT_EQ(output.queued(), core.queuedBytes());
  flush();
  ASSERT_EQ(transport->writes.size(), 5u);  // Capabilities, DatasetList, two Superseded, one frame
  EXPECT_EQ(errorIn(transport->writes[2], 3), ErrorCode::Superseded);
  EXPECT_EQ(errorIn(transport->writes[3], 4), ErrorCode::Superseded);
  const auto [last, id] = decoded(transport->writes[4]);
  EXPECT_EQ(id, 5u);
  ASSERT_TRUE(std::holds_alternative<proto::Frame>(last));
  EXPECT_EQ(std::get<proto::Frame>(last).statsJson, "{}") << "the exact frame, not the provisional one";
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 2u);
  EXPECT_EQ(output.queued(), 0u);

  // A frame being written is never replaced: the next one waits behind it.
  render(6, false, frame(8, "{}"));
  render(7, false, frame(8, "{}"));
  ASSERT_EQ(transport->writes.size(), 6u);
  flush();
  ASSERT_EQ(transport->writes.size(), 7u);
  EXPECT_EQ(decoded(transport->writes[5]).second, 6u);
  EXPECT_EQ(decoded(transport->writes[6]).second, 7u);
}

TEST_F(ConnectionTest, AFramePastTheOutputBudgetIsRefusedAndTheBudgetIsReleasedWhenTheSessionEnds) {
  greet();
  receive(proto::ListDatasets{}, 2);  // being written, and counted against the budget
  ASSERT_TRUE(transport->writing);
  EXPECT_EQ(output.queued(), core.queuedBytes());
  RenderJob job;
  job.requestId = 5;
  core.rendered(job, proto::Frame{1024, 1024, proto::Encoding::RawRgba8, "{}", std::vector<uint8_t>(2u << 20)});
  EXPECT_EQ(stats.total(ServerEvent::OutputRefused), 1u);
  ASSERT_EQ(transport->writes.size(), 2u) << "Capabilities, and the reply to ListDatasets being written";
  EXPECT_EQ(output.queued(), core.queuedBytes());
  core.end(errorMessage(ErrorCode::ShuttingDown, "server is stopping"));
  EXPECT_GT(output.queued(), 0u);
  writeOne();
  ASSERT_EQ(transport->writes.size(), 3u);
  EXPECT_EQ(errorIn(transport->writes[2], 5), ErrorCode::LimitExceeded) << "Busy's words in version 1";
  const std::string refusal = std::get<proto::Error>(decoded(transport->writes[2]).first).message;
  EXPECT_NE(refusal.find("max_total_output_bytes"), std::string::npos) << refusal;
  EXPECT_EQ(proto::retryAfterMs(refusal), 500u) << refusal;
  transport->writing = false;
  core.written(false);  // the client went away with replies unwritten
  EXPECT_TRUE(transport->closed);
  EXPECT_EQ(output.queued(), 0u);
  EXPECT_EQ(core.queuedBytes(), 0u);
  EXPECT_EQ(ended.size(), 1u);
}

// From version 3 a frame past the output budget is Busy with a retry hint: the replies drain as clients read them.
TEST_F(ConnectionTest, AFramePastTheOutputBudgetIsBusyWithARetryHint) {
  greet(proto::kMaxVersion);
  receive(proto::ListDatasets{}, 2);  // being written, and counted against the budget
  ASSERT_TRUE(transport->writing);
  RenderJob job;
  job.requestId = 5;
  core.rendered(job, proto::Frame{1024, 1024, proto::Encoding::RawRgba8, "{}", std::vector<uint8_t>(2u << 20)});
  EXPECT_EQ(stats.total(ServerEvent::OutputRefused), 1u);
  writeOne();
  ASSERT_EQ(transport->writes.size(), 3u);
  const auto [reply, id] = decoded(transport->writes[2]);
  EXPECT_EQ(id, 5u);
  ASSERT_TRUE(std::holds_alternative<proto::Error>(reply));
  EXPECT_EQ(std::get<proto::Error>(reply).code, ErrorCode::Busy);
  EXPECT_EQ(proto::retryAfterMs(std::get<proto::Error>(reply).message), 500u) << std::get<proto::Error>(reply).message;
}

TEST_F(ConnectionTest, ASessionPastItsOwnOutputLimitIsDropped) {
  greet();
  config.maxOutputBytes = 2 * listReplyBytes();
  receive(proto::ListDatasets{}, 2);
  receive(proto::ListDatasets{}, 2);
  EXPECT_FALSE(transport->closed);
  receive(proto::ListDatasets{}, 2);
  EXPECT_TRUE(transport->closed) << "dropped at once, not after a flush";
  EXPECT_EQ(stats.total(ServerEvent::SlowClientDropped), 1u);
  EXPECT_EQ(output.queued(), 0u);
}

TEST_F(ConnectionTest, AReplyNotTakenWithinTheWriteDeadlineCloses) {
  core.start();
  receive(proto::Hello{1, 1, "test"}, 1);
  EXPECT_EQ(transport->armed.at(Deadline::Write), config.writeTimeoutS);
  core.expired(Deadline::Write);
  EXPECT_TRUE(transport->closed);
  EXPECT_EQ(stats.total(ServerEvent::SlowClientDropped), 1u);
  EXPECT_EQ(output.queued(), 0u);
}

TEST_F(ConnectionTest, WholeMessagesAreDecodedOrAnswered) {
  greet();
  std::vector<uint8_t> bytes = proto::encode(proto::ListDatasets{}, 2);
  bytes.push_back(0);  // a body longer than its header says: that message is refused, the session goes on
  core.received(bytes);
  flush();
  ASSERT_EQ(transport->writes.size(), 2u);
  EXPECT_EQ(errorIn(transport->writes[1], 2), ErrorCode::Malformed);
  EXPECT_FALSE(transport->closed);
  EXPECT_EQ(transport->reads, 3);

  bytes = proto::encode(proto::ListDatasets{}, 3);
  bytes[0] ^= 0xff;  // no magic: the connection closes
  core.received(bytes);
  ASSERT_EQ(transport->writes.size(), 3u);
  EXPECT_EQ(errorIn(transport->writes[2], 0), ErrorCode::BadMagic);
  flush();
  EXPECT_TRUE(transport->closed);
  EXPECT_EQ(stats.total(ServerEvent::ProtocolError), 2u);
}

// The video stream: frames are encoded aside, one at a time and in order; a newer rendered frame replaces one still
// waiting for the encoder (its request answered Superseded), but a frame once encoded is always sent, so that the
// client's decoder sees every frame of the stream.
TEST_F(ConnectionTest, VideoFramesAreEncodedAsideInOrderAndNeverDroppedOnceEncoded) {
  greet(4);
  render(3, proto::Encoding::Vp8);
  EXPECT_EQ(transport->asides.size(), 1u) << "encoded aside, not on the connection's context";
  EXPECT_EQ(transport->writes.size(), 1u);
  render(4, proto::Encoding::Vp8);  // waits for the encoder
  render(5, proto::Encoding::Vp8);  // replaces 4, which is answered Superseded
  EXPECT_EQ(transport->asides.size(), 1u) << "one frame is encoded at a time";
  settle();
  ASSERT_EQ(transport->writes.size(), 4u);  // Capabilities, Superseded 4, the frames of 3 and 5
  EXPECT_EQ(errorIn(transport->writes[1], 4), ErrorCode::Superseded);
  image::VideoDecoder decoder(proto::Encoding::Vp8);
  for (size_t i : {size_t(2), size_t(3)}) {
    const auto [message, id] = decoded(transport->writes[i]);
    EXPECT_EQ(id, i == 2 ? 3u : 5u);
    const auto& frame = std::get<proto::Frame>(message);
    EXPECT_EQ(frame.encoding, proto::Encoding::Vp8);
    const nlohmann::json frameStats = nlohmann::json::parse(frame.statsJson);
    EXPECT_EQ(frameStats["video"]["key"].get<bool>(), i == 2);
    EXPECT_TRUE(frameStats["provisional"].get<bool>());
    EXPECT_TRUE(frameStats.contains("encode_ms"));
    // Its Render arrived `id` ms after the clock's epoch (render()): long before its encoding started.
    EXPECT_GT(frameStats["encode_start_ms"].get<double>(), 1000.0);
    EXPECT_EQ(decoder.decode(frame.payload).width, 32) << "each decodes, in order";
  }
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 1u);

  // An encoded frame queued unsent is never replaced: the next one is encoded only once it is written.
  render(6, proto::Encoding::Vp8);
  transport->runAsides();  // 6 encoded and being written
  render(7, proto::Encoding::Vp8);
  transport->runAsides();  // 7 encoded, queued behind 6
  render(8, proto::Encoding::Vp8);
  EXPECT_TRUE(transport->asides.empty()) << "8 waits: an encoded frame is queued unsent";
  render(9, proto::Encoding::Vp8);  // replaces 8
  settle();
  std::vector<uint32_t> ids;
  for (size_t i = 4; i < transport->writes.size(); ++i) ids.push_back(decoded(transport->writes[i]).second);
  EXPECT_EQ(ids, (std::vector<uint32_t>{6, 7, 8, 9}));  // 8 as Superseded
  EXPECT_EQ(errorIn(transport->writes[6], 8), ErrorCode::Superseded);
}

// An encoding aside waits for the encoder threads in its frame's class (EncoderQueue), as its Render waited for a
// render thread: a moving camera's video frame as interactive, a batch Render's still frame as batch, the exact
// frame that follows a drag's provisional one as still.
TEST_F(ConnectionTest, EncodingsAsideAreQueuedInTheirFramesClass) {
  greet(4);
  const auto frame = [&](uint32_t requestId, proto::Encoding encoding, bool interactive, bool batch, bool refinement) {
    RenderJob job;
    job.requestId = requestId;
    job.received = std::chrono::steady_clock::time_point{} + std::chrono::milliseconds(requestId);
    job.scene.interactive = interactive;
    job.scene.batch = batch;
    job.scene.width = job.scene.height = 32;
    job.refinement = refinement;
    if (!image::isVideoEncoding(encoding)) job.stillToEncode = 90;
    core.rendered(job, proto::Frame{32, 32, encoding, refinement ? "{}" : R"({"provisional": true})",
                                    std::vector<uint8_t>(32 * 32 * 4, uint8_t(requestId))});
    settle();
  };
  frame(3, proto::Encoding::Vp8, true, false, false);
  frame(4, proto::Encoding::Png, false, true, false);
  frame(5, proto::Encoding::Png, true, false, true);
  frame(6, proto::Encoding::Jpeg, true, false, false);
  EXPECT_EQ(transport->asideClasses, (std::vector<FrameClass>{FrameClass::Interactive, FrameClass::Batch,
                                                              FrameClass::Still, FrameClass::Interactive}));
}

// Still frames left with their pixels (RenderJob::stillToEncode, as a render thread leaves them for a session that
// encodes aside) are encoded aside one at a time and sent in the order they were rendered: a frame rendered while
// another is encoded, and a video frame after it, wait for it; each payload decodes to the rendered pixels.
TEST_F(ConnectionTest, StillFramesLeftWithTheirPixelsAreEncodedAsideInOrder) {
  greet(4);
  std::map<uint32_t, std::vector<uint8_t>> rendered;
  const auto still = [&](uint32_t requestId, proto::Encoding encoding, bool refinement) {
    RenderJob job;
    job.requestId = requestId;
    job.refinement = refinement;
    job.stillToEncode = 90;
    std::vector<uint8_t> pixels(32 * 32 * 4, 255);
    for (size_t i = 0; i < pixels.size(); i += 4) pixels[i] = uint8_t(i / 4 + requestId), pixels[i + 2] = 40;
    rendered[requestId] = pixels;
    core.rendered(job, proto::Frame{32, 32, encoding, refinement ? R"({"a": 1})" : R"({"provisional": true})", pixels});
  };
  still(3, proto::Encoding::Png, true);
  EXPECT_EQ(transport->asides.size(), 1u) << "encoded aside, not on the connection's context";
  EXPECT_EQ(transport->writes.size(), 1u) << "nothing sent before it is encoded";
  still(4, proto::Encoding::ZstdRgba8, true);
  render(5, proto::Encoding::Vp8);  // a video frame rendered after them
  EXPECT_EQ(transport->asides.size(), 1u) << "one frame is encoded at a time";
  while (!transport->asides.empty()) {  // each encoded frame written before the next is encoded (nothing replaced)
    auto [work, then] = std::move(transport->asides.front());
    transport->asides.erase(transport->asides.begin());
    work();
    then();
    flush();
  }
  ASSERT_EQ(transport->writes.size(), 4u);  // Capabilities, 3, 4, 5
  for (uint32_t id : {3u, 4u}) {
    const auto [message, requestId] = decoded(transport->writes[id - 2]);
    EXPECT_EQ(requestId, id);
    const auto& frame = std::get<proto::Frame>(message);
    EXPECT_EQ(image::decodeFrameImage(frame).rgba, rendered[id]) << "lossless, the rendered pixels";
    const nlohmann::json frameStats = nlohmann::json::parse(frame.statsJson);
    EXPECT_EQ(frameStats["a"], 1) << "the render thread's statistics kept";
    EXPECT_TRUE(frameStats["encode_ms"].is_number());
  }
  EXPECT_EQ(decoded(transport->writes[3]).second, 5u);
  EXPECT_EQ(std::get<proto::Frame>(decoded(transport->writes[3]).first).encoding, proto::Encoding::Vp8);

  // A frame whose encoding exceeds the session's message limit answers LimitExceeded, naming the limit.
  RenderJob job;
  job.requestId = 6;
  job.stillToEncode = 90;
  job.maxBodyBytes = 64;
  core.rendered(job, proto::Frame{32, 32, proto::Encoding::Png, "{}", std::vector<uint8_t>(32 * 32 * 4, 7)});
  settle();
  const auto [refused, id] = decoded(transport->writes.back());
  EXPECT_EQ(id, 6u);
  ASSERT_TRUE(std::holds_alternative<proto::Error>(refused));
  EXPECT_EQ(std::get<proto::Error>(refused).code, ErrorCode::LimitExceeded);
  EXPECT_NE(std::get<proto::Error>(refused).message.find("message limit of 64"), std::string::npos);

  // A provisional frame refused so answers its request: the exact frame the scheduler queued after it is not sent.
  job.requestId = 7;
  job.stillProvisional = true;
  core.rendered(job, proto::Frame{32, 32, proto::Encoding::Png, R"({"provisional": true})",
                                  std::vector<uint8_t>(32 * 32 * 4, 7)});
  settle();
  const size_t written = transport->writes.size();
  EXPECT_EQ(errorIn(transport->writes.back(), 7), ErrorCode::LimitExceeded);
  job.refinement = true;
  job.maxBodyBytes = UINT64_MAX;
  core.rendered(job, proto::Frame{32, 32, proto::Encoding::Png, "{}", std::vector<uint8_t>(32 * 32 * 4, 7)});
  settle();
  EXPECT_EQ(transport->writes.size(), written) << "request 7 was answered once, by its error";
}

// Latest wins before the encoder too: a still frame waiting for it gives way to a newer one (its request answered
// Superseded, or nothing when the newer is its own exact frame), so that render threads faster than the encoders
// leave no backlog of frames to encode and then replace.
TEST_F(ConnectionTest, AStillFrameWaitingForTheEncoderGivesWayToANewerOne) {
  greet(4);
  const auto still = [&](uint32_t requestId, bool refinement) {
    RenderJob job;
    job.requestId = requestId;
    job.refinement = refinement;
    job.stillToEncode = 90;
    core.rendered(job, proto::Frame{16, 16, proto::Encoding::Png, refinement ? "{}" : R"({"provisional": true})",
                                    std::vector<uint8_t>(16 * 16 * 4, uint8_t(requestId))});
  };
  still(3, false);                      // being encoded
  still(4, false);                      // waits
  still(5, false);                      // replaces 4: Superseded
  still(5, true);                       // 5's exact frame replaces its provisional one: no answer for that
  while (!transport->asides.empty()) {  // each encoded frame written before the next is encoded (nothing replaced)
    flush();
    auto [work, then] = std::move(transport->asides.front());
    transport->asides.erase(transport->asides.begin());
    work();
    then();
  }
  flush();
  std::vector<std::pair<uint32_t, std::string>> answers;
  for (size_t i = 1; i < transport->writes.size(); ++i) {
    const auto [message, id] = decoded(transport->writes[i]);
    answers.emplace_back(id, proto::messageTypeName(proto::messageType(message)));
  }
  const std::vector<std::pair<uint32_t, std::string>> expected{{4, "Error"}, {3, "Frame"}, {5, "Frame"}};
  EXPECT_EQ(answers, expected);
  EXPECT_EQ(errorIn(transport->writes[1], 4), ErrorCode::Superseded);
  const proto::Frame exact = std::get<proto::Frame>(decoded(transport->writes[3]).first);
  EXPECT_FALSE(nlohmann::json::parse(exact.statsJson).value("provisional", false)) << "the exact frame";
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 1u);
}

// The exact frame of a request replaces its own provisional video frame still waiting for the encoder, without a
// Superseded: the request is answered by its exact frame.
TEST_F(ConnectionTest, AnExactFrameTakesThePlaceOfItsOwnVideoFrameWaitingToBeEncoded) {
  greet(4);
  render(3, proto::Encoding::Vp9);
  render(4, proto::Encoding::Vp9);           // waits
  render(4, proto::Encoding::Png, 32, true);  // its exact frame: held behind 3's encoding, then replaces 4's
  settle();
  ASSERT_EQ(transport->writes.size(), 3u);
  EXPECT_EQ(std::get<proto::Frame>(decoded(transport->writes[1]).first).encoding, proto::Encoding::Vp9);
  const auto [exact, id] = decoded(transport->writes[2]);
  EXPECT_EQ(id, 4u);
  EXPECT_EQ(std::get<proto::Frame>(exact).encoding, proto::Encoding::Png);
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 0u);
  // A new size starts the stream again with a key frame.
  render(5, proto::Encoding::Vp9, 48);
  settle();
  const proto::Frame frame = std::get<proto::Frame>(decoded(transport->writes.back()).first);
  EXPECT_EQ(frame.width, 48u);
  const nlohmann::json video = nlohmann::json::parse(frame.statsJson)["video"];
  EXPECT_TRUE(video["key"].get<bool>());
  EXPECT_EQ(video["key_reason"], "size");
}

// A moving frame drawn at its stream's smaller size (RenderJob::outputScale) for which no encoder fits in the video
// memory goes as a still JPEG of the scene's size, as every frame of the scene does, scaled up from the drawing.
TEST_F(ConnectionTest, AFrameDrawnSmallerForItsStreamGoesAsAStillOfTheScenesSizeWhereNoEncoderFits) {
  std::vector<uint8_t> pixels(32 * 32 * 4, 255);
  for (size_t i = 0; i < pixels.size(); i += 4) pixels[i] = uint8_t(i / 4), pixels[i + 1] = 90;
  const proto::Frame frame = frameWhereNoEncoderFits(4, false, pixels);
  EXPECT_EQ(frame.encoding, proto::Encoding::Jpeg);
  EXPECT_EQ(frame.width, 64u);
  EXPECT_EQ(frame.height, 64u);
  EXPECT_EQ(nlohmann::json::parse(frame.statsJson)["video_fallback"], "memory") << frame.statsJson;
  const image::Image8 shown = image::FrameDecoder().decode(frame);
  EXPECT_EQ(shown.width, 64);
  EXPECT_EQ(shown.height, 64);
  // The drawing's first row, scaled up: its red channel rises along the row as the drawing's did.
  EXPECT_LT(shown.rgba[0], shown.rgba[4 * 60]);
}

// For a client that shows moving frames scaled (protocol version 8) the same frame goes at the size it was drawn.
TEST_F(ConnectionTest, AFrameDrawnSmallerForItsStreamGoesAsDrawnToAClientThatScalesIt) {
  const proto::Frame frame = frameWhereNoEncoderFits(8, true, std::vector<uint8_t>(32 * 32 * 4, 200));
  EXPECT_EQ(frame.encoding, proto::Encoding::Jpeg);
  EXPECT_EQ(frame.width, 32u);
  EXPECT_EQ(frame.height, 32u);
  EXPECT_EQ(image::FrameDecoder().decode(frame).width, 32);
}

// A provisional JPEG sent smaller than its scene is encoded above its quality (its client scales its losses up).
TEST(ReplyJpegQuality, AProvisionalFrameSentSmallerThanItsSceneIsEncodedAboveItsQuality) {
  RenderJob job;
  job.scene.width = job.scene.height = 64;
  const int q = image::kDefaultJpegQuality;
  EXPECT_EQ(replyJpegQuality(job, true), q);
  EXPECT_EQ(replyJpegQuality(job, true, 64, 64), q);
  EXPECT_EQ(replyJpegQuality(job, true, 32, 32), std::min(kAsDrawnJpegQualityMax, q + kAsDrawnJpegQualityRaise));
  EXPECT_EQ(replyJpegQuality(job, false, 32, 32), q) << "an exact frame is never smaller";
  job.provisionalJpegQuality = 70;  // the crowd's
  EXPECT_EQ(replyJpegQuality(job, true, 32, 32), 70 + kAsDrawnJpegQualityRaise);
  job.provisionalJpegQuality.reset();
  job.scene.jpegQuality = 92;
  EXPECT_EQ(replyJpegQuality(job, true, 32, 64), kAsDrawnJpegQualityMax);
}

// Render threads finish a session's frames out of order: a video frame whose Render arrived before that of the frame
// waiting for the encoder, or of one already encoded, is dropped (Superseded), never encoded after it. The stream
// never goes back to an older camera, nor to an older size (which cost two more key frames: a browser's resize
// mid-drag met it).
TEST_F(ConnectionTest, AVideoFrameOfAnOlderRenderIsNeverEncodedAfterANewerOnes) {
  greet(4);
  render(3, proto::Encoding::Vp8, 48);  // being encoded
  render(6, proto::Encoding::Vp8, 32);  // waits: the new size
  render(5, proto::Encoding::Vp8, 48);  // older than the one waiting: dropped
  settle();
  render(4, proto::Encoding::Vp8, 48);  // older than the one encoded: dropped
  render(7, proto::Encoding::Vp8, 32);
  settle();
  std::vector<std::pair<uint32_t, std::string>> answers;
  std::vector<std::string> keys;
  for (size_t i = 1; i < transport->writes.size(); ++i) {
    const auto [message, id] = decoded(transport->writes[i]);
    answers.emplace_back(id, proto::messageTypeName(proto::messageType(message)));
    if (const auto* frame = std::get_if<proto::Frame>(&message)) {
      const nlohmann::json video = nlohmann::json::parse(frame->statsJson)["video"];
      keys.push_back(video["key"].get<bool>() ? video["key_reason"].get<std::string>() : "-");
    }
  }
  const std::vector<std::pair<uint32_t, std::string>> expected{
      {5, "Error"}, {3, "Frame"}, {6, "Frame"}, {4, "Error"}, {7, "Frame"}};
  EXPECT_EQ(answers, expected);
  EXPECT_EQ(keys, (std::vector<std::string>{"start", "size", "-"}));
  EXPECT_EQ(errorIn(transport->writes[1], 5), ErrorCode::Superseded);
  EXPECT_EQ(errorIn(transport->writes[4], 4), ErrorCode::Superseded);
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 2u);
}

// Latest wins on output by when the Renders arrived, not by when their frames were drawn: a still frame older than the
// one queued unsent (render threads finish a session's frames out of order) is dropped, and the newer one stays.
TEST_F(ConnectionTest, AStillFrameOfAnOlderRenderNeverReplacesANewerOneQueued) {
  greet(4);
  render(3, proto::Encoding::RawRgba8);  // being written
  render(5, proto::Encoding::RawRgba8);  // queued unsent
  render(4, proto::Encoding::RawRgba8);  // older than 5: dropped, Superseded
  render(6, proto::Encoding::RawRgba8);  // newer than 5: replaces it, 5 Superseded
  settle();
  std::vector<std::pair<uint32_t, std::string>> answers;
  for (size_t i = 1; i < transport->writes.size(); ++i) {
    const auto [message, id] = decoded(transport->writes[i]);
    answers.emplace_back(id, proto::messageTypeName(proto::messageType(message)));
  }
  const std::vector<std::pair<uint32_t, std::string>> expected{
      {3, "Frame"}, {5, "Error"}, {4, "Error"}, {6, "Frame"}};
  EXPECT_EQ(answers, expected);
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 2u);
  // The exact frame of an older request whose provisional frame answered it goes without a word.
  render(8, proto::Encoding::RawRgba8);  // being written
  render(9, proto::Encoding::RawRgba8);  // queued unsent
  render(7, proto::Encoding::RawRgba8, 32, true);
  settle();
  ASSERT_EQ(transport->writes.size(), 7u);
  EXPECT_EQ(decoded(transport->writes[5]).second, 8u);
  EXPECT_EQ(decoded(transport->writes[6]).second, 9u);
  // An exact frame queued unsent, whose provisional frame answered its request, gives way to a newer frame without a
  // word: a provisional Frame is followed by at most one exact Frame, never by an Error.
  render(10, proto::Encoding::RawRgba8);        // being written
  render(11, proto::Encoding::RawRgba8, 32, true);  // queued unsent
  render(12, proto::Encoding::RawRgba8);
  settle();
  ASSERT_EQ(transport->writes.size(), 9u);
  EXPECT_EQ(decoded(transport->writes[7]).second, 10u);
  EXPECT_EQ(decoded(transport->writes[8]).second, 12u);
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 2u);
}

// An exact frame waiting unsent for the client's reports goes without a word once a newer Render came: its camera
// has moved on (the rest that asked for it was only a late move), and on a slow link its bytes (a 1024² png: 650 ms
// at 10 Mbit/s) would hold the moving frames behind it. The exact frame of the newest camera is still sent, once the
// client has had every frame on its way and the camera rested since (a client waiting for its replies sends no Render
// while a slow link holds them).
TEST_F(ConnectionTest, AnExactFrameOfACameraThatMovedOnIsNotSent) {
  using Clock = std::chrono::steady_clock;
  greet(4);
  receive(proto::OpenDataset{"sparse"}, 2);
  flush();
  const auto report = [&](uint32_t id) { receive(proto::FrameReceived{1000}, id); };
  /// The render thread's frame of request `id`, whose Render (or refinement) arrived at `received`.
  const auto rendered = [&](uint32_t id, proto::Encoding encoding, bool exact, Clock::time_point received) {
    RenderJob job;
    job.requestId = id;
    job.refinement = exact;
    job.received = received;
    core.rendered(job, proto::Frame{32, 32, encoding, exact ? "{}" : R"({"provisional": true})",
                                    std::vector<uint8_t>(32 * 32 * 4, uint8_t(id))});
    settle();
  };
  const auto start = Clock::now() - std::chrono::milliseconds(50);  // the frames below were asked before the Render 6
  rendered(3, proto::Encoding::Vp8, false, start);
  report(3);
  rendered(4, proto::Encoding::Vp8, false, start + std::chrono::milliseconds(1));
  rendered(5, proto::Encoding::Vp8, false, start + std::chrono::milliseconds(2));
  ASSERT_EQ(core.link().inFlight(), 2);
  rendered(5, proto::Encoding::Png, true, start + std::chrono::milliseconds(3));  // the camera seemed to rest
  const size_t written = transport->writes.size();
  receive(proto::RenderRequest{proto::Encoding::Png, kConnectionScene}, 6);  // it moved on
  report(4);
  settle();
  std::vector<std::pair<uint32_t, proto::Encoding>> frames;
  for (size_t i = written; i < transport->writes.size(); ++i) {
    const auto [message, id] = decoded(transport->writes[i]);
    ASSERT_TRUE(std::holds_alternative<proto::Frame>(message)) << "no Error: 5's provisional frame answered it";
    frames.emplace_back(id, std::get<proto::Frame>(message).encoding);
  }
  EXPECT_TRUE(frames.empty()) << "5's exact frame was sent";
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 0u);
  // The newest camera's frames: its provisional frame at once; its exact frame (the request was interactive) only
  // once nothing is on its way and the rest has passed since both the last Render and the last report.
  rendered(6, proto::Encoding::Vp8, false, Clock::now());
  ASSERT_EQ(transport->writes.size(), written + 1);
  EXPECT_EQ(decoded(transport->writes[written]).second, 6u);
  RenderJob exact;
  exact.requestId = 6;
  exact.refinement = true;
  exact.received = Clock::now();
  exact.scene.interactive = true;
  core.rendered(exact, proto::Frame{32, 32, proto::Encoding::Png, "{}", std::vector<uint8_t>(32 * 32 * 4, 6)});
  settle();
  EXPECT_EQ(transport->writes.size(), written + 1) << "frames on their way: the exact frame waits";
  report(5);
  settle();
  EXPECT_EQ(transport->writes.size(), written + 1) << "one frame still on its way";
  const auto reported = Clock::now();
  report(6);
  settle();
  EXPECT_EQ(transport->writes.size(), written + 1) << "nothing on its way, but the camera has not rested yet";
  EXPECT_TRUE(transport->armed.count(Deadline::Pace));
  const double restMs = scheduler->restMs(*transport->renderSink());
  std::this_thread::sleep_until(reported + std::chrono::microseconds(int64_t(restMs * 1000)) +
                                std::chrono::milliseconds(5));
  core.expired(Deadline::Pace);
  settle();
  ASSERT_EQ(transport->writes.size(), written + 2);
  const auto [last, id] = decoded(transport->writes.back());
  EXPECT_EQ(id, 6u);
  EXPECT_EQ(std::get<proto::Frame>(last).encoding, proto::Encoding::Png);
}

// A client that stopped reporting is waited for no longer than the pacer waits: once its oldest frame on the way has
// gone unreported for a second, the exact frame held for the camera's rest is written.
TEST_F(ConnectionTest, AnExactFrameIsNotHeldForAClientThatStoppedReporting) {
  greet(4);
  render(3, proto::Encoding::Vp8);
  settle();
  receive(proto::FrameReceived{1000}, 3);
  render(4, proto::Encoding::Vp8);
  settle();
  ASSERT_EQ(core.link().inFlight(), 1);
  RenderJob exact;
  exact.requestId = 4;
  exact.refinement = true;
  exact.received = std::chrono::steady_clock::now();
  exact.scene.interactive = true;
  core.rendered(exact, proto::Frame{32, 32, proto::Encoding::Png, "{}", std::vector<uint8_t>(32 * 32 * 4, 4)});
  settle();
  const size_t before = transport->writes.size();
  std::this_thread::sleep_for(std::chrono::milliseconds(int64_t(LinkPacer::kStaleMs) + 20));
  core.expired(Deadline::Pace);
  settle();
  ASSERT_EQ(transport->writes.size(), before + 1) << "the exact frame still held";
  const auto [message, id] = decoded(transport->writes.back());
  EXPECT_EQ(id, 4u);
  EXPECT_EQ(std::get<proto::Frame>(message).encoding, proto::Encoding::Png);
}

// A client that reports its frames (FrameReceived) keeps at most two on their way; a third waits at the server, where
// a newer frame still replaces it, until a report makes room.
TEST_F(ConnectionTest, FramesWaitForTheClientsReportsOnceItReports) {
  greet(4);
  const auto report = [&](uint32_t id) { receive(proto::FrameReceived{1000}, id); };
  report(90);  // nothing on its way: ignored, unanswered
  EXPECT_EQ(transport->writes.size(), 1u);
  render(3, proto::Encoding::RawRgba8);
  flush();
  report(3);
  EXPECT_TRUE(core.link().reporting());
  render(4, proto::Encoding::RawRgba8);
  render(5, proto::Encoding::RawRgba8, 32, true);
  flush();
  ASSERT_EQ(transport->writes.size(), 4u) << "two frames on their way";
  render(6, proto::Encoding::RawRgba8);
  EXPECT_EQ(transport->writes.size(), 4u) << "a third waits";
  EXPECT_TRUE(transport->armed.count(Deadline::Pace)) << "released when the oldest goes stale at the latest";
  render(7, proto::Encoding::RawRgba8);  // replaces 6 (Superseded) and waits in its place
  flush();
  ASSERT_EQ(transport->writes.size(), 5u);
  EXPECT_EQ(errorIn(transport->writes[4], 6), ErrorCode::Superseded);
  core.expired(Deadline::Pace);  // not stale yet: still waiting
  EXPECT_EQ(transport->writes.size(), 5u);
  report(4);
  ASSERT_EQ(transport->writes.size(), 6u);
  EXPECT_EQ(decoded(transport->writes[5]).second, 7u);
  EXPECT_EQ(core.link().inFlight(), 2);
}

// A video frame is encoded ahead of the link's room: once the oldest frame on its way is expected to be reported (its
// write plus the usual delivery) less the encoder's time, not once it is. It then waits at the server for the report;
// the encoding is no longer part of the time between frames (a drag over a far link, 80 ms of round trip, ran at
// 19 frames a second with the 1024x1024 encoding in that time, 22 without).
TEST_F(ConnectionTest, AVideoFrameIsEncodedAheadOfTheLinksRoom) {
  using Clock = std::chrono::steady_clock;
  greet(4);
  const auto report = [&](uint32_t id) { receive(proto::FrameReceived{1000}, id); };
  render(3, proto::Encoding::Vp8);
  settle();
  std::this_thread::sleep_for(std::chrono::milliseconds(60));
  report(3);  // the usual delivery: 60 ms
  render(4, proto::Encoding::Vp8);
  settle();
  const auto oldestWritten = Clock::now();
  render(5, proto::Encoding::Vp8);
  settle();
  ASSERT_EQ(core.link().inFlight(), LinkPacer::kFramesInFlight);
  const size_t written = transport->writes.size();
  render(6, proto::Encoding::Vp8);
  EXPECT_TRUE(transport->asides.empty()) << "the link is not expected to have room for 60 ms";
  ASSERT_TRUE(transport->armed.count(Deadline::Pace));
  EXPECT_LT(transport->armed[Deadline::Pace], 0.07)
      << "woken when the room is expected, less the encoder's time; not when the oldest frame goes stale";
  std::this_thread::sleep_until(oldestWritten + std::chrono::milliseconds(62));
  core.expired(Deadline::Pace);
  ASSERT_EQ(transport->asides.size(), 1u) << "encoded ahead: 4 is not reported yet";
  EXPECT_EQ(core.link().inFlight(), LinkPacer::kFramesInFlight);
  settle();
  EXPECT_EQ(transport->writes.size(), written) << "the frame encoded waits for the report";
  report(4);
  settle();
  ASSERT_EQ(transport->writes.size(), written + 1);
  EXPECT_EQ(decoded(transport->writes.back()).second, 6u);
}

// A png frame's speed follows the session's link as its reports measure it: fast while nothing says the link is slow,
// small once frames that followed one another took long to arrive (below kSmallPngBelowKbps).
TEST_F(ConnectionTest, APngFramesSpeedFollowsTheLinkItsReportsMeasure) {
  greet(4);
  receive(proto::OpenDataset{"sparse"}, 2);
  flush();
  scheduler->start();
  receive(proto::RenderRequest{proto::Encoding::Png, kConnectionScene}, 3);
  const std::optional<RenderJob> first = awaitRenderedJob(3);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->pngSpeed, image::PngSpeed::Fast) << "nothing measured the link";
  const std::optional<double> link = measureASlowLink();
  ASSERT_TRUE(link);
  ASSERT_LT(*link, kSmallPngBelowKbps);
  receive(proto::RenderRequest{proto::Encoding::Png, kConnectionScene}, 4);
  const std::optional<RenderJob> second = awaitRenderedJob(4);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->pngSpeed, image::PngSpeed::Small) << "a link measured at " << *link << " kbit/s";
  scheduler->stop();
}

// A scene accepting webp gets its png frames as webp only once the session's reports measure the link below
// kWebpBelowKbps, and still when that measurement is older than the video's bitrate heeds; one that does not accept
// it keeps png on the same link.
TEST_F(ConnectionTest, PngFramesComeAsWebpOnlyToASceneThatAcceptsItOnALinkMeasuredSlow) {
  greet(7);
  receive(proto::OpenDataset{"sparse"}, 2);
  flush();
  scheduler->start();
  std::string accepting(kConnectionScene);
  accepting.insert(accepting.rfind('}'), R"(, "accepts_webp": true)");
  receive(proto::RenderRequest{proto::Encoding::Png, accepting}, 3);
  const std::optional<RenderJob> first = awaitRenderedJob(3);
  ASSERT_TRUE(first);
  EXPECT_FALSE(first->webpForPng) << "nothing measured the link";
  EXPECT_EQ(replyEncoding(*first, false), proto::Encoding::Png);
  const std::optional<double> link = measureASlowLink();
  ASSERT_TRUE(link);
  ASSERT_LT(*link, kWebpBelowKbps);
  // Nothing holds a video's bitrate down after two seconds of nothing new, but lossless frames still go by the
  // settled rate (the exact frame after a drag whose frames kept up with the link).
  std::this_thread::sleep_for(std::chrono::milliseconds(2100));
  ASSERT_FALSE(core.link().capacityKbps(std::chrono::steady_clock::now()));
  receive(proto::RenderRequest{proto::Encoding::Png, accepting}, 4);
  const std::optional<RenderJob> slow = awaitRenderedJob(4);  // before the next Render, which would replace it waiting
  receive(proto::RenderRequest{proto::Encoding::Png, kConnectionScene}, 5);
  const std::optional<RenderJob> notAccepting = awaitRenderedJob(5);
  ASSERT_TRUE(slow && notAccepting);
  EXPECT_TRUE(slow->webpForPng) << "a link measured at " << *link << " kbit/s";
  EXPECT_EQ(replyEncoding(*slow, false), proto::Encoding::Webp);
  EXPECT_EQ(replyEncoding(*slow, true), proto::Encoding::Webp) << "a provisional png frame too";
  EXPECT_FALSE(notAccepting->webpForPng);
  EXPECT_EQ(replyEncoding(*notAccepting, false), proto::Encoding::Png);
  scheduler->stop();
}

// FrameReceived exists from version 4 on: an older session that sends it is told so and goes on.
TEST_F(ConnectionTest, FrameReceivedInAnOlderSessionIsAnUnknownType) {
  greet(3);
  core.received(proto::encode(proto::FrameReceived{10}, 9, 4));
  flush();
  ASSERT_EQ(transport->writes.size(), 2u);
  EXPECT_EQ(errorIn(transport->writes[1], 9), ErrorCode::UnknownType);
  EXPECT_FALSE(core.link().reporting());
  EXPECT_FALSE(transport->closed);
}

}  // namespace
}  // namespace voxbrick::server
