// The message handler on its own: decoded messages in, replies out, no sockets (a real store, real presets).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "TestDatasets.h"
#include "render/core/TransferFunction.h"
#include "render/core/TransferFunctionPresets.h"
#include "server/Datasets.h"
#include "server/MessageHandler.h"
#include "server/ServerStats.h"

namespace voxbrick::server {
namespace {

using nlohmann::json;
using proto::ErrorCode;

ServerConfig handlerConfig() {
  ServerConfig config;
  config.maxImageSide = 100;
  config.maxMessageBytes = 65536;  // room for the tests' raw 80x64 frames (20 KB)
  return config;
}

const char* kHandlerScene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [80, 64], "transfer_function": "sparse"})";

class MessageHandlerTest : public ::testing::Test {
 protected:
  ServerConfig config = handlerConfig();
  DatasetRegistry datasets{test::testDatasets(), size_t(16) << 20};
  render::TransferFunctionPresets presets = render::TransferFunctionPresets::load(test::shippedPresets());
  ServerStats stats;
  MessageHandler handler{config, datasets, presets, stats, [this] {
                           ServerStats::Gauges gauges{3, 1, datasets.opened(), 2, {}, 0};
                           gauges.deviceBusyMs = {1500, 250};
                           gauges.deviceWaitMs = {500, 2750};
                           return stats.toJson(gauges);
                         }};
  ConnectionState state;

  Outcome handle(const proto::Message& message, uint32_t id = 1) { return handler.handle(state, message, id); }
  void greet() { ASSERT_TRUE(state.greeted || handle(proto::Hello{1, 1, "test"}).replies.size() == 1); }
  void greetAndOpen() {
    greet();
    ASSERT_EQ(handle(proto::OpenDataset{"sparse"}).replies.size(), 1u);
    ASSERT_TRUE(state.dataset);
  }
  /// The render job of a Render that must be accepted.
  RenderJob job(uint32_t id, const std::string& scene = kHandlerScene) {
    Outcome o = handle(proto::RenderRequest{proto::Encoding::RawRgba8, scene}, id);
    EXPECT_TRUE(o.replies.empty());
    EXPECT_TRUE(o.render.has_value());
    return o.render ? std::move(*o.render) : RenderJob{};
  }
};

/// The one reply of `outcome`, of type M, answering `id`.
template <typename M>
M onlyReply(const Outcome& outcome, uint32_t id) {
  EXPECT_EQ(outcome.replies.size(), 1u);
  if (outcome.replies.size() != 1) return M{};
  EXPECT_EQ(outcome.replies[0].requestId, id);
  const M* m = std::get_if<M>(&outcome.replies[0].message);
  EXPECT_NE(m, nullptr) << "reply is message type "
                        << proto::messageTypeName(proto::messageType(outcome.replies[0].message));
  return m ? *m : M{};
}

/// The error code of `outcome`'s one reply, which must be an Error answering `id` with no job attached.
ErrorCode errorCode(const Outcome& outcome, uint32_t id = 1) {
  EXPECT_FALSE(outcome.render.has_value());
  return onlyReply<proto::Error>(outcome, id).code;
}

TEST_F(MessageHandlerTest, HelloGetsCapabilities) {
  const Outcome o = handle(proto::Hello{1, proto::kMaxVersion, "test"}, 9);
  const auto caps = onlyReply<proto::Capabilities>(o, 9);
  EXPECT_EQ(caps.version, proto::kMaxVersion);  // the highest both speak
  EXPECT_EQ(state.version, proto::kMaxVersion);
  EXPECT_EQ(caps.maxImageSide, 100u);
  EXPECT_EQ(caps.maxMessageBytes, 65536u);
  EXPECT_EQ(caps.maxQueuedPerSession, 1u);
  EXPECT_EQ(caps.encodings, proto::encodingsOf(proto::kMaxVersion));
  EXPECT_FALSE(o.close);
  EXPECT_TRUE(state.greeted);
}

TEST_F(MessageHandlerTest, AVersionOneHelloGetsAVersionOneSessionWithoutJpeg) {
  const auto caps = onlyReply<proto::Capabilities>(handle(proto::Hello{1, 1, "old"}, 9), 9);
  EXPECT_EQ(caps.version, 1u);
  EXPECT_EQ(state.version, 1u);
  EXPECT_EQ(caps.encodings, (std::vector<proto::Encoding>{proto::Encoding::RawRgba8, proto::Encoding::Png,
                                                          proto::Encoding::ZstdRgba8}));
}

TEST_F(MessageHandlerTest, WithoutCoalescingCapabilitiesAllowMoreQueued) {
  config.scheduler.coalesce = false;
  MessageHandler uncoalesced(config, datasets, presets, stats, [] { return json::object(); });
  const auto caps = onlyReply<proto::Capabilities>(uncoalesced.handle(state, proto::Hello{}, 1), 1);
  EXPECT_EQ(caps.maxQueuedPerSession, ServerConfig::kMaxQueuedWithoutCoalescing);
}

TEST_F(MessageHandlerTest, SecondHelloIsUnexpected) {
  greet();
  const Outcome o = handle(proto::Hello{}, 2);
  EXPECT_EQ(errorCode(o, 2), ErrorCode::UnexpectedMessage);
  EXPECT_FALSE(o.close);
  EXPECT_TRUE(state.greeted);
}

TEST_F(MessageHandlerTest, UnsupportedVersionIsRefusedAndCloses) {
  for (const proto::Hello& hello : {proto::Hello{uint16_t(proto::kMaxVersion + 1), uint16_t(proto::kMaxVersion + 2), "future"},
                                    proto::Hello{0, 0, "past"}}) {
    const Outcome o = handle(hello, 4);
    EXPECT_EQ(errorCode(o, 4), ErrorCode::UnsupportedVersion) << hello.client;
    EXPECT_TRUE(o.close) << hello.client;
    EXPECT_FALSE(state.greeted);
  }
}

TEST_F(MessageHandlerTest, AnythingBeforeHelloIsUnexpectedAndTheSessionGoesOn) {
  for (const proto::Message& m : std::vector<proto::Message>{proto::ListDatasets{}, proto::OpenDataset{"sparse"},
                                                             proto::RenderRequest{proto::Encoding::Png, kHandlerScene},
                                                             proto::GetStats{}, proto::Frame{}}) {
    const Outcome o = handle(m, 3);
    EXPECT_EQ(errorCode(o, 3), ErrorCode::UnexpectedMessage) << proto::messageTypeName(proto::messageType(m));
    EXPECT_FALSE(o.close);
  }
  EXPECT_FALSE(state.dataset);
  onlyReply<proto::Capabilities>(handle(proto::Hello{}), 1);  // Hello is still awaited
}

TEST_F(MessageHandlerTest, ListDatasetsNamesTheStores) {
  greet();
  EXPECT_EQ(onlyReply<proto::DatasetList>(handle(proto::ListDatasets{}, 5), 5).names,
            std::vector<std::string>{"sparse"});
}

TEST_F(MessageHandlerTest, OpeningAnUnknownDatasetIsUnknownDataset) {
  greetAndOpen();
  const auto before = state.dataset;
  for (const char* name : {"nope", "../datasets/sparse", "..", ""}) {
    const Outcome o = handle(proto::OpenDataset{name}, 6);
    EXPECT_EQ(errorCode(o, 6), ErrorCode::UnknownDataset) << name;
    EXPECT_FALSE(o.close);
  }
  EXPECT_EQ(state.dataset, before) << "a failed OpenDataset leaves the open dataset as it was";
}

TEST_F(MessageHandlerTest, OpeningADatasetGivesItsInfo) {
  greet();
  const auto info = onlyReply<proto::DatasetInfo>(handle(proto::OpenDataset{"sparse"}, 7), 7);
  EXPECT_EQ(info.name, "sparse");
  const json meta = json::parse(info.metaJson);
  EXPECT_EQ(meta["dims"], json({32, 32, 32}));
  EXPECT_EQ(meta["brick_size"], 16);
  ASSERT_TRUE(state.dataset);
  EXPECT_EQ(state.dataset->name(), "sparse");
}

TEST_F(MessageHandlerTest, RenderBeforeOpenDatasetIsUnexpected) {
  greet();
  EXPECT_EQ(errorCode(handle(proto::RenderRequest{proto::Encoding::Png, kHandlerScene}, 8), 8),
            ErrorCode::UnexpectedMessage);
}

TEST_F(MessageHandlerTest, RenderWithABadSceneIsInvalidScene) {
  greetAndOpen();
  for (const char* scene : {"{not json", "[1, 2]", R"({"size": [64, 0]})", R"({"step": -1})", R"({"colour": 1})",
                            R"({"transfer_function": "/etc/passwd"})"})
    EXPECT_EQ(errorCode(handle(proto::RenderRequest{proto::Encoding::Png, scene}, 9), 9), ErrorCode::InvalidScene)
        << scene;
  EXPECT_EQ(state.outstandingRenders, 0);
}

TEST_F(MessageHandlerTest, RenderWithAnUnknownPresetIsInvalidScene) {
  greetAndOpen();
  const Outcome o = handle(proto::RenderRequest{proto::Encoding::Png, R"({"transfer_function": "no-such-tf"})"}, 10);
  EXPECT_EQ(errorCode(o, 10), ErrorCode::InvalidScene);
  EXPECT_NE(onlyReply<proto::Error>(o, 10).message.find("no-such-tf"), std::string::npos);
}

TEST_F(MessageHandlerTest, RenderAboveTheImageLimitIsLimitExceeded) {
  greetAndOpen();
  EXPECT_EQ(errorCode(handle(proto::RenderRequest{proto::Encoding::Png, R"({"size": [101, 10]})"}, 11), 11),
            ErrorCode::LimitExceeded);
  EXPECT_EQ(errorCode(handle(proto::RenderRequest{proto::Encoding::Png, R"({"size": [10, 101]})"}, 12), 12),
            ErrorCode::LimitExceeded);
  // The limit itself is allowed.
  EXPECT_TRUE(handle(proto::RenderRequest{proto::Encoding::Png, R"({"size": [100, 100]})"}).render.has_value());
}

TEST_F(MessageHandlerTest, AcceptedRenderBecomesAJob) {
  greetAndOpen();
  const RenderJob j = job(13);
  EXPECT_EQ(j.requestId, 13u);
  EXPECT_EQ(j.encoding, proto::Encoding::RawRgba8);
  EXPECT_EQ(j.dataset, state.dataset);
  EXPECT_EQ(j.scene.width, 80);
  EXPECT_EQ(j.scene.height, 64);
  EXPECT_EQ(j.scene.transferFunctionName, "sparse");
  const auto& points = j.scene.transferFunction.points();
  const auto& preset = presets.get("sparse").points();
  ASSERT_EQ(points.size(), preset.size());
  for (size_t i = 0; i < points.size(); ++i)
    EXPECT_TRUE(points[i].x == preset[i].x && points[i].rgba == preset[i].rgba) << "the preset read at start";
  EXPECT_EQ(stats.total(ServerEvent::RenderRequest), 1u);
  EXPECT_EQ(state.outstandingRenders, 0) << "counted once the queue takes it";
}

TEST_F(MessageHandlerTest, GetStatsGivesTheServerStatistics) {
  greetAndOpen();
  job(1);
  const json j = json::parse(onlyReply<proto::Stats>(handle(proto::GetStats{}, 14), 14).json);
  EXPECT_EQ(j["renders"]["requested"], 1);
  EXPECT_EQ(j["sessions"]["active"], 3);
  EXPECT_EQ(j["render_threads"], 2);
  EXPECT_EQ(j["render_busy_s"], json::parse("[1.5, 0.25]")) << "each render thread's busy seconds";
  EXPECT_EQ(j["render_wait_s"], json::parse("[0.5, 2.75]")) << "each render thread's seconds asking for a job";
  ASSERT_EQ(j["datasets"].size(), 1u);
  EXPECT_EQ(j["datasets"][0]["name"], "sparse");
}

TEST_F(MessageHandlerTest, GoodbyeClosesWithoutAReply) {
  Outcome o = handle(proto::Goodbye{});  // before Hello too
  EXPECT_TRUE(o.close);
  EXPECT_TRUE(o.replies.empty());
  greet();
  o = handle(proto::Goodbye{});
  EXPECT_TRUE(o.close);
  EXPECT_TRUE(o.replies.empty());
}

TEST_F(MessageHandlerTest, ServerMessagesFromAClientAreUnexpected) {
  greet();
  for (const proto::Message& m :
       std::vector<proto::Message>{proto::Frame{}, proto::Capabilities{}, proto::DatasetList{}, proto::DatasetInfo{},
                                   proto::Error{}, proto::Stats{}}) {
    const Outcome o = handle(m, 15);
    EXPECT_EQ(errorCode(o, 15), ErrorCode::UnexpectedMessage);
    EXPECT_NE(onlyReply<proto::Error>(o, 15).message.find("sent by servers"), std::string::npos);
    EXPECT_FALSE(o.close);
  }
}

TEST_F(MessageHandlerTest, AQueuedJobIsOutstandingUntilRendered) {
  greetAndOpen();
  RenderJob j = job(16);
  EXPECT_TRUE(handler.submitted(state, 16, Submission{}).replies.empty());
  EXPECT_TRUE(state.awaitingFrames());
  proto::Frame frame;
  frame.width = 80;
  const Outcome o = handler.rendered(state, j, frame);
  EXPECT_EQ(onlyReply<proto::Frame>(o, 16).width, 80u);
  EXPECT_FALSE(state.awaitingFrames());
  EXPECT_EQ(stats.total(ServerEvent::Frame), 1u);
  EXPECT_EQ(stats.total(ServerEvent::RenderError), 0u);
}

TEST_F(MessageHandlerTest, AFailedRenderIsAnsweredWithItsErrorAndCounted) {
  greetAndOpen();
  RenderJob j = job(17);
  handler.submitted(state, 17, Submission{});
  const Outcome o = handler.rendered(state, j, proto::Error{ErrorCode::Internal, "render failed: test"});
  EXPECT_EQ(errorCode(o, 17), ErrorCode::Internal);
  EXPECT_EQ(stats.total(ServerEvent::RenderError), 1u);
  EXPECT_EQ(stats.total(ServerEvent::Frame), 0u);
  EXPECT_EQ(state.outstandingRenders, 0);
}

TEST_F(MessageHandlerTest, AReplacedJobIsAnsweredSuperseded) {
  greetAndOpen();
  handler.submitted(state, 18, Submission{});
  Submission second;
  second.replaced = job(18);
  job(19);
  const Outcome o = handler.submitted(state, 19, std::move(second));
  const auto error = onlyReply<proto::Error>(o, 18);  // the reply carries the replaced request's id
  EXPECT_EQ(error.code, ErrorCode::Superseded);
  EXPECT_NE(error.message.find("replaced by request 19"), std::string::npos) << error.message;
  EXPECT_FALSE(o.close);
  EXPECT_EQ(state.outstandingRenders, 1) << "one waits: the newest";
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 1u);
}

// The exact frame after a provisional one was queued by the render thread: replacing it answers nothing, and its
// Frame neither counts as a render answered nor as outstanding.
TEST_F(MessageHandlerTest, ARefinementIsReplacedSilentlyAndNotCountedOutstanding) {
  greetAndOpen();
  RenderJob first = job(30);
  handler.submitted(state, 30, Submission{});
  handler.rendered(state, first, proto::Frame{});  // the provisional frame answers request 30
  EXPECT_EQ(state.outstandingRenders, 0);
  RenderJob refinement = first;
  refinement.refinement = true;
  const Outcome exact = handler.rendered(state, refinement, proto::Frame{});
  EXPECT_EQ(onlyReply<proto::Frame>(exact, 30).width, 0u);
  EXPECT_EQ(state.outstandingRenders, 0);
  EXPECT_EQ(stats.total(ServerEvent::Refined), 1u);

  Submission second;
  second.replaced = refinement;
  job(31);
  EXPECT_TRUE(handler.submitted(state, 31, std::move(second)).replies.empty());
  EXPECT_EQ(state.outstandingRenders, 1) << "the new request waits";
  EXPECT_EQ(stats.total(ServerEvent::Superseded), 0u);
}

// Each Render carries the session's previous camera of the same dataset, for paging ahead of a drag.
TEST_F(MessageHandlerTest, ARawFrameAboveTheMessageLimitIsRefusedBeforeItIsQueued) {
  greetAndOpen();
  // 100x100 raw is 40 000 bytes of pixels: within the 64 KiB limit; a zstd or png frame is checked once encoded.
  EXPECT_EQ(job(1, R"({"size": [100, 100]})").maxBodyBytes, 65536u);
  ServerConfig small = config;
  small.maxMessageBytes = 32768;
  MessageHandler tight{small, datasets, presets, stats, [this] { return stats.toJson(ServerStats::Gauges{}); }};
  ConnectionState session;
  tight.handle(session, proto::Hello{1, 1, "test"}, 1);
  tight.handle(session, proto::OpenDataset{"sparse"}, 2);
  const Outcome o =
      tight.handle(session, proto::RenderRequest{proto::Encoding::RawRgba8, R"({"size": [100, 100]})"}, 3);
  EXPECT_FALSE(o.render.has_value());
  const proto::Error e = onlyReply<proto::Error>(o, 3);
  EXPECT_EQ(e.code, proto::ErrorCode::LimitExceeded);
  EXPECT_NE(e.message.find("32768"), std::string::npos) << e.message;
  EXPECT_TRUE(tight.handle(session, proto::RenderRequest{proto::Encoding::Png, R"({"size": [100, 100]})"}, 4)
                  .render.has_value());
}

TEST_F(MessageHandlerTest, ARenderCarriesThePreviousCamera) {
  greetAndOpen();
  EXPECT_FALSE(job(40).previousCamera);
  const RenderJob second = job(41);
  ASSERT_TRUE(second.previousCamera);
  EXPECT_EQ(second.previousCamera->azimuth, second.scene.camera.azimuth);
}

TEST_F(MessageHandlerTest, AFullQueueIsLimitExceededAndAStoppedOneIsSilent) {
  greetAndOpen();
  Submission full;
  full.result = Submission::Result::Full;
  EXPECT_EQ(errorCode(handler.submitted(state, 20, std::move(full)), 20), ErrorCode::LimitExceeded);
  Submission stopped;
  stopped.result = Submission::Result::Stopped;
  const Outcome o = handler.submitted(state, 21, std::move(stopped));
  EXPECT_TRUE(o.replies.empty()) << "ShuttingDown ends the session; the request gets no other reply";
  EXPECT_EQ(state.outstandingRenders, 0);
}

TEST_F(MessageHandlerTest, UndecodableMessagesCloseOnlyWhenTheirCodeSaysSo) {
  const Outcome malformed =
      MessageHandler::failed(std::make_exception_ptr(proto::ProtocolError(ErrorCode::Malformed, "bad")), 22);
  EXPECT_EQ(errorCode(malformed, 22), ErrorCode::Malformed);
  EXPECT_FALSE(malformed.close);
  const Outcome tooLarge =
      MessageHandler::failed(std::make_exception_ptr(proto::ProtocolError(ErrorCode::TooLarge, "big")), 0);
  EXPECT_EQ(errorCode(tooLarge, 0), ErrorCode::TooLarge);
  EXPECT_TRUE(tooLarge.close);
}

}  // namespace
}  // namespace voxbrick::server
