// `voxbrick load` against the real server: the scene key batch, each well-behaved client's figures with Jain's index
// over them, and the dragging clients' camera-to-frame latency.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "cli/CliRun.h"
#include "proto/Messages.h"
#include "server/ServerProcess.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using nlohmann::json;
using test::ServerProcess;

class LoadTest : public test::SparseDatasetSuite {
 protected:
  void SetUp() override {
    mServer = std::make_unique<ServerProcess>("--datasets " + datasets() + " --render-threads 1", scratch());
  }

  /// Runs `voxbrick load` on the suite's server with `options` (64x64 frames unless they name a --size); its JSON
  /// report.
  json load(const std::string& options) {
    const auto report = scratch() / "load.json";
    const std::string size = options.find("--size") == std::string::npos ? " --size 64x64" : "";
    const auto r = test::runVoxbrick("load 127.0.0.1:" + std::to_string(mServer->port()) + " --dataset sparse" + size +
                                     " --json " + report.string() + " " + options);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    const std::vector<char> text = test::readFile(report);
    return json::parse(std::string(text.begin(), text.end()));
  }

  std::unique_ptr<ServerProcess> mServer;
};

TEST_F(LoadTest, BatchClientsSendTheKeyAndEachClientIsReported) {
  const json r = load("--clients 3 --duration 1 --batch --require-clean");
  EXPECT_EQ(r["batch"], true);
  EXPECT_EQ(r["scene"]["batch"], true) << r["scene"];
  // The server knows the key: no client had to drop it, and every client got frames with it.
  EXPECT_EQ(r["batch_refused"], 0);
  EXPECT_EQ(r["protocol_version"], proto::kMaxVersion) << "the load's sessions speak the newest version";
  EXPECT_EQ(r["errors"], 0);

  ASSERT_EQ(r["per_client"].size(), 3u) << r.dump();
  int64_t frames = 0, busy = 0;
  double sum = 0, squares = 0;
  for (const json& c : r["per_client"]) {
    EXPECT_GT(c["frames"].get<int64_t>(), 0) << c;
    EXPECT_NEAR(c["frames_per_s"].get<double>(), c["frames"].get<double>() / r["duration_s"].get<double>(), 1e-6);
    EXPECT_GT(c["latency_ms"]["p50"].get<double>(), 0) << c;
    EXPECT_LE(c["latency_ms"]["p50"].get<double>(), c["latency_ms"]["p99"].get<double>()) << c;
    frames += c["frames"].get<int64_t>();
    busy += c["busy"].get<int64_t>();
    const double rate = c["frames_per_s"].get<double>();
    sum += rate, squares += rate * rate;
  }
  EXPECT_EQ(frames, r["frames"].get<int64_t>());
  EXPECT_EQ(busy, r["busy"].get<int64_t>());
  EXPECT_NEAR(r["jain_index"].get<double>(), sum * sum / (3 * squares), 1e-9);
  EXPECT_GE(r["jain_index"].get<double>(), 1.0 / 3);
  EXPECT_LE(r["jain_index"].get<double>(), 1.0 + 1e-9);

  // Without --batch the scene has no such key.
  const json plain = load("--clients 1 --duration 0.3 --require-clean");
  EXPECT_EQ(plain["batch"], false);
  EXPECT_FALSE(plain["scene"].contains("batch")) << plain["scene"];
}

TEST_F(LoadTest, DraggingClientsTimeEachFrameFromItsCamera) {
  const json r = load("--clients 2 --duration 1 --drag 20 --encoding png --require-clean");
  ASSERT_GT(r["frames"].get<int64_t>(), 0) << r.dump();
  ASSERT_EQ(r["per_client"].size(), 2u);
  for (const json& c : r["per_client"]) {
    EXPECT_GT(c["frames"].get<int64_t>(), 0) << c;
    // Its first frame's time in the run, and its rate from then: what a client the server let in late is judged by.
    ASSERT_TRUE(c["first_frame_s"].is_number()) << c;
    EXPECT_GT(c["first_frame_s"].get<double>(), 0) << c;
    EXPECT_LT(c["first_frame_s"].get<double>(), 1) << c;
    EXPECT_NEAR(c["frames_per_s_since_first"].get<double>(),
                c["frames"].get<double>() / (r["duration_s"].get<double>() - c["first_frame_s"].get<double>()),
                1e-6 * c["frames_per_s_since_first"].get<double>())
        << c;
  }
  // A frame cannot arrive before it was drawn: its camera's age is at least the server's render time, at every rank.
  EXPECT_GE(r["latency_ms"]["p50"].get<double>(), r["render_ms_p50"].get<double>()) << r["latency_ms"];
  EXPECT_GT(r["render_ms_p50"].get<double>(), 0);
  EXPECT_TRUE(r["jain_index"].is_number()) << r.dump();
}

// --drag-cycle: clients drag and rest in turn, each from its own phase; on a server that keeps one dragging session
// their drags meet refusals, and the report gives each drag's wait for its first frame and the drags refused
// throughout (ended by a still Render, as a viewer's release does: its frame is an exact one, not a moving frame).
TEST_F(LoadTest, DraggingClientsInCyclesReportEachDragsWait) {
  const auto config = scratch() / "one-drag.toml";
  test::writeFile(config, "[scheduler]\nmax_interactive_sessions = 1\n");
  mServer = std::make_unique<ServerProcess>(
      "--datasets " + datasets() + " --render-threads 1 --config " + config.string(), scratch());
  const json r = load("--clients 3 --duration 5 --drag 20 --interactive 50 --drag-cycle 0.6,1.2");
  ASSERT_TRUE(r["drag_cycle"].is_object()) << r.dump();
  const json& cycle = r["drag_cycle"];
  EXPECT_EQ(cycle["drag_s"], 0.6);
  EXPECT_EQ(cycle["rest_s"], 1.2);
  int64_t taken = 0, refused = 0, cycles = 0;
  for (const json& c : r["per_client"]) {
    taken += c["drags_taken"].get<int64_t>();
    refused += c["drags_refused"].get<int64_t>();
    // 5 s of 1.8 s cycles: two drags at least began and ended, or got their first frame, within the run.
    EXPECT_GE(c["drags_taken"].get<int64_t>() + c["drags_refused"].get<int64_t>(), 2) << c;
    cycles += c["drags_taken"].get<int64_t>() > 0 ? 1 : 0;
    if (c["drags_taken"].get<int64_t>() > 0) {
      EXPECT_GT(c["drag_wait_ms_max"].get<double>(), 0) << c;
      EXPECT_GT(c["frames"].get<int64_t>(), 0) << c;
    }
  }
  EXPECT_EQ(cycle["drags_taken"].get<int64_t>(), taken);
  EXPECT_EQ(cycle["drags_refused"].get<int64_t>(), refused);
  EXPECT_GT(taken, 0);
  EXPECT_GE(cycles, 2) << "the drags are spread over the clients: " << r["per_client"];
  EXPECT_GT(r["busy"].get<int64_t>(), 0) << "three clients with drags a third of the time meet the one-session bound";
  EXPECT_GE(cycle["wait_ms"]["max"].get<double>(), cycle["wait_ms"]["p50"].get<double>());
  // Every drag that ended within the run released with a still Render, each answered with its frame: as many
  // release waits as drags that ended (the run's end may cut the last release's answer short, never more).
  const int64_t answered = cycle["releases_answered"].get<int64_t>();
  EXPECT_GE(answered, refused) << cycle;
  EXPECT_LE(answered, taken + refused + 3) << cycle;
  EXPECT_GT(cycle["release_ms"]["p50"].get<double>(), 0) << cycle;
  EXPECT_GE(cycle["release_ms"]["max"].get<double>(), cycle["release_ms"]["p50"].get<double>()) << cycle;
  EXPECT_EQ(r["errors"], 0) << r["error_samples"];
  // Without the option: null.
  EXPECT_TRUE(load("--clients 1 --duration 0.3 --drag 20")["drag_cycle"].is_null());
}

// Moving frames in JPEG travel at the size they were drawn (protocol version 8): sent as large as drawn.
TEST_F(LoadTest, DraggingClientsGetStillEncodedMovingFramesAtTheirDrawnSize) {
  const json r = load("--clients 1 --duration 1 --drag 20 --interactive 10 --size 256x256 --encoding png "
                      "--provisional-encoding jpeg --require-clean");
  ASSERT_TRUE(r["drawn_scale"].is_object() && r["sent_scale"].is_object()) << r.dump();
  for (const char* p : {"p10", "p50", "p90"}) EXPECT_EQ(r["sent_scale"][p], r["drawn_scale"][p]) << r.dump();
  EXPECT_LT(r["sent_scale"]["p10"].get<double>(), 1) << "the first frame is the cheapest drawing: " << r.dump();
}

// Dragging clients asking their moving frames as a vp8 stream decode every video frame in order, each client's
// stream starting with one key frame; the report says so beside bytes and latency.
TEST_F(LoadTest, DraggingClientsDecodeTheirVideoStreams) {
  const json r = load("--clients 2 --duration 1.5 --drag 20 --interactive 30 --encoding png "
                      "--provisional-encoding vp8 --require-clean");
  EXPECT_EQ(r["provisional_encoding"], "vp8");
  ASSERT_TRUE(r["video"].is_object()) << r.dump();
  EXPECT_GT(r["video"]["frames"].get<int64_t>(), 4);
  EXPECT_EQ(r["video"]["key_frames"].get<int64_t>(), 2) << "one key frame a client: its stream's first";
  EXPECT_GT(r["video"]["decode_ms"]["p50"].get<double>(), 0);
  EXPECT_EQ(r["video"]["frames_444"], 0) << "vp8 has no 4:4:4";
  EXPECT_EQ(r["errors"], 0);
  // The drawings' and the stream's sides, as fractions of the scene's.
  for (const char* key : {"drawn_scale", "sent_scale"}) {
    ASSERT_TRUE(r[key].is_object()) << key << ": " << r.dump();
    EXPECT_GT(r[key]["p10"].get<double>(), 0) << r[key];
    EXPECT_LE(r[key]["p10"].get<double>(), r[key]["p50"].get<double>()) << r[key];
    EXPECT_LE(r[key]["p50"].get<double>(), r[key]["p90"].get<double>()) << r[key];
    EXPECT_LE(r[key]["p90"].get<double>(), 1) << r[key];
  }
  // Frames after the first are chosen by the rate the first ones measured: their predicted and actual times.
  ASSERT_TRUE(r["interactive_ms"].is_object()) << r.dump();
  EXPECT_GT(r["interactive_ms"]["predicted_p50"].get<double>(), 0) << r["interactive_ms"];
  EXPECT_GT(r["interactive_ms"]["actual_p50"].get<double>(), 0) << r["interactive_ms"];
}

// --vp9-444: the clients' vp9 streams come in 4:4:4 (protocol version 9), each frame decoded as 4:2:0's are.
TEST_F(LoadTest, DraggingClientsAskingVp9InFourFourFourGetIt) {
  const json r = load("--clients 1 --duration 1 --drag 20 --interactive 30 --encoding png "
                      "--provisional-encoding vp9 --vp9-444 --require-clean");
  ASSERT_TRUE(r["video"].is_object()) << r.dump();
  EXPECT_GT(r["video"]["frames"].get<int64_t>(), 2);
  EXPECT_EQ(r["video"]["frames_444"], r["video"]["frames"]) << r.dump();
  EXPECT_EQ(r["errors"], 0);
}

}  // namespace
}  // namespace voxbrick
