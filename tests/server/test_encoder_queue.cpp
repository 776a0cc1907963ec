// The encoder threads' queue: classes served by weight, first come first served within one, every task run.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "server/EncoderQueue.h"

namespace voxbrick::server {
namespace {

constexpr std::array<double, kFrameClasses> kWeights{16, 3, 1};  // the scheduler's defaults

/// The names of the tasks run, in order.
struct Order {
  std::mutex mutex;
  std::vector<std::string> names;
  std::function<void()> task(std::string name, std::chrono::milliseconds takes = {}) {
    return [this, name, takes] {
      if (takes.count()) std::this_thread::sleep_for(takes);
      std::lock_guard lock(mutex);
      names.push_back(name);
    };
  }
};

/// A task that holds its thread until `open` is set, and says when it runs (`running`).
std::function<void()> gate(std::shared_future<void> open, std::promise<void>* running = nullptr) {
  return [open, running] {
    if (running) running->set_value();
    open.wait();
  };
}

// A moving camera's frame queued after a batch client's frames is encoded first, then a resting camera's exact frame,
// then the batch frames in the order they came.
TEST(EncoderQueue, ClassesAreServedInOrderNotTheTasksArrival) {
  Order order;
  std::promise<void> open, running;
  EncoderQueue queue(1, kWeights);
  queue.post(FrameClass::Batch, gate(open.get_future().share(), &running));
  running.get_future().wait();
  for (int i = 0; i < 3; ++i) queue.post(FrameClass::Batch, order.task("batch" + std::to_string(i)));
  queue.post(FrameClass::Still, order.task("still"));
  queue.post(FrameClass::Interactive, order.task("interactive"));
  EXPECT_EQ(queue.queued(), (std::array<size_t, kFrameClasses>{1, 1, 3}));
  open.set_value();
  queue.join();
  EXPECT_EQ(order.names, (std::vector<std::string>{"interactive", "still", "batch0", "batch1", "batch2"}));
}

// Interactive work that never lets up still leaves batch work its weight's share of the threads' time (1 in 17 with
// the default weights), instead of none.
TEST(EncoderQueue, ABusyClassDoesNotStarveTheOthers) {
  Order order;
  std::promise<void> open, running;
  EncoderQueue queue(1, kWeights);
  queue.post(FrameClass::Interactive, gate(open.get_future().share(), &running));
  running.get_future().wait();
  constexpr int kInteractive = 120;
  for (int i = 0; i < kInteractive; ++i)
    queue.post(FrameClass::Interactive, order.task("i", std::chrono::milliseconds(2)));
  for (int i = 0; i < 3; ++i) queue.post(FrameClass::Batch, order.task("b", std::chrono::milliseconds(2)));
  open.set_value();
  queue.join();
  ASSERT_EQ(order.names.size(), size_t(kInteractive + 3));
    // A batch task about every 16 interactive ones: the last of the three well before the interactive work ends.
  const auto last = std::find(order.names.rbegin(), order.names.rend(), "b");
  const size_t lastBatch = size_t(order.names.rend() - last) - 1;
  EXPECT_LT(lastBatch, size_t(kInteractive) * 3 / 4) << "batch work waited for the interactive work to end";
  EXPECT_LE(std::count(order.names.begin(), order.names.begin() + 10, "b"), 1) << "interactive work is served first";
}

// With two threads, one is kept for interactive work while it comes: a crowd's still encodings take the other only,
// and a moving camera's frame starts at once although a still one was queued before it. Without interactive work the
// still encodings take both.
TEST(EncoderQueue, AThreadIsKeptForInteractiveWorkWhileItComes) {
  using namespace std::chrono_literals;
  {
    EncoderQueue queue(2, kWeights, 1, 60s);
    std::promise<void> open, firstRunning, interactiveRan;
    const auto opened = open.get_future().share();
    queue.post(FrameClass::Interactive, [] {});  // interactive work comes: the reserve holds from now
    queue.post(FrameClass::Still, gate(opened, &firstRunning));
    firstRunning.get_future().wait();
    std::atomic<bool> secondStarted = false;
    queue.post(FrameClass::Still, [&secondStarted] { secondStarted = true; });
    queue.post(FrameClass::Interactive, [&interactiveRan] { interactiveRan.set_value(); });
    ASSERT_EQ(interactiveRan.get_future().wait_for(30s), std::future_status::ready) << "the kept thread took it";
    std::this_thread::sleep_for(50ms);
    EXPECT_FALSE(secondStarted) << "the second still frame waits for the first, not for the kept thread";
    EXPECT_EQ(queue.queued(), (std::array<size_t, kFrameClasses>{0, 1, 0}));
    open.set_value();
    queue.join();
    EXPECT_TRUE(secondStarted);
  }
  EncoderQueue queue(2, kWeights, 1, 60s);
  std::promise<void> open, running[2];
  const auto opened = open.get_future().share();
  for (auto& r : running) queue.post(FrameClass::Still, gate(opened, &r));
  for (auto& r : running)
    EXPECT_EQ(r.get_future().wait_for(30s), std::future_status::ready) << "no interactive work: both threads";
  open.set_value();
}

// join() runs every task queued, on all threads; one posted afterwards runs on the caller's thread.
TEST(EncoderQueue, JoinRunsEveryTaskQueued) {
  std::atomic<int> ran = 0;
  std::promise<void> open;
  auto queue = std::make_unique<EncoderQueue>(3, kWeights);
  const auto opened = open.get_future().share();
  for (int i = 0; i < 3; ++i) queue->post(FrameClass::Still, gate(opened));
  for (int i = 0; i < 50; ++i) queue->post(FrameClass(i % 3), [&ran] { ++ran; });
  open.set_value();
  queue->join();
  EXPECT_EQ(ran.load(), 50);
  const auto caller = std::this_thread::get_id();
  std::thread::id where;
  queue->post(FrameClass::Batch, [&where] { where = std::this_thread::get_id(); });
  EXPECT_EQ(where, caller);
}

TEST(EncoderQueue, RefusesNoThreadsAndWeightsNotAboveZero) {
  EXPECT_THROW(EncoderQueue(0, kWeights), std::invalid_argument);
  EXPECT_THROW(EncoderQueue(1, {16, 0, 1}), std::invalid_argument);
}

}  // namespace
}  // namespace voxbrick::server
