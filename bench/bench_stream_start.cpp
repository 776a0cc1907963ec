// What starting a video stream costs the server: a VideoEncoder built with the server's settings for a frame size
// (image::videoThreadsFor's threads) and its first frames encoded, one stream after another in one process, as
// sessions start their streams (and a stream starts again at a new size). Times: the encoder's construction, its
// key frame, the frame after it; memory: the process's resident set grown by holding the encoder and its two frames,
// and the bytes malloc has given out for it (the encoder's own, whatever the allocator keeps: what
// image::videoEncoderBytes estimates, and the server's memory.video_mb counts).
// bench/run_stream_start.sh runs it with and without glibc's transparent huge pages for malloc (GLIBC_TUNABLES).
//
//   bench_stream_start --csv OUT.csv [--sizes 512x512,1024x1024,1920x1080] [--repeats 5] FRAME.png
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/Median.h"
#include "image/ImageFile.h"
#include "image/Video.h"

namespace {

using namespace voxbrick;
using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// The bytes malloc has given out and not taken back (glibc: every arena, and blocks of their own mappings).
double heldBytes() {
  const struct mallinfo2 info = mallinfo2();
  return double(info.uordblks) + double(info.hblkhd);
}

/// The process's resident set, in MiB (Linux: /proc/self/status).
double residentMiB() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bench_stream_start: what starting a video stream costs (construction, first frames, memory)"};
  std::string csvPath, framePath;
  std::vector<std::string> sizes{"512x512", "1024x1024", "1920x1080"};
  int repeats = 5;
  int available = int(std::thread::hardware_concurrency());
  app.add_option("--csv", csvPath, "the CSV to write")->required();
  app.add_option("--sizes", sizes, "stream sizes, WxH")->delimiter(',');
  app.add_option("--repeats", repeats, "streams started one after another for each codec and size")
      ->check(CLI::Range(1, 100));
  app.add_option("--cores", available, "the cores image::videoThreadsFor may give a stream (default: this machine's)")
      ->check(CLI::Range(1, 256));
  std::vector<int> chromas{420};
  app.add_option("--chroma", chromas, "VP9's colour sampling: 420 (the server's), 444 (profile 1; rows of their own)")
      ->delimiter(',')
      ->check(CLI::IsMember({420, 444}));
  app.add_option("frame", framePath, "a frame (PNG), scaled to each size")->required()->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  // The server's allocator policy (cli/Allocator.cpp, keepFreedMemoryForFrames): blocks up to 32 MB kept for reuse.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
  try {
    const image::Image8 source = image::readImage(framePath);
    std::ofstream csv(csvPath);
    csv << "codec,size,threads,repeats,first_construct_ms,construct_ms,first_key_ms,key_ms,next_ms,resident_mib,held_mib,"
           "estimate_mib\n";
    std::vector<std::pair<proto::Encoding, bool>> formats{{proto::Encoding::Vp8, false}};
    for (const int chroma : chromas) formats.emplace_back(proto::Encoding::Vp9, chroma == 444);
    for (const auto& [codec, fullChroma] : formats)
      for (const std::string& size : sizes) {
        int width = 0, height = 0;
        if (std::sscanf(size.c_str(), "%dx%d", &width, &height) != 2 || width < 16 || height < 16)
          throw image::ImageFailure("bench_stream_start: size '" + size + "' is not WxH");
        const image::Image8 a = image::scaleImage(source, width, height);
        image::Image8 b = a;
        std::reverse(b.rgba.begin(), b.rgba.end());  // a second picture, unlike the first
        image::VideoSettings settings;
        settings.width = width, settings.height = height;
        settings.bitrateKbps = int(double(width) * height * 0.05 * 30 / 1000);  // the server's start
        settings.threads = image::videoThreadsFor(codec, width, height, available);
        settings.fullChroma = fullChroma;
        std::vector<double> construct, key, next, resident, held;
        for (int r = 0; r < repeats; ++r) {
          const double before = residentMiB(), heldBefore = heldBytes();
          auto start = Clock::now();
          auto encoder = std::make_unique<image::VideoEncoder>(codec, settings);
          construct.push_back(msSince(start));
          start = Clock::now();
          encoder->encode(a, 0);
          key.push_back(msSince(start));
          start = Clock::now();
          encoder->encode(b, 1000.0 / 30);
          next.push_back(msSince(start));
          resident.push_back(residentMiB() - before);
          held.push_back((heldBytes() - heldBefore) / (1 << 20));
        }
        char line[320];
        std::snprintf(line, sizeof line, "%s,%s,%d,%d,%.1f,%.1f,%.1f,%.1f,%.1f,%.0f,%.1f,%.1f\n",
                      (std::string(proto::encodingName(codec)) + (fullChroma ? " 4:4:4" : "")).c_str(), size.c_str(),
                      settings.threads, repeats, construct[0],
                      upperMedian(construct), key[0], upperMedian(key), upperMedian(next),
                      *std::max_element(resident.begin(), resident.end()), upperMedian(held),
                      double(image::videoEncoderBytes(codec, width, height, settings.threads, fullChroma)) /
                          (1 << 20));
        csv << line;
        std::fputs(line, stdout);
      }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_stream_start: %s\n", e.what());
    return 1;
  }
  return 0;
}
