// PNG frames encoded Small against Fast (image::PngSpeed): for each lossless frame, the bytes, the median encode and
// decode ms of each, and the time a frame takes to reach a client (encoded, then sent) on links of 10, 100 and 1000
// Mbit/s. The table behind server::kSmallPngBelowKbps (bench/run_png_speed.sh writes
// bench/results/image/png-speed.{csv,md}).
//
//   bench_png --csv OUT.csv FRAME.png... [--repeats 5] [--out DIR]
// (--out: also writes each frame's two PNGs, NAME-small.png and NAME-fast.png, for bench/browser_decode.mjs.)
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "BenchTiming.h"
#include "image/Image.h"
#include "image/ImageFile.h"

namespace {

using namespace voxbrick;
using bench::medianMs;

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"PNG frames encoded Small against Fast: bytes, encode and decode ms"};
  std::vector<std::string> frames;
  std::string csvPath;
  int repeats = 5;
  std::string outDir;
  app.add_option("--csv", csvPath, "CSV to write")->required();
  app.add_option("--repeats", repeats, "encodes and decodes timed per frame and speed (the median is kept)")
      ->check(CLI::Range(1, 100));
  app.add_option("--out", outDir, "also write each frame's Small and Fast PNGs to this folder");
  app.add_option("frames", frames, "lossless frames (PNG)")->required()->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  try {
    std::ofstream csv(csvPath);
    csv << "frame,size,speed,bytes,encode_ms,decode_ms\n";
    for (const std::string& path : frames) {
      const image::Image8 frame = image::readImage(path);
      for (const auto& [name, speed] : {std::pair{"small", image::PngSpeed::Small}, {"fast", image::PngSpeed::Fast}}) {
        std::vector<uint8_t> bytes;
        const double encodeMs = medianMs(repeats, [&] { bytes = image::encodePng(frame, speed); });
        image::Image8 back;
        const double decodeMs = medianMs(repeats, [&] { back = image::decodePng(bytes, path); });
        if (back.rgba != frame.rgba) throw image::ImageFailure(path + ": the " + name + " PNG is not lossless");
        if (!outDir.empty()) {
          std::ofstream out(std::filesystem::path(outDir) /
                                (std::filesystem::path(path).stem().string() + "-" + name + ".png"),
                            std::ios::binary);
          out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
          if (!out) throw image::ImageFailure(outDir + ": cannot write the " + name + " PNG of " + path);
        }
        csv << std::filesystem::path(path).stem().string() << ',' << frame.width << 'x' << frame.height << ','
            << name << ',' << bytes.size() << ',' << encodeMs << ',' << decodeMs << '\n';
      }
      std::printf("%s measured\n", path.c_str());
    }
    if (!csv.flush()) throw std::runtime_error(csvPath + ": cannot write");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_png: %s\n", e.what());
    return 1;
  }
  return 0;
}
