// A scripted camera drag through a running server with interactive frames (PROTOCOL.md, Session 8): one session
// sends --views cameras of an orbit, --hz a second without waiting, each with "interactive": true and a time budget;
// then, after the drag, the exact frame of every view. Reports for every interactive frame drawn its time against
// its budget (within 1.5x passes), its PSNR against the exact frame of its view, and the time from the last camera
// to the exact frame the server sends once the camera rests. Writes NAME.csv and NAME.md.
//
//   bench_drag --address HOST:PORT --dataset NAME [--size 512] [--views 36] [--hz 20] [--budget 100]
//              [--elevation 20] [--out bench/results/interactive] [--name interactive] [--label TEXT]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "client/Client.h"
#include "image/FrameImage.h"
#include "image/Image.h"

using namespace voxbrick;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

namespace {

struct Options {
  std::string address, dataset, out = "bench/results/interactive", name = "interactive", label;
  int size = 512, views = 36;
  double hz = 20, budget = 100, elevation = 20;
};

struct View {
  uint32_t id = 0;
  double azimuth = 0;
  Clock::time_point sent;
  bool superseded = false;
  json interactive;  // the provisional frame's choice; null when it got none
  double latencyMs = 0;
  image::ImageF frame;
  double psnr = 0;
};

std::string sceneJson(const Options& o, double azimuth, bool interactive) {
  json s = {{"camera", {{"orbit", {azimuth, o.elevation}}}}, {"size", {o.size, o.size}}};
  if (interactive) s["interactive"] = true, s["time_budget_ms"] = o.budget;
  return s.dump();
}

double msBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

/// The drag: sends every view's camera at o.hz, reads frames as they come; returns when the last view's exact frame
/// has arrived, its time since the last camera in `restToExactMs`.
void drag(const Options& o, client::Client& c, std::vector<View>& views, double& restToExactMs) {
  std::mutex mutex;
  std::map<uint32_t, size_t> byId;
  Clock::time_point lastSent;
  uint32_t lastId = 0;
  std::thread reader([&] {
    for (;;) {
      auto [id, m] = c.receive();
      const auto at = Clock::now();
      std::lock_guard lock(mutex);
      const auto it = byId.find(id);
      if (it == byId.end()) continue;
      View& v = views[it->second];
      if (auto* f = std::get_if<proto::Frame>(&m)) {
        const json stats = json::parse(f->statsJson);
        if (client::isProvisional(*f)) {
          v.interactive = stats.value("interactive", json());
          v.latencyMs = msBetween(v.sent, at);
          // Sent as drawn (protocol version 8): shown at the scene's size, as a client scales it.
          v.frame = image::toImageF(image::scaleImage(image::decodeFrameImage(*f), o.size, o.size));
        } else if (id == lastId) {
          restToExactMs = msBetween(lastSent, at);
          return;
        }
      } else if (auto* e = std::get_if<proto::Error>(&m)) {
        if (e->code != proto::ErrorCode::Superseded) throw std::runtime_error("request failed: " + e->message);
        v.superseded = true;
      }
    }
  });
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.hz));
  auto next = Clock::now();
  for (size_t i = 0; i < views.size(); ++i) {
    {
      std::lock_guard lock(mutex);
      views[i].azimuth = 30 + 360.0 * double(i) / double(views.size());
      views[i].sent = lastSent = Clock::now();
      views[i].id = c.send(proto::RenderRequest{proto::Encoding::Png, sceneJson(o, views[i].azimuth, true)});
      lastId = views[i].id;
      byId[views[i].id] = i;
    }
    next += period;
    std::this_thread::sleep_until(next);
  }
  reader.join();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("A scripted camera drag through a server with interactive frames");
  Options o;
  app.add_option("--address", o.address, "HOST:PORT of the server")->required();
  app.add_option("--dataset", o.dataset, "dataset to drag over")->required();
  app.add_option("--size", o.size, "frame side in pixels")->capture_default_str();
  app.add_option("--views", o.views, "cameras of the drag (one full turn)")
      ->capture_default_str()
      ->check(CLI::Range(2, 3600));
  app.add_option("--hz", o.hz, "cameras sent a second")->capture_default_str()->check(CLI::Range(0.1, 1000.0));
  app.add_option("--budget", o.budget, "time_budget_ms of each interactive frame")->capture_default_str();
  app.add_option("--elevation", o.elevation, "degrees")->capture_default_str();
  app.add_option("--out", o.out, "output directory")->capture_default_str();
  app.add_option("--name", o.name, "output files NAME.csv and NAME.md")->capture_default_str();
  app.add_option("--label", o.label, "what the dataset is, for the report");
  CLI11_PARSE(app, argc, argv);

  const auto [host, port] = client::parseAddress(o.address);
  client::Client c(host, port, std::chrono::seconds(600));
  c.hello("bench_drag");
  c.openDataset(o.dataset);
  c.render(sceneJson(o, 30, false));  // warm: the first view's bricks, the device's rate
  std::vector<View> views(size_t(o.views));
  double restToExactMs = 0;
  drag(o, c, views, restToExactMs);
  // After the drag: the exact frame of every view that got an interactive frame.
  int drawn = 0, within = 0;
  std::vector<double> psnrs;
  for (View& v : views) {
    if (v.interactive.is_null()) continue;
    const image::ImageF exact = image::toImageF(image::decodeFrameImage(c.render(sceneJson(o, v.azimuth, false))));
    v.psnr = std::min(99.0, image::compareImages(v.frame, exact).psnr);
    psnrs.push_back(v.psnr);
    ++drawn;
    within += v.interactive.value("actual_ms", 0.0) <= 1.5 * o.budget;
  }
  std::filesystem::create_directories(o.out);
  std::ofstream csv(std::filesystem::path(o.out) / (o.name + ".csv"));
  csv << "view,azimuth,outcome,budget_ms,predicted_ms,actual_ms,within_1_5x,latency_ms,width,height,step,lod,psnr_db\n";
  for (size_t i = 0; i < views.size(); ++i) {
    const View& v = views[i];
    const json& k = v.interactive;
    csv << i << ',' << v.azimuth << ',' << (k.is_null() ? "superseded" : "frame") << ',' << o.budget;
    if (k.is_null()) {
      csv << ",,,,,,,,,\n";
      continue;
    }
    csv << ',' << k.value("predicted_ms", 0.0) << ',' << k.value("actual_ms", 0.0) << ','
        << (k.value("actual_ms", 0.0) <= 1.5 * o.budget ? 1 : 0) << ',' << v.latencyMs << ',' << k.value("width", 0)
        << ',' << k.value("height", 0) << ',' << k.value("step", 0.0) << ',' << k.value("lod", 0.0) << ',' << v.psnr
        << '\n';
  }
  std::sort(psnrs.begin(), psnrs.end());
  char summary[512];
  std::snprintf(summary, sizeof summary, "| %s | %d | %d | %d | %d | %.1f | %.1f | %.0f |\n",
                o.label.empty() ? o.dataset.c_str() : o.label.c_str(), o.views, drawn, within, o.views - drawn,
                psnrs.empty() ? 0 : psnrs.front(), psnrs.empty() ? 0 : psnrs[psnrs.size() / 2], restToExactMs);
  std::ofstream md(std::filesystem::path(o.out) / (o.name + ".md"));
  md << "| dataset | cameras | interactive frames | within 1.5x budget | superseded | worst PSNR dB | median PSNR dB "
        "| last camera to exact frame ms |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n"
     << summary;
  std::printf("%s", summary);
  return within == drawn && drawn > 0 ? 0 : 2;
}
