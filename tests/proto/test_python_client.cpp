// The Python client against the C++ codec: each decodes what the other encodes, and the client runs a whole session
// against a scripted server on a loopback socket.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <zlib.h>

#include <nlohmann/json.hpp>
#include <thread>

#include "proto/Messages.h"
#include "support/TestSupport.h"

namespace {

using namespace voxbrick::proto;
using voxbrick::test::runShell;
using voxbrick::test::ScratchDir;
using Bytes = std::vector<uint8_t>;

const std::string kClient = std::string("python3 ") + VOXBRICK_SOURCE_DIR + "/examples/python/voxbrick_client.py";

Bytes readBytes(const std::filesystem::path& path) {
  const std::vector<char> data = voxbrick::test::readFile(path);
  return Bytes(data.begin(), data.end());
}

/// Decodes a whole message from a file written by the client; checks that it re-encodes to the same bytes.
std::pair<Header, Message> decodeFile(const std::filesystem::path& path) {
  const Bytes wire = readBytes(path);
  EXPECT_GE(wire.size(), kHeaderBytes);
  const Header header = decodeHeader(std::span<const uint8_t, kHeaderBytes>(wire.data(), kHeaderBytes), Limits{});
  const Message message = decodeBody(header, std::span(wire).subspan(kHeaderBytes), Limits{});
  EXPECT_EQ(encode(message, header.requestId, header.version), wire);
  return {header, message};
}

/// Runs the client's --decode on `wire` and parses what it prints.
nlohmann::json pythonDecode(const Bytes& wire) {
  ScratchDir dir;
  voxbrick::test::writeFile(dir / "message.bin", wire.data(), wire.size());
  const auto result = runShell(kClient + " --decode " + (dir / "message.bin").string());
  EXPECT_EQ(result.exitCode, 0) << result.output;
  return nlohmann::json::parse(result.output);
}

TEST(PythonClient, CppDecodesThePythonHello) {
  ScratchDir dir;
  const auto result = runShell(kClient + " --encode-hello " + (dir / "hello.bin").string());
  ASSERT_EQ(result.exitCode, 0) << result.output;
  const auto [header, message] = decodeFile(dir / "hello.bin");
  EXPECT_EQ(header.type, MessageType::Hello);
  EXPECT_EQ(header.version, kVersion);
  EXPECT_EQ(header.requestId, 1u);
  const Hello& hello = std::get<Hello>(message);
  EXPECT_EQ(hello.minVersion, kMinVersion);
  EXPECT_EQ(hello.maxVersion, kMaxVersion) << "the package offers every version the C++ codec knows";
  EXPECT_EQ(hello.client, "voxbrick_client.py 1");
}

// Version 5's messages, the token over TCP: the Python decoder reads what the C++ encoder writes, field by field, and
// knows them for version 5 only.
TEST(PythonClient, PythonDecodesTheTokenMessagesOfVersionFive) {
  const nlohmann::json authenticate = pythonDecode(encode(Authenticate{"radiology-Secret_1"}, 7, 5));
  EXPECT_EQ(authenticate,
            (nlohmann::json{{"type", "Authenticate"}, {"request_id", 7}, {"version", 5}, {"token", "radiology-Secret_1"}}));
  const nlohmann::json authenticated = pythonDecode(encode(Authenticated{"radiology"}, 7, 5));
  EXPECT_EQ(authenticated, (nlohmann::json{{"type", "Authenticated"}, {"request_id", 7}, {"version", 5},
                                           {"token_id", "radiology"}}));
  const nlohmann::json forbidden = pythonDecode(encode(Error{ErrorCode::Forbidden, "no such token"}, 7, 5));
  EXPECT_EQ(forbidden.at("code"), "Forbidden");
}

// Version 6's messages, an array sent to become a dataset: the Python decoder reads what the C++ encoder writes (the
// u64 size, the chunk's bytes), and knows them and AlreadyExists for version 6 only.
TEST(PythonClient, PythonDecodesTheUploadMessagesOfVersionSix) {
  const nlohmann::json upload =
      pythonDecode(encode(Upload{"scan-7", R"({"dims": [4, 2, 1], "type": "uint16"})", 0x1234567890ull}, 7, 6));
  EXPECT_EQ(upload, (nlohmann::json{{"type", "Upload"},
                                    {"request_id", 7},
                                    {"version", 6},
                                    {"name", "scan-7"},
                                    {"meta_json", R"({"dims": [4, 2, 1], "type": "uint16"})"},
                                    {"bytes", 0x1234567890ull}}));
  EXPECT_EQ(pythonDecode(encode(UploadReady{1u << 20}, 7, 6)),
            (nlohmann::json{{"type", "UploadReady"}, {"request_id", 7}, {"version", 6}, {"chunk_bytes", 1u << 20}}));
  const nlohmann::json chunk = pythonDecode(encode(UploadChunk{{'a', 'b', 'c'}}, 8, 6));
  EXPECT_EQ(chunk.at("data_bytes"), 3);
  EXPECT_EQ(chunk.at("data_crc32"), 0x352441C2u);  // CRC-32 of "abc"
  EXPECT_EQ(pythonDecode(encode(Error{ErrorCode::AlreadyExists, "taken"}, 7, 6)).at("code"), "AlreadyExists");
  // In a version-5 header the Python decoder refuses them, as the C++ one does.
  ScratchDir dir;
  Bytes old = encode(UploadReady{1}, 7, 6);
  old[4] = 5;
  voxbrick::test::writeFile(dir / "old.bin", old.data(), old.size());
  EXPECT_NE(runShell(kClient + " --decode " + (dir / "old.bin").string()).exitCode, 0);
}

// jpeg exists from version 2 on: the Python client writes a jpeg Render in a version-2 header, and refuses a jpeg
// value in a version-1 message as the C++ decoder does.
TEST(PythonClient, JpegTravelsInVersionTwoOnly) {
  ScratchDir dir;
  const auto result =
      runShell(kClient + " --encode-render " + (dir / "render.bin").string() + " --encoding jpeg --scene-json '{}'");
  ASSERT_EQ(result.exitCode, 0) << result.output;
  const auto [header, message] = decodeFile(dir / "render.bin");
  EXPECT_EQ(header.version, 2u);
  EXPECT_EQ(std::get<RenderRequest>(message).encoding, Encoding::Jpeg);

  const Frame frame{3, 2, Encoding::Jpeg, R"({"provisional": false})", {0xFF, 0xD8, 0xFF, 0xD9}};
  const nlohmann::json decoded = pythonDecode(encode(frame, 5, 2));
  EXPECT_EQ(decoded["encoding"], "jpeg");
  EXPECT_EQ(decoded["version"], 2);
  EXPECT_EQ(decoded["payload_bytes"], 4);
  Bytes v1 = encode(frame, 5, 2);
  v1[4] = 1;  // the same bytes in a version-1 header
  ScratchDir bad;
  voxbrick::test::writeFile(bad / "message.bin", v1.data(), v1.size());
  const auto refused = runShell(kClient + " --decode " + (bad / "message.bin").string() + " 2>&1");
  EXPECT_NE(refused.exitCode, 0);
  EXPECT_NE(refused.output.find("Frame.encoding: unknown value 3"), std::string::npos) << refused.output;
}

TEST(PythonClient, CppDecodesThePythonRender) {
  ScratchDir dir;
  const std::string scene = R"({"camera": {"orbit": [10, 20, 3]}, "size": [64, 48], "note": "ünï 体"})";
  for (const auto& [name, encoding] :
       {std::pair{"png", Encoding::Png}, {"raw_rgba8", Encoding::RawRgba8}, {"zstd_rgba8", Encoding::ZstdRgba8}}) {
    const auto result = runShell(kClient + " --encode-render " + (dir / "render.bin").string() + " --encoding " + name +
                                 " --scene-json '" + scene + "'");
    ASSERT_EQ(result.exitCode, 0) << result.output;
    const auto [header, message] = decodeFile(dir / "render.bin");
    EXPECT_EQ(header.type, MessageType::Render);
    EXPECT_EQ(header.requestId, 1u);
    const RenderRequest& render = std::get<RenderRequest>(message);
    EXPECT_EQ(render.encoding, encoding) << name;
    EXPECT_EQ(render.sceneJson, scene);
  }
}

TEST(PythonClient, PythonDecodesACppFrame) {
  Bytes payload(100000);
  for (size_t i = 0; i < payload.size(); ++i) payload[i] = uint8_t(i * 7 + 3);
  const std::string stats = R"({"bricks_drawn": 12, "ms": {"total": 3.5}, "queue_ms": 0.25, "encode_ms": 1})";
  const nlohmann::json out = pythonDecode(encode(Frame{320, 200, Encoding::ZstdRgba8, stats, payload}, 42));
  EXPECT_EQ(out["type"], "Frame");
  EXPECT_EQ(out["request_id"], 42);
  EXPECT_EQ(out["width"], 320);
  EXPECT_EQ(out["height"], 200);
  EXPECT_EQ(out["encoding"], "zstd_rgba8");
  EXPECT_EQ(out["stats_json"], stats);
  EXPECT_EQ(out["payload_bytes"], payload.size());
  EXPECT_EQ(out["payload_crc32"], crc32(0, payload.data(), uInt(payload.size())));
}

TEST(PythonClient, PythonDecodesACppErrorAndCapabilities) {
  const nlohmann::json error = pythonDecode(encode(Error{ErrorCode::LimitExceeded, "image 9000×9000 > 8192"}, 7));
  EXPECT_EQ(error["type"], "Error");
  EXPECT_EQ(error["request_id"], 7);
  EXPECT_EQ(error["code"], "LimitExceeded");
  EXPECT_EQ(error["message"], "image 9000×9000 > 8192");

  const nlohmann::json caps =
      pythonDecode(encode(Capabilities{1, "voxbrick", 1u << 20, 4096, 2, {Encoding::Png, Encoding::RawRgba8}}, 1));
  EXPECT_EQ(caps["server"], "voxbrick");
  EXPECT_EQ(caps["max_message_bytes"], 1u << 20);
  EXPECT_EQ(caps["max_image_side"], 4096);
  EXPECT_EQ(caps["max_queued_per_session"], 2);
  EXPECT_EQ(caps["encodings"], nlohmann::json::array({"png", "raw_rgba8"}));
}

TEST(PythonClient, PythonRefusesMalformedMessages) {
  ScratchDir dir;
  Bytes trailing = encode(Goodbye{}, 1);
  trailing[12] = 1;  // body length 1
  trailing.push_back(0);
  Bytes badCode = encode(Error{ErrorCode::Internal, ""}, 1);
  badCode[kHeaderBytes] = 99;
  for (const auto& [wire, expected] : {std::pair{trailing, "Malformed: Goodbye: 1 trailing byte(s)"},
                                       {badCode, "Malformed: Error.code: unknown value 99"}}) {
    voxbrick::test::writeFile(dir / "bad.bin", wire.data(), wire.size());
    const auto result = runShell(kClient + " --decode " + (dir / "bad.bin").string());
    EXPECT_EQ(result.exitCode, 1) << result.output;
    EXPECT_NE(result.output.find(expected), std::string::npos) << result.output;
  }
}

/// A one-connection server on 127.0.0.1 that answers like the real one and records what it received.
class ScriptedServer {
 public:
  static inline const Bytes kPayload = {0x89, 'P', 'N', 'G', 1, 2, 3, 4, 5};

  ScriptedServer() {
    mListener = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof address;
    if (mListener < 0 || bind(mListener, reinterpret_cast<sockaddr*>(&address), length) != 0 ||
        listen(mListener, 1) != 0 || getsockname(mListener, reinterpret_cast<sockaddr*>(&address), &length) != 0)
      throw std::runtime_error("ScriptedServer: cannot listen on 127.0.0.1");
    mPort = ntohs(address.sin_port);
    mThread = std::thread([this] { serve(); });
  }
  ~ScriptedServer() {
    if (mThread.joinable()) mThread.join();
    close(mListener);
  }
  ScriptedServer(const ScriptedServer&) = delete;
  ScriptedServer& operator=(const ScriptedServer&) = delete;

  std::string address() const { return "127.0.0.1:" + std::to_string(mPort); }
  /// Everything received, in order; read it only after the client has exited (the session is then over).
  std::vector<std::pair<Header, Message>> received() {
    if (mThread.joinable()) mThread.join();
    if (!mFailure.empty()) ADD_FAILURE() << "the server could not read the client: " << mFailure;
    return mReceived;
  }

 private:
  void serve() {
    pollfd waiting{mListener, POLLIN, 0};
    if (poll(&waiting, 1, 30000) != 1) return;  // the client never came: the test fails on its output
    const int connection = accept(mListener, nullptr, nullptr);
    try {
      converse(connection);
    } catch (const std::exception& e) {
      mFailure = e.what();
    }
    close(connection);
  }

  void converse(int connection) {
    Bytes header(kHeaderBytes);
    while (readAll(connection, header)) {
      const Header h = decodeHeader(std::span<const uint8_t, kHeaderBytes>(header.data(), kHeaderBytes), Limits{});
      Bytes body(h.bodyBytes);
      if (!readAll(connection, body)) break;
      const Message request = decodeBody(h, body, Limits{});
      mReceived.emplace_back(h, request);
      if (std::holds_alternative<Goodbye>(request)) break;
      const Bytes reply = encode(answer(request), h.requestId);
      if (send(connection, reply.data(), reply.size(), MSG_NOSIGNAL) != ssize_t(reply.size())) break;
    }
  }

  static Message answer(const Message& request) {
    if (std::holds_alternative<Hello>(request)) return Capabilities{1, "scripted", 64u << 20, 8192, 1, {Encoding::Png}};
    if (std::holds_alternative<ListDatasets>(request)) return DatasetList{{"mri", "sparse"}};
    if (const auto* open = std::get_if<OpenDataset>(&request)) {
      if (open->name == "mri") return DatasetInfo{"mri", R"({"dims": [4, 4, 4]})"};
      return Error{ErrorCode::UnknownDataset, "no dataset '" + open->name + "'"};
    }
    if (std::holds_alternative<RenderRequest>(request))
      return Frame{64, 32, Encoding::Png, R"({"ms": {"total": 2.5}, "queue_ms": 0.5})", kPayload};
    return Error{ErrorCode::UnexpectedMessage, "not scripted"};
  }

  static bool readAll(int fd, Bytes& buffer) {
    for (size_t done = 0; done < buffer.size();) {
      const ssize_t n = recv(fd, buffer.data() + done, buffer.size() - done, 0);
      if (n <= 0) return false;
      done += size_t(n);
    }
    return true;
  }

  int mListener = -1;
  uint16_t mPort = 0;
  std::vector<std::pair<Header, Message>> mReceived;
  std::string mFailure;
  std::thread mThread;
};

std::vector<MessageType> typesOf(const std::vector<std::pair<Header, Message>>& messages) {
  std::vector<MessageType> types;
  for (const auto& [header, message] : messages) types.push_back(messageType(message));
  return types;
}

TEST(PythonClient, ClientRendersAFrameFromAServer) {
  ScratchDir dir;
  voxbrick::test::writeFile(dir / "scene.json",
                            R"({"camera": {"eye": [1, 2, 3], "fov": 40}, "transfer_function": "hot"})");
  ScriptedServer server;
  const auto result =
      runShell(kClient + " " + server.address() + " --dataset mri --scene " + (dir / "scene.json").string() +
               " --orbit 10,20,3 --size 64x32 -o " + (dir / "frame.png").string());
  ASSERT_EQ(result.exitCode, 0) << result.output;
  EXPECT_NE(result.output.find("64x32 png, 9 bytes"), std::string::npos) << result.output;
  EXPECT_EQ(readBytes(dir / "frame.png"), ScriptedServer::kPayload);

  const auto received = server.received();
  ASSERT_EQ(typesOf(received), (std::vector<MessageType>{MessageType::Hello, MessageType::OpenDataset,
                                                         MessageType::Render, MessageType::Goodbye}));
  for (size_t i = 0; i < received.size(); ++i) EXPECT_EQ(received[i].first.requestId, i + 1);
  EXPECT_EQ(std::get<OpenDataset>(received[1].second).name, "mri");
  const RenderRequest& render = std::get<RenderRequest>(received[2].second);
  EXPECT_EQ(render.encoding, Encoding::Png);
  // --orbit replaces the scene file's eye camera and keeps the rest; --size sets the size.
  const nlohmann::json scene = nlohmann::json::parse(render.sceneJson);
  EXPECT_EQ(scene,
            nlohmann::json::parse(
                R"({"camera": {"orbit": [10, 20, 3], "fov": 40}, "transfer_function": "hot", "size": [64, 32]})"));
}

TEST(PythonClient, ClientListsDatasetsWithoutADataset) {
  ScriptedServer server;
  const auto result = runShell(kClient + " " + server.address());
  ASSERT_EQ(result.exitCode, 0) << result.output;
  EXPECT_EQ(result.output, "mri\nsparse\n");
  EXPECT_EQ(typesOf(server.received()),
            (std::vector<MessageType>{MessageType::Hello, MessageType::ListDatasets, MessageType::Goodbye}));
}

TEST(PythonClient, ClientReportsAnErrorReply) {
  ScriptedServer server;
  ScratchDir dir;
  const auto result = runShell(kClient + " " + server.address() + " --dataset nope -o " + (dir / "x.png").string());
  EXPECT_EQ(result.exitCode, 1) << result.output;
  EXPECT_NE(result.output.find("UnknownDataset: no dataset 'nope'"), std::string::npos) << result.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
  EXPECT_EQ(typesOf(server.received()),
            (std::vector<MessageType>{MessageType::Hello, MessageType::OpenDataset, MessageType::Goodbye}));
}

}  // namespace
