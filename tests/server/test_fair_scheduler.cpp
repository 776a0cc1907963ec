// Fair under a crowd: the render queue's shares by measured time and by class, the budget that follows the load,
// the threads kept for dragging sessions, Busy for batch work over capacity and one render for identical frames
// (the null frame source: what is tested is the queue); the quotas on their own; and admission against the real
// `voxbrick serve` process (Busy at Hello beyond capacity, the quotas of server.toml).
#include <gtest/gtest.h>

#include <algorithm>
#include <condition_variable>
#include <fstream>
#include <atomic>
#include <functional>
#include <mutex>
#include <thread>

#include <nlohmann/json.hpp>

#include "ServerErrorOf.h"
#include "ServerProcess.h"
#include "TestDatasets.h"
#include "client/Client.h"
#include "image/FrameImage.h"
#include "render/core/TransferFunctionPresets.h"
#include "render/engine/NullFrameSource.h"
#include "server/Datasets.h"
#include "server/Quotas.h"
#include "server/RenderScheduler.h"

namespace voxbrick::server {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

/// Collects the replies a scheduler delivers to one session, with the width of each frame.
class CountingSink : public RenderScheduler::Sink, public std::enable_shared_from_this<CountingSink> {
 public:
  bool wantsReplies() const override { return true; }
  void rendered(RenderJob job, proto::Message reply) override {
    {
      std::lock_guard lock(mMutex);
      mReplies.emplace_back(job.requestId, std::move(reply));
      mToEncode.push_back(job.stillToEncode);
    }
    mChanged.notify_all();
  }
  /// Each reply's RenderJob::stillToEncode, in order.
  std::vector<std::optional<int>> toEncode() {
    std::lock_guard lock(mMutex);
    return mToEncode;
  }
  std::vector<std::pair<uint32_t, proto::Message>> await(size_t count, std::chrono::seconds limit = 60s) {
    std::unique_lock lock(mMutex);
    mChanged.wait_for(lock, limit, [&] { return mReplies.size() >= count; });
    return mReplies;
  }
  size_t count() {
    std::lock_guard lock(mMutex);
    return mReplies.size();
  }

 private:
  std::mutex mMutex;
  std::condition_variable mChanged;
  std::vector<std::pair<uint32_t, proto::Message>> mReplies;
  std::vector<std::optional<int>> mToEncode;
};

json statsOf(const proto::Message& m) {
  const auto* frame = std::get_if<proto::Frame>(&m);
  return frame ? json::parse(frame->statsJson) : json();
}

class FairSchedulerTest : public ::testing::Test {
 protected:
  DatasetRegistry datasets{test::testDatasets(), size_t(16) << 20};
  render::TransferFunctionPresets presets = render::TransferFunctionPresets::load(test::shippedPresets());

  RenderJob job(uint32_t id, int width, const std::string& extra = "") {
    RenderJob j;
    j.requestId = id;
    j.encoding = proto::Encoding::RawRgba8;
    j.dataset = datasets.open("sparse");
    j.scene = render::Scene::fromJson(R"({"camera": {"orbit": [40, 25, 2.2]}, "transfer_function": "sparse", )" +
                                          extra + R"("size": [)" + std::to_string(width) + ", 8]}",
                                      "scene", presets);
    j.received = std::chrono::steady_clock::now();
    return j;
  }
  /// A scheduler of `threads` null sources; a frame takes `drawTime` plus `perPixel` for each pixel.
  static std::unique_ptr<RenderScheduler> scheduler(int threads, SchedulerConfig config,
                                                    std::chrono::microseconds drawTime,
                                                    std::chrono::nanoseconds perPixel,
                                                    std::vector<render::NullFrameSource*>* sources = nullptr) {
    std::vector<std::unique_ptr<render::FrameSource>> made;
    for (int i = 0; i < threads; ++i) {
      auto source = std::make_unique<render::NullFrameSource>(drawTime, 1000, perPixel);
      if (sources) sources->push_back(source.get());
      made.push_back(std::move(source));
    }
    return std::make_unique<RenderScheduler>(std::move(made), config);
  }
};

// A session that floods (64 jobs waiting, each four times as costly) gets no more render time than one asking
// cheap frames: shares are of measured milliseconds, not of frames. Turn-taking by frames would draw them 1:1.
TEST_F(FairSchedulerTest, ASessionThatFloodsGetsNoMoreThanItsShareOfTime) {
  std::vector<render::NullFrameSource*> sources;
  auto s = scheduler(1, {.coalesce = false}, 0us, 25us, &sources);  // width 32: 6.4 ms, width 8: 1.6 ms
  auto heavy = std::make_shared<CountingSink>(), light = std::make_shared<CountingSink>();
  for (uint32_t i = 0; i < 64; ++i) s->submit(heavy, job(i, 32));
  for (uint32_t i = 0; i < 64; ++i) s->submit(light, job(100 + i, 8));
  s->start();
  light->await(40);
  s->stop();
  const std::vector<int> widths = sources[0]->widthsDrawn();
  ASSERT_GE(widths.size(), 40u);
  const auto first = std::vector<int>(widths.begin(), widths.begin() + 40);
  const auto heavyFrames = std::count(first.begin(), first.end(), 32), lightFrames = std::count(first.begin(), first.end(), 8);
  EXPECT_GE(lightFrames, 3 * heavyFrames) << heavyFrames << " heavy and " << lightFrames << " light of the first 40";
  EXPECT_GE(heavyFrames, 4) << "the heavy session still gets its share";
}

// A cold thread's one-time work (the renderer made for the dataset: half a second for an atlas on llvmpipe) is no
// session's: the session whose frame happened to set it off is charged the frame alone and keeps taking turns with
// the sessions that queued meanwhile. Charged the warm-up, it would wait until the other had drawn 200 frames (400 ms
// of 2 ms frames) before its next one.
TEST_F(FairSchedulerTest, AColdThreadsWarmUpIsChargedToNoSession) {
  std::vector<render::NullFrameSource*> sources;
  // 2 ms a frame; each request drawn (a session's identical requests would otherwise share one render).
  auto s = scheduler(1, {.coalesce = false, .shareFrames = false}, 2000us, 0ns, &sources);
  sources[0]->warmUpNextFrame(400ms);
  auto first = std::make_shared<CountingSink>(), second = std::make_shared<CountingSink>();
  s->submit(first, job(0, 8));
  s->start();
  std::this_thread::sleep_for(100ms);  // the first frame is warming the thread up: both sessions queue meanwhile
  for (uint32_t i = 1; i <= 40; ++i) {
    s->submit(first, job(i, 8));
    s->submit(second, job(100 + i, 9));
  }
  second->await(20);
  first->await(21);
  s->stop();
  ASSERT_GE(statsOf(first->await(1)[0].second)["ms"]["warmup"].get<double>(), 390.0) << "the frame says it warmed up";
  const std::vector<int> widths = sources[0]->widthsDrawn();
  ASSERT_GE(widths.size(), 41u);
  const auto next = std::vector<int>(widths.begin() + 1, widths.begin() + 41);
  const auto firstFrames = std::count(next.begin(), next.end(), 8);
  EXPECT_GE(firstFrames, 15) << "the session that warmed the thread up drew " << firstFrames << " of the next 40";
  EXPECT_GE(40 - firstFrames, 15);
}

// Each render thread's time drawing and asking for work counts as it goes: a thread that waits long counts its wait
// before the wait ends, and the figures only grow; drawing moves time from waiting to busy.
TEST_F(FairSchedulerTest, TheThreadsTimeDrawingAndWaitingCountsAsItGoes) {
  auto s = scheduler(1, {.coalesce = false}, 20000us, 0ns);  // 20 ms a frame
  s->start();
  std::this_thread::sleep_for(60ms);
  const double waited = s->deviceWaitMs().at(0);
  EXPECT_GE(waited, 40.0) << "a wait in progress counts";
  EXPECT_EQ(s->deviceBusyMs().at(0), 0.0) << "nothing drawn yet";
  std::vector<std::shared_ptr<CountingSink>> sinks;  // three sessions, a frame each
  for (uint32_t i = 0; i < 3; ++i)  // three frames of their own (a frame asked alike would be drawn once for all)
    s->submit(sinks.emplace_back(std::make_shared<CountingSink>()), job(i, 8 + int(i)));
  for (const auto& sink : sinks) sink->await(1);
  const double busy = s->deviceBusyMs().at(0), waitedAfter = s->deviceWaitMs().at(0);
  s->stop();
  EXPECT_GE(busy, 3 * 18.0) << "three frames of 20 ms";
  EXPECT_GE(waitedAfter, waited) << "the figure only grows";
}

// With every class waiting, a moving camera's frames take most of the thread, a resting camera's exact frames
// their share after them, and batch work the least, never nothing.
TEST_F(FairSchedulerTest, ClassesAreServedInteractiveThenStillThenBatchByWeight) {
  std::vector<render::NullFrameSource*> sources;
  auto s = scheduler(1, {.coalesce = false}, 2ms, 0ns, &sources);
  auto batch = std::make_shared<CountingSink>(), still = std::make_shared<CountingSink>(),
       moving = std::make_shared<CountingSink>();
  for (uint32_t i = 0; i < 60; ++i) s->submit(batch, job(i, 30, R"("batch": true, )"));
  for (uint32_t i = 0; i < 60; ++i) s->submit(still, job(100 + i, 20));
  for (uint32_t i = 0; i < 60; ++i) s->submit(moving, job(200 + i, 10, R"("interactive": true, )"));
  s->start();
  moving->await(38);
  s->stop();
  const std::vector<int> widths = sources[0]->widthsDrawn();
  ASSERT_GE(widths.size(), 40u);
  const auto first = std::vector<int>(widths.begin(), widths.begin() + 40);
  const auto interactive = std::count(first.begin(), first.end(), 10), exact = std::count(first.begin(), first.end(), 20),
             batchFrames = std::count(first.begin(), first.end(), 30);
  // Weights 16, 3, 1 of equal frames: 32, 6 and 2 of 40.
  EXPECT_GE(interactive, 28) << interactive << " interactive, " << exact << " still, " << batchFrames << " batch";
  EXPECT_GE(exact, 3);
  EXPECT_GE(batchFrames, 1) << "batch work is served last, not never";
  EXPECT_LT(batchFrames, exact);
  EXPECT_EQ(first.front(), 10) << "the first frame drawn is the moving camera's";
}

// Quality yields before latency: with eight sessions dragging on two threads at 10 frames a second each, a frame's
// budget is 2 * 1000 / (10 * 8) = 25 ms, not the 100 ms its scene asks; alone, a session keeps its own.
TEST_F(FairSchedulerTest, TheInteractiveBudgetFollowsTheNumberOfSessionsDragging) {
  auto s = scheduler(2, {}, 0us, 0ns);
  std::vector<std::shared_ptr<CountingSink>> sinks;
  for (int i = 0; i < 8; ++i) sinks.push_back(std::make_shared<CountingSink>());
  for (int i = 0; i < 8; ++i) s->submit(sinks[size_t(i)], job(uint32_t(i), 16, R"("interactive": true, "time_budget_ms": 100, )"));
  s->start();
  const auto replies = sinks[0]->await(1);
  ASSERT_FALSE(replies.empty());
  const json stats = statsOf(replies[0].second);
  ASSERT_TRUE(stats.contains("load")) << stats.dump();
  EXPECT_DOUBLE_EQ(stats["load"]["time_budget_ms"].get<double>(), 25);
  EXPECT_DOUBLE_EQ(stats["load"]["requested_budget_ms"].get<double>(), 100);
  EXPECT_EQ(stats["load"]["jpeg_quality"].get<int>(), 70);
  EXPECT_EQ(stats["class"], "interactive");
  s->stop();

  auto alone = scheduler(2, {}, 0us, 0ns);
  auto one = std::make_shared<CountingSink>();
  alone->submit(one, job(1, 16, R"("interactive": true, "time_budget_ms": 100, )"));
  alone->start();
  const json own = statsOf(one->await(1).at(0).second);
  EXPECT_FALSE(own.contains("load")) << "alone, nothing is cut: " << own.dump();
  alone->stop();
}

// The measured capacity counts what a moving frame costs the render threads in all: here each of 20 sessions drags one
// frame (10 ms) and gets the exact frame when its camera rests (10 ms more), so a moving frame costs 20 ms, and one
// thread keeps 1000 / (5 × 20) = 10 sessions at 5 frames a second; counting the moving frames alone it said 20.
TEST_F(FairSchedulerTest, TheCapacityCountsWhatAMovingFrameCostsInAll) {
  // The 20 start dragging before anything is measured: no cold bound for them.
  auto s = scheduler(1, {.coldInteractiveSessionsPerThread = 0, .shareFrames = false}, 10000us, 0ns);
  EXPECT_EQ(s->interactiveCapacity(), 0u) << "nothing measured yet: no limit";
  std::vector<std::shared_ptr<CountingSink>> sinks;
  for (uint32_t i = 0; i < 20; ++i) {
    sinks.push_back(std::make_shared<CountingSink>());
    s->submit(sinks.back(), job(i, 16, R"("interactive": true, )"));
  }
  s->start();
  for (const auto& sink : sinks) ASSERT_EQ(sink->await(2).size(), 2u) << "the moving frame, then the exact one";
  const size_t capacity = s->interactiveCapacity();
  s->stop();
  EXPECT_GE(capacity, 8u);
  EXPECT_LE(capacity, 12u);
}

// The last frame of a drag refused Busy (a still Render on release, served as the drag's last) is no cost of the drags
// the threads keep: a crowd whose drags are refused would otherwise shrink the capacity, be refused the more, and
// shrink it again (80 clients dragging and letting go took it from 26 to 7 on two threads). Here 16 refused drags'
// last frames beside one session's 20 moving frames, each 10 ms: the capacity 0.9 x 1000 / (5 x 10) = 18, not 10.
TEST_F(FairSchedulerTest, ARefusedDragsLastFrameIsNoCostOfTheDragsKept) {
  auto s = scheduler(1, {.coldInteractiveSessionsPerThread = 1, .shareFrames = false}, 10000us, 0ns);
  auto a = std::make_shared<CountingSink>();
  ASSERT_EQ(s->submit(a, job(1, 16, R"("interactive": true, )")).result, Submission::Result::Queued);
  std::vector<std::shared_ptr<CountingSink>> refused;
  for (uint32_t i = 0; i < 16; ++i) {
    refused.push_back(std::make_shared<CountingSink>());
    ASSERT_EQ(s->submit(refused.back(), job(100 + i, 16, R"("interactive": true, )")).result, Submission::Result::Busy);
    ASSERT_EQ(s->submit(refused.back(), job(200 + i, 16)).result, Submission::Result::Queued) << "released";
  }
  s->start();
  for (const auto& sink : refused) {
    ASSERT_EQ(sink->await(1).size(), 1u);
    EXPECT_EQ(statsOf(sink->await(1)[0].second)["class"], "interactive") << "served as the drag's last";
  }
  for (uint32_t i = 0; i < 20; ++i) {
    const size_t before = a->count();
    ASSERT_EQ(s->submit(a, job(2 + i, 16, R"("interactive": true, )")).result, Submission::Result::Queued);
    a->await(before + 1);
  }
  const size_t capacity = s->interactiveCapacity();
  s->stop();
  EXPECT_GE(capacity, 15u);
  EXPECT_LE(capacity, 18u);
}

// The thread's time after a frame counts in what the frame costs: here each moving frame (10 ms) is followed by 20 ms
// of paging ahead for the camera the drag would reach next, and by its exact frame (10 ms), so that a moving frame
// costs the thread 40 ms, and one thread keeps 1000 / (5 x 40) = 5 sessions at 5 frames a second; counting the
// drawing alone it said 10 (on an H200 the capacity so counted let in 41 sessions that got 3 to 4.5 frames a second).
TEST_F(FairSchedulerTest, TheCapacityCountsTheThreadsTimeAfterEachFrame) {
  std::vector<render::NullFrameSource*> sources;
  auto s = scheduler(1, {.coldInteractiveSessionsPerThread = 0, .shareFrames = false}, 10000us, 0ns, &sources);
  sources[0]->prefetchTakes(20ms);
  const render::CameraSpec before =
      render::Scene::fromJson(R"({"camera": {"orbit": [38, 25, 2.2]}, "transfer_function": "sparse"})", "scene",
                              presets)
          .camera;
  std::vector<std::shared_ptr<CountingSink>> sinks;
  for (uint32_t i = 0; i < 20; ++i) {
    sinks.push_back(std::make_shared<CountingSink>());
    RenderJob moving = job(i, 16, R"("interactive": true, )");
    moving.previousCamera = before;  // a drag: the camera it reaches next is paged ahead after the frame
    s->submit(sinks.back(), std::move(moving));
  }
  s->start();
  for (const auto& sink : sinks) ASSERT_EQ(sink->await(2).size(), 2u) << "the moving frame, then the exact one";
  const size_t capacity = s->interactiveCapacity();
  s->stop();
  EXPECT_EQ(sources[0]->prefetches(), 20u) << "each moving frame paged ahead";
  EXPECT_GE(capacity, 3u);
  EXPECT_LE(capacity, 6u) << "the 20 ms after each moving frame were not counted";
}

// A session's first moving camera is admitted only while fewer sessions drag than the capacity: beyond it the Render
// is answered Busy with a retry hint and nothing is queued; a session already dragging drags on, and a still frame is
// no drag (right after the refused one, it is the drag's last, which a viewer waits for on release). Once nobody
// drags, the late session may.
TEST_F(FairSchedulerTest, AFirstMoveBeyondCapacityIsBusyAndTheSessionsDraggingDragOn) {
  auto s = scheduler(1, {.maxInteractiveSessions = 2}, 0us, 0ns);
  auto a = std::make_shared<CountingSink>(), b = std::make_shared<CountingSink>(),
       late = std::make_shared<CountingSink>();
  EXPECT_EQ(s->submit(a, job(1, 16, R"("interactive": true, )")).result, Submission::Result::Queued);
  EXPECT_EQ(s->submit(b, job(2, 17, R"("interactive": true, )")).result, Submission::Result::Queued);
  ASSERT_TRUE(s->refuseNewSession()) << "a new session is refused at Hello too";
  const Submission refused = s->submit(late, job(3, 18, R"("interactive": true, )"));
  ASSERT_EQ(refused.result, Submission::Result::Busy);
  EXPECT_EQ(refused.retryAfterMs, RenderScheduler::kLineStepMs) << "the first in line";
  EXPECT_NE(refused.why.find("over capacity: 2 sessions are dragging"), std::string::npos) << refused.why;
  const auto atHello = s->refuseNewSession();
  ASSERT_TRUE(atHello);
  EXPECT_EQ(atHello->retryAfterMs, RenderScheduler::kOverCapacityHintMs) << "no place at Hello";
  EXPECT_FALSE(refused.quota);
  EXPECT_EQ(s->busyDrags(), 1u);
  EXPECT_EQ(s->submit(late, job(4, 18)).result, Submission::Result::Queued) << "a still frame is no drag";
  EXPECT_EQ(s->submit(a, job(5, 16, R"("interactive": true, )")).result, Submission::Result::Queued)
      << "a session dragging drags on";
  s->start();
  ASSERT_EQ(late->await(1).size(), 1u);
  EXPECT_EQ(statsOf(late->await(1)[0].second)["class"], "interactive")
      << "a still frame right after a drag told Busy ends it, as a viewer's release does: served as a drag's last";
  EXPECT_EQ(a->await(1).size(), 1u);
  std::this_thread::sleep_for(RenderScheduler::kInteractiveWindow + 200ms);  // nobody drags any more
  EXPECT_EQ(s->submit(late, job(6, 18, R"("interactive": true, )")).result, Submission::Result::Queued);
  EXPECT_EQ(s->busyDrags(), 1u);
  s->stop();
}

// Room that opens goes to the sessions refused, in the order they were refused, not to whoever asks first: a session
// asking while those ahead of it hold their places is Busy. A place is held while its session asks again within its
// hint and kLineGrace, and given up by a still Render (the drag released).
// Before the line, a session refused waited out its 2 s hint while one that came later, or came back, took the room.
TEST_F(FairSchedulerTest, RoomThatOpensGoesToTheSessionsInLineInTurn) {
  auto s = scheduler(1, {.maxInteractiveSessions = 1}, 0us, 0ns);
  const std::string moving = R"("interactive": true, )";
  auto a = std::make_shared<CountingSink>(), b = std::make_shared<CountingSink>(), c = std::make_shared<CountingSink>(),
       d = std::make_shared<CountingSink>();
  ASSERT_EQ(s->submit(a, job(1, 16, moving)).result, Submission::Result::Queued);
  std::vector<uint32_t> hints;
  for (const auto& sink : {b, c, d}) {
    const Submission out = s->submit(sink, job(2, 16, moving));
    ASSERT_EQ(out.result, Submission::Result::Busy);
    hints.push_back(out.retryAfterMs);
  }
  const uint32_t step = RenderScheduler::kLineStepMs;
  EXPECT_EQ(hints, (std::vector<uint32_t>{step, step, step}));
  EXPECT_EQ(s->waitingToDrag(), 3u);
  // Asking again keeps the place (and its hint).
  std::this_thread::sleep_for(600ms);
  for (const auto& sink : {d, c, b}) EXPECT_EQ(s->submit(sink, job(3, 16, moving)).result, Submission::Result::Busy);
  std::this_thread::sleep_for(RenderScheduler::kInteractiveWindow - 600ms + 200ms);  // a's drag is over: room for one
  ASSERT_EQ(s->interactiveSessions(), 0u);
  auto newcomer = std::make_shared<CountingSink>();
  const Submission late = s->submit(newcomer, job(4, 16, moving));
  EXPECT_EQ(late.result, Submission::Result::Busy) << "a newcomer goes behind the line";
  EXPECT_NE(late.why.find("3 wait ahead of this one"), std::string::npos) << late.why;
  const Submission third = s->submit(d, job(5, 16, moving));
  EXPECT_EQ(third.result, Submission::Result::Busy) << "the room is the first's";
  EXPECT_EQ(third.retryAfterMs, step);
  EXPECT_EQ(s->submit(c, job(6, 16, moving)).result, Submission::Result::Busy);
  EXPECT_EQ(s->submit(b, job(7, 16, moving)).result, Submission::Result::Queued) << "the first in line drags";
  EXPECT_EQ(s->waitingToDrag(), 3u) << "c, d and the newcomer";
  EXPECT_EQ(s->submit(d, job(8, 16)).result, Submission::Result::Queued);
  EXPECT_EQ(s->waitingToDrag(), 2u) << "a still Render gives the place up";
  // A place not asked for within its hint and the grace lapses.
  std::this_thread::sleep_for(std::chrono::milliseconds(step) + RenderScheduler::kLineGrace + 200ms);
  EXPECT_EQ(s->waitingToDrag(), 0u);
  EXPECT_EQ(s->busyDrags(), 9u);
  s->stop();
}

// A still Render ends a session's drag at once (a viewer's release; it is still served as the drag's last frame): its
// room goes to the next in line then, not a second later, as it did while every session counted as dragging for a
// second after its last move.
TEST_F(FairSchedulerTest, AReleaseEndsTheDragAndItsRoomGoesToTheNextInLine) {
  auto s = scheduler(1, {.maxInteractiveSessions = 1}, 0us, 0ns);
  auto a = std::make_shared<CountingSink>(), b = std::make_shared<CountingSink>();
  ASSERT_EQ(s->submit(a, job(1, 16, R"("interactive": true, )")).result, Submission::Result::Queued);
  ASSERT_EQ(s->submit(b, job(2, 16, R"("interactive": true, )")).result, Submission::Result::Busy);
  ASSERT_EQ(s->submit(a, job(3, 16)).result, Submission::Result::Queued) << "a's release";
  EXPECT_EQ(s->interactiveSessions(), 0u);
  EXPECT_EQ(s->submit(b, job(4, 16, R"("interactive": true, )")).result, Submission::Result::Queued);
  s->start();
  const auto replies = a->await(1);  // the release replaced the moving camera waiting (latest wins)
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].first, 3u);
  EXPECT_EQ(statsOf(replies[0].second)["class"], "interactive") << "the release's frame is the drag's last";
  s->stop();
}

// A drag that has held its room for a whole turn (interactive_turn_s) without letting go, while others wait in line,
// is told Busy at its next move and goes to the back of the line; its room goes to the first in line. Without anyone
// due in line it drags on past its turn. Before, a session (a script) dragging without end kept its room for ever: 16
// viewer tabs that came a second after 64 dragging TCP clients got no frame in their 10 s drags.
TEST_F(FairSchedulerTest, ADragThatHeldItsRoomAWholeTurnGoesToTheBackOfTheLine) {
  auto s = scheduler(1, {.maxInteractiveSessions = 1, .interactiveTurnS = 0.5}, 0us, 0ns);
  const std::string moving = R"("interactive": true, )";
  auto a = std::make_shared<CountingSink>(), b = std::make_shared<CountingSink>();
  s->start();
  uint32_t id = 1;
  // Alone, a drags past its turn: each move's frame comes (a newer move replaces the exact frame of the one before).
  for (int i = 0; i < 8; ++i) {
    if (i > 0) std::this_thread::sleep_for(100ms);
    ASSERT_EQ(s->submit(a, job(id++, 16, moving)).result, Submission::Result::Queued) << i;
    ASSERT_EQ(a->await(size_t(i + 1)).size(), size_t(i + 1));
  }
  ASSERT_EQ(s->submit(b, job(id++, 16, moving)).result, Submission::Result::Busy);
  const Submission over = s->submit(a, job(id++, 16, moving));
  const size_t atTurnEnd = a->count();  // 8, or 9 on a machine so slow that the last move's exact frame came first
  ASSERT_EQ(over.result, Submission::Result::Busy) << "its turn is over: b waits";
  EXPECT_NE(over.why.find("turn to drag is over"), std::string::npos) << over.why;
  EXPECT_EQ(over.retryAfterMs, RenderScheduler::kLineStepMs);
  EXPECT_EQ(s->turnsEnded(), 1u);
  EXPECT_EQ(s->interactiveSessions(), 0u) << "a's drag ended";
  EXPECT_EQ(s->submit(b, job(id++, 16, moving)).result, Submission::Result::Queued) << "the room is b's";
  const Submission behind = s->submit(a, job(id++, 16, moving));
  EXPECT_EQ(behind.result, Submission::Result::Busy) << "a waits in line now";
  EXPECT_EQ(s->waitingToDrag(), 1u);
  // Its drag is paused: no exact frame of its last camera (which would come within 150 ms of the camera's rest).
  std::this_thread::sleep_for(400ms);
  EXPECT_EQ(a->count(), atTurnEnd);
  // Its release while it waits is its drag's last frame.
  ASSERT_EQ(s->submit(a, job(id++, 16)).result, Submission::Result::Queued);
  const auto replies = a->await(atTurnEnd + 1);
  ASSERT_EQ(replies.size(), atTurnEnd + 1);
  EXPECT_EQ(statsOf(replies.back().second)["class"], "interactive");
  s->stop();
}

// The hint grows a step for each kPlacesAStep places in line, to kLineMaxHintMs; room is held only for those ahead due
// back soon: one told to come back in a second does not keep it idle meanwhile (with hints of up to 2 s and every
// place held, 80 clients dragging and letting go drew a third of the frames they drew without the line).
TEST_F(FairSchedulerTest, TheHintGrowsWithThePlaceAndRoomWaitsOnlyForThoseDueSoon) {
  auto s = scheduler(1, {.maxInteractiveSessions = 1}, 0us, 0ns);
  const std::string moving = R"("interactive": true, )";
  ASSERT_EQ(s->submit(std::make_shared<CountingSink>(), job(1, 16, moving)).result, Submission::Result::Queued);
  const auto dragged = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(800ms);  // the line forms late in the drag: its last is due back after the drag ends
  std::vector<std::shared_ptr<CountingSink>> line;
  std::vector<uint32_t> hints;
  for (uint32_t i = 0; i < 26; ++i) {
    line.push_back(std::make_shared<CountingSink>());
    const Submission out = s->submit(line.back(), job(10 + i, 16, moving));
    ASSERT_EQ(out.result, Submission::Result::Busy);
    hints.push_back(out.retryAfterMs);
  }
  const uint32_t step = RenderScheduler::kLineStepMs;
  for (size_t i = 0; i < hints.size(); ++i)
    EXPECT_EQ(hints[i],
              std::min(step * uint32_t(1 + i / RenderScheduler::kPlacesAStep), RenderScheduler::kLineMaxHintMs))
        << i;
  EXPECT_EQ(hints.back(), RenderScheduler::kLineMaxHintMs);
  // All but the last release their drags: it alone waits, due back a second after it was refused.
  for (uint32_t i = 0; i + 1 < line.size(); ++i)
    ASSERT_EQ(s->submit(line[i], job(40 + i, 16)).result, Submission::Result::Queued);
  ASSERT_EQ(s->waitingToDrag(), 1u);
  std::this_thread::sleep_until(dragged + RenderScheduler::kInteractiveWindow + 200ms);  // room, the last not due yet
  auto newcomer = std::make_shared<CountingSink>();
  EXPECT_EQ(s->submit(newcomer, job(70, 16, moving)).result, Submission::Result::Queued)
      << "the room is not held for one due back later";
  const Submission back = s->submit(line.back(), job(71, 16, moving));
  EXPECT_EQ(back.result, Submission::Result::Busy);
  EXPECT_EQ(back.retryAfterMs, step) << "now first in line";
  EXPECT_EQ(s->waitingToDrag(), 1u) << "its place kept";
  s->stop();
}

// A crowd that comes before the capacity is measured (a cold server; every viewer reconnecting after a restart) is
// not all let in: cold_interactive_sessions_per_thread sessions a thread drag, the others' first moves are Busy with
// a hint of when the capacity will be measured. Before this bound, 80 clients dragging at once on two threads were all
// taken and got 2 frames a second each, where the measured capacity was 37 (llvmpipe, 128x128).
TEST_F(FairSchedulerTest, BeforeTheCapacityIsMeasuredAFewSessionsAThreadMayDrag) {
  auto s = scheduler(2, {.coldInteractiveSessionsPerThread = 3}, 0us, 0ns);
  std::vector<std::shared_ptr<CountingSink>> sinks;
  size_t queued = 0, busy = 0;
  for (uint32_t i = 0; i < 20; ++i) {
    sinks.push_back(std::make_shared<CountingSink>());
    const Submission out = s->submit(sinks.back(), job(i, 16 + int(i), R"("interactive": true, )"));
    if (out.result == Submission::Result::Queued) ++queued;
    if (out.result == Submission::Result::Busy) {
      ++busy;
      // When the frames of those dragging will have measured it: 16 frames at the 50 ms predicted before any, over
      // the 2 threads.
      EXPECT_EQ(out.retryAfterMs, 400u);
      EXPECT_NE(out.why.find("measuring its capacity: 6 sessions are dragging"), std::string::npos) << out.why;
    }
  }
  EXPECT_EQ(queued, 6u) << "3 sessions for each of 2 threads";
  EXPECT_EQ(busy, 14u);
  const auto atHello = s->refuseNewSession();
  ASSERT_TRUE(atHello);
  EXPECT_EQ(atHello->retryAfterMs, 400u);
  s->stop();

  auto unbounded = scheduler(2, {.coldInteractiveSessionsPerThread = 0}, 0us, 0ns);
  for (uint32_t i = 0; i < 20; ++i)
    EXPECT_EQ(unbounded->submit(std::make_shared<CountingSink>(), job(i, 16, R"("interactive": true, )")).result,
              Submission::Result::Queued);
  unbounded->stop();
}

// Long still frames never hold every thread while a session drags: its next frame starts at once on the thread
// kept for it, instead of waiting for a still frame to finish.
TEST_F(FairSchedulerTest, StillFramesLeaveAThreadToADraggingSession) {
  auto s = scheduler(2, {}, 0us, 50us);  // width 60: 24 ms a frame, width 1000: 400 ms
  auto moving = std::make_shared<CountingSink>();
  s->submit(moving, job(1, 60, R"("interactive": true, )"));
  std::vector<std::shared_ptr<CountingSink>> stills;
  for (int i = 0; i < 4; ++i) {
    stills.push_back(std::make_shared<CountingSink>());
    s->submit(stills.back(), job(uint32_t(10 + i), 1000));
  }
  s->start();
  moving->await(1);
  std::this_thread::sleep_for(60ms);  // both threads would now be drawing still frames without the reservation
  const auto asked = std::chrono::steady_clock::now();
  s->submit(moving, job(2, 60, R"("interactive": true, )"));
  const auto replies = moving->await(2);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - asked).count();
  ASSERT_GE(replies.size(), 2u);
  EXPECT_LT(ms, 250) << "the dragging session's frame waited for a still frame (400 ms)";
  EXPECT_LT(statsOf(replies[1].second)["queue_ms"].get<double>(), 100);
  s->stop();
}

/// A session that asks its next frame as soon as the last arrives, as `voxbrick load`'s clients do.
class AskingAgainSink : public CountingSink {
 public:
  AskingAgainSink(RenderScheduler& s, std::function<RenderJob()> next) : mScheduler(s), mNext(std::move(next)) {}
  void rendered(RenderJob job, proto::Message reply) override {
    CountingSink::rendered(job, std::move(reply));
    if (!mStopped) mScheduler.submit(std::static_pointer_cast<Sink>(shared_from_this()), mNext());
  }
  void stopAsking() { mStopped = true; }

 private:
  RenderScheduler& mScheduler;
  std::function<RenderJob()> mNext;
  std::atomic<bool> mStopped{false};
};

// A session that stops dragging gets its exact frame soon, however many sessions keep asking still frames: the frame
// that ends a drag (a still Render right after it, as the viewer page asks on release, or the exact frame of the last
// moving frame once the camera rests, as a TCP client waits for) is served in the interactive class, not behind the
// still crowd's share.
TEST_F(FairSchedulerTest, TheExactFrameEndingADragIsServedAsInteractiveBesideAStillCrowd) {
  auto s = scheduler(2, {}, 0us, 20us);  // width 1000: 160 ms (8 rows), width 60: 10 ms
  std::vector<std::shared_ptr<AskingAgainSink>> crowd;
  std::atomic<uint32_t> id{1000};
  for (int i = 0; i < 12; ++i) {
    crowd.push_back(std::make_shared<AskingAgainSink>(*s, [&] { return job(id++, 1000); }));
    s->submit(crowd.back(), job(id++, 1000));
  }
  s->start();
  auto page = std::make_shared<CountingSink>(), tcp = std::make_shared<CountingSink>();
  // Both had still frames of their own before: their share of still time is spent like the crowd's.
  for (uint32_t i = 0; i < 3; ++i) {
    s->submit(page, job(100 + i, 1000));
    s->submit(tcp, job(200 + i, 1000));
    page->await(i + 1);
    tcp->await(i + 1);
  }
  for (uint32_t i = 0; i < 20; ++i) {
    s->submit(page, job(i, 60 + int(i), R"("interactive": true, )"));
    s->submit(tcp, job(300 + i, 90 + int(i), R"("interactive": true, )"));
    std::this_thread::sleep_for(30ms);
  }
  // Released: the page asks the last camera as a still frame; the TCP client waits for the exact frame of its last.
  const auto released = std::chrono::steady_clock::now();
  s->submit(page, job(20, 79));
  auto exactAfter = [&](CountingSink& sink, uint32_t rid) {
    json found;
    for (int tries = 0; tries < 20 && found.is_null(); ++tries)
      for (const auto& [r, reply] : sink.await(sink.count() + 1, 1s)) {
        const json stats = statsOf(reply);
        if (r == rid && !stats.value("provisional", true)) found = stats;
      }
    if (!found.is_null())
      found["after_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - released).count();
    return found;
  };
  const json pageExact = exactAfter(*page, 20), tcpExact = exactAfter(*tcp, 319);
  for (auto& c : crowd) c->stopAsking();
  s->stop();
  for (const json& exact : {pageExact, tcpExact}) {
    ASSERT_FALSE(exact.is_null()) << "no exact frame after the drag";
    EXPECT_EQ(exact.value("class", ""), "interactive") << exact.dump();
    EXPECT_FALSE(exact.contains("load")) << "the crowd's cuts are for moving frames: " << exact.dump();
    // The crowd's round is 12 frames of 160 ms on the one thread still frames may take: about 2 s.
    EXPECT_LT(exact["after_ms"].get<double>(), 1000) << exact.dump();
  }
}

// A batch Render expected to wait beyond batch_max_wait_ms is refused Busy, with that wait as its retry hint.
TEST_F(FairSchedulerTest, BatchWorkOverCapacityIsBusyWithARetryHint) {
  auto s = scheduler(1, {.batchMaxWaitMs = 120}, 0us, 0ns);  // not started: everything waits
  std::vector<std::shared_ptr<CountingSink>> sinks;
  std::vector<Submission> results;
  for (int i = 0; i < 4; ++i) {
    sinks.push_back(std::make_shared<CountingSink>());
    results.push_back(s->submit(sinks.back(), job(uint32_t(i), 16, R"("batch": true, )")));
  }
  // Before any frame is measured a frame is predicted at 50 ms: 50 and 100 ms fit, 150 does not.
  EXPECT_EQ(results[0].result, Submission::Result::Queued);
  EXPECT_EQ(results[1].result, Submission::Result::Queued);
  ASSERT_EQ(results[2].result, Submission::Result::Busy);
  EXPECT_EQ(results[2].retryAfterMs, 150u);
  EXPECT_NE(results[2].why.find("batch"), std::string::npos) << results[2].why;
  EXPECT_EQ(s->busyRenders(), 2u);
  // A viewer's still frame is never refused for the batch queue.
  auto viewer = std::make_shared<CountingSink>();
  EXPECT_EQ(s->submit(viewer, job(9, 16)).result, Submission::Result::Queued);
  s->stop();
}

// Sessions asking the identical frame get one render: those waiting when it starts, and one asking while it is
// drawn; each gets it under its own request id, marked shared.
TEST_F(FairSchedulerTest, SessionsAskingTheSameFrameShareOneRender) {
  std::vector<render::NullFrameSource*> sources;
  auto s = scheduler(1, {}, 200ms, 0ns, &sources);
  auto a = std::make_shared<CountingSink>(), b = std::make_shared<CountingSink>(), c = std::make_shared<CountingSink>(),
       d = std::make_shared<CountingSink>();
  s->submit(a, job(1, 24));
  s->submit(b, job(2, 24));
  s->submit(d, job(4, 25));  // another frame: drawn on its own
  s->start();
  std::this_thread::sleep_for(50ms);
  s->submit(c, job(3, 24));  // while it is drawn
  ASSERT_EQ(a->await(1).size(), 1u);
  ASSERT_EQ(b->await(1).size(), 1u);
  ASSERT_EQ(c->await(1).size(), 1u);
  ASSERT_EQ(d->await(1).size(), 1u);
  s->stop();
  EXPECT_EQ(sources[0]->framesDrawn(), 2u);
  EXPECT_EQ(s->sharedFrames(), 2u);
  EXPECT_EQ(b->await(1)[0].first, 2u);
  EXPECT_EQ(c->await(1)[0].first, 3u);
  EXPECT_TRUE(statsOf(b->await(1)[0].second).value("shared", false));
  EXPECT_FALSE(statsOf(a->await(1)[0].second).value("shared", false)) << "the session it was drawn for";
}

// A session that encodes aside gets its still frame's pixels from the render thread, with the JPEG quality to encode
// them at, so that the thread draws on meanwhile; a frame others share is encoded once, on the render thread, and
// every session sharing it gets it encoded.
TEST_F(FairSchedulerTest, AStillFrameIsLeftToItsSessionToEncodeUnlessShared) {
  auto s = scheduler(1, {}, 100ms, 0ns);
  auto alone = std::make_shared<CountingSink>(), a = std::make_shared<CountingSink>(),
       b = std::make_shared<CountingSink>();
  const auto still = [&](uint32_t id, int width) {
    RenderJob j = job(id, width, R"("jpeg_quality": 77, )");
    j.encoding = proto::Encoding::Jpeg;
    j.encodeAside = true;
    return j;
  };
  s->submit(alone, still(1, 23));
  s->submit(a, still(2, 24));
  s->submit(b, still(3, 24));
  s->start();
  ASSERT_EQ(alone->await(1).size(), 1u);
  ASSERT_EQ(a->await(1).size(), 1u);
  ASSERT_EQ(b->await(1).size(), 1u);
  s->stop();
  EXPECT_EQ(s->sharedFrames(), 1u);
  EXPECT_EQ(alone->toEncode(), (std::vector<std::optional<int>>{77}));
  const proto::Frame left = std::get<proto::Frame>(alone->await(1)[0].second);
  EXPECT_EQ(left.payload.size(), 23u * 8 * 4) << "its RGBA8 pixels";
  EXPECT_FALSE(statsOf(left).contains("encode_ms"));
  RenderJob unlimited;
  unlimited.maxBodyBytes = UINT64_MAX;
  const proto::Message encoded = encodeStill(left, 77, unlimited);
  EXPECT_EQ(image::decodeFrameImage(std::get<proto::Frame>(encoded)).width, 23);
  for (const auto& sink : {a, b}) {
    EXPECT_EQ(sink->toEncode(), (std::vector<std::optional<int>>{std::nullopt}));
    const proto::Frame frame = std::get<proto::Frame>(sink->await(1)[0].second);
    EXPECT_EQ(frame.encoding, proto::Encoding::Jpeg);
    EXPECT_EQ(image::decodeFrameImage(frame).width, 24) << "encoded on the render thread";
    EXPECT_TRUE(statsOf(frame)["encode_ms"].is_number());
    // Encoded once its Render had waited for its thread and been drawn: not before.
    const auto stats = statsOf(frame);
    EXPECT_GE(stats["encode_start_ms"].get<double>(), stats["queue_ms"].get<double>());
  }
}

TEST(Quotas, SessionsPerAddressAndTokenHold) {
  Quotas q({.sessionsPerAddress = 2, .sessionsPerToken = 1});
  EXPECT_FALSE(q.admit({1}, "10.0.0.1", false));
  EXPECT_FALSE(q.admit({2}, "10.0.0.1", false));
  const auto third = q.admit({3}, "10.0.0.1", false);
  ASSERT_TRUE(third);
  EXPECT_NE(third->find("sessions_per_address = 2"), std::string::npos) << *third;
  const TokenGrant tok{"tok", {"*"}, std::nullopt, std::nullopt};
  EXPECT_FALSE(q.admit({4}, "10.0.0.2", false, &tok));
  const auto sameToken = q.admit({5}, "10.0.0.3", false, &tok);
  ASSERT_TRUE(sameToken);
  EXPECT_NE(sameToken->find("token 'tok' holds 1 sessions (quotas.sessions_per_token = 1)"), std::string::npos)
      << *sameToken;
  q.remove({1});
  EXPECT_FALSE(q.admit({6}, "10.0.0.1", false)) << "a closed session frees its place";
}

TEST(Quotas, ATokensOwnQuotasReplaceThePerTokenOnesAndHoldWhenItIsPresentedLater) {
  Quotas q({.sessionsPerToken = 1, .framesPerSecondPerToken = 100});
  const TokenGrant team{"team", {"*"}, 2, 1.0};
  EXPECT_FALSE(q.admit({1}, "10.0.0.1", false, &team));
  EXPECT_FALSE(q.admit({2}, "10.0.0.2", false)) << "a TCP session: its token comes with Authenticate";
  EXPECT_FALSE(q.attachToken({2}, team));
  EXPECT_FALSE(q.admit({3}, "10.0.0.3", false));
  const auto third = q.attachToken({3}, team);
  ASSERT_TRUE(third);
  EXPECT_NE(third->find("token 'team' holds 2 sessions (its sessions = 2)"), std::string::npos) << *third;
  const auto t0 = Quotas::Clock::now();
  EXPECT_FALSE(q.takeFrame({1}, t0));
  const auto refused = q.takeFrame({2}, t0);
  ASSERT_TRUE(refused) << "the token's one frame a second, shared by its sessions";
  EXPECT_NE(refused->why.find("token 'team' may send 1 Renders a second"), std::string::npos) << refused->why;
  EXPECT_FALSE(q.takeFrame({3}, t0)) << "the session whose token was refused is held to its address only";
}

TEST(Quotas, FramesPerSecondAreABucketOfOneSecond) {
  Quotas q({.framesPerSecondPerAddress = 4});
  ASSERT_FALSE(q.admit({1}, "10.0.0.1", false));
  ASSERT_FALSE(q.admit({2}, "10.0.0.1", false));
  const auto t0 = Quotas::Clock::now();
  for (int i = 0; i < 4; ++i) EXPECT_FALSE(q.takeFrame({uint64_t(1 + i % 2)}, t0)) << i;
  const auto refused = q.takeFrame({1}, t0);
  ASSERT_TRUE(refused) << "the address' two sessions share its 4 a second";
  EXPECT_EQ(refused->retryAfterMs, 250u);
  EXPECT_NE(refused->why.find("frames_per_s_per_address"), std::string::npos) << refused->why;
  EXPECT_FALSE(q.takeFrame({2}, t0 + 260ms));
  EXPECT_FALSE(q.takeFrame({7}, t0)) << "a session the quotas never admitted is held to nothing";
  // A frame given back (its Render refused after all) may be taken again, up to the bucket's second.
  ASSERT_TRUE(q.takeFrame({1}, t0 + 260ms));
  q.returnFrame({2});
  EXPECT_FALSE(q.takeFrame({1}, t0 + 260ms));
  ASSERT_TRUE(q.takeFrame({1}, t0 + 260ms));
  for (int i = 0; i < 10; ++i) q.returnFrame({1});
  for (int i = 0; i < 4; ++i) EXPECT_FALSE(q.takeFrame({1}, t0 + 260ms)) << i;
  EXPECT_TRUE(q.takeFrame({1}, t0 + 260ms)) << "no more than the bucket holds";
}

TEST(Quotas, LoopbackMayBeExempt) {
  Quotas q({.sessionsPerAddress = 1, .loopbackExempt = true});
  EXPECT_FALSE(q.admit({1}, "127.0.0.1", true));
  EXPECT_FALSE(q.admit({2}, "127.0.0.1", true));
}

/// The real server with a server.toml holding `toml`, over the sparse store.
class CrowdServerTest : public test::SparseDatasetSuite {
 protected:
  /// Greets each client, then opens the sparse store in each (every session is taken before any asks a frame).
  static void openEach(std::initializer_list<client::Client*> clients) {
    for (client::Client* c : clients) c->hello("test");
    for (client::Client* c : clients) c->openDataset("sparse");
  }
  std::unique_ptr<test::ServerProcess> start(const std::string& toml) {
    const auto config = scratch() / "crowd.toml";
    std::ofstream(config) << toml;
    return std::make_unique<test::ServerProcess>(
        "--datasets " + datasets() + " --render-threads 1 --config " + config.string(), scratch());
  }
};

constexpr const char* kCrowdScene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [32, 32], "transfer_function": "sparse")";

// Quotas from server.toml hold: a third session of one address is refused at Hello, naming the quota; a Render past
// the address' frame rate is Busy with a retry hint, and LimitExceeded with the same hint in a version-2 session.
TEST_F(CrowdServerTest, QuotasFromServerTomlHold) {
  auto server = start("[quotas]\nsessions_per_address = 2\nframes_per_s_per_address = 2\n");
  client::Client a("127.0.0.1", server->port()), b("127.0.0.1", server->port());
  EXPECT_EQ(a.hello("test").version, proto::kMaxVersion);
  b.hello("test", 2);
  client::Client c("127.0.0.1", server->port());
  const client::ServerError third = test::serverErrorOf([&] { c.hello("test"); });
  EXPECT_EQ(third.code(), proto::ErrorCode::LimitExceeded);
  EXPECT_NE(std::string(third.what()).find("sessions_per_address"), std::string::npos) << third.what();
  a.openDataset("sparse");
  b.openDataset("sparse");
  a.render(kCrowdScene + std::string("}"));
  a.render(kCrowdScene + std::string("}"));  // the bucket holds 2
  const client::ServerError busy = test::serverErrorOf([&] { a.render(kCrowdScene + std::string("}")); });
  EXPECT_EQ(busy.code(), proto::ErrorCode::Busy);
  const auto hint = proto::retryAfterMs(busy.what());
  ASSERT_TRUE(hint) << busy.what();
  EXPECT_GT(*hint, 0u);
  EXPECT_LE(*hint, 500u);
  const client::ServerError old = test::serverErrorOf([&] { b.render(kCrowdScene + std::string("}")); });
  EXPECT_EQ(old.code(), proto::ErrorCode::LimitExceeded) << "version 2 has no Busy";
  EXPECT_TRUE(proto::retryAfterMs(old.what())) << old.what();
  std::this_thread::sleep_for(std::chrono::milliseconds(*hint + 50));
  EXPECT_NO_THROW(a.render(kCrowdScene + std::string("}"))) << "the quota has room again after the hint";
}

// A Render the quota let through but the scheduler refused (a first drag beyond capacity, asked again each hint while
// the session waits in line) gives its frame back: waiting one's turn does not spend the address' quota. Before, the
// second refused drag was already refused by the quota, and the session's still frame too.
TEST_F(CrowdServerTest, ADragRefusedBeyondCapacitySpendsNoQuota) {
  auto server = start("[quotas]\nframes_per_s_per_address = 2\n[scheduler]\nmax_interactive_sessions = 1\n");
  const std::string moving = kCrowdScene + std::string(R"(, "interactive": true})");
  client::Client viewer("127.0.0.1", server->port()), other("127.0.0.1", server->port());
  openEach({&viewer, &other});
  viewer.render(moving);  // one of the address' 2 frames this second
  for (int i = 0; i < 5; ++i) {
    const client::ServerError busy = test::serverErrorOf([&] { other.render(moving); });
    EXPECT_EQ(busy.code(), proto::ErrorCode::Busy) << busy.what();
    EXPECT_NE(std::string(busy.what()).find("over capacity"), std::string::npos) << i << ": " << busy.what();
  }
  EXPECT_NO_THROW(other.render(kCrowdScene + std::string("}"))) << "the address' second frame is still there";
}

// By default (interactive_turn_s = 2) a drag alone is never paused, however long; once another session waits in
// line, a drag held two seconds is told Busy at its next move, its turn over, and the one waiting is taken.
TEST_F(CrowdServerTest, ByDefaultADragHeldTwoSecondsWhileAnotherWaitsGivesUpItsRoom) {
  auto server = start("[scheduler]\nmax_interactive_sessions = 1\n");
  const std::string moving = kCrowdScene + std::string(R"(, "interactive": true})");
  client::Client viewer("127.0.0.1", server->port()), other("127.0.0.1", server->port());
  openEach({&viewer, &other});
  const auto began = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - began < std::chrono::milliseconds(2500)) {
    ASSERT_NO_THROW(viewer.render(moving)) << "a drag alone is not paused";
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const client::ServerError waiting = test::serverErrorOf([&] { other.render(moving); });
  EXPECT_EQ(waiting.code(), proto::ErrorCode::Busy) << waiting.what();
  const client::ServerError over = test::serverErrorOf([&] { viewer.render(moving); });
  EXPECT_EQ(over.code(), proto::ErrorCode::Busy) << over.what();
  EXPECT_NE(std::string(over.what()).find("turn to drag is over (2 s"), std::string::npos) << over.what();
  const auto hint = proto::retryAfterMs(waiting.what());
  ASSERT_TRUE(hint) << waiting.what();
  std::this_thread::sleep_for(std::chrono::milliseconds(*hint));
  EXPECT_NO_THROW(other.render(moving)) << "the room went to the one waiting";
  const client::ServerError behind = test::serverErrorOf([&] { viewer.render(moving); });
  EXPECT_EQ(behind.code(), proto::ErrorCode::Busy) << behind.what();
}

// Beyond capacity (max_interactive_sessions sessions dragging) a new session is taken (its still frames are drawn;
// its first drag waits in line); with busy_at_hello it gets Busy at Hello with a retry hint and is closed. The session
// already dragging is served on.
TEST_F(CrowdServerTest, ANewSessionBeyondCapacityIsBusyAtHelloWhereSoConfigured) {
  {
    auto server = start("[scheduler]\nmax_interactive_sessions = 1\n");
    client::Client viewer("127.0.0.1", server->port()), late("127.0.0.1", server->port());
    viewer.hello("test");
    viewer.openDataset("sparse");
    viewer.render(kCrowdScene + std::string(R"(, "interactive": true})"));
    EXPECT_NO_THROW(late.hello("test"));
    late.openDataset("sparse");
    EXPECT_NO_THROW(late.render(kCrowdScene + std::string("}")));
  }
  auto server = start("[scheduler]\nmax_interactive_sessions = 1\nbusy_at_hello = true\n");
  client::Client viewer("127.0.0.1", server->port());
  viewer.hello("test");
  viewer.openDataset("sparse");
  viewer.render(kCrowdScene + std::string(R"(, "interactive": true})"));
  client::Client late("127.0.0.1", server->port());
  const client::ServerError busy = test::serverErrorOf([&] { late.hello("test"); });
  EXPECT_EQ(busy.code(), proto::ErrorCode::Busy) << busy.what();
  EXPECT_TRUE(proto::retryAfterMs(busy.what())) << busy.what();
  EXPECT_NE(std::string(busy.what()).find("over capacity"), std::string::npos) << busy.what();
  EXPECT_NO_THROW(viewer.render(kCrowdScene + std::string(R"(, "interactive": true})")));
  // Once nobody drags (the window is a second), sessions are taken again.
  std::this_thread::sleep_for(std::chrono::milliseconds(1200));
  client::Client later("127.0.0.1", server->port());
  EXPECT_NO_THROW(later.hello("test"));
}

// Against the real server: a session's first moving camera beyond capacity is answered Busy with a retry hint, and
// the session is kept (its still frames are drawn); once nobody drags, it may. Before the capacity is measured the
// cold bound holds the same way.
TEST_F(CrowdServerTest, AFirstDragBeyondCapacityIsBusyAndTheSessionStays) {
  const std::string moving = kCrowdScene + std::string(R"(, "interactive": true})");
  for (const auto& [toml, said] :
       {std::pair<std::string, std::string>{"[scheduler]\nmax_interactive_sessions = 1\n", "over capacity"},
        {"[scheduler]\ncold_interactive_sessions_per_thread = 1\n", "measuring its capacity"}}) {
    auto server = start(toml);
    client::Client viewer("127.0.0.1", server->port()), other("127.0.0.1", server->port());
    viewer.hello("test");
    other.hello("test");  // nobody drags yet: both are taken
    viewer.openDataset("sparse");
    other.openDataset("sparse");
    viewer.render(moving);
    const client::ServerError busy = test::serverErrorOf([&] { other.render(moving); });
    EXPECT_EQ(busy.code(), proto::ErrorCode::Busy) << busy.what();
    EXPECT_NE(std::string(busy.what()).find(said), std::string::npos) << busy.what();
    ASSERT_TRUE(proto::retryAfterMs(busy.what())) << busy.what();
    EXPECT_EQ(nlohmann::json::parse(viewer.stats())["sessions"]["waiting_to_drag"], 1) << "in line";
    EXPECT_NO_THROW(viewer.render(moving)) << "the session dragging drags on";
    // Its still frames are drawn; the first, as its drag's last (a viewer's release while it waits out the hint):
    // past the hint (250 ms, the first in line) and the second a drag lasts, within 3 s.
    if (said == "over capacity") std::this_thread::sleep_for(std::chrono::milliseconds(1100));
    const proto::Frame released = other.render(kCrowdScene + std::string("}"));
    EXPECT_EQ(nlohmann::json::parse(released.statsJson)["class"], "interactive") << released.statsJson;
    EXPECT_EQ(nlohmann::json::parse(viewer.stats())["sessions"]["waiting_to_drag"], 0) << "released: out of line";
    const proto::Frame still = other.render(kCrowdScene + std::string("}"));
    EXPECT_EQ(nlohmann::json::parse(still.statsJson)["class"], "still") << still.statsJson;
    std::this_thread::sleep_for(std::chrono::milliseconds(1200));  // nobody drags now
    EXPECT_NO_THROW(other.render(moving));
  }
}

}  // namespace
}  // namespace voxbrick::server
