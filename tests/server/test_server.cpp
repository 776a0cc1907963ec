// The render service end to end: the real `voxbrick serve` process, real sockets on loopback, real GL (llvmpipe).
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "ServerProcess.h"
#include "client/Client.h"
#include "image/FrameImage.h"
#include "image/Image.h"
#include "render/engine/Datasets.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using client::Client;
using client::ServerError;
using nlohmann::json;
using proto::ErrorCode;
using test::ScratchDir;
using test::ServerProcess;

class ServerTest : public test::SparseDatasetSuite {
 protected:
  std::unique_ptr<ServerProcess> start(const std::string& extra = "", int renderThreads = 2) {
    return std::make_unique<ServerProcess>(
        "--datasets " + datasets() + " --render-threads " + std::to_string(renderThreads) + " " + extra, scratch());
  }
};

const char* kScene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [80, 64], "transfer_function": "sparse",
                         "step": 0.75})";

std::unique_ptr<Client> session(const ServerProcess& server, const std::string& dataset = "sparse") {
  auto c = std::make_unique<Client>("127.0.0.1", server.port(), std::chrono::seconds(60));
  c->hello("test");
  if (!dataset.empty()) c->openDataset(dataset);
  return c;
}

std::vector<uint8_t> pixels(const proto::Frame& frame) { return image::decodeFrameImage(frame).rgba; }

/// The error a request gets; fails the test if it gets anything else.
ErrorCode errorOf(const std::function<void()>& request) {
  try {
    request();
  } catch (const ServerError& e) {
    return e.code();
  }
  ADD_FAILURE() << "the request succeeded";
  return ErrorCode::Internal;
}

/// Reads until the server closes; returns the error codes it sent first.
std::vector<ErrorCode> errorsUntilClosed(Client& c) {
  std::vector<ErrorCode> codes;
  try {
    for (;;) {
      auto [id, m] = c.receive();
      if (auto* e = std::get_if<proto::Error>(&m)) codes.push_back(e->code);
    }
  } catch (const client::ConnectionError& e) {
    EXPECT_NE(std::string(e.what()).find("closed"), std::string::npos) << e.what();
  }
  return codes;
}

TEST_F(ServerTest, ServedFramesEqualTheRenderCommandBitForBit) {
  auto server = start();
  auto c = session(*server);
  EXPECT_EQ(c->listDatasets(), std::vector<std::string>{"sparse"});
  const proto::Frame png = c->render(kScene, proto::Encoding::Png);
  ASSERT_EQ(png.width, 80u);
  ASSERT_EQ(png.height, 64u);
  const json stats = json::parse(png.statsJson);
  EXPECT_GT(stats["bricks_drawn"].get<int>(), 0);
  EXPECT_TRUE(stats.contains("queue_ms") && stats.contains("encode_ms"));
  EXPECT_EQ(stats["png_speed"], "fast") << "a link that keeps up gets png frames encoded fast";

  test::writeFile(scratch() / "scene.json", std::string(kScene));
  const auto r = test::runVoxbrick("render " + datasets() + "/sparse --scene " + (scratch() / "scene.json").string() +
                                   " -q -o " + (scratch() / "rendered.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const image::Image8 rendered = image::readPng(scratch() / "rendered.png");
  const std::vector<uint8_t> served = pixels(png);
  ASSERT_EQ(served.size(), rendered.rgba.size());
  EXPECT_EQ(served, rendered.rgba) << "the served frame differs from `voxbrick render` with the same scene";
  size_t lit = 0;
  for (size_t i = 0; i < served.size(); i += 4) lit += served[i] > 0 ? 1 : 0;
  EXPECT_GT(lit, 100u) << "an empty frame would prove nothing";

  // The other encodings carry the same pixels.
  EXPECT_EQ(pixels(c->render(kScene, proto::Encoding::RawRgba8)), served);
  EXPECT_EQ(pixels(c->render(kScene, proto::Encoding::ZstdRgba8)), served);
  ASSERT_GE(c->version(), 7) << "webp";
  const proto::Frame webp = c->render(kScene, proto::Encoding::Webp);
  EXPECT_EQ(webp.encoding, proto::Encoding::Webp);
  EXPECT_EQ(pixels(webp), served);
  EXPECT_LT(webp.payload.size(), png.payload.size());
  // A scene that accepts webp on a link that keeps up (loopback, nothing measured slow) still gets png.
  std::string accepting(kScene);
  accepting.insert(accepting.rfind('}'), R"(, "accepts_webp": true)");
  EXPECT_EQ(c->render(accepting, proto::Encoding::Png).encoding, proto::Encoding::Png);
  c->goodbye();
}

TEST_F(ServerTest, APngAboveTheMessageLimitGoesAsWebpToASceneThatAcceptsIt) {
  // The limit set between the frame's png and its webp (measured first): a scene that accepts webp gets the same
  // pixels as webp, saying why in its statistics; one that does not is answered LimitExceeded, as before.
  std::string scene(kScene);
  scene.replace(scene.find("[80, 64]"), 8, "[320, 256]");
  std::string accepting = scene;
  accepting.insert(accepting.rfind('}'), R"(, "accepts_webp": true)");
  proto::Frame png, webp;
  {
    auto server = start();
    auto c = session(*server);
    png = c->render(scene, proto::Encoding::Png);
    webp = c->render(scene, proto::Encoding::Webp);
  }
  const auto body = [](const proto::Frame& f) { return f.statsJson.size() + f.payload.size() + 17; };
  ASSERT_LT(body(webp) + 4096, body(png));
  const size_t limit = (body(png) + body(webp)) / 2;
  auto server = start("--max-message-bytes " + std::to_string(limit));
  auto c = session(*server);
  const proto::Frame sent = c->render(accepting, proto::Encoding::Png);
  EXPECT_EQ(sent.encoding, proto::Encoding::Webp);
  EXPECT_EQ(pixels(sent), pixels(png));
  EXPECT_TRUE(json::parse(sent.statsJson).value("webp_for_size", false)) << sent.statsJson;
  EXPECT_EQ(errorOf([&] { c->render(scene, proto::Encoding::Png); }), ErrorCode::LimitExceeded);
  EXPECT_EQ(c->render(accepting, proto::Encoding::Png).encoding, proto::Encoding::Webp) << "the session goes on";
}

// Lossless webp is version 7's: an older session asking for it as the Render's encoding is Malformed, and a scene
// accepting it is InvalidScene naming the key and the version; the session goes on.
TEST_F(ServerTest, WebpIsRefusedToAnOlderSessionNamingTheVersion) {
  auto server = start();
  auto c = std::make_unique<Client>("127.0.0.1", server->port(), std::chrono::seconds(60));
  c->hello("test", 6);
  c->openDataset("sparse");
  EXPECT_THROW(c->render(kScene, proto::Encoding::Webp), std::invalid_argument) << "the client knows v6 lacks it";
  std::string accepting(kScene);
  accepting.insert(accepting.rfind('}'), R"(, "accepts_webp": true)");
  try {
    c->render(accepting, proto::Encoding::Png);
    ADD_FAILURE() << "a version-6 session's scene accepting webp was rendered";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), ErrorCode::InvalidScene);
    EXPECT_NE(std::string(e.what()).find("'accepts_webp' needs protocol version 7"), std::string::npos) << e.what();
  }
  EXPECT_EQ(c->render(kScene, proto::Encoding::Png).encoding, proto::Encoding::Png);
  c->goodbye();
}

// Quality by target over the wire: a Render whose scene asks for "psnr:40" is drawn with the setting the dataset's
// quality table names, says so in its statistics, and equals the frame of that setting asked for directly; a dataset
// without a table answers with an error that says how to make one.
TEST_F(ServerTest, AQualityTargetIsResolvedFromTheDatasetsTable) {
  auto server = start();
  auto c = session(*server);
  json scene = json::parse(kScene);
  scene.erase("step");
  scene["quality"] = "psnr:40";
  const ErrorCode code = errorOf([&] { c->render(scene.dump()); });
  EXPECT_EQ(code, ErrorCode::InvalidScene);

  // Step 2 is fast and coarse, step 0.5 slow and fine (made-up figures, as bench --calibrate would write them).
  const std::filesystem::path table = std::filesystem::path(datasets()) / "sparse" / "quality.json";
  test::writeFile(table, json{{"format", "voxbrick-quality"},
                              {"version", 1},
                              {"device", "test"},
                              {"size", {80, 64}},
                              {"views", 2},
                              {"entries",
                               {{{"transfer_function", "sparse"},
                                 {"shading", false},
                                 {"step", 2},
                                 {"raycast", true},
                                 {"slab", 0},
                                 {"ert", 0.999},
                                 {"pre_integration", false},
                                 {"sub_block", 8},
                                 {"lod", 0},
                                 {"ms_median", 10},
                                 {"psnr_min", 35}},
                                {{"transfer_function", "sparse"},
                                 {"shading", false},
                                 {"step", 0.5},
                                 {"raycast", true},
                                 {"slab", 0},
                                 {"ert", 0.999},
                                 {"pre_integration", false},
                                 {"sub_block", 8},
                                 {"lod", 0},
                                 {"ms_median", 30},
                                 {"psnr_min", 48}}}}}
                             .dump());
  const proto::Frame frame = c->render(scene.dump());
  const json stats = json::parse(frame.statsJson);
  ASSERT_TRUE(stats.contains("quality")) << frame.statsJson;
  EXPECT_EQ(stats["quality"]["setting"], "step 0.5, raycast, ert 0.999, sub-block 8");
  EXPECT_EQ(stats["quality"]["met"], true);
  EXPECT_EQ(stats["quality"]["expected_psnr"], 48);
  json direct = json::parse(kScene);
  direct["step"] = 0.5;
  EXPECT_EQ(pixels(frame), pixels(c->render(direct.dump())));
  direct["step"] = 2;
  EXPECT_NE(pixels(frame), pixels(c->render(direct.dump()))) << "the two settings must draw different frames";
  std::filesystem::remove(table);
  c->goodbye();
}

// A .vdb in the datasets directory is listed and served live, with the frames of the store prep makes of it.
TEST_F(ServerTest, ServesAVdbFileWithTheFramesOfItsPreppedStore) {
  const std::filesystem::path work = scratch() / "vdb-case", datasets = work / "datasets";
  std::filesystem::create_directories(datasets);
  auto run = [](const std::string& args) {
    const auto r = test::runVoxbrick(args);
    ASSERT_EQ(r.exitCode, 0) << r.output;
  };
  run("prep synthetic:sparse,n=64 --brick 16 -q -o " + (work / "withvdb").string());
  std::filesystem::copy_file(work / "withvdb" / "vdb" / "level0-z00000.vdb", datasets / "sparse.vdb");
  // The server reads a .vdb with the defaults (first float grid, bricks of 32), so the store is prepped likewise.
  run("prep " + (datasets / "sparse.vdb").string() + " --no-vdb -q -o " + (datasets / "sparse-prepped").string());

  ServerProcess server("--datasets " + datasets.string() + " --render-threads 2", work);
  auto c = session(server, "");
  EXPECT_EQ(c->listDatasets(), (std::vector<std::string>{"sparse-prepped", "sparse.vdb"}));
  const proto::DatasetInfo liveInfo = c->openDataset("sparse.vdb");
  const std::vector<uint8_t> live = pixels(c->render(kScene, proto::Encoding::RawRgba8));
  const proto::DatasetInfo preppedInfo = c->openDataset("sparse-prepped");
  const std::vector<uint8_t> prepped = pixels(c->render(kScene, proto::Encoding::RawRgba8));
  EXPECT_EQ(json::parse(liveInfo.metaJson)["value_range"], json::parse(preppedInfo.metaJson)["value_range"]);
  EXPECT_EQ(json::parse(liveInfo.metaJson)["dims"], json::parse(preppedInfo.metaJson)["dims"]);
  ASSERT_EQ(live.size(), prepped.size());
  EXPECT_EQ(live, prepped) << "the .vdb served live differs from its prepped store";
  size_t lit = 0;
  for (size_t i = 0; i < live.size(); i += 4) lit += live[i] > 0 ? 1 : 0;
  EXPECT_GT(lit, 100u) << "an empty frame would prove nothing";
  // The same frame again, now from bricks the host cache holds.
  c->openDataset("sparse.vdb");
  EXPECT_EQ(pixels(c->render(kScene, proto::Encoding::RawRgba8)), live);
  c->goodbye();
}

// A tetrahedral mesh store is a dataset like a grid: listed, described with its kind, served with the frames of
// `voxbrick render`.
TEST_F(ServerTest, ServesATetMeshWithTheRenderCommandsFrame) {
  const std::filesystem::path work = scratch() / "mesh-case", datasets = work / "datasets";
  std::filesystem::create_directories(datasets);
  auto r = test::runVoxbrick("prep synthetic-mesh:ball,n=10 -q -o " + (datasets / "ball").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  ServerProcess server("--datasets " + datasets.string() + " --render-threads 2", work);
  auto c = session(server, "");
  EXPECT_EQ(c->listDatasets(), std::vector<std::string>{"ball"});
  const json meta = json::parse(c->openDataset("ball").metaJson);
  EXPECT_EQ(meta["kind"], "tet-mesh");
  EXPECT_GT(meta["tets"].get<int>(), 1000);
  // The default drawing, ray cast: served as `render` draws it.
  const std::string scene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [80, 64], "transfer_function": "hot"})";
  const proto::Frame frame = c->render(scene, proto::Encoding::RawRgba8);
  EXPECT_GE(json::parse(frame.statsJson)["tet_ray_passes"].get<int>(), 2) << frame.statsJson;
  test::writeFile(work / "scene.json", scene);
  r = test::runVoxbrick("render " + (datasets / "ball").string() + " --scene " + (work / "scene.json").string() +
                        " -q -o " + (work / "rendered.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const std::vector<uint8_t> served = pixels(frame);
  EXPECT_EQ(served, image::readPng(work / "rendered.png").rgba) << "the served mesh frame differs from `render`";
  size_t lit = 0;
  for (size_t i = 0; i < served.size(); i += 4) lit += served[i] > 0 ? 1 : 0;
  EXPECT_GT(lit, 500u) << "an empty frame would prove nothing";
  EXPECT_GT(json::parse(frame.statsJson)["samples_estimated"].get<double>(), 0.0);
  // Projected in MPVO order (the seed's drawing): every tet drawn, the same frame within the ray's termination.
  const std::string mpvoScene =
      R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [80, 64], "transfer_function": "hot", "visibility": "mpvo"})";
  const proto::Frame mpvoFrame = c->render(mpvoScene, proto::Encoding::RawRgba8);
  EXPECT_EQ(json::parse(mpvoFrame.statsJson)["tets_drawn"], meta["tets"]);
  EXPECT_EQ(json::parse(mpvoFrame.statsJson)["tet_ray_passes"], 0);
  const std::vector<uint8_t> projected = pixels(mpvoFrame);
  ASSERT_EQ(projected.size(), served.size());
  for (size_t i = 0; i < projected.size(); ++i) ASSERT_NEAR(int(projected[i]), int(served[i]), 2) << i;
  c->goodbye();
  // The frame-cost limit holds for meshes too: a large frame is refused before drawing, a small one is drawn.
  ServerProcess limited("--datasets " + datasets.string() + " --max-render-msamples 1", work);
  auto l = session(limited, "ball");
  const char* large = R"({"camera": {"orbit": [40, 25, 1.5]}, "size": [1024, 1024], "transfer_function": "hot"})";
  EXPECT_EQ(errorOf([&] { l->render(large); }), ErrorCode::LimitExceeded);
  EXPECT_EQ(l->render(scene).width, 80u);
}

// A mesh larger than the server's host cache is paged by view: a frame whose chunks fit is served as `render` draws
// it under the same budget; a view whose chunks cannot fit is refused with LimitExceeded and the session goes on.
TEST_F(ServerTest, ServesAMeshLargerThanItsHostBudgetPagedByView) {
  const std::filesystem::path work = scratch() / "paged-mesh", datasets = work / "datasets";
  std::filesystem::create_directories(datasets);
  // 444528 tets: 17 MiB held whole, above the smallest host cache a server takes (16 MiB).
  auto r = test::runVoxbrick("prep synthetic-mesh:box,n=42 --tets-per-chunk 2048 -q -o " + (datasets / "box").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  ServerProcess server("--datasets " + datasets.string() + " --host-cache 16 --render-threads 1", work);
  auto c = session(server, "");
  const json meta = json::parse(c->openDataset("box").metaJson);
  EXPECT_EQ(meta["paged"], true);
  EXPECT_EQ(meta["tets"].get<int>(), 444528);
  // ct-bone leaves the low values transparent: the chunks it shows fit.
  const std::string scene = R"({"camera": {"orbit": [40, 25]}, "size": [80, 64], "transfer_function": "ct-bone"})";
  const proto::Frame frame = c->render(scene, proto::Encoding::RawRgba8);
  const json stats = json::parse(frame.statsJson);
  EXPECT_GT(stats["tet_chunks_skipped_empty"].get<int>(), 0) << frame.statsJson;
  EXPECT_GT(stats["tet_chunks_read"].get<int>(), 0) << frame.statsJson;
  test::writeFile(work / "scene.json", scene);
  r = test::runVoxbrick("render " + (datasets / "box").string() + " --host-cache 16 --scene " +
                        (work / "scene.json").string() + " -o " + (work / "rendered.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("mesh paged within 16.0 MiB"), std::string::npos) << r.output;
  const std::vector<uint8_t> served = pixels(frame);
  EXPECT_EQ(served, image::readPng(work / "rendered.png").rgba) << "the served paged frame differs from `render`";
  size_t lit = 0;
  for (size_t i = 0; i < served.size(); i += 4) lit += served[i] > 0 ? 1 : 0;
  EXPECT_GT(lit, 300u) << "an empty frame would prove nothing";
  // hot shows every value: the whole box would be needed.
  const std::string all = R"({"camera": {"orbit": [40, 25]}, "size": [80, 64], "transfer_function": "hot"})";
  try {
    c->render(all);
    ADD_FAILURE() << "a view needing more than the host budget was served";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), ErrorCode::LimitExceeded);
    EXPECT_NE(std::string(e.what()).find("this view needs"), std::string::npos) << e.what();
  }
  EXPECT_EQ(pixels(c->render(scene, proto::Encoding::RawRgba8)), served) << "the session goes on";
  const json serverStats = json::parse(c->stats());
  ASSERT_EQ(serverStats["datasets"].size(), 1u);
  EXPECT_LE(serverStats["datasets"][0]["cache"]["peak_resident_bytes"].get<size_t>(), size_t(16) << 20)
      << serverStats.dump();
  // Replaced on disk by a small mesh (`prep --force`): the same session draws the new one, held whole.
  r = test::runVoxbrick("prep synthetic-mesh:ball,n=10 --force -q -o " + (datasets / "box").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const proto::Frame replaced = c->render(all, proto::Encoding::RawRgba8);
  EXPECT_EQ(json::parse(replaced.statsJson)["tet_chunks_read"], 0) << replaced.statsJson;
  EXPECT_NE(pixels(replaced), served);
  c->goodbye();
}

TEST_F(ServerTest, MalformedMessagesGetTheirErrorsAndOtherSessionsGoOn) {
  auto server = start();
  auto good = session(*server);
  const std::vector<uint8_t> reference = pixels(good->render(kScene, proto::Encoding::RawRgba8));
  auto goodStillServed = [&] { EXPECT_EQ(pixels(good->render(kScene, proto::Encoding::RawRgba8)), reference); };

  // Errors that leave the session open.
  Client bad("127.0.0.1", server->port());
  EXPECT_EQ(errorOf([&] { bad.listDatasets(); }), ErrorCode::UnexpectedMessage);  // before Hello
  bad.hello();
  EXPECT_EQ(errorOf([&] { bad.render(kScene); }), ErrorCode::UnexpectedMessage);  // before OpenDataset
  EXPECT_EQ(errorOf([&] { bad.openDataset("../etc"); }), ErrorCode::UnknownDataset);
  EXPECT_EQ(errorOf([&] { bad.openDataset("nope"); }), ErrorCode::UnknownDataset);
  bad.openDataset("sparse");
  EXPECT_EQ(errorOf([&] { bad.render("{not json"); }), ErrorCode::InvalidScene);
  EXPECT_EQ(errorOf([&] { bad.render(R"({"size": [64, 0]})"); }), ErrorCode::InvalidScene);
  EXPECT_EQ(errorOf([&] { bad.render(R"({"size": [4294967808, 64]})"); }), ErrorCode::InvalidScene);
  EXPECT_EQ(errorOf([&] { bad.render(R"({"step": -1})"); }), ErrorCode::InvalidScene);
  EXPECT_EQ(errorOf([&] { bad.render(R"({"transfer_function": "/etc/passwd"})"); }), ErrorCode::InvalidScene);
  EXPECT_EQ(errorOf([&] { bad.render(R"({"size": [5000, 64]})"); }), ErrorCode::LimitExceeded);
  {
    proto::Header h;
    h.type = proto::MessageType(999);
    h.bodyBytes = 3;
    auto head = proto::encodeHeader(h);
    std::vector<uint8_t> bytes(head.size() + 3, 1);  // a body of three bytes
    std::copy(head.begin(), head.end(), bytes.begin());
    bad.sendBytes(bytes);
    auto [id, m] = bad.receive();
    ASSERT_TRUE(std::holds_alternative<proto::Error>(m));
    EXPECT_EQ(std::get<proto::Error>(m).code, ErrorCode::UnknownType);
  }
  {
    std::vector<uint8_t> bytes = proto::encode(proto::OpenDataset{"sparse"}, 7);
    bytes.push_back(0);  // a trailing byte inside the declared body
    bytes[12] += 1;
    bad.sendBytes(bytes);
    auto [id, m] = bad.receive();
    ASSERT_TRUE(std::holds_alternative<proto::Error>(m));
    EXPECT_EQ(std::get<proto::Error>(m).code, ErrorCode::Malformed);
    EXPECT_EQ(id, 7u);
  }
  EXPECT_EQ(bad.listDatasets().size(), 1u);  // still served
  goodStillServed();

  // Errors that close the connection: bad magic, unsupported version, a body over the limit.
  {
    Client c("127.0.0.1", server->port());
    c.sendBytes(std::vector<uint8_t>(16, 'x'));
    EXPECT_EQ(errorsUntilClosed(c), std::vector<ErrorCode>{ErrorCode::BadMagic});
  }
  {
    Client c("127.0.0.1", server->port());
    proto::Header h;
    h.version = proto::kMaxVersion + 1;
    auto head = proto::encodeHeader(h);
    c.sendBytes(std::vector<uint8_t>(head.begin(), head.end()));
    EXPECT_EQ(errorsUntilClosed(c), std::vector<ErrorCode>{ErrorCode::UnsupportedVersion});
  }
  {
    Client c("127.0.0.1", server->port());
    proto::Header h;
    h.type = proto::MessageType::Render;
    h.bodyBytes = 0xFFFFFFFFu;
    auto head = proto::encodeHeader(h);
    c.sendBytes(std::vector<uint8_t>(head.begin(), head.end()));
    EXPECT_EQ(errorsUntilClosed(c), std::vector<ErrorCode>{ErrorCode::TooLarge});
  }
  {
    Client c("127.0.0.1", server->port());
    c.send(proto::Hello{uint16_t(proto::kMaxVersion + 1), uint16_t(proto::kMaxVersion + 2), "future"});  // above ours
    EXPECT_EQ(errorsUntilClosed(c), std::vector<ErrorCode>{ErrorCode::UnsupportedVersion});
  }
  {  // a client that leaves mid-frame
    auto c = session(*server);
    c->send(proto::RenderRequest{proto::Encoding::Png, kScene});
    c->close();
  }
  goodStillServed();
  EXPECT_TRUE(server->running());
}

TEST_F(ServerTest, LimitsAreEnforced) {
  // The message limit holds for replies too: 64 KiB leaves room for a 100x100 PNG frame.
  auto server = start("--max-sessions 3 --idle-timeout 1 --max-image-side 100 --max-message-bytes 65536");
  auto a = session(*server);
  // Image side and message size.
  EXPECT_EQ(errorOf([&] { a->render(R"({"size": [101, 10]})"); }), ErrorCode::LimitExceeded);
  {
    auto c = session(*server);
    std::string big = R"({"step": 1, "background": [0, 0, 0])";
    big += std::string(70000, ' ') + "}";
    // The server refuses the message from its header and closes: the rest of it may meet a closed socket.
    try {
      c->send(proto::RenderRequest{proto::Encoding::Png, big});
    } catch (const client::ConnectionError&) {
    }
    EXPECT_EQ(errorsUntilClosed(*c), std::vector<ErrorCode>{ErrorCode::TooLarge});
  }
  // Sessions: two more fit, the fourth is refused.
  auto b = session(*server, "");
  auto c = session(*server, "");
  {
    Client d("127.0.0.1", server->port());
    EXPECT_EQ(errorsUntilClosed(d), std::vector<ErrorCode>{ErrorCode::LimitExceeded});
  }
  // Idle sessions are closed after a second; a session waiting for its frame is not idle.
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  EXPECT_EQ(errorsUntilClosed(*b), std::vector<ErrorCode>{ErrorCode::Timeout});
  auto fresh = session(*server);  // room again
  EXPECT_EQ(fresh->render(R"({"size": [100, 100], "transfer_function": "sparse"})").width, 100u);
  const json stats = json::parse(fresh->stats());
  EXPECT_GE(stats["sessions"]["refused"].get<int>(), 1);
  EXPECT_GE(stats["sessions"]["timed_out"].get<int>(), 1);
}

/// An environment variable set for the servers a test starts, put back as it was after.
class SetForServers {
 public:
  SetForServers(const char* name, const std::string& value) : mName(name) {
    if (const char* before = std::getenv(name)) mBefore = before;
    ::setenv(name, value.c_str(), 1);
  }
  ~SetForServers() { mBefore ? ::setenv(mName, mBefore->c_str(), 1) : ::unsetenv(mName); }
  SetForServers(const SetForServers&) = delete;
  SetForServers& operator=(const SetForServers&) = delete;

 private:
  const char* mName;
  std::optional<std::string> mBefore;
};

// Without --config, serve reads server.toml from the configuration directory (an installed PREFIX/share/voxbrick,
// the source tree's config/, or $VOXBRICK_CONFIG_DIR), and --no-config reads none.
TEST_F(ServerTest, ServeReadsTheConfigurationDirectorysServerTomlUnlessToldNot) {
  test::ScratchDir dir;
  std::filesystem::create_directories(dir / "config");
  const std::string file = (dir / "config" / "server.toml").string();
  test::writeFile(file, std::string("[limits]\nmax_image_side = 64\n"));
  std::unique_ptr<ServerProcess> configured, defaults;
  {
    SetForServers configDir("VOXBRICK_CONFIG_DIR", (dir / "config").string());
    configured = start();
    defaults = start("--no-config");
  }
  // kScene is 80 pixels wide: above the file's limit, within the default's.
  auto limited = session(*configured);
  EXPECT_EQ(errorOf([&] { limited->render(kScene); }), ErrorCode::LimitExceeded);
  EXPECT_NE(configured->log().find("configuration: " + file), std::string::npos) << configured->log();
  EXPECT_EQ(session(*defaults)->render(kScene).width, 80u);
  EXPECT_NE(defaults->log().find("configuration: the built-in defaults"), std::string::npos) << defaults->log();
}

TEST_F(ServerTest, FramesAboveTheMessageLimitAreRefusedNotSent) {
  // The default body limit is 1 MiB in both directions (PROTOCOL.md, Limits): a 512x512 raw frame needs 1 MiB of
  // pixels and more, so it is refused before it is drawn; a PNG of it fits; a larger limit lets the raw one through.
  auto server = start();
  auto c = session(*server);
  const std::string scene = R"({"size": [512, 512], "transfer_function": "sparse"})";
  try {
    c->render(scene, proto::Encoding::RawRgba8);
    ADD_FAILURE() << "a frame above the limit was sent";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), ErrorCode::LimitExceeded);
    EXPECT_NE(std::string(e.what()).find("1048576"), std::string::npos) << e.what();
  }
  const json cache = json::parse(c->stats())["datasets"][0]["cache"];
  EXPECT_EQ(cache["hits"].get<int>() + cache["misses"].get<int>(), 0) << "refused before drawing: no brick read";
  EXPECT_EQ(c->render(scene, proto::Encoding::Png).width, 512u);
  // Encoded frames are checked once encoded: a noisy PNG larger than a tiny limit is refused too.
  auto tiny = start("--max-message-bytes 4096");
  auto t = session(*tiny);
  EXPECT_EQ(errorOf([&] { t->render(R"({"size": [256, 256], "transfer_function": "sparse"})"); }),
            ErrorCode::LimitExceeded);
  auto large = start("--max-message-bytes 2000000");
  EXPECT_EQ(pixels(session(*large)->render(scene, proto::Encoding::RawRgba8)).size(), size_t(512) * 512 * 4);
}

TEST_F(ServerTest, AbandonedRendersAreCancelledAndCostlyOnesRefused) {
  // A render far longer than the test's frames (step 0.002: about 300 million samples of a 64³ field).
  const std::string heavy = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [256, 256], "transfer_function": "sparse",
                                "step": 0.002})";
  {
    auto server = start("", 1);  // one render thread: before, the abandoned frame held it to the end
    {
      auto gone = session(*server);
      gone->send(proto::RenderRequest{proto::Encoding::Png, heavy});
      std::this_thread::sleep_for(std::chrono::milliseconds(700));  // drawing now
    }                                                               // the client leaves without its frame
    auto c = session(*server);
    const proto::Frame frame = c->render(kScene, proto::Encoding::RawRgba8);
    EXPECT_EQ(frame.width, 80u);
    const json stats = json::parse(c->stats());
    EXPECT_EQ(stats["renders"]["cancelled"].get<int>(), 1) << stats.dump();
    EXPECT_EQ(stats["renders"]["frames"].get<int>(), 1) << "the abandoned frame was never finished";
  }
  // A cost limit: the heavy scene is refused before it is drawn, naming the limit; the ordinary one is drawn.
  auto server = start("--max-render-msamples 100");
  auto c = session(*server);
  try {
    c->render(heavy);
    ADD_FAILURE() << "a render above the cost limit was drawn";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), ErrorCode::LimitExceeded);
    EXPECT_NE(std::string(e.what()).find("million samples, above the limit of 100 million"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(c->render(kScene, proto::Encoding::RawRgba8).width, 80u);
  EXPECT_LE(json::parse(c->stats())["renders"]["frames"].get<int>(), 1);
}

TEST_F(ServerTest, ANewerRenderReplacesOneStillQueued) {
  auto server = start("", 1);
  auto c = session(*server);
  // Eight cameras sent at once, as a drag would: every request gets exactly one reply, the last one a frame,
  // and the ones replaced while waiting are answered Superseded.
  std::vector<uint32_t> ids;
  for (int i = 0; i < 8; ++i) {
    json scene = json::parse(kScene);
    scene["camera"]["orbit"] = {10.0 * i, 20, 2.2};
    scene["size"] = {160, 160};
    ids.push_back(c->send(proto::RenderRequest{proto::Encoding::Png, scene.dump()}));
  }
  std::map<uint32_t, std::string> replies;
  while (replies.size() < ids.size()) {
    auto [id, m] = c->receive();
    ASSERT_FALSE(replies.count(id)) << "two replies to request " << id;
    if (auto* e = std::get_if<proto::Error>(&m)) {
      EXPECT_EQ(e->code, ErrorCode::Superseded) << e->message;
      replies[id] = "superseded";
    } else {
      ASSERT_TRUE(std::holds_alternative<proto::Frame>(m));
      replies[id] = "frame";
    }
  }
  EXPECT_EQ(replies[ids.back()], "frame");
  int superseded = 0;
  for (const auto& [id, what] : replies) superseded += what == "superseded" ? 1 : 0;
  EXPECT_GE(superseded, 4) << "with one render thread most of a burst should be replaced";
}

TEST_F(ServerTest, ShutsDownCleanlyOnSignals) {
  for (int signal : {SIGTERM, SIGINT}) {
    auto server = start();
    auto c = session(*server);
    c->render(kScene);
    auto idle = session(*server, "");
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_EQ(server->stop(signal), 0) << server->log();
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(10));
    EXPECT_EQ(errorsUntilClosed(*c), std::vector<ErrorCode>{ErrorCode::ShuttingDown});
    EXPECT_NE(server->log().find("stopped"), std::string::npos) << server->log();
  }
}

/// The environment process `pid` runs with (/proc): NAME -> value.
std::map<std::string, std::string> environmentOf(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/environ", std::ios::binary);
  std::map<std::string, std::string> env;
  for (std::string entry; std::getline(in, entry, '\0');)
    if (const size_t eq = entry.find('='); eq != std::string::npos) env[entry.substr(0, eq)] = entry.substr(eq + 1);
  return env;
}

/// The kernel's transparent huge page mode ("always", "madvise", "never"), "" where it does not say.
std::string hugePageMode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string modes;
  std::getline(in, modes);
  const size_t open = modes.find('['), close = modes.find(']');
  return open < close && close != std::string::npos ? modes.substr(open + 1, close - open - 1) : "";
}

TEST_F(ServerTest, AsksGlibcForHugePagesWhereTheKernelGrantsThemOnRequest) {
  // Where the kernel's mode is madvise (Debian's default), `serve` runs itself again with glibc's malloc asking for
  // transparent huge pages, keeping the tunables it was given; VOXBRICK_MALLOC_HUGE_PAGES=0 says no. In another
  // mode nothing is asked (always: granted unasked; never: none). Either way the server serves.
  const bool asks = hugePageMode() == "madvise";
  if (!std::getenv("GLIBC_TUNABLES")) {
    // The environment the process was started with (glibc cuts a list of tunables at its first ':' there).
    auto server = start();
    EXPECT_EQ(environmentOf(server->pid())["GLIBC_TUNABLES"], asks ? "glibc.malloc.hugetlb=1" : "");
  }
  {
    SetForServers tunables("GLIBC_TUNABLES", "glibc.malloc.perturb=0");
    auto server = start();
    EXPECT_EQ(session(*server)->render(kScene).width, 80u);
    EXPECT_NE(server->log().find(asks ? "malloc: GLIBC_TUNABLES=glibc.malloc.perturb=0:glibc.malloc.hugetlb=1; the "
                                        "kernel's transparent huge pages: madvise"
                                      : "malloc: the kernel's transparent huge pages"),
              std::string::npos)
        << server->log();
  }
  SetForServers off("VOXBRICK_MALLOC_HUGE_PAGES", "0");
  auto server = start();
  EXPECT_EQ(environmentOf(server->pid())["GLIBC_TUNABLES"].find("hugetlb"), std::string::npos);
  EXPECT_EQ(session(*server)->render(kScene).width, 80u);
  if (asks) {
    EXPECT_NE(server->log().find("VOXBRICK_MALLOC_HUGE_PAGES=0"), std::string::npos) << server->log();
  }
}

TEST_F(ServerTest, BadConfigurationIsRefusedWithTheKeyNamed) {
  test::writeFile(scratch() / "bad.toml", std::string("[limits]\nmax_sesions = 4\n"));
  auto r = test::runVoxbrick("serve --config " + (scratch() / "bad.toml").string());
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("unknown key limits.max_sesions"), std::string::npos) << r.output;
  test::writeFile(scratch() / "range.toml", std::string("[limits]\nmax_image_side = 100000\n"));
  r = test::runVoxbrick("serve --config " + (scratch() / "range.toml").string());
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("limits.max_image_side"), std::string::npos) << r.output;
  r = test::runVoxbrick("serve --datasets " + (scratch() / "missing").string() + " --port 0");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("does not exist"), std::string::npos) << r.output;
  // The shipped configuration is valid.
  auto server = std::make_unique<ServerProcess>(
      std::string("--config ") + VOXBRICK_SOURCE_DIR + "/config/server.toml --datasets " + datasets(), scratch());
  EXPECT_EQ(session(*server)->listDatasets().size(), 1u);
  // A port in use and a host that is not an address are errors that name them.
  r = test::runVoxbrick("serve --datasets " + datasets() + " --port " + std::to_string(server->port()));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("cannot listen on 127.0.0.1:" + std::to_string(server->port())), std::string::npos)
      << r.output;
  r = test::runVoxbrick("serve --datasets " + datasets() + " --host nowhere --port 0");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("host 'nowhere'"), std::string::npos) << r.output;
}

TEST_F(ServerTest, RequestCommandAndPythonClientGetTheSameFrame) {
  auto server = start();
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  test::writeFile(scratch() / "scene.json", std::string(kScene));
  auto r = test::runVoxbrick("request " + address + " --dataset sparse --scene " + (scratch() / "scene.json").string() +
                             " -o " + (scratch() / "request.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = test::runShell(std::string("python3 ") + VOXBRICK_SOURCE_DIR + "/examples/python/voxbrick_client.py " + address +
                     " --dataset sparse --scene " + (scratch() / "scene.json").string() + " -o " +
                     (scratch() / "python.png").string() + " 2>&1");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(image::readPng(scratch() / "request.png").rgba, image::readPng(scratch() / "python.png").rgba);
  r = test::runVoxbrick("request " + address + " --dataset nope -o " + (scratch() / "x.png").string());
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("UnknownDataset"), std::string::npos) << r.output;
}

/// kScene, progressive.
std::string progressiveScene() {
  json scene = json::parse(kScene);
  scene["progressive"] = true;
  return scene.dump();
}

// A cold server has no brick in memory: a progressive Render gets a provisional frame first (bricks drawn from the
// coarsest level while they are read), then the exact frame, which equals a plain Render's and `voxbrick render`'s.
TEST_F(ServerTest, AProgressiveRenderSendsAProvisionalFrameThenTheExactOne) {
  auto server = start();
  auto c = session(*server);
  std::vector<proto::Frame> provisional;
  const proto::Frame exact = c->render(progressiveScene(), proto::Encoding::RawRgba8,
                                       [&](const proto::Frame& f) { provisional.push_back(f); });
  ASSERT_EQ(provisional.size(), 1u) << "a cold cache must stand in";
  const json first = json::parse(provisional[0].statsJson), last = json::parse(exact.statsJson);
  EXPECT_TRUE(first["provisional"].get<bool>());
  EXPECT_GT(first["bricks_standin"].get<int>(), 0);
  EXPECT_FALSE(last["provisional"].get<bool>());
  EXPECT_EQ(last["bricks_standin"].get<int>(), 0);
  EXPECT_NE(pixels(provisional[0]), pixels(exact)) << "the provisional frame is coarser";
  size_t lit = 0;
  for (size_t i = 0; i < pixels(provisional[0]).size(); i += 4) lit += pixels(provisional[0])[i] > 0 ? 1 : 0;
  EXPECT_GT(lit, 100u) << "a provisional frame is never empty";

  // Everything is resident now: no provisional frame, and the same pixels as a plain Render.
  int more = 0;
  const proto::Frame again =
      c->render(progressiveScene(), proto::Encoding::RawRgba8, [&](const proto::Frame&) { ++more; });
  EXPECT_EQ(more, 0);
  EXPECT_EQ(pixels(again), pixels(exact));
  EXPECT_EQ(pixels(c->render(kScene, proto::Encoding::RawRgba8)), pixels(exact));
  const json stats = json::parse(c->stats());
  EXPECT_EQ(stats["renders"]["refined"].get<int>(), 1);
  c->goodbye();

  test::writeFile(scratch() / "scene.json", std::string(kScene));
  const auto r = test::runVoxbrick("render " + datasets() + "/sparse --scene " + (scratch() / "scene.json").string() +
                                   " -q -o " + (scratch() / "rendered.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(pixels(exact), image::readPng(scratch() / "rendered.png").rgba);
}

// The command-line clients expose it: each writes the provisional frame beside the exact one.
TEST_F(ServerTest, ClientsWriteTheProvisionalFrameOfAProgressiveRender) {
  test::writeFile(scratch() / "scene.json", std::string(kScene));
  const std::string scene = (scratch() / "scene.json").string();
  {
    auto server = start();
    const auto r = test::runVoxbrick("request 127.0.0.1:" + std::to_string(server->port()) +
                                     " --dataset sparse --progressive --scene " + scene + " -o " +
                                     (scratch() / "progressive.png").string());
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("provisional frame"), std::string::npos) << r.output;
    EXPECT_TRUE(std::filesystem::exists(scratch() / "progressive.provisional.png"));
  }
  {
    auto server = start();
    const auto r = test::runShell(std::string("python3 ") + VOXBRICK_SOURCE_DIR +
                                  "/examples/python/voxbrick_client.py 127.0.0.1:" + std::to_string(server->port()) +
                                  " --dataset sparse --progressive --scene " + scene + " -o " +
                                  (scratch() / "python-progressive.png").string() + " 2>&1");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("bricks stood in"), std::string::npos) << r.output;
    EXPECT_TRUE(std::filesystem::exists(scratch() / "python-progressive.provisional.png"));
  }
  EXPECT_EQ(image::readPng(scratch() / "progressive.png").rgba,
            image::readPng(scratch() / "python-progressive.png").rgba);
  EXPECT_NE(image::readPng(scratch() / "progressive.png").rgba,
            image::readPng(scratch() / "progressive.provisional.png").rgba);
}

/// The largest difference of one channel of two frames' pixels (8-bit RGBA of the same size), in 1/255.
int largestDifference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  EXPECT_EQ(a.size(), b.size());
  int worst = a.size() == b.size() ? 0 : 255;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, std::abs(int(a[i]) - int(b[i])));
  return worst;
}

// The GPU budget is the server's: whatever datasets two render threads draw, their atlases stay within it, the
// least recently used renderers giving way, and frames do not change: they are the frame drawn without the budget.
TEST_F(ServerTest, TheGpuBudgetHoldsAcrossDatasetsAndThreads) {
  ScratchDir many;
  const auto dir = many / "datasets";
  std::filesystem::create_directories(dir);
  // 512 bricks of 18^3 floats: 11.9 MB of atlas each, more than a thread's 8 MB share.
  const auto r = test::runVoxbrick("prep synthetic:sparse,n=128 --brick 16 --no-vdb -q -o " + (dir / "a").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  for (const char* name : {"b", "c"})
    std::filesystem::copy(dir / "a", dir / name, std::filesystem::copy_options::recursive);
  std::vector<uint8_t> unbudgeted;  // the three datasets are one volume: its frame with the whole atlas resident
  {
    ServerProcess whole("--datasets " + dir.string() + " --render-threads 1", many.path());
    unbudgeted = pixels(session(whole, "a")->render(kScene, proto::Encoding::RawRgba8));
    size_t lit = 0;
    for (size_t i = 0; i < unbudgeted.size(); i += 4) lit += unbudgeted[i] + unbudgeted[i + 1] + unbudgeted[i + 2] > 0;
    ASSERT_GT(lit, 100u) << "the frame shows the volume";
  }
  ServerProcess server("--datasets " + dir.string() + " --render-threads 2 --gpu-budget 16", many.path());
  std::map<std::string, std::vector<uint8_t>> first;
  for (int round = 0; round < 3; ++round)
    for (const char* name : {"a", "b", "c"}) {
      auto c = session(server, name);
      const std::vector<uint8_t> frame = pixels(c->render(kScene, proto::Encoding::RawRgba8));
      if (round == 0)
        first[name] = frame;
      else
        EXPECT_EQ(frame, first[name]) << name << ", round " << round;
      // Drawn in batches of what the budget holds, front to back as one batch would: the same pixels, or one
      // rounded the other way.
      EXPECT_LE(largestDifference(frame, unbudgeted), 1) << name << ", round " << round
                                                         << ": against the frame "
                                                            "drawn without the budget";
      const json gpu = json::parse(c->stats())["gpu"];
      EXPECT_EQ(gpu["budget_bytes"].get<uint64_t>(), uint64_t(16) << 20);
      EXPECT_LE(gpu["atlas_bytes"].get<uint64_t>(), uint64_t(16) << 20) << name << ", round " << round;
      EXPECT_LE(gpu["peak_atlas_bytes"].get<uint64_t>(), uint64_t(16) << 20) << name << ", round " << round;
      c->goodbye();
    }
  auto c = session(server, "");
  const json stats = json::parse(c->stats());
  EXPECT_GT(stats["gpu"]["renderers_released"].get<int>(), 0);
  EXPECT_EQ(first["a"], first["b"]);
  // The host budget (the default 1024 MB) is shared by the three datasets open.
  ASSERT_EQ(stats["datasets"].size(), 3u);
  uint64_t budgets = 0;
  for (const json& d : stats["datasets"]) {
    budgets += d["cache"]["budget_bytes"].get<uint64_t>();
    EXPECT_LE(d["cache"]["resident_bytes"].get<uint64_t>(), d["cache"]["budget_bytes"].get<uint64_t>());
  }
  EXPECT_LE(budgets, uint64_t(1024) << 20);
  EXPECT_GT(budgets, uint64_t(1000) << 20);
}

TEST_F(ServerTest, ACorruptDatasetIsQuarantinedAndEveryOtherKeepsRendering) {
  ScratchDir work;
  const auto dir = work / "datasets";
  std::filesystem::create_directories(dir);
  std::filesystem::copy(std::filesystem::path(datasets()) / "sparse", dir / "good",
                        std::filesystem::copy_options::recursive);
  std::filesystem::copy(dir / "good", dir / "bad", std::filesystem::copy_options::recursive);
  {
    // Eight bytes flipped every 2 KiB of bricks.bin: every brick of any size fails its decode.
    std::fstream file(dir / "bad" / "bricks.bin", std::ios::in | std::ios::out | std::ios::binary);
    const auto size = std::streamoff(std::filesystem::file_size(dir / "bad" / "bricks.bin"));
    for (std::streamoff at = 512; at + 8 < size; at += 2048) {
      char bytes[8];
      file.seekg(at);
      file.read(bytes, 8);
      for (char& c : bytes) c = static_cast<char>(~c);
      file.seekp(at);
      file.write(bytes, 8);
    }
    ASSERT_TRUE(file.good());
  }
  // One render thread: before, a failed frame left its context unusable for every later frame of any dataset.
  ServerProcess server("--datasets " + dir.string() + " --render-threads 1", work.path());
  auto good = session(server, "good");
  const std::vector<uint8_t> before = pixels(good->render(kScene, proto::Encoding::RawRgba8));

  auto bad = session(server, "bad");
  std::string first, second;
  try {
    bad->render(kScene, proto::Encoding::RawRgba8);
    ADD_FAILURE() << "a corrupt dataset rendered";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), ErrorCode::Internal);
    first = e.what();
  }
  EXPECT_NE(first.find("quarantined"), std::string::npos) << first;
  EXPECT_NE(first.find("bricks.bin"), std::string::npos) << first;
  for (int round = 0; round < 3; ++round) {
    EXPECT_EQ(pixels(good->render(kScene, proto::Encoding::RawRgba8)), before) << "round " << round;
    try {
      bad->render(kScene, proto::Encoding::RawRgba8);
      ADD_FAILURE() << "a quarantined dataset rendered";
    } catch (const ServerError& e) {
      EXPECT_EQ(e.code(), ErrorCode::Internal);
      second = e.what();
    }
    EXPECT_NE(second.find("is quarantined until it is replaced"), std::string::npos) << second;
  }
  const json stats = json::parse(good->stats());
  for (const json& d : stats["datasets"]) EXPECT_EQ(d["quarantined"].is_string(), d["name"] == "bad") << d.dump();

  // Replaced on disk (as `prep --force` does: a new directory): the same session draws the new data.
  std::filesystem::remove_all(dir / "bad");
  std::filesystem::copy(dir / "good", dir / "bad", std::filesystem::copy_options::recursive);
  EXPECT_EQ(pixels(bad->render(kScene, proto::Encoding::RawRgba8)), before);
  auto again = session(server, "bad");
  EXPECT_EQ(pixels(again->render(kScene, proto::Encoding::RawRgba8)), before);
}

TEST_F(ServerTest, ADatasetReplacedOnDiskIsServedFresh) {
  ScratchDir work;
  const auto dir = work / "datasets";
  std::filesystem::create_directories(dir);
  auto prep = [&](int seed) {
    const auto r = test::runVoxbrick("prep synthetic:blobs,n=48,seed=" + std::to_string(seed) +
                                     " --brick 16 --no-vdb --force -q -o " + (dir / "d").string());
    ASSERT_EQ(r.exitCode, 0) << r.output;
  };
  prep(1);
  ServerProcess server("--datasets " + dir.string() + " --render-threads 1", work.path());
  const std::string scene = R"({"size": [64, 48], "transfer_function": "hot"})";
  auto c = session(server, "d");
  const std::vector<uint8_t> first = pixels(c->render(scene, proto::Encoding::RawRgba8));
  prep(2);  // `prep --force` over the served store
  const std::vector<uint8_t> after = pixels(c->render(scene, proto::Encoding::RawRgba8));
  EXPECT_NE(after, first) << "the session still draws the replaced store";
  EXPECT_EQ(pixels(session(server, "d")->render(scene, proto::Encoding::RawRgba8)), after);
}

TEST_F(ServerTest, ShortLoadWithFaultsLeavesGoodClientsUnharmed) {
  // Short deadlines: the silent and trickle faults each last one of them.
  auto server = start("--hello-timeout 1 --read-timeout 2");
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  const auto report = scratch() / "load.json";
  const auto r =
      test::runVoxbrick("load " + address + " --dataset sparse --clients 16 --duration 10 --size 64x64 " +
                        "--tf sparse --fault-clients 4 --idle-sessions 8 --require-clean --json " + report.string());
  ASSERT_EQ(r.exitCode, 0) << r.output << server->log();
  std::ifstream in(report);
  const json j = json::parse(in);
  EXPECT_EQ(j["errors"].get<int>(), 0);
  EXPECT_GT(j["frames"].get<int>(), 16);
  // The worst frame over the clients' orbit, warm: min <= max, the ratio their quotient.
  const double lo = j["warm_render_ms"]["min"].get<double>(), hi = j["warm_render_ms"]["max"].get<double>();
  EXPECT_GT(lo, 0);
  EXPECT_LE(lo, hi);
  EXPECT_NEAR(j["frame_rate_min_over_max"].get<double>(), lo / hi, 1e-9);
  EXPECT_NE(r.output.find("min/max frame rate 1:"), std::string::npos) << r.output;
  for (const char* fault : {"disconnect", "garbage", "huge", "malformed", "slow", "silent", "trickle", "unread"}) {
    EXPECT_GT(j["faults"][fault]["done"].get<int>(), 0) << fault;
    EXPECT_EQ(j["faults"][fault]["unexpected"].get<int>(), 0) << fault;
  }
  // Resident memory stays bounded: a 64^3 store, two render threads and their atlases.
  EXPECT_LT(j["server"]["memory"]["peak_rss_bytes"].get<double>(), 1.5e9);
  // The server's counters as the run began, and after it: the run's frames and render-thread seconds lie between.
  const json& before = j["server_before"];
  ASSERT_TRUE(before.is_object()) << before.dump();
  EXPECT_GE(j["server"]["renders"]["frames"].get<int>() - before["renders"]["frames"].get<int>(),
            j["frames"].get<int>());
  ASSERT_EQ(before["render_busy_s"].size(), j["server"]["render_busy_s"].size());
  double busyBefore = 0, busyAfter = 0;
  for (size_t t = 0; t < before["render_busy_s"].size(); ++t)
    busyBefore += before["render_busy_s"][t].get<double>(), busyAfter += j["server"]["render_busy_s"][t].get<double>();
  EXPECT_GT(busyAfter, busyBefore) << "the run's drawing";
  EXPECT_TRUE(server->running());
  EXPECT_EQ(server->stop(SIGTERM), 0);
}

}  // namespace
}  // namespace voxbrick
