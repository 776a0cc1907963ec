// The render queue and threads, drawn by the null frame source (no GL context: what is tested is the queue), and a
// render thread's reply to a job, drawn by a real engine (llvmpipe without a GPU).
#include <gtest/gtest.h>

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <nlohmann/json.hpp>

#include "TestDatasets.h"
#include "image/FrameImage.h"
#include "render/core/TransferFunction.h"
#include "render/core/TransferFunctionPresets.h"
#include "render/engine/NullFrameSource.h"
#include "render/engine/RenderEngine.h"
#include "server/Datasets.h"
#include "server/RenderScheduler.h"
#include "server/ServerConfig.h"

namespace voxbrick::server {
namespace {

using nlohmann::json;

/// Collects the replies a scheduler delivers to one session.
class RecordingSink : public RenderScheduler::Sink {
 public:
  std::atomic<bool> wants{true};

  bool wantsReplies() const override { return wants; }
  void rendered(RenderJob job, proto::Message reply) override {
    {
      std::lock_guard lock(mMutex);
      mReplies.emplace_back(job.requestId, std::move(reply));
    }
    mChanged.notify_all();
  }
  /// The replies so far, once there are `count` of them (or after 60 s).
  std::vector<std::pair<uint32_t, proto::Message>> await(size_t count) {
    std::unique_lock lock(mMutex);
    mChanged.wait_for(lock, std::chrono::seconds(60), [&] { return mReplies.size() >= count; });
    return mReplies;
  }

 private:
  std::mutex mMutex;
  std::condition_variable mChanged;
  std::vector<std::pair<uint32_t, proto::Message>> mReplies;
};

class RenderSchedulerTest : public ::testing::Test {
 protected:
  DatasetRegistry datasets{test::testDatasets(), size_t(16) << 20};
  render::TransferFunctionPresets presets = render::TransferFunctionPresets::load(test::shippedPresets());

  RenderJob job(uint32_t id, int width = 40) {
    RenderJob j;
    j.requestId = id;
    j.encoding = proto::Encoding::RawRgba8;
    j.dataset = datasets.open("sparse");
    j.scene =
        render::Scene::fromJson(R"({"camera": {"orbit": [40, 25, 2.2]}, "transfer_function": "sparse", "size": [)" +
                                    std::to_string(width) + ", 32]}",
                                "scene", presets);
    j.received = std::chrono::steady_clock::now();
    return j;
  }
  /// A scheduler of `threads` null sources, each frame taking `drawTime`; `sources` (if given) gets them.
  static std::unique_ptr<RenderScheduler> scheduler(int threads, bool coalesce,
                                                    std::chrono::microseconds drawTime = std::chrono::microseconds(0),
                                                    std::vector<render::NullFrameSource*>* sources = nullptr) {
    std::vector<std::unique_ptr<render::FrameSource>> made;
    for (int i = 0; i < threads; ++i) {
      auto source = std::make_unique<render::NullFrameSource>(drawTime);
      if (sources) sources->push_back(source.get());
      made.push_back(std::move(source));
    }
    return std::make_unique<RenderScheduler>(std::move(made), coalesce);
  }
};

TEST_F(RenderSchedulerTest, TheNewestWaitingJobOfASessionWinsAndSessionsTakeTurns) {
  auto s = scheduler(1, true);
  auto a = std::make_shared<RecordingSink>(), b = std::make_shared<RecordingSink>();
  Submission first = s->submit(a, job(1));
  EXPECT_EQ(first.result, Submission::Result::Queued);
  EXPECT_FALSE(first.replaced);
  Submission second = s->submit(a, job(2, 48));
  EXPECT_EQ(second.result, Submission::Result::Queued);
  ASSERT_TRUE(second.replaced);
  EXPECT_EQ(second.replaced->requestId, 1u);
  EXPECT_EQ(s->queuedSessions(), 1u);
  EXPECT_FALSE(s->submit(b, job(3)).replaced);
  EXPECT_EQ(s->queuedSessions(), 2u);
  s->start();
  const auto fromA = a->await(1), fromB = b->await(1);
  ASSERT_EQ(fromA.size(), 1u);
  ASSERT_EQ(fromB.size(), 1u);
  EXPECT_EQ(fromA[0].first, 2u);
  EXPECT_EQ(fromB[0].first, 3u);
  ASSERT_TRUE(std::holds_alternative<proto::Frame>(fromA[0].second));
  EXPECT_EQ(std::get<proto::Frame>(fromA[0].second).width, 48u) << "the newer request's scene was drawn";
  s->stop();
  EXPECT_EQ(s->queuedSessions(), 0u);
  EXPECT_EQ(a->await(1).size(), 1u) << "the replaced job was never rendered";
}

// An interactive job: a provisional frame within its budget, then the exact one for the same request once the
// camera rests, drawn without the time budget.
TEST_F(RenderSchedulerTest, AnInteractiveJobIsRefinedToTheExactFrame) {
  std::vector<render::NullFrameSource*> sources;
  auto s = scheduler(1, true, std::chrono::microseconds(0), &sources);
  auto a = std::make_shared<RecordingSink>();
  s->start();
  RenderJob moving = job(7);
  moving.scene.interactive = true;
  s->submit(a, moving);
  const auto two = a->await(2);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].first, 7u);
  EXPECT_EQ(two[1].first, 7u);
  ASSERT_TRUE(std::holds_alternative<proto::Frame>(two[0].second));
  ASSERT_TRUE(std::holds_alternative<proto::Frame>(two[1].second));
  const json first = json::parse(std::get<proto::Frame>(two[0].second).statsJson);
  const json second = json::parse(std::get<proto::Frame>(two[1].second).statsJson);
  EXPECT_TRUE(first["provisional"].get<bool>());
  EXPECT_FALSE(second["provisional"].get<bool>());
  EXPECT_EQ(sources[0]->framesDrawn(), 2u);
  s->stop();
}

// The exact frame of a moving camera waits for the camera to rest: one and a half times the longest of the session's
// last four intervals between Renders (at most kMaxRestMs), so that a client whose moves come unevenly does not read
// as resting at its next quick move.
TEST_F(RenderSchedulerTest, TheRestBeforeAnExactFrameFollowsTheLongestRecentInterval) {
  auto s = scheduler(1, true);  // never started: the jobs only wait
  auto a = std::make_shared<RecordingSink>();
  EXPECT_EQ(s->restMs(*a), RenderScheduler::kMaxRestMs) << "no Render yet";
  auto t = std::chrono::steady_clock::now();
  const auto move = [&](uint32_t id, int afterMs) {
    t += std::chrono::milliseconds(afterMs);
    RenderJob j = job(id);
    j.scene.interactive = true;
    j.received = t;
    s->submit(a, j);
    return s->restMs(*a);
  };
  EXPECT_EQ(move(1, 0), RenderScheduler::kMaxRestMs) << "one Render: no interval yet";
  EXPECT_DOUBLE_EQ(move(2, 20), 30);
  EXPECT_DOUBLE_EQ(move(3, 60), 90);  // a late move
  EXPECT_DOUBLE_EQ(move(4, 20), 90);
  EXPECT_DOUBLE_EQ(move(5, 20), 90);
  EXPECT_DOUBLE_EQ(move(6, 20), 90) << "the late move is among the last four intervals";
  EXPECT_DOUBLE_EQ(move(7, 20), 30) << "no longer";
  EXPECT_EQ(move(8, 400), RenderScheduler::kMaxRestMs) << "a new drag after a pause";
}

// Sessions take turns: one with many jobs waiting (without coalescing) does not hold back another's single job.
TEST_F(RenderSchedulerTest, ASessionWithManyJobsWaitingDoesNotHoldBackAnother) {
  std::vector<render::NullFrameSource*> sources;
  auto s = scheduler(1, false, std::chrono::milliseconds(2), &sources);
  auto busy = std::make_shared<RecordingSink>(), other = std::make_shared<RecordingSink>();
  for (uint32_t i = 1; i <= 10; ++i) s->submit(busy, job(i, 40));
  s->submit(other, job(100, 64));
  s->start();
  ASSERT_EQ(busy->await(10).size(), 10u);
  ASSERT_EQ(other->await(1).size(), 1u);
  s->stop();
  const std::vector<int> widths = sources[0]->widthsDrawn();
  ASSERT_EQ(widths.size(), 11u);
  const auto position = std::find(widths.begin(), widths.end(), 64) - widths.begin();
  EXPECT_EQ(position, 1) << "the other session's job is drawn second, after the first of the busy one's ten";
}

// A refinement overtaken by a newer Render of its session is given up part way (the source is asked between its
// steps), and the newer request is drawn.
TEST_F(RenderSchedulerTest, ARefinementOvertakenWhileDrawnIsCancelled) {
  std::vector<render::NullFrameSource*> sources;
  auto s = scheduler(1, true, std::chrono::milliseconds(300), &sources);
  auto a = std::make_shared<RecordingSink>();
  s->start();
  RenderJob exact = job(1, 40);
  exact.received = std::chrono::steady_clock::now();
  s->refine(a, exact);  // a progressive request's exact frame: 300 ms to draw
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  s->submit(a, job(2, 48));  // the camera moved on
  const auto replies = a->await(1);
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].first, 2u);
  s->stop();
  EXPECT_EQ(s->cancelled(), 1u);
  EXPECT_EQ(sources[0]->widthsDrawn(), std::vector<int>{48});
}

// The frame a render thread has just answered is followed by paging ahead along the camera's motion.
TEST_F(RenderSchedulerTest, AMovedCameraIsPagedAhead) {
  std::vector<render::NullFrameSource*> sources;
  auto s = scheduler(1, true, std::chrono::microseconds(0), &sources);
  auto a = std::make_shared<RecordingSink>();
  s->start();
  RenderJob still = job(1);
  still.previousCamera = still.scene.camera;  // it did not move: nothing to page ahead for
  s->submit(a, still);
  ASSERT_EQ(a->await(1).size(), 1u);
  RenderJob moved = job(2);
  moved.previousCamera = moved.scene.camera;
  moved.previousCamera->azimuth -= 5;
  s->submit(a, moved);
  ASSERT_EQ(a->await(2).size(), 2u);
  s->stop();
  EXPECT_EQ(sources[0]->prefetches(), 1u);
}

// A refinement waits only if the session has nothing newer waiting: a camera that moved on drops it.
TEST_F(RenderSchedulerTest, ARefinementYieldsToANewerJob) {
  auto s = scheduler(1, true);
  auto a = std::make_shared<RecordingSink>();
  s->submit(a, job(1));
  s->refine(a, job(2));  // dropped: job 1 waits
  s->start();
  ASSERT_EQ(a->await(1).size(), 1u);
  s->submit(a, job(3));
  const auto replies = a->await(2);
  ASSERT_EQ(replies.size(), 2u);
  EXPECT_EQ(replies[0].first, 1u);
  EXPECT_EQ(replies[1].first, 3u);
  s->stop();
}

// The exact frame of a request older than one the session sent since (already taken by a render thread, so not
// waiting) is dropped: queued, it would overtake the newer request's own exact frame and give it up.
TEST_F(RenderSchedulerTest, ARefinementOfAnOlderRequestIsDroppedOnceANewerOneCame) {
  auto s = scheduler(1, true);
  auto a = std::make_shared<RecordingSink>();
  RenderJob older = job(1);
  RenderJob newer = job(2);
  older.received = std::chrono::steady_clock::now();
  newer.received = older.received + std::chrono::milliseconds(5);
  s->submit(a, std::move(newer));
  s->start();
  ASSERT_EQ(a->await(1).size(), 1u);                            // the newer one is drawn: nothing waits now
  s->refine(a, std::move(older));                               // its exact frame: dropped
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // a null frame takes no time
  s->stop();
  const auto replies = a->await(1);
  ASSERT_EQ(replies.size(), 1u) << "no reply to the older request's exact frame";
  EXPECT_EQ(replies[0].first, 2u);
}

TEST_F(RenderSchedulerTest, WithoutCoalescingASessionMayQueueSixtyFour) {
  auto s = scheduler(1, false);
  auto a = std::make_shared<RecordingSink>();
  for (uint32_t i = 1; i <= ServerConfig::kMaxQueuedWithoutCoalescing; ++i) {
    const Submission r = s->submit(a, job(i));
    EXPECT_EQ(r.result, Submission::Result::Queued) << i;
    EXPECT_FALSE(r.replaced) << i;
  }
  EXPECT_EQ(s->submit(a, job(100)).result, Submission::Result::Full);
  EXPECT_EQ(s->queuedSessions(), 1u);
}

TEST_F(RenderSchedulerTest, StopDropsWaitingJobsAndRefusesNewOnes) {
  auto s = scheduler(1, true, std::chrono::milliseconds(200));  // a frame takes long enough for the others to wait
  std::vector<std::shared_ptr<RecordingSink>> sinks;
  s->start();
  for (uint32_t i = 1; i <= 4; ++i) {
    sinks.push_back(std::make_shared<RecordingSink>());
    s->submit(sinks.back(), job(i, 40 + int(i)));  // four different frames: none rides along another's render
  }
  s->stop();
  // One thread finishes at most the frame it was drawing; the others waiting are dropped.
  size_t replies = 0;
  for (const auto& sink : sinks) replies += sink->await(0).size();
  EXPECT_LE(replies, 1u);
  EXPECT_EQ(s->queuedSessions(), 0u);
  EXPECT_EQ(s->submit(sinks[0], job(5)).result, Submission::Result::Stopped);
  s->stop();  // idempotent
}

TEST_F(RenderSchedulerTest, JobsOfAnEndedSessionAreNotRendered) {
  auto s = scheduler(1, true);
  auto gone = std::make_shared<RecordingSink>(), here = std::make_shared<RecordingSink>();
  gone->wants = false;
  s->submit(gone, job(1));
  s->submit(here, job(2));
  s->start();
  ASSERT_EQ(here->await(1).size(), 1u);
  s->stop();
  EXPECT_TRUE(gone->await(0).empty());
}

TEST(RenderReply, AFrameCarriesTheImageAndTheServerTimings) {
  DatasetRegistry datasets(test::testDatasets(), size_t(16) << 20);
  const auto presets = render::TransferFunctionPresets::load(test::shippedPresets());
  render::RenderEngine engine({render::Backend::Auto, size_t(64) << 20});
  RenderJob job;
  job.requestId = 5;
  job.encoding = proto::Encoding::Png;
  job.dataset = datasets.open("sparse");
  job.scene = render::Scene::fromJson(R"({"size": [40, 32], "transfer_function": "sparse"})", "scene", presets);
  job.received = std::chrono::steady_clock::now();
  const proto::Message reply = renderReply(engine, job, 3).message;
  ASSERT_TRUE(std::holds_alternative<proto::Frame>(reply));
  const auto& frame = std::get<proto::Frame>(reply);
  EXPECT_EQ(frame.width, 40u);
  EXPECT_EQ(frame.height, 32u);
  EXPECT_EQ(frame.encoding, proto::Encoding::Png);
  const image::Image8 image = image::decodeFrameImage(frame);
  size_t lit = 0;
  for (size_t i = 0; i < image.rgba.size(); i += 4) lit += image.rgba[i] > 0 ? 1 : 0;
  EXPECT_GT(lit, 20u) << "an empty frame would prove nothing";
  const json stats = json::parse(frame.statsJson);
  EXPECT_GT(stats["bricks_drawn"].get<int>(), 0);
  EXPECT_GE(stats["queue_ms"].get<double>(), 0.0);
  EXPECT_GE(stats["encode_ms"].get<double>(), 0.0);
  // Its encoding started once it had waited for its thread and been drawn (both rounded in the statistics).
  EXPECT_GE(stats["encode_start_ms"].get<double>(),
            stats["queue_ms"].get<double>() + stats["ms"]["total"].get<double>() - 0.5);
  EXPECT_EQ(stats["render_thread"], 3);

  // What the renderer throws becomes the reply, through errorReply.
  job.dataset = nullptr;
  const proto::Message error = renderReply(engine, job, 3).message;
  ASSERT_TRUE(std::holds_alternative<proto::Error>(error));
  EXPECT_EQ(std::get<proto::Error>(error).code, proto::ErrorCode::InvalidScene);
}

}  // namespace
}  // namespace voxbrick::server
