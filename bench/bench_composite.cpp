// The MPI compositor alone (distributed/Compositor.h), under mpirun: every rank makes a partial frame of SIZE² whose
// active rectangle covers a share of the frame as a part of a volume would (overlapping its neighbours'), and the
// frames are composited REPEAT times after a barrier. Rank 0 prints one CSV line per size and encoding:
// ranks,size,encoding,ms_median,ms_max_rank,bytes_total,bytes_max_rank. Usage:
//   mpirun -n N bench_composite --sizes 512,1024,2048 --repeat 10
#include <mpi.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <numeric>
#include <random>
#include <vector>

#include "distributed/Cluster.h"
#include "distributed/Compositor.h"

using namespace voxbrick;

namespace {

// A part's frame: a translucent rectangle about half the frame's side, placed by rank, with some texture.
image::ImageF partFrame(int size, int rank, int ranks) {
  image::ImageF image{size, size, std::vector<float>(size_t(size) * size * 4, 0.0f)};
  const int side = size / 2 + size / 4;
  const int x0 = ranks > 1 ? (size - side) * (rank % 2) : size / 8;
  const int y0 = ranks > 1 ? (size - side) * rank / (ranks - 1) : size / 8;
  std::mt19937 random(unsigned(rank + 1));
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int y = y0; y < std::min(size, y0 + side); ++y) {
    for (int x = x0; x < std::min(size, x0 + side); ++x) {
      float a = 0.2f + 0.5f * unit(random);
      float* p = image.pixel(x, y);
      p[0] = a * 0.9f, p[1] = a * 0.5f, p[2] = a * 0.2f, p[3] = a;
    }
  }
  return image;
}

}  // namespace

int main(int argc, char** argv) {
  distributed::MpiSession mpi;  // MPI_Finalize when main returns
  const int rank = mpi.rank(), ranks = mpi.size();
  CLI::App app{"the MPI compositor's time and bytes per frame"};
  std::vector<int> sizes{512, 1024, 2048};
  int repeat = 10;
  app.add_option("--sizes", sizes, "frame sides")->delimiter(',');
  app.add_option("--repeat", repeat, "frames timed per size");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return rank == 0 ? app.exit(e) : 1;
  }
  std::vector<int> order(static_cast<size_t>(ranks));
  std::iota(order.begin(), order.end(), 0);
  std::reverse(order.begin() + ranks / 2, order.end());  // not simply rank order
  if (rank == 0) std::printf("ranks,size,encoding,ms_median,ms_max_rank,bytes_total,bytes_max_rank\n");
  for (int size : sizes) {
    const image::ImageF partial = partFrame(size, rank, ranks);
    for (auto encoding : {distributed::PixelEncoding::Half, distributed::PixelEncoding::Float}) {
      distributed::CompositeOptions options;
      options.encoding = encoding;
      options.timeoutSeconds = 60;
      std::vector<double> times;
      double bytes = 0, maxBytes = 0;
      for (int i = 0; i <= repeat; ++i) {  // the first is a warm-up
        MPI_Barrier(MPI_COMM_WORLD);
        distributed::CompositeStats stats;
        distributed::composite(MPI_COMM_WORLD, partial, order, options, &stats);
        double ms = stats.ms, slowest = 0, sent = double(stats.bytesSent), total = 0, most = 0;
        MPI_Reduce(&ms, &slowest, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
        MPI_Reduce(&sent, &total, 1, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
        MPI_Reduce(&sent, &most, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
        if (i == 0) continue;
        times.push_back(slowest);
        bytes = total, maxBytes = most;
      }
      if (rank != 0) continue;
      std::sort(times.begin(), times.end());
      std::printf("%d,%d,%s,%.3f,%.3f,%.0f,%.0f\n", ranks, size, distributed::pixelEncodingName(encoding),
                  times[times.size() / 2], times.back(), bytes, maxBytes);
      std::fflush(stdout);
    }
  }
  return 0;
}
