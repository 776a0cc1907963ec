// The MPI compositor against the serial reference, run under mpirun by ctest (tests/distributed/CMakeLists.txt):
// every rank makes the same random partial frames from one seed (random active rectangles, some parts empty, random
// visibility orders and sizes), composites its own with distributed::composite, and rank 0 compares the result with
// render::compositeSerial. Exits 0 only if every case on rank 0 matches (float: exactly up to rounding order; half:
// within 1/2048 per channel). With --fault exit|stop RANK, that rank dies (_exit) or stops (SIGSTOP) before
// compositing, and the test passes only if rank 0 reports an error naming it within the deadline.
#include <mpi.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <random>
#include <string>

#include "distributed/Cluster.h"
#include "distributed/Compositor.h"

using namespace voxbrick;

namespace {

image::ImageF randomPartial(std::mt19937& random, int width, int height) {
  image::ImageF image{width, height, std::vector<float>(size_t(width) * height * 4, 0.0f)};
  if (random() % 4 == 0) return image;  // an empty part
  int x0 = int(random() % unsigned(width)), y0 = int(random() % unsigned(height));
  int x1 = x0 + 1 + int(random() % unsigned(width - x0)), y1 = y0 + 1 + int(random() % unsigned(height - y0));
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      if (unit(random) < 0.1f) continue;  // holes inside the rectangle
      float alpha = unit(random);
      float* p = image.pixel(x, y);
      for (int c = 0; c < 3; ++c) p[c] = alpha * unit(random);
      p[3] = alpha;
    }
  }
  return image;
}

double maxDifference(const image::ImageF& a, const image::ImageF& b) {
  if (a.width != b.width || a.height != b.height) return 1e9;
  double worst = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) worst = std::max(worst, double(std::fabs(a.rgba[i] - b.rgba[i])));
  return worst;
}

int runCases(int rank, int size) {
  int failures = 0;
  for (int seed = 1; seed <= 24; ++seed) {
    std::mt19937 random(unsigned(seed * 7919 + size));
    int width = 1 + int(random() % 97), height = 1 + int(random() % 61);
    if (seed == 1) width = height = 1;
    std::vector<image::ImageF> parts;
    for (int i = 0; i < size; ++i) parts.push_back(randomPartial(random, width, height));
    std::vector<int> order(static_cast<size_t>(size));
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), random);
    for (auto encoding : {distributed::PixelEncoding::Float, distributed::PixelEncoding::Half}) {
      distributed::CompositeOptions options;
      options.encoding = encoding;
      distributed::CompositeStats stats;
      image::ImageF result = distributed::composite(MPI_COMM_WORLD, parts[size_t(rank)], order, options, &stats);
      if (rank != 0) continue;
      double tolerance = encoding == distributed::PixelEncoding::Float ? 1e-5 : 1.0 / 1024;
      double difference = maxDifference(result, render::compositeSerial(parts, order));
      if (difference > tolerance) {
        std::fprintf(stderr, "case %d (%dx%d, %s): max difference %g\n", seed, width, height,
                     distributed::pixelEncodingName(encoding), difference);
        ++failures;
      }
    }
  }
  return failures;
}

int runFault(int rank, int size, const std::string& kind, int victim) {
  std::vector<int> order(static_cast<size_t>(size));
  std::iota(order.begin(), order.end(), 0);
  image::ImageF partial{64, 64, std::vector<float>(64 * 64 * 4, 0.5f)};
  int pid = int(getpid());
  std::vector<int> pids(static_cast<size_t>(size));
  MPI_Allgather(&pid, 1, MPI_INT, pids.data(), 1, MPI_INT, MPI_COMM_WORLD);
  if (rank == victim) {
    if (kind == "exit") _exit(3);
    raise(SIGSTOP);
  }
  distributed::CompositeOptions options;
  options.timeoutSeconds = 2;
  auto start = std::chrono::steady_clock::now();
  try {
    distributed::composite(MPI_COMM_WORLD, partial, order, options);
  } catch (const distributed::PeerError& error) {
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("rank %d: error after %.2f s: %s\n", rank, seconds, error.what());
    std::fflush(stdout);
    bool named = std::string(error.what()).find("rank " + std::to_string(victim)) != std::string::npos;
    if (rank == 0) {
      // A stopped rank would keep mpirun waiting: the test ends it (all ranks share this host under ctest).
      if (kind == "stop") kill(pid_t(pids[size_t(victim)]), SIGKILL);
      if (named && seconds < 5) std::printf("fault named: rank %d\n", victim);
      std::fflush(stdout);
      _exit(named && seconds < 5 ? 0 : 1);
    }
    _exit(0);
  }
  if (rank == 0) {
    std::fprintf(stderr, "rank 0: compositing finished although rank %d %s\n", victim, kind.c_str());
    _exit(1);
  }
  _exit(0);
}

}  // namespace

int main(int argc, char** argv) {
  distributed::MpiSession mpi;  // MPI_Finalize when main returns; the fault paths leave by _exit without it
  const int rank = mpi.rank(), size = mpi.size();
  if (argc == 4 && std::strcmp(argv[1], "--fault") == 0) return runFault(rank, size, argv[2], std::atoi(argv[3]));
  int failures = runCases(rank, size);
  if (rank == 0) std::printf("%d ranks: %d failing cases\n", size, failures);
  return failures == 0 ? 0 : 1;
}
