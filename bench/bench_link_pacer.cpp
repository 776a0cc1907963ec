// The video bitrate server/LinkPacer sets, in closed loop with a modelled link and client, without sockets or a
// clock (made-up times): a drag's frames ready every 33 ms, each written when LinkPacer::mayWrite allows (a newer one
// replaces one waiting), of the bytes its bitrate gives at 30 frames a second (give or take 30 %), through a
// bottleneck of a given rate and round trip, each reported by the client late by its own delays: none (`prompt`, a
// C++ client), 0 to 8 ms and one report in 20 late by 10 to 40 more (`browser`), or one in 5 so (`busy`: a two-core
// Chromium), or as `browser` but never less than 40 ms after the report before (`paced`: a page that takes that long a
// frame, whose reports are spaced by it, not by the link). The pace is two of the drag's 33 ms (kFramesInFlight of
// them), the cap a 1024² stream's (VideoStream::capKbps). `--drop` makes the link five times slower after 6 s. Per link and client, the means over the seeds (after 4 s, or 8 s with --drop) of the bitrate, frames written
// a second, their time from ready to arrival (p50, p99) and bytes. It judges the rate the pacer reads, not the
// encoder or the browser: bench/run_browser_ab.sh runs the real ones. It uses nothing of LinkPacer's but what every
// version had, so that an older one can be built with it: g++ -std=c++20 -O2 -IOLD_TREE bench/bench_link_pacer.cpp
// OLD_TREE/server/LinkPacer.cpp.
//
//   bench_link_pacer [--drop] [--seeds 5] [--seconds 12] [--cap-kbps 4719] [--csv OUT.csv]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "server/LinkPacer.h"

namespace {

using voxbrick::server::LinkPacer;

struct Link {
  const char* name;
  double kbps, roundTripMs;
};
struct Client {
  const char* name;
  double lateMs, hiccupShare;  ///< each report late by up to lateMs, and one in 1/hiccupShare by 10 to 40 ms more
  double minGapMs = 0;         ///< and at least this long after the one before (a page that takes that long a frame)
};
struct Figures {
  double kbps = 0, fps = 0, p50 = 0, p99 = 0, bytes = 0;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[size_t(q * double(v.size() - 1))];
}

Figures run(const Link& link, const Client& client, unsigned seed, double seconds, bool drop, double cap) {
  const auto start = LinkPacer::Clock::now();
  const auto at = [start](double ms) { return start + std::chrono::microseconds(int64_t(ms * 1000)); };
  const double frameMs = 1000.0 / 30, fromMs = drop ? 8000 : 4000;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  LinkPacer pacer;
  std::deque<double> reports;  // when each written frame's report reaches the server
  double linkFree = 0, lastReport = 0, nextReady = 0, readyAt = 0;
  bool ready = false;
  std::vector<double> kbps, bytes, latency;
  for (double t = 0; t < seconds * 1000; t += 0.1) {
    while (!reports.empty() && reports.front() <= t) {
      pacer.received(at(t));
      reports.pop_front();
    }
    if (t >= nextReady) ready = true, readyAt = nextReady, nextReady += frameMs;
    if (!ready || !pacer.mayWrite(at(t))) continue;
    const double target = pacer.videoKbps(cap / 3, cap, at(t), LinkPacer::kFramesInFlight * frameMs);
    const double size = target * 1000 / 8 / 30 * (0.7 + 0.6 * uniform(rng)) + 60;
    pacer.sent(uint64_t(size), at(t), true);
    const double rate = drop && t > 6000 ? link.kbps / 5 : link.kbps;
    linkFree = std::max(linkFree, t) + size * 8 / rate;
    const double arrives = linkFree + link.roundTripMs / 2;
    const double late = client.lateMs * uniform(rng) + (uniform(rng) < client.hiccupShare ? 10 + 30 * uniform(rng) : 0);
    lastReport = std::max(lastReport + client.minGapMs, arrives + late);  // reports leave the client in order
    reports.push_back(lastReport + link.roundTripMs / 2);
    ready = false;
    if (t >= fromMs) kbps.push_back(target), bytes.push_back(size), latency.push_back(arrives - readyAt);
  }
  Figures f;
  for (size_t i = 0; i < kbps.size(); ++i) f.kbps += kbps[i] / double(kbps.size()), f.bytes += bytes[i] / double(kbps.size());
  f.fps = double(kbps.size()) / (seconds - fromMs / 1000);
  f.p50 = percentile(latency, 0.5);
  f.p99 = percentile(latency, 0.99);
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The video bitrate LinkPacer sets on modelled links and clients"};
  bool drop = false;
  unsigned seeds = 5;
  double seconds = 12, cap = 4719;
  std::string csvPath;
  app.add_flag("--drop", drop, "the link five times slower after 6 s");
  app.add_option("--seeds", seeds, "runs of each link and client (their means)")->check(CLI::Range(1, 100));
  app.add_option("--seconds", seconds, "each run's length")->check(CLI::Range(10.0, 600.0));
  app.add_option("--cap-kbps", cap, "the stream's cap (VideoStream::capKbps: 4719 at 1024x1024)")
      ->check(CLI::Range(150.0, 1e6));
  app.add_option("--csv", csvPath, "also write the table as CSV");
  CLI11_PARSE(app, argc, argv);
  const Link links[] = {{"10 Mbit/s, 40 ms", 10000, 40},  {"100 Mbit/s, 80 ms", 100000, 80},
                        {"2 Mbit/s, 40 ms", 2000, 40},    {"5 Mbit/s, 60 ms", 5000, 60},
                        {"1 Gbit/s, 1 ms", 1000000, 1}};
  const Client clients[] = {{"prompt", 1, 0}, {"browser", 8, 0.05}, {"busy", 8, 0.2}, {"paced", 8, 0.05, 40}};
  std::ofstream csv;
  if (!csvPath.empty()) {
    csv.open(csvPath);
    csv << "link,client,drop,kbps,frames_per_s,latency_p50_ms,latency_p99_ms,bytes_per_frame\n";
  }
  std::printf("| link | client | kbit/s | frames/s | p50 ms | p99 ms | bytes/frame |\n|---|---|---:|---:|---:|---:|---:|\n");
  for (const Link& link : links)
    for (const Client& client : clients) {
      Figures mean;
      for (unsigned s = 1; s <= seeds; ++s) {
        const Figures f = run(link, client, s, seconds, drop, cap);
        mean.kbps += f.kbps / seeds, mean.fps += f.fps / seeds, mean.p50 += f.p50 / seeds, mean.p99 += f.p99 / seeds;
        mean.bytes += f.bytes / seeds;
      }
      std::printf("| %s | %s | %.0f | %.1f | %.1f | %.1f | %.0f |\n", link.name, client.name, mean.kbps, mean.fps,
                  mean.p50, mean.p99, mean.bytes);
      if (csv.is_open())
        csv << '"' << link.name << "\"," << client.name << ',' << (drop ? 1 : 0) << ',' << mean.kbps << ',' << mean.fps
            << ',' << mean.p50 << ',' << mean.p99 << ',' << mean.bytes << '\n';
    }
  return 0;
}
