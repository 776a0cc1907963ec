// JPEG frames against lossless ones: for each lossless frame (PNG) and each JPEG quality and chroma layout, the
// bytes of the JPEG frame the server would send and its PSNR against the lossless frame, beside the PNG and zstd
// payloads of the same frame. The table behind image::kDefaultJpegQuality and image::kFrameJpegChroma
// (bench/run_jpeg.sh renders the frames and writes bench/results/jpeg/jpeg.{csv,md}).
//
//   bench_jpeg --csv OUT.csv FRAME.png... [--qualities 50,60,...] [--repeats 3]
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "BenchTiming.h"
#include "image/FrameImage.h"
#include "image/Image.h"
#include "image/ImageFile.h"

namespace {

using namespace voxbrick;
using bench::medianMs;

/// One frame's rows of the CSV: png, zstd, then jpeg at every quality and chroma layout.
void measure(const std::filesystem::path& path, const std::vector<int>& qualities, int repeats, std::ofstream& csv) {
  const image::Image8 frame = image::readImage(path);
  const image::ImageF reference = image::toImageF(frame);
  const std::string name = path.stem().string();
  const std::string size = std::to_string(frame.width) + "x" + std::to_string(frame.height);
  for (const proto::Encoding lossless : {proto::Encoding::Png, proto::Encoding::ZstdRgba8}) {
    std::vector<uint8_t> bytes;
    const double ms = medianMs(repeats, [&] { bytes = image::encodeFrameImage(frame, lossless); });
    csv << name << ',' << size << ',' << proto::encodingName(lossless) << ",,," << bytes.size() << ",inf," << ms
        << '\n';
  }
  for (const auto& [chromaName, chroma] :
       {std::pair{"444", image::JpegChroma::Full}, std::pair{"420", image::JpegChroma::Half}}) {
    for (const int quality : qualities) {
      std::vector<uint8_t> bytes;
      const double ms = medianMs(repeats, [&] { bytes = image::encodeJpeg(frame, quality, chroma); });
      const image::Image8 decoded = image::decodeJpeg(bytes, name);
      const double psnr = image::compareImages(reference, image::toImageF(decoded)).psnr;
      csv << name << ',' << size << ",jpeg," << chromaName << ',' << quality << ',' << bytes.size() << ',' << psnr
          << ',' << ms << '\n';
    }
  }
  std::printf("%s: %s measured\n", name.c_str(), size.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"JPEG frame bytes and PSNR against the lossless frame"};
  std::vector<std::string> frames;
  std::string csvPath;
  std::vector<int> qualities{50, 60, 70, 75, 80, 85, 90, 95};
  int repeats = 3;
  app.add_option("frames", frames, "lossless frames (PNG)")->required()->check(CLI::ExistingFile);
  app.add_option("--csv", csvPath, "CSV to write")->required();
  app.add_option("--qualities", qualities, "JPEG qualities")->delimiter(',')->check(CLI::Range(1, 100));
  app.add_option("--repeats", repeats, "encodes timed per setting (the median is kept)")->check(CLI::Range(1, 100));
  CLI11_PARSE(app, argc, argv);
  try {
    std::ofstream csv(csvPath);
    csv << "frame,size,encoding,chroma,quality,bytes,psnr_db,encode_ms\n";
    for (const std::string& frame : frames) measure(frame, qualities, repeats, csv);
    if (!csv.flush()) throw std::runtime_error(csvPath + ": cannot write");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_jpeg: %s\n", e.what());
    return 1;
  }
  return 0;
}
