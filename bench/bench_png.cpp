// The lossless frame encodings: PNG encoded Small against Fast (image::PngSpeed), and lossless WebP at libwebp's
// presets 0 to 2 (image::encodeWebp; 1 is the server's): for each lossless frame, the bytes, the median encode and
// decode ms of each. The table behind server::kSmallPngBelowKbps and server::kWebpBelowKbps (bench/run_png_speed.sh
// writes bench/results/image/png-speed.{csv,md}, with the time a frame takes to reach a client on links of 10, 100
// and 1000 Mbit/s).
//
//   bench_png --csv OUT.csv FRAME.png... [--repeats 5] [--out DIR]
// (--out: also writes each frame's files, NAME-small.png, NAME-fast.png, NAME-webp1.webp..., for
// bench/browser_decode.mjs.)
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
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
  CLI::App app{"Lossless frames as PNG (Small, Fast) and WebP: bytes, encode and decode ms"};
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
    // Each way of writing a frame losslessly: its name, file extension, encoder and decoder.
    struct Way {
      std::string name, extension;
      std::function<std::vector<uint8_t>(const image::Image8&)> encode;
      std::function<image::Image8(const std::vector<uint8_t>&, const std::string&)> decode;
    };
    const auto png = [](image::PngSpeed speed) {
      return [speed](const image::Image8& frame) { return image::encodePng(frame, speed); };
    };
    const auto webp = [](int level) {
      return [level](const image::Image8& frame) { return image::encodeWebp(frame, level); };
    };
    const auto decodePng = [](const std::vector<uint8_t>& b, const std::string& w) { return image::decodePng(b, w); };
    const auto decodeWebp = [](const std::vector<uint8_t>& b, const std::string& w) { return image::decodeWebp(b, w); };
    const std::vector<Way> ways{{"small", ".png", png(image::PngSpeed::Small), decodePng},
                                {"fast", ".png", png(image::PngSpeed::Fast), decodePng},
                                {"webp0", ".webp", webp(0), decodeWebp},
                                {"webp1", ".webp", webp(1), decodeWebp},
                                {"webp2", ".webp", webp(2), decodeWebp}};
    for (const std::string& path : frames) {
      const image::Image8 frame = image::readImage(path);
      for (const Way& way : ways) {
        const std::string& name = way.name;
        std::vector<uint8_t> bytes;
        const double encodeMs = medianMs(repeats, [&] { bytes = way.encode(frame); });
        image::Image8 back;
        const double decodeMs = medianMs(repeats, [&] { back = way.decode(bytes, path); });
        if (back.rgba != frame.rgba) throw image::ImageFailure(path + ": the " + name + " file is not lossless");
        if (!outDir.empty()) {
          std::ofstream out(std::filesystem::path(outDir) /
                                (std::filesystem::path(path).stem().string() + "-" + name + way.extension),
                            std::ios::binary);
          out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
          if (!out) throw image::ImageFailure(outDir + ": cannot write the " + name + " file of " + path);
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
