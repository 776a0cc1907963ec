// A drag's frames as the server could send them: the frames of a camera turning (lossless PNGs, in order, as
// `voxbrick orbit` writes them) sent as JPEG at several qualities, and as one VP8 or VP9 stream at several bitrates
// (the server's encoder settings, image/Video.h), each frame's bytes and its PSNR against the lossless frame, with
// encode and decode times. The table behind the video encodings' defaults (bench/run_video.sh writes
// bench/results/video/video.{csv,md}).
//
//   bench_video --csv OUT.csv --fps 30 FRAME.png... [--qualities 50,70,85] [--kbps 1000,2000,4000] [--threads 1,4]
//               [--scales 1,0.5] [--speeds 8,6] [--fixed-speed] [--rate-control cbr,vbr] [--aq 3,0]
//               [--start-frames 11,0] [--streams DIR] [--times FILE] [--max-frame-ms 33.3,0] [--references DIR]
//
// --times: the times (ms, one a line or space apart) at which a client was shown a drag's frames, as a browser
// recorded them (bench/browser_link.mjs --frames-out): the stream is fed one frame at each time, the drag's frame of
// that moment (frames skipped where the gaps are long), in place of every frame at --fps. --max-frame-ms: the most
// time a frame's bits are reckoned over (image::VideoSettings::maxFrameMs; 0: the real gap). --references: each
// frame's PSNR is taken against the file of its name in DIR (the exact frame of its view, at any size: the decoded
// frame is scaled to it, as a viewer shows it), in place of against the frame itself: for frames that are a cheaper
// drawing of each view.
//
// Besides the whole drag's means, each row has its start's: the first kStartFrames frames (a third of a second at 30
// frames a second), where the stream begins at a key frame.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "image/FrameImage.h"
#include "image/Image.h"
#include "image/Video.h"

namespace {

using namespace voxbrick;
using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

constexpr size_t kStartFrames = 11;

struct Row {
  std::string encoding, setting;
  double bytes = 0, psnr = 0, psnrMin = 1e9, encodeMs = 0, decodeMs = 0, keyBytes = 0;
  double startBytes = 0, startPsnr = 0, startPsnrMin = 1e9;  ///< over the first kStartFrames frames
  size_t count = 0;
  std::vector<double> sizes{};  ///< every frame's bytes
  double bytesP90 = 0, bytesMax = 0;
};

void accumulate(Row& row, size_t bytes, double psnr, double encodeMs, double decodeMs) {
  row.sizes.push_back(double(bytes));
  if (row.count++ < kStartFrames) {
    row.startBytes += double(bytes);
    row.startPsnr += psnr;
    row.startPsnrMin = std::min(row.startPsnrMin, psnr);
  }
  row.bytes += double(bytes);
  row.psnr += psnr;
  row.psnrMin = std::min(row.psnrMin, psnr);
  row.encodeMs += encodeMs;
  row.decodeMs += decodeMs;
}

void finish(Row& row, size_t frames) {
  const double n = double(frames), start = double(std::min(frames, kStartFrames));
  row.bytes /= n, row.psnr /= n, row.encodeMs /= n, row.decodeMs /= n;
  row.startBytes /= start, row.startPsnr /= start;
  std::sort(row.sizes.begin(), row.sizes.end());
  if (!row.sizes.empty()) {
    row.bytesP90 = row.sizes[std::min(row.sizes.size() - 1, size_t(0.9 * double(row.sizes.size())))];
    row.bytesMax = row.sizes.back();
  }
}

double psnr(const image::Image8& a, const image::Image8& b) {
  return image::compareImages(image::toImageF(a), image::toImageF(b)).psnr;
}

/// The PSNR of `shown` (a decoded frame of the drag's frame `i`) against its reference (--references) scaled to the
/// reference's size, or against `frame` itself (shown scaled to its size).
double shownPsnr(const image::Image8& shown, const image::Image8& frame, const std::vector<image::Image8>& references,
                 size_t i) {
  const image::Image8& against = references.empty() ? frame : references[i];
  return psnr(against, image::scaleImage(shown, against.width, against.height));
}

Row jpegRow(const std::vector<image::Image8>& frames, const std::vector<image::Image8>& references, int quality) {
  Row row{"jpeg", "q" + std::to_string(quality)};
  for (size_t i = 0; i < frames.size(); ++i) {
    const image::Image8& frame = frames[i];
    auto start = Clock::now();
    proto::Frame sent{uint32_t(frame.width), uint32_t(frame.height), proto::Encoding::Jpeg, "{}",
                      image::encodeFrameImage(frame, proto::Encoding::Jpeg, quality)};
    const double encodeMs = msSince(start);
    start = Clock::now();
    const image::Image8 shown = image::decodeFrameImage(sent);
    const double decodeMs = msSince(start);
    accumulate(row, sent.payload.size(), shownPsnr(shown, frame, references, i), encodeMs, decodeMs);
  }
  finish(row, frames.size());
  return row;
}

/// The frames a stream is fed, and when: each frame at `fps`, or with `times` (ms) the drag's frame of each moment.
struct Feed {
  std::vector<size_t> frame;
  std::vector<double> ms;
};

Feed feedOf(size_t frames, double fps, const std::vector<double>& times) {
  Feed feed;
  for (size_t i = 0; i < (times.empty() ? frames : times.size()); ++i) {
    const double ms = times.empty() ? 1000.0 * double(i) / fps : times[i] - times[0];
    feed.ms.push_back(ms);
    feed.frame.push_back(times.empty() ? i : size_t(std::llround(ms * fps / 1000)) % frames);
  }
  return feed;
}

/// A stream of the frames scaled by `scale` (1: as they are) with `settings` (its size aside), each decoded
/// frame scaled back to the frame's size before its PSNR is taken (as a viewer shows a smaller stream). The row's
/// setting names the bitrate and whatever differs from the server's defaults.
Row videoRow(const std::vector<image::Image8>& frames, const std::vector<image::Image8>& references, const Feed& feed,
             proto::Encoding codec, double scale, image::VideoSettings settings, const std::string& streamsDir) {
  const image::VideoSettings defaults;
  std::string setting = std::to_string(settings.bitrateKbps) + " kbit/s";
  if (settings.threads > 1) setting += "; " + std::to_string(settings.threads) + " threads";
  char scaled[32];
  std::snprintf(scaled, sizeof scaled, "; scale %g", scale);
  if (scale != 1) setting += scaled;
  if (settings.speed != defaults.speed) setting += "; speed " + std::to_string(settings.speed);
  if (codec == proto::Encoding::Vp8 && !settings.adaptiveSpeed) setting += "; fixed speed";
  if (!settings.constantBitrate) setting += "; vbr";
  if (codec == proto::Encoding::Vp9 && settings.aqMode != defaults.aqMode)
    setting += "; aq " + std::to_string(settings.aqMode);
  if (settings.fullChroma) setting += "; 4:4:4";
  if (settings.startFrames != defaults.startFrames)
    setting += settings.startFrames == 0 ? std::string("; no start cap")
                                         : "; start cap " + std::to_string(settings.startFrames) + " frames";
  char frameMs[48];
  std::snprintf(frameMs, sizeof frameMs, "; frames reckoned over at most %.1f ms", settings.maxFrameMs);
  if (settings.maxFrameMs != defaults.maxFrameMs) setting += settings.maxFrameMs == 0 ? "; real gaps" : frameMs;
  Row row{proto::encodingName(codec), setting};
  const int width = std::max(16, int(std::lround(frames[0].width * scale)));
  const int height = std::max(16, int(std::lround(frames[0].height * scale)));
  settings.width = width, settings.height = height;
  image::VideoEncoder encoder(codec, settings);
  image::VideoDecoder decoder(codec);
  // --streams: the chunks as they would travel, each as its length (4 bytes, little-endian), 1 if a key frame, and
  // its bytes (bench/browser_decode.mjs feeds them to a browser's decoder).
  std::ofstream stream;
  if (!streamsDir.empty()) {
    std::string name = std::string(proto::encodingName(codec)) + "-" + std::to_string(width) + "x" +
                       std::to_string(height) + "-" + std::to_string(settings.bitrateKbps) + "kbps-" +
                       std::to_string(settings.threads) + "t" + (settings.fullChroma ? "-444" : "") + ".chunks";
    stream.open(streamsDir + "/" + name, std::ios::binary);
    if (!stream) throw image::ImageFailure("bench_video: cannot write " + streamsDir + "/" + name);
  }
  for (size_t i = 0; i < feed.frame.size(); ++i) {
    const image::Image8& frame = frames[feed.frame[i]];
    // Scaled before the encoding is timed: the server draws a smaller stream's frames at its size.
    const image::Image8 sized = image::scaleImage(frame, width, height);
    auto start = Clock::now();
    const image::VideoChunk chunk = encoder.encode(sized, feed.ms[i]);
    const double encodeMs = msSince(start);
    start = Clock::now();
    const image::Image8 decoded = decoder.decode(chunk.bytes);
    const double decodeMs = msSince(start);
    accumulate(row, chunk.bytes.size(), shownPsnr(decoded, frame, references, feed.frame[i]), encodeMs, decodeMs);
    if (chunk.key) row.keyBytes = double(chunk.bytes.size());
    if (stream.is_open()) {
      const uint32_t n = uint32_t(chunk.bytes.size());
      const char head[5] = {char(n & 0xff), char((n >> 8) & 0xff), char((n >> 16) & 0xff), char(n >> 24),
                            char(chunk.key ? 1 : 0)};
      stream.write(head, sizeof head);
      stream.write(reinterpret_cast<const char*>(chunk.bytes.data()), std::streamsize(n));
    }
  }
  finish(row, feed.frame.size());
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bench_video: a drag's frames as JPEG and as a VP8/VP9 stream, bytes against PSNR"};
  std::string csvPath;
  std::vector<std::string> paths;
  std::vector<int> qualities{50, 70, 85, 95}, kbps{500, 1000, 2000, 4000, 8000};
  double fps = 30;
  std::vector<int> threads{1};
  std::vector<double> scales{1};
  std::vector<int> speeds{image::VideoSettings{}.speed};
  app.add_option("--csv", csvPath, "the CSV to write")->required();
  app.add_option("--qualities", qualities, "JPEG qualities")->delimiter(',');
  app.add_option("--kbps", kbps, "video bitrates, kbit/s")->delimiter(',');
  app.add_option("--fps", fps, "the frames' rate (the stream's timestamps)")->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "encoder threads (each a row of every bitrate; the server's choice is "
                                       "image::videoThreadsFor)")->delimiter(',');
  app.add_option("--scales", scales, "stream sizes as fractions of the frames' (each a row of every bitrate; the "
                                     "decoded frame is scaled back to the frame's size for its PSNR); above 1, a "
                                     "drawing scaled up to the stream's size, as the server does a reduced one")
      ->delimiter(',')
      ->check(CLI::Range(0.05, 8.0));
  app.add_option("--speeds", speeds, "libvpx realtime speeds (VP8 4..16, VP9 5..9; each a row of every bitrate)")
      ->delimiter(',');
  bool fixedSpeed = false;
  app.add_flag("--fixed-speed", fixedSpeed,
               "VP8 at each speed as set (the server lets libvpx adapt it to the time "
               "encoding takes: image::VideoSettings::adaptiveSpeed)");
  std::vector<std::string> rateControls{"cbr"};
  std::vector<int> aqModes{image::VideoSettings{}.aqMode};
  app.add_option("--rate-control", rateControls, "cbr (the server's), vbr (each a row of every bitrate)")
      ->delimiter(',')
      ->check(CLI::IsMember({"cbr", "vbr"}));
  app.add_option("--aq", aqModes, "VP9's adaptive quantisation modes, 0..3 (each a row of every VP9 bitrate)")
      ->delimiter(',')
      ->check(CLI::Range(0, 3));
  std::vector<std::string> codecNames{"vp8", "vp9"};
  app.add_option("--codecs", codecNames, "the video codecs measured: vp8, vp9")
      ->delimiter(',')
      ->check(CLI::IsMember({"vp8", "vp9"}));
  std::vector<int> chromas{420};
  app.add_option("--chroma", chromas, "VP9's colour sampling: 420 (the server's), 444 (profile 1; each a row of "
                                      "every VP9 bitrate)")
      ->delimiter(',')
      ->check(CLI::IsMember({420, 444}));
  std::vector<int> startFrames{image::VideoSettings{}.startFrames};
  app.add_option("--start-frames", startFrames,
                 "the frames of a stream's start whose quantizer is capped (image::VideoSettings::startFrames; 0: "
                 "no cap; each a row of every bitrate)")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000));
  std::string streamsDir;
  app.add_option("--streams", streamsDir, "also write each video row's chunks to a file in this folder, for "
                                          "bench/browser_decode.mjs");
  std::string timesPath;
  app.add_option("--times", timesPath, "a file of the times (ms) a client was shown the drag's frames: a frame is "
                                       "fed at each, the drag's frame of that moment (at --fps), in place of every "
                                       "frame at --fps")->check(CLI::ExistingFile);
  std::vector<double> maxFrameMs{image::VideoSettings{}.maxFrameMs};
  app.add_option("--max-frame-ms", maxFrameMs, "the most time a frame's bits are reckoned over "
                                               "(image::VideoSettings::maxFrameMs; 0: the real gap; each a row of "
                                               "every bitrate)")
      ->delimiter(',')
      ->check(CLI::Range(0.0, 10000.0));
  std::string referencesDir;
  app.add_option("--references", referencesDir, "a folder of each frame's reference, of the frame's file name (the "
                                               "exact frame of its view, at any size): PSNR against it")
      ->check(CLI::ExistingDirectory);
  app.add_option("frames", paths, "the drag's lossless frames, in order")->required();
  CLI11_PARSE(app, argc, argv);
  try {
    std::vector<image::Image8> frames;
    for (const std::string& path : paths) frames.push_back(image::readPng(path));
    for (const image::Image8& f : frames)
      if (f.width != frames[0].width || f.height != frames[0].height)
        throw image::ImageFailure("bench_video: the frames differ in size");
    std::vector<double> times;
    if (!timesPath.empty()) {
      std::ifstream in(timesPath);
      for (double t; in >> t;) times.push_back(t);
      if (times.size() < 2 || !in.eof()) throw image::ImageFailure("bench_video: " + timesPath + " is no list of times");
      if (!std::is_sorted(times.begin(), times.end()))
        throw image::ImageFailure("bench_video: the times of " + timesPath + " go back");
    }
    std::vector<image::Image8> references;
    if (!referencesDir.empty())
      for (const std::string& path : paths)
        references.push_back(image::readPng(referencesDir + "/" + std::filesystem::path(path).filename().string()));
    const Feed feed = feedOf(frames.size(), fps, times);
    std::vector<Row> rows;
    for (int q : qualities) rows.push_back(jpegRow(frames, references, q));
    for (const proto::Encoding codec : {proto::Encoding::Vp8, proto::Encoding::Vp9})
      if (std::find(codecNames.begin(), codecNames.end(), proto::encodingName(codec)) != codecNames.end())
      for (int t : threads)
        for (double scale : scales)
          for (int speed : speeds)
            for (const std::string& rc : rateControls)
              for (int aq : codec == proto::Encoding::Vp9 ? aqModes : std::vector<int>{image::VideoSettings{}.aqMode})
                for (int chroma : codec == proto::Encoding::Vp9 ? chromas : std::vector<int>{420})
                for (int start : startFrames)
                  for (double frameMs : maxFrameMs)
                  for (int k : kbps) {
                    image::VideoSettings settings;
                    settings.startFrames = start;
                    settings.maxFrameMs = frameMs;
                    settings.bitrateKbps = k, settings.threads = t, settings.speed = speed;
                    settings.adaptiveSpeed = !fixedSpeed;
                    settings.constantBitrate = rc == "cbr";
                    settings.aqMode = aq;
                    settings.fullChroma = chroma == 444;
                    rows.push_back(videoRow(frames, references, feed, codec, scale, settings, streamsDir));
                  }
    std::ofstream csv(csvPath);
    csv << "size,frames,fps,encoding,setting,bytes_per_frame,psnr_mean_db,psnr_min_db,encode_ms,decode_ms,key_bytes,"
           "start_bytes_per_frame,start_psnr_mean_db,start_psnr_min_db,bytes_p90,bytes_max\n";
    for (const Row& r : rows) {
      char line[640];
      std::snprintf(line, sizeof line, "%dx%d,%zu,%g,%s,%s,%.0f,%.2f,%.2f,%.2f,%.2f,%.0f,%.0f,%.2f,%.2f,%.0f,%.0f\n",
                    frames[0].width, frames[0].height, r.count, fps, r.encoding.c_str(), r.setting.c_str(), r.bytes,
                    r.psnr, r.psnrMin, r.encodeMs, r.decodeMs, r.keyBytes, r.startBytes, r.startPsnr, r.startPsnrMin,
                    r.bytesP90, r.bytesMax);
      csv << line;
      std::fputs(line, stdout);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_video: %s\n", e.what());
    return 1;
  }
  return 0;
}
