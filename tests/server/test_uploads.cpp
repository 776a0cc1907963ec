// Uploads on their own and through the message handler: who may upload, every refusal (and that nothing is left
// behind by one), the chunks, the real `voxbrick prep` run on the voxels, the store moved into place and never over an
// existing dataset, abandoned uploads cleaned up.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include <nlohmann/json.hpp>

#include "TestDatasets.h"
#include "render/core/TransferFunctionPresets.h"
#include "server/Datasets.h"
#include "server/ErrorReply.h"
#include "server/MessageHandler.h"
#include "server/ServerStats.h"
#include "server/Uploads.h"
#include "support/TestSupport.h"

namespace voxbrick::server {
namespace {

using proto::ErrorCode;

/// Every entry of `dir`, hidden ones included, sorted.
std::vector<std::string> entries(const std::filesystem::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

/// A u8 volume of nx*ny*nz voxels, a ramp.
std::vector<uint8_t> ramp(int nx, int ny, int nz) {
  std::vector<uint8_t> v(size_t(nx) * ny * nz);
  for (size_t i = 0; i < v.size(); ++i) v[i] = uint8_t((i * 7) % 251);
  return v;
}

proto::Upload request(const std::string& name, int nx = 24, int ny = 20, int nz = 16, const std::string& type = "uint8",
                      int bytesPerVoxel = 1) {
  return proto::Upload{name,
                       nlohmann::json{{"dims", {nx, ny, nz}}, {"type", type}, {"spacing", {1, 1, 2}}}.dump(),
                       uint64_t(nx) * ny * nz * bytesPerVoxel};
}

/// The error code (and message, in `what`) `f` throws as the message handler would answer it.
template <class F>
ErrorCode refusal(F&& f, std::string* what = nullptr) {
  try {
    f();
  } catch (...) {
    const proto::Error e = errorReply(std::current_exception());
    if (what) *what = e.message;
    return e.code;
  }
  ADD_FAILURE() << "nothing was refused";
  return ErrorCode::Internal;
}

std::vector<std::string> onlyNames(const Outcome& o) {
  return o.replies.size() == 1 ? std::get<proto::DatasetList>(o.replies[0].message).names : std::vector<std::string>{};
}

TokenGrant grant(const std::string& id, bool upload, std::vector<std::string> datasets = {"*"}) {
  TokenGrant g;
  g.id = id;
  g.upload = upload;
  g.datasets = std::move(datasets);
  return g;
}

UploadConfig quota(uint64_t maxBytes, int concurrent = 1) {
  UploadConfig c;
  c.maxBytes = maxBytes;
  c.maxConcurrent = concurrent;
  return c;
}

class UploadsTest : public ::testing::Test {
 protected:
  test::ScratchDir dir;
  std::filesystem::path datasets = dir / "datasets";
  void SetUp() override { std::filesystem::create_directories(datasets); }
  Uploads uploads(UploadConfig config = quota(1 << 20), uint32_t chunk = 4096) {
    return Uploads(config, datasets, test::voxbrickExe(), chunk);
  }
};

TEST(UploadHeader, TheVoxelsAreDescribedAsPrepReadsThem) {
  const std::string header = Uploads::nrrdHeader(request("a", 3, 4, 5, "uint16", 2), "/data/voxels.raw");
  EXPECT_NE(header.find("type: uint16\n"), std::string::npos) << header;
  EXPECT_NE(header.find("sizes: 3 4 5\n"), std::string::npos) << header;
  EXPECT_NE(header.find("endian: little\n"), std::string::npos) << header;
  EXPECT_NE(header.find("data file: /data/voxels.raw\n"), std::string::npos) << header;
  EXPECT_NE(header.find("spacings: 1 1 2\n"), std::string::npos) << header;
  // An origin (or patient axes) places the volume: directions and origin, numbers exact.
  proto::Upload placed{"a",
                       R"({"dims": [2, 2, 2], "type": "float", "endian": "big", "spacing": [0.1, 0.25, 3],
                           "origin": [-12.5, 0, 1e-3], "patient": true})",
                       32};
  const std::string p = Uploads::nrrdHeader(placed, "v.raw");
  EXPECT_NE(p.find("endian: big\n"), std::string::npos) << p;
  EXPECT_NE(p.find("space: RAS\n"), std::string::npos) << p;
  EXPECT_NE(p.find("space directions: (0.1,0,0) (0,0.25,0) (0,0,3)\n"), std::string::npos) << p;
  EXPECT_NE(p.find("space origin: (-12.5,0,0.001)\n"), std::string::npos) << p;
}

TEST(UploadHeader, BadDescriptionsAreMalformedNamingTheKey) {
  const std::vector<std::pair<proto::Upload, std::string>> cases = {
      {{"a", "[1, 2]", 1}, "not a JSON object"},
      {{"a", "{", 1}, "not a JSON object"},
      {{"a", R"({"dims": [1, 1, 1], "type": "uint8", "colour": 1})", 1}, "unknown key 'colour'"},
      {{"a", R"({"type": "uint8"})", 1}, "'dims' is missing"},
      {{"a", R"({"dims": [1, 1], "type": "uint8"})", 1}, "'dims' must be an array of three"},
      {{"a", R"({"dims": [1, 0, 1], "type": "uint8"})", 0}, "each must be an integer from 1"},
      {{"a", R"({"dims": [1, 1.5, 1], "type": "uint8"})", 1}, "each must be an integer from 1"},
      {{"a", R"({"dims": [1, 1, 1]})", 1}, "'type' is missing"},
      {{"a", R"({"dims": [1, 1, 1], "type": "complex"})", 1}, "'type' \"complex\" is not"},
      {{"a", R"({"dims": [2, 2, 2], "type": "float"})", 31}, "bytes: 31 where dims [2,2,2] of float take 32"},
      {{"a", R"({"dims": [1048576, 1048576, 1048576], "type": "double"})", 8}, "take 9223372036854775808"},
      {{"a", R"({"dims": [1, 1, 1], "type": "uint8", "endian": "middle"})", 1}, "'endian' must be"},
      {{"a", R"({"dims": [1, 1, 1], "type": "uint8", "spacing": [1, -1, 1]})", 1}, "'spacing' must hold three"},
      {{"a", R"({"dims": [1, 1, 1], "type": "uint8", "origin": [0, 0]})", 1}, "'origin' must be an array"},
      {{"a", R"({"dims": [1, 1, 1], "type": "uint8", "patient": 1})", 1}, "'patient' must be true or false"},
  };
  for (const auto& [upload, words] : cases) {
    std::string what;
    EXPECT_EQ(refusal([&] { Uploads::nrrdHeader(upload, "v.raw"); }, &what), ErrorCode::Malformed) << upload.metaJson;
    EXPECT_NE(what.find(words), std::string::npos) << what;
    EXPECT_TRUE(what.starts_with("Upload.")) << what;
  }
}

TEST_F(UploadsTest, OnlyATokenThatMayUploadMayUploadAndNothingIsLeftByARefusal) {
  std::filesystem::create_directories(datasets / "taken");
  test::writeFile(datasets / "taken" / "store.json", "{}");
  const auto before = entries(datasets);
  Uploads off(quota(0), datasets, test::voxbrickExe(), 4096);
  Uploads on = uploads(quota(100000, 1));
  const TokenGrant mayUpload = grant("lab", true, {"lab-*", "taken"}), mayNot = grant("viewer", false),
                   anonymous = grant("", true);
  std::string what;
  EXPECT_EQ(refusal([&] { off.begin(request("lab-1"), &mayUpload); }, &what), ErrorCode::Forbidden);
  EXPECT_NE(what.find("takes no uploads"), std::string::npos) << what;
  EXPECT_EQ(refusal([&] { on.begin(request("lab-1"), nullptr); }, &what), ErrorCode::Forbidden);
  EXPECT_NE(what.find("presented none"), std::string::npos) << what;
  EXPECT_EQ(refusal([&] { on.begin(request("lab-1"), &anonymous); }), ErrorCode::Forbidden);
  EXPECT_EQ(refusal([&] { on.begin(request("lab-1"), &mayNot); }, &what), ErrorCode::Forbidden);
  EXPECT_NE(what.find("token 'viewer' may not upload"), std::string::npos) << what;
  EXPECT_EQ(refusal([&] { on.begin(request("other"), &mayUpload); }, &what), ErrorCode::Forbidden);
  EXPECT_NE(what.find("may not open a dataset named 'other'"), std::string::npos) << what;
  for (const char* bad : {"", ".lab-1", "..", "lab/1", "lab 1", "../lab-1"}) {
    EXPECT_EQ(refusal([&] { on.begin(request(bad), &mayUpload); }, &what), ErrorCode::Malformed) << bad;
    EXPECT_NE(what.find("is not a dataset name"), std::string::npos) << what;
  }
  EXPECT_EQ(refusal([&] { on.begin(request("lab-1", 100, 100, 11), &mayUpload); }, &what), ErrorCode::LimitExceeded);
  EXPECT_NE(what.find("110000 bytes is above this server's quota of 100000 bytes"), std::string::npos) << what;
  EXPECT_EQ(refusal([&] { on.begin(request("taken"), &mayUpload); }, &what), ErrorCode::AlreadyExists);
  EXPECT_NE(what.find("'taken' exists"), std::string::npos) << what;
  EXPECT_EQ(entries(datasets), before);
  EXPECT_EQ(on.active(), 0);

  // A name of 255 bytes is one (the scratch folder is not named after it).
  Uploads any = uploads(quota(100000, 1));
  const TokenGrant everything = grant("all", true);
  EXPECT_TRUE(any.begin(request(std::string(255, 'n')), &everything));
  EXPECT_EQ(entries(datasets), before);

  // One at a time, and never two uploads of one name.
  Uploads two = uploads(quota(100000, 2));
  auto first = two.begin(request("lab-1"), &mayUpload);
  EXPECT_EQ(two.active(), 1);
  EXPECT_EQ(refusal([&] { two.begin(request("lab-1"), &mayUpload); }, &what), ErrorCode::AlreadyExists);
  EXPECT_NE(what.find("is being uploaded"), std::string::npos) << what;
  auto second = two.begin(request("lab-2"), &mayUpload);
  EXPECT_EQ(refusal([&] { two.begin(request("lab-3"), &mayUpload); }, &what), ErrorCode::Busy);
  EXPECT_EQ(proto::retryAfterMs(what), 5000u) << what;
  EXPECT_NE(entries(datasets), before);  // their scratch folders
  first.reset();
  second.reset();
  EXPECT_EQ(two.active(), 0);
  EXPECT_EQ(entries(datasets), before);
}

TEST_F(UploadsTest, ChunksMustFitAndAnUploadIsPreppedIntoADataset) {
  Uploads u = uploads(quota(1 << 20), 4096);
  const TokenGrant lab = grant("lab", true);
  const std::vector<uint8_t> voxels = ramp(24, 20, 16);  // 7680 bytes: two chunks
  auto upload = u.begin(request("ramp"), &lab);
  EXPECT_EQ(refusal([&] { upload->append({}); }), ErrorCode::Malformed);
  std::vector<uint8_t> tooBig(4097);
  std::string what;
  EXPECT_EQ(refusal([&] { upload->append(tooBig); }, &what), ErrorCode::Malformed);
  EXPECT_NE(what.find("above the chunk size of 4096"), std::string::npos) << what;
  EXPECT_FALSE(upload->append(std::span(voxels).first(4096)));
  EXPECT_EQ(upload->received(), 4096u);
  std::vector<uint8_t> pastEnd(voxels.size() - 4096 + 1);
  EXPECT_EQ(refusal([&] { upload->append(pastEnd); }, &what), ErrorCode::Malformed);
  EXPECT_NE(what.find("past the upload's end: 3584 of its 7680 bytes were left"), std::string::npos) << what;
  EXPECT_TRUE(upload->append(std::span(voxels).subspan(4096)));
  EXPECT_TRUE(upload->complete());
  upload->prepare();
  upload.reset();
  // Moved into place, scratch gone, and the store holds the voxels: the registry opens it with their dims.
  EXPECT_EQ(entries(datasets), std::vector<std::string>{"ramp"});
  DatasetRegistry registry(datasets, size_t(16) << 20);
  EXPECT_EQ(registry.names(), std::vector<std::string>{"ramp"});
  const nlohmann::json info = nlohmann::json::parse(registry.open("ramp")->infoJson());
  EXPECT_EQ(info["dims"], nlohmann::json({24, 20, 16}));
  EXPECT_EQ(info["spacing"], nlohmann::json({1.0, 1.0, 2.0}));
  // The same voxels through `voxbrick prep` of the same header: the same store.
  test::writeFile(dir / "same.raw", voxels.data(), voxels.size());
  test::writeFile(dir / "same.nhdr", Uploads::nrrdHeader(request("same"), dir / "same.raw"));
  ASSERT_EQ(test::runVoxbrick("prep " + (dir / "same.nhdr").string() + " -o " + (dir / "same").string() + " -q")
                .exitCode,
            0);
  EXPECT_EQ(test::readFile(dir / "same" / "bricks.bin"), test::readFile(datasets / "ramp" / "bricks.bin"));
}

TEST_F(UploadsTest, ANameTakenDuringTheUploadIsNeverOverwritten) {
  Uploads u = uploads();
  const TokenGrant lab = grant("lab", true);
  const std::vector<uint8_t> voxels = ramp(8, 8, 8);
  auto upload = u.begin(request("late", 8, 8, 8), &lab);
  ASSERT_TRUE(upload->append(voxels));
  std::filesystem::create_directories(datasets / "late");
  test::writeFile(datasets / "late" / "mine.txt", "an operator's");
  std::string what;
  EXPECT_EQ(refusal([&] { upload->prepare(); }, &what), ErrorCode::AlreadyExists);
  EXPECT_NE(what.find("appeared during the upload"), std::string::npos) << what;
  upload.reset();
  EXPECT_EQ(entries(datasets), std::vector<std::string>{"late"});
  EXPECT_EQ(entries(datasets / "late"), std::vector<std::string>{"mine.txt"});
}

TEST_F(UploadsTest, AnAbandonedUploadStopsItsPrepAndLeavesNothing) {
  Uploads u = uploads(quota(64 << 20), 1 << 20);
  const TokenGrant lab = grant("lab", true);
  // Large enough that prep runs for a while on a busy machine; cancelled right after it starts.
  auto upload = u.begin(request("gone", 256, 256, 128), &lab);
  const std::vector<uint8_t> chunk(1 << 20, 7);
  for (int i = 0; i < 8; ++i) (void)upload->append(chunk);
  ASSERT_TRUE(upload->complete());
  std::thread prep([&] { EXPECT_ANY_THROW(upload->prepare()); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  upload->cancel();
  prep.join();
  upload.reset();
  EXPECT_TRUE(entries(datasets).empty());
  // Cancelled before it starts: prep never runs.
  auto later = u.begin(request("gone", 8, 8, 8), &lab);
  ASSERT_TRUE(later->append(ramp(8, 8, 8)));
  later->cancel();
  std::string what;
  EXPECT_EQ(refusal([&] { later->prepare(); }, &what), ErrorCode::Internal);
  EXPECT_NE(what.find("was abandoned"), std::string::npos) << what;
  later.reset();
  EXPECT_TRUE(entries(datasets).empty());
}

TEST_F(UploadsTest, ScratchLeftByAStoppedServerIsRemovedAtStart) {
  std::filesystem::create_directories(datasets / ".upload-x-abc123");
  test::writeFile(datasets / ".upload-x-abc123" / "voxels.raw", "123");
  std::filesystem::create_directories(datasets / "kept");
  Uploads u = uploads();
  EXPECT_EQ(entries(datasets), std::vector<std::string>{"kept"});
}

// Through the message handler: versions, the session's state, the answers.
class UploadHandlerTest : public UploadsTest {
 protected:
  ServerConfig config;
  DatasetRegistry registry{datasets, size_t(16) << 20};
  render::TransferFunctionPresets presets = render::TransferFunctionPresets::load(test::shippedPresets());
  ServerStats stats;
  Uploads store = uploads(quota(1 << 20), 4096);
  MessageHandler handler{config, registry, presets, stats, [] { return nlohmann::json::object(); }, nullptr, nullptr,
                         &store};
  ConnectionState state;
  std::shared_ptr<const TokenGrant> lab = std::make_shared<const TokenGrant>(grant("lab", true));

  Outcome handle(const proto::Message& message, uint32_t id = 1) { return handler.handle(state, message, id); }
  void greet(uint16_t version = proto::kMaxVersion, bool token = true) {
    ASSERT_EQ(handle(proto::Hello{1, version, "test"}).replies.size(), 1u);
    state.access = token ? lab : nullptr;
    state.authenticated = token;
  }
  static ErrorCode code(const Outcome& o) {
    EXPECT_EQ(o.replies.size(), 1u);
    const auto* e = o.replies.empty() ? nullptr : std::get_if<proto::Error>(&o.replies[0].message);
    return e ? e->code : ErrorCode(0);
  }
};

TEST_F(UploadHandlerTest, AnOlderSessionDoesNotKnowUploads) {
  greet(5);
  const Outcome o = handle(request("old"));
  EXPECT_EQ(code(o), ErrorCode::UnknownType);
  EXPECT_FALSE(o.close);
  EXPECT_EQ(code(handle(proto::UploadChunk{{1}})), ErrorCode::UnknownType);
  EXPECT_TRUE(entries(datasets).empty());
}

TEST_F(UploadHandlerTest, ARefusedUploadLeavesTheSessionOpen) {
  greet(proto::kMaxVersion, false);
  const Outcome o = handle(request("mine"), 4);
  EXPECT_EQ(code(o), ErrorCode::Forbidden);
  EXPECT_EQ(o.replies[0].requestId, 4u);
  EXPECT_FALSE(o.close);  // Forbidden closes for a wrong token only
  EXPECT_EQ(code(handle(proto::UploadChunk{{1}})), ErrorCode::UnexpectedMessage);
  EXPECT_EQ(stats.toJson({})["uploads"]["refused"], 1);
}

TEST_F(UploadHandlerTest, ChunksThenPrepThenTheNewDatasetsInfo) {
  greet();
  const Outcome ready = handle(request("fresh"), 2);
  ASSERT_EQ(ready.replies.size(), 1u);
  EXPECT_EQ(std::get<proto::UploadReady>(ready.replies[0].message).chunkBytes, 4096u);
  EXPECT_EQ(code(handle(request("again"), 3)), ErrorCode::UnexpectedMessage);  // one at a time per session
  const std::vector<uint8_t> voxels = ramp(24, 20, 16);
  Outcome o = handle(proto::UploadChunk{std::vector<uint8_t>(voxels.begin(), voxels.begin() + 4096)}, 4);
  EXPECT_TRUE(o.replies.empty());
  EXPECT_FALSE(o.prepare);
  o = handle(proto::UploadChunk{std::vector<uint8_t>(voxels.begin() + 4096, voxels.end())}, 5);
  EXPECT_TRUE(o.replies.empty());
  ASSERT_TRUE(o.prepare);
  EXPECT_EQ(o.prepare->requestId, 5u);
  EXPECT_TRUE(state.awaitingFrames());  // not idle while its store is prepped
  EXPECT_EQ(code(handle(proto::UploadChunk{{1}}, 6)), ErrorCode::UnexpectedMessage);
  std::exception_ptr error;
  try {
    o.prepare->upload->prepare();
  } catch (...) {
    error = std::current_exception();
  }
  const Outcome done = handler.prepared(state, *o.prepare, error);
  // Its scratch and its place are free before the answer goes, though the job still holds it.
  EXPECT_EQ(entries(datasets), std::vector<std::string>{"fresh"});
  EXPECT_EQ(store.active(), 0);
  o.prepare.reset();
  ASSERT_EQ(done.replies.size(), 1u);
  EXPECT_EQ(done.replies[0].requestId, 5u);
  const auto& info = std::get<proto::DatasetInfo>(done.replies[0].message);
  EXPECT_EQ(info.name, "fresh");
  EXPECT_EQ(nlohmann::json::parse(info.metaJson)["dims"], nlohmann::json({24, 20, 16}));
  EXPECT_FALSE(state.upload);
  EXPECT_FALSE(state.awaitingFrames());
  EXPECT_FALSE(state.dataset);  // listed and openable, not opened
  EXPECT_EQ(onlyNames(handle(proto::ListDatasets{})), std::vector<std::string>{"fresh"});
  EXPECT_EQ(stats.toJson({})["uploads"]["done"], 1);
}

TEST_F(UploadHandlerTest, ABadChunkEndsTheUploadAndItsScratch) {
  greet();
  ASSERT_EQ(handle(request("bad"), 2).replies.size(), 1u);
  EXPECT_EQ(entries(datasets).size(), 1u);  // its scratch
  EXPECT_EQ(code(handle(proto::UploadChunk{std::vector<uint8_t>(4097)}, 3)), ErrorCode::Malformed);
  EXPECT_FALSE(state.upload);
  EXPECT_TRUE(entries(datasets).empty());
  EXPECT_EQ(store.active(), 0);
  // The session goes on: a new upload of the name is taken.
  EXPECT_EQ(handle(request("bad"), 4).replies.size(), 1u);
  EXPECT_TRUE(state.upload);
}

}  // namespace
}  // namespace voxbrick::server
