// Protocol version 2 and its jpeg encoding against the real `voxbrick serve` process: negotiation, the jpeg frame
// and its quality, the refusals (version 1, a transparent frame), and `provisional_encoding` on a progressive render.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "RawSocket.h"
#include "ServerErrorOf.h"
#include "ServerProcess.h"
#include "client/Client.h"
#include "image/FrameImage.h"
#include "image/Image.h"

namespace voxbrick {
namespace {

using client::Client;
using client::ServerError;
using nlohmann::json;
using proto::Encoding;
using proto::ErrorCode;
using test::ServerProcess;

class JpegServerTest : public test::SparseDatasetSuite {
 protected:
  std::unique_ptr<ServerProcess> start() {
    return serve("--render-threads 2");
  }
};

const char* kJpegScene = R"({"camera": {"orbit": [40, 25, 2.2]}, "size": [96, 80], "transfer_function": "sparse",
                         "background": [0.2, 0.3, 0.4]})";

std::string sceneWith(const json& extra) {
  json scene = json::parse(kJpegScene);
  scene.update(extra);
  return scene.dump();
}

std::unique_ptr<Client> jpegSession(const ServerProcess& server, uint16_t maxVersion) {
  auto c = std::make_unique<Client>("127.0.0.1", server.port(), std::chrono::seconds(60));
  const proto::Capabilities caps = c->hello("test", maxVersion);
  EXPECT_EQ(caps.version, maxVersion);
  c->openDataset("sparse");
  return c;
}

double psnr(const proto::Frame& a, const proto::Frame& b) {
  return image::compareImages(image::toImageF(image::decodeFrameImage(a)), image::toImageF(image::decodeFrameImage(b)))
      .psnr;
}

/// The next message a raw connection receives (fails the test if none comes within 30 s).
proto::Message next(test::RawSocket& s) {
  std::optional<proto::Message> m = s.receive(std::chrono::seconds(30));
  if (!m) {
    ADD_FAILURE() << "no message";
    return proto::Goodbye{};
  }
  return std::move(*m);
}

// A version-1 client (offering only version 1, as the clients before version 2 do) never sees jpeg: not in
// Capabilities, and a Render asking for it is refused as an unknown encoding, the session going on.
TEST_F(JpegServerTest, AVersionOneSessionHasNoJpeg) {
  auto server = start();
  test::RawSocket s(server->port());
  ASSERT_TRUE(s.sendAll(proto::encode(proto::Hello{1, 1, "v1"}, 1)));
  const proto::Capabilities caps = std::get<proto::Capabilities>(next(s));
  EXPECT_EQ(caps.version, 1u);
  EXPECT_EQ(caps.encodings, (std::vector<Encoding>{Encoding::RawRgba8, Encoding::Png, Encoding::ZstdRgba8}));
  ASSERT_TRUE(s.sendAll(proto::encode(proto::OpenDataset{"sparse"}, 2)));
  ASSERT_TRUE(std::holds_alternative<proto::DatasetInfo>(next(s)));
  // The encoder refuses to write jpeg in version 1, so the bytes are written by hand: encoding 3, then the scene.
  std::vector<uint8_t> render = proto::encode(proto::RenderRequest{Encoding::Png, kJpegScene}, 3);
  render[proto::kHeaderBytes] = 3;
  ASSERT_TRUE(s.sendAll(render));
  const proto::Error error = std::get<proto::Error>(next(s));
  EXPECT_EQ(error.code, ErrorCode::Malformed);
  EXPECT_EQ(error.message, "Render.encoding: unknown value 3 in protocol version 1");
  // Nor in a version-2 header: the session is version 1.
  ASSERT_TRUE(s.sendAll(proto::encode(proto::RenderRequest{Encoding::Jpeg, kJpegScene}, 6, 2)));
  const proto::Error v2 = std::get<proto::Error>(next(s));
  EXPECT_EQ(v2.code, ErrorCode::Malformed);
  EXPECT_EQ(v2.message, "Render.encoding: unknown value 3 in protocol version 1");
  // A provisional_encoding of jpeg is refused too, naming the key; png still works.
  ASSERT_TRUE(s.sendAll(proto::encode(
      proto::RenderRequest{Encoding::Png, sceneWith({{"progressive", true}, {"provisional_encoding", "jpeg"}})}, 4)));
  const proto::Error scene = std::get<proto::Error>(next(s));
  EXPECT_EQ(scene.code, ErrorCode::InvalidScene);
  EXPECT_NE(scene.message.find("provisional_encoding"), std::string::npos) << scene.message;
  ASSERT_TRUE(s.sendAll(proto::encode(proto::RenderRequest{Encoding::Png, kJpegScene}, 5)));
  const proto::Frame frame = std::get<proto::Frame>(next(s));
  EXPECT_EQ(frame.encoding, Encoding::Png);

  // The C++ client offering only version 1 is refused locally before anything is sent.
  Client c("127.0.0.1", server->port());
  EXPECT_EQ(c.hello("v1", 1).version, 1u);
  c.openDataset("sparse");
  EXPECT_THROW(c.render(kJpegScene, Encoding::Jpeg), std::invalid_argument);
}

// A version-2 client gets jpeg frames: the size asked for, close to the lossless frame, smaller than it, and at the
// quality the scene asks; headers carry version 2.
TEST_F(JpegServerTest, AVersionTwoSessionGetsJpegFrames) {
  auto server = start();
  auto c = jpegSession(*server, 2);
  EXPECT_EQ(c->version(), 2u);
  const proto::Frame png = c->render(kJpegScene, Encoding::Png);
  const proto::Frame jpeg = c->render(kJpegScene, Encoding::Jpeg);
  EXPECT_EQ(jpeg.encoding, Encoding::Jpeg);
  ASSERT_GE(jpeg.payload.size(), 4u);
  EXPECT_EQ(jpeg.payload[0], 0xFF);  // a JPEG file: SOI marker
  EXPECT_EQ(jpeg.payload[1], 0xD8);
  const image::Image8 decoded = image::decodeFrameImage(jpeg);
  EXPECT_EQ(decoded.width, 96);
  EXPECT_EQ(decoded.height, 80);
  EXPECT_GE(psnr(jpeg, png), 30.0);
  EXPECT_LT(jpeg.payload.size(), png.payload.size());
  // jpeg_quality: a lower quality is smaller and further from the lossless frame.
  const proto::Frame low = c->render(sceneWith({{"jpeg_quality", 20}}), Encoding::Jpeg);
  EXPECT_LT(low.payload.size(), jpeg.payload.size());
  EXPECT_LT(psnr(low, png), psnr(jpeg, png));
  EXPECT_EQ(test::serverErrorOf([&] {
              c->render(sceneWith({{"jpeg_quality", 101}}), Encoding::Jpeg);
            }).code(),
            ErrorCode::InvalidScene);

  // Replies in a version-2 session carry version 2 in their headers.
  test::RawSocket s(server->port());
  ASSERT_TRUE(s.sendAll(proto::encode(proto::Hello{1, 2, "v2"}, 1)));
  const proto::Capabilities caps = std::get<proto::Capabilities>(next(s));
  EXPECT_EQ(caps.version, 2u);
  EXPECT_EQ(caps.encodings, proto::encodingsOf(2));
  EXPECT_EQ(s.lastHeader().version, 2u);
  ASSERT_TRUE(s.sendAll(proto::encode(proto::ListDatasets{}, 2, 2)));
  EXPECT_TRUE(std::holds_alternative<proto::DatasetList>(next(s)));
  EXPECT_EQ(s.lastHeader().version, 2u);
  // A message written in version 1 is still read (its reply in the session's version 2).
  ASSERT_TRUE(s.sendAll(proto::encode(proto::ListDatasets{}, 3, 1)));
  EXPECT_TRUE(std::holds_alternative<proto::DatasetList>(next(s)));
  EXPECT_EQ(s.lastHeader().version, 2u);
}

// JPEG has no alpha: a transparent frame cannot be sent as jpeg, whether exact or provisional.
TEST_F(JpegServerTest, ATransparentJpegFrameIsRefusedNamingTheKey) {
  auto server = start();
  auto c = jpegSession(*server, 2);
  const ServerError e = test::serverErrorOf([&] { c->render(sceneWith({{"background", "none"}}), Encoding::Jpeg); });
  EXPECT_EQ(e.code(), ErrorCode::InvalidScene);
  EXPECT_NE(std::string(e.what()).find("'background'"), std::string::npos) << e.what();
  const ServerError p = test::serverErrorOf([&] {
    c->render(sceneWith({{"background", "none"}, {"progressive", true}, {"provisional_encoding", "jpeg"}}),
              Encoding::Png);
  });
  EXPECT_EQ(p.code(), ErrorCode::InvalidScene);
  EXPECT_NE(std::string(p.what()).find("'background'"), std::string::npos) << p.what();
  EXPECT_EQ(test::serverErrorOf([&] {
              c->render(sceneWith({{"provisional_encoding", "webp"}}), Encoding::Png);
            }).code(),
            ErrorCode::InvalidScene);
  // The session goes on: the same transparent frame as png.
  EXPECT_EQ(c->render(sceneWith({{"background", "none"}}), Encoding::Png).encoding, Encoding::Png);
}

// provisional_encoding: on a cold server a progressive Render's provisional frame comes as jpeg, and its exact frame
// as png, equal to a plain png Render of the same scene.
TEST_F(JpegServerTest, AProvisionalFrameTakesTheProvisionalEncoding) {
  auto server = start();
  auto c = jpegSession(*server, 2);
  std::vector<proto::Frame> provisional;
  const proto::Frame exact = c->render(sceneWith({{"progressive", true}, {"provisional_encoding", "jpeg"}}),
                                       Encoding::Png, [&](const proto::Frame& f) { provisional.push_back(f); });
  ASSERT_EQ(provisional.size(), 1u) << "a cold cache must stand in";
  EXPECT_EQ(provisional[0].encoding, Encoding::Jpeg);
  EXPECT_TRUE(json::parse(provisional[0].statsJson)["provisional"].get<bool>());
  const image::Image8 early = image::decodeFrameImage(provisional[0]);
  EXPECT_EQ(early.width, 96);
  EXPECT_EQ(early.height, 80);
  EXPECT_EQ(exact.encoding, Encoding::Png);
  EXPECT_FALSE(json::parse(exact.statsJson)["provisional"].get<bool>());
  const proto::Frame plain = c->render(kJpegScene, Encoding::Png);
  EXPECT_EQ(image::decodeFrameImage(exact).rgba, image::decodeFrameImage(plain).rgba);
}

}  // namespace
}  // namespace voxbrick
