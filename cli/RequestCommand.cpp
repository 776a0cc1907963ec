// `voxbrick request HOST:PORT --dataset NAME [scene options] -o frame.png`: one frame from a running server.
#include <chrono>
#include <cstdio>
#include <memory>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>

#include "cli/Commands.h"
#include "cli/ConnectOptions.h"
#include "cli/SceneOptions.h"
#include "client/Client.h"
#include "image/FrameImage.h"
#include "image/Image.h"
#include "image/ImageFile.h"
#include "image/Video.h"
#include "render/core/RenderErrors.h"
#include "render/engine/Datasets.h"

namespace voxbrick::cli {
namespace {

struct RequestArgs {
  SceneArgs scene;
  ConnectArgs connect;
  std::string address, dataset, output, statsPath, encoding = "png";
  double timeout = 120, busyWait = 60;
  int jpegQuality = 90;
  bool list = false;
};

/// Writes a frame as the output's extension asks: a jpeg frame to a .jpg file as its bytes (no second loss), any
/// other decoded (a video frame in the session's stream, by `decoder`) and encoded again. A provisional frame sent at
/// the size it was drawn (protocol version 8), smaller than the scene's `width` x `height`, is scaled up to it
/// bilinearly first, as a viewer shows it.
void writeFrame(const std::string& path, const proto::Frame& frame, int jpegQuality, image::FrameDecoder& decoder,
                int width, int height) {
  image::Image8 decoded = decoder.decode(frame);  // checks the payload whatever is written
  const bool asDrawn = decoded.width != width || decoded.height != height;
  if (asDrawn) decoded = image::scaleImage(decoded, width, height);
  if (!asDrawn && frame.encoding == proto::Encoding::Jpeg && image::imageFormatFor(path) == image::ImageFormat::Jpeg)
    image::writeFileAtomically(path, frame.payload);
  else
    image::writeImage(path, decoded, {jpegQuality});
}

/// The waits of Busy replies, within --busy-wait seconds in all: each the server's retry hint times a random factor in
/// [1, 1.2] (so that clients refused together do not come back together), as the Python client waits.
class BusyWaits {
 public:
  explicit BusyWaits(double seconds) : mLeft(std::chrono::duration<double>(seconds)) {}
  /// Waits out `e` and returns true if it is a Busy reply (client::retryAfter) whose wait is within what is left;
  /// false (nothing waited) otherwise, when the caller throws it as it came.
  bool waitOut(const client::ServerError& e) {
    const auto hint = client::retryAfter(e.code(), e.what());
    if (!hint) return false;
    const std::chrono::duration<double> wait =
        std::chrono::duration<double>(*hint) * std::uniform_real_distribution<double>(1, 1.2)(mRandom);
    if (wait > mLeft) return false;
    std::fprintf(stderr, "request: %s; asking again in %.0f ms\n", e.what(),
                 std::chrono::duration<double, std::milli>(wait).count());
    std::this_thread::sleep_for(wait);
    mLeft -= wait;
    ++mCount;
    return true;
  }
  int count() const { return mCount; }

 private:
  std::chrono::duration<double> mLeft;
  std::mt19937 mRandom{std::random_device{}()};
  int mCount = 0;
};

void runRequest(const RequestArgs& a, const CLI::App& cmd) {
  if (!a.output.empty()) image::imageFormatFor(a.output);  // an output we cannot write is refused before connecting
  const auto [host, port] = client::parseAddress(a.address);
  const bool listing = a.list || a.dataset.empty();
  if (!listing && a.output.empty()) throw render::RenderInputError("-o/--output is required to render");
  render::Scene scene;
  if (!listing) {
    scene = buildScene(a.scene, cmd);
    checkOutputFormat(scene, a.output);
  }
  const proto::Encoding encoding = client::encodingNamed(a.encoding);
  // A jpeg frame is encoded by the server, at --jpeg-quality if given (else the server's default).
  if (encoding == proto::Encoding::Jpeg && cmd.get_option("--jpeg-quality")->count() > 0)
    scene.jpegQuality = a.jpegQuality;
  BusyWaits busy(a.busyWait);
  // A session with the dataset open. A server over capacity may refuse the session at Hello (busy_at_hello; it then
  // closes), or the dataset while it fetches it (a PACS series): a new session once the hint has passed.
  const auto openSession = [&] {
    for (;;) {
      try {
        auto c = std::make_unique<client::Client>(host, port, std::chrono::milliseconds(int64_t(a.timeout * 1000)),
                                                  tlsOptionsOf(a.connect));
        c->hello("voxbrick-request 0.1");
        if (const std::string token = accessTokenOf(a.connect); !token.empty()) c->authenticate(token);
        if (!listing) c->openDataset(a.dataset);
        return c;
      } catch (const client::ServerError& e) {
        if (!busy.waitOut(e)) throw;
      }
    }
  };
  const std::unique_ptr<client::Client> c = openSession();
  if (listing) {
    for (const std::string& name : c->listDatasets()) std::printf("%s\n", name.c_str());
    c->goodbye();
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  const auto msSinceStart = [&] {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  };
  // A progressive scene may first bring provisional frames (bricks still on their way drawn coarser): each is
  // written beside the output, the last one wins.
  const std::string provisional = provisionalPath(a.output);
  image::FrameDecoder decoder;
  const auto onProvisional = [&](const proto::Frame& early) {
    writeFrame(provisional, early, a.jpegQuality, decoder, scene.width, scene.height);
    const nlohmann::json stats = nlohmann::json::parse(early.statsJson);
    std::printf("request: provisional frame (%lld bricks stood in) at %.1f ms, wrote %s\n",
                static_cast<long long>(stats.value("bricks_standin", int64_t{0})), msSinceStart(), provisional.c_str());
  };
  // A Render answered Busy (a frame-rate quota, batch work over capacity) is sent again once its hint has passed; the
  // session goes on.
  const proto::Frame frame = [&] {
    for (;;) {
      try {
        return c->render(scene.toJson(), encoding, onProvisional);
      } catch (const client::ServerError& e) {
        if (!busy.waitOut(e)) throw;
      }
    }
  }();
  const double ms = msSinceStart();
  c->goodbye();
  writeFrame(a.output, frame, a.jpegQuality, decoder, scene.width, scene.height);
  if (!a.statsPath.empty()) writeText(a.statsPath, nlohmann::json::parse(frame.statsJson).dump(2) + "\n");
  std::printf("request: wrote %s (%ux%u, %zu bytes as %s) in %.1f ms", a.output.c_str(), frame.width, frame.height,
              frame.payload.size(), a.encoding.c_str(), ms);
  if (busy.count() > 0) std::printf(", after %d Busy replies waited out", busy.count());
  std::printf("\n");
}

}  // namespace

void addRequestCommand(CLI::App& app) {
  auto a = std::make_shared<RequestArgs>();
  CLI::App* cmd = app.add_subcommand("request", "Ask a running server for one frame and save it as PNG or JPEG");
  cmd->add_option("address", a->address, "HOST:PORT of the server")->required();
  cmd->add_option("--dataset", a->dataset, "dataset to render (without it: list the datasets)");
  cmd->add_flag("--list", a->list, "list the server's datasets");
  cmd->add_option("-o,--output", a->output, "image to write: .png, or .jpg/.jpeg (JPEG)");
  cmd->add_option("--jpeg-quality", a->jpegQuality,
                  "JPEG quality of a .jpg/.jpeg output, and with --encoding jpeg of the frame the server sends "
                  "(default 90; for the frame, the server's)")
      ->capture_default_str()
      ->check(between(1, 100));
  cmd->add_option("--stats", a->statsPath, "write the frame's statistics as JSON");
  cmd->add_option("--encoding", a->encoding,
                  "how the frame travels: png, raw, zstd, jpeg (lossy; needs a server of protocol version 2) or webp "
                  "(lossless, fewer bytes; version 7)")
      ->check(CLI::IsMember(proto::encodingShortNames()))
      ->capture_default_str();
  cmd->add_option("--timeout", a->timeout, "seconds to wait for the server")
      ->capture_default_str()
      ->check(between(0.001, 86400, "seconds"));
  cmd->add_option("--busy-wait", a->busyWait,
                  "seconds in all to wait out Busy replies (a server over capacity, a quota, a dataset being "
                  "fetched): each is asked again after the server's retry hint; 0: the first Busy is an error")
      ->capture_default_str()
      ->check(between(0, 86400, "seconds"));
  addConnectOptions(cmd, a->connect);
  addSceneOptions(cmd, a->scene);
  cmd->callback([a, cmd] { runRequest(*a, *cmd); });
}

}  // namespace voxbrick::cli
