// The MPI compositor alone (distributed/Compositor.h), under mpirun: every rank draws its part of a volume as a
// k-d split of it would give (the volume covering much of the frame, split into one box per rank, each rank's
// partial frame the ray-marched blobs inside its box), and the frames are composited REPEAT times after a barrier,
// through to the finished 8-bit frame on rank 0 (the variants taking turns repeat by repeat). Rank 0 prints one CSV
// line per size, encoding, variant and factorisation:
//   impl,ranks,size,encoding,factors,ms_median,ms_max,ms_composite_median,bytes_total,bytes_max_rank,
//   active_share,union_share,inputs,footprint_share,handled_max_rank
// impl: binary-swap (the compositor before radix-k), radix-k (each rank reading only its part's footprint, the box's
// projection on the screen, as the server does) or radix-k-whole (each rank reading its whole partial frame, as before
// footprints). ms: the slowest rank's time from the barrier to the finished 8-bit frame (the radix-k compositor
// finishes inside compositeFinished; binary swap composites, then rank 0 finishes the whole frame as RankRenderer
// did); ms_composite: the compositing call alone; active_share: the active pixels of all parts over ranks × frame
// pixels; union_share: the frame's pixels active in some part; inputs: a digest of every rank's partial frame, the
// same for both implementations when the inputs are; footprint_share: the pixels of the footprints as read
// (DenseFrame: a wide one as whole rows) over ranks × frame pixels; handled_max_rank: the most pixels one rank handled (CompositeStats::pixelsHandled: what the cost model
// charges for). The source builds against either compositor (the binary-swap one on main before radix-k, which
// run_mpi.sh --baseline-build uses): the partial frames are made by the same code. Usage:
//   mpirun -n N bench_composite --sizes 512,1024,2048 --repeat 10 [--factors default|all] [--encodings half,float]
//                               [--variants footprint,whole]
//   bench_composite --print-factors 8,64,512     (radixFactors of each, as N:KxK…)
#include <mpi.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <string>
#include <vector>

#include "distributed/Cluster.h"
#include "distributed/Compositor.h"
#include "render/core/PartialFrame.h"
#if __has_include("distributed/PixelRuns.h")
#define VOXBRICK_BENCH_RADIX_K 1
#endif

using namespace voxbrick;

namespace {

using Vec = std::array<double, 3>;

struct Box {
  Vec lo, hi;
};

// The volume [-0.5, 0.5]^3 split as render::partitionBricks splits one: a k-d tree, each split across the longest
// side, the two sides' shares in proportion to their part counts (balanced by volume).
void split(const Box& box, int parts, std::vector<Box>& out) {
  if (parts == 1) {
    out.push_back(box);
    return;
  }
  int axis = 0;
  for (int a = 1; a < 3; ++a) {
    if (box.hi[size_t(a)] - box.lo[size_t(a)] > box.hi[size_t(axis)] - box.lo[size_t(axis)]) axis = a;
  }
  const int left = parts / 2;
  const double at = box.lo[size_t(axis)] + (box.hi[size_t(axis)] - box.lo[size_t(axis)]) * left / parts;
  Box a = box, b = box;
  a.hi[size_t(axis)] = at;
  b.lo[size_t(axis)] = at;
  split(a, left, out);
  split(b, parts - left, out);
}

// Density: a soft sphere (skin) around a few blobs; the transfer function keeps what is above 0.2.
double density(const Vec& p) {
  static const double blobs[][4] = {{-0.15, -0.1, 0.05, 0.16},
                                    {0.18, 0.12, -0.1, 0.13},
                                    {0.0, 0.2, 0.15, 0.1},
                                    {-0.1, -0.22, -0.18, 0.11},
                                    {0.2, -0.15, 0.2, 0.09}};
  const double r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  double d = std::exp(-std::pow((r - 0.42) / 0.03, 2)) * 0.45;
  for (const auto& b : blobs) {
    const double dx = p[0] - b[0], dy = p[1] - b[1], dz = p[2] - b[2];
    d += std::exp(-(dx * dx + dy * dy + dz * dz) / (b[3] * b[3]));
  }
  return d;
}

// The bench's perspective camera at an angle: the eye looking at the volume's centre, a 40° view.
struct BenchCamera {
  Vec eye{0.775, 0.527, 0.9}, forward{}, right{}, up{};
  double halfView = std::tan(0.5 * 40.0 * M_PI / 180);

  BenchCamera() {
    const double length = std::sqrt(eye[0] * eye[0] + eye[1] * eye[1] + eye[2] * eye[2]);
    forward = {-eye[0] / length, -eye[1] / length, -eye[2] / length};
    const double rl = std::sqrt(forward[2] * forward[2] + forward[0] * forward[0]);
    right = {forward[2] / rl, 0, -forward[0] / rl};
    up = {right[1] * forward[2] - right[2] * forward[1], right[2] * forward[0] - right[0] * forward[2],
          right[0] * forward[1] - right[1] * forward[0]};
  }
};

// A part's premultiplied frame at `side`² pixels: rays from the bench's camera, sampled every 1/96 inside the part's
// box (at the same distances for every part, as a partitioned renderer does), front to back.
image::ImageF drawPart(const Box& box, int side) {
  image::ImageF image{side, side, std::vector<float>(size_t(side) * size_t(side) * 4, 0.0f)};
  const BenchCamera camera;
  const Vec &eye = camera.eye, &forward = camera.forward, &right = camera.right, &up = camera.up;
  const double step = 1.0 / 96, halfView = camera.halfView;
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const double u = ((x + 0.5) / side * 2 - 1) * halfView, v = (1 - (y + 0.5) / side * 2) * halfView;
      Vec dir;
      for (size_t a = 0; a < 3; ++a) dir[a] = forward[a] + u * right[a] + v * up[a];
      const double dl = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
      for (auto& c : dir) c /= dl;
      double t0 = 0, t1 = 1e9;
      for (size_t a = 0; a < 3; ++a) {
        const double inv = 1 / dir[a];
        double ta = (box.lo[a] - eye[a]) * inv, tb = (box.hi[a] - eye[a]) * inv;
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta), t1 = std::min(t1, tb);
      }
      if (t0 >= t1) continue;
      double rgba[4] = {0, 0, 0, 0};
      for (double t = std::ceil(t0 / step) * step; t < t1 && rgba[3] < 0.99; t += step) {
        const Vec p{eye[0] + t * dir[0], eye[1] + t * dir[1], eye[2] + t * dir[2]};
        const double d = density(p);
        if (d < 0.2) continue;
        const double alpha = 1 - std::exp(-(d - 0.2) * 6 * step * 8), keep = 1 - rgba[3];
        const double colour[3] = {0.9 * d, 0.6 * d * d, 0.3 + 0.2 * d};
        for (int c = 0; c < 3; ++c) rgba[c] += keep * alpha * std::min(colour[c], 1.0);
        rgba[3] += keep * alpha;
      }
      float* out = image.pixel(x, y);
      for (int c = 0; c < 4; ++c) out[c] = float(rgba[c]);
    }
  }
  return image;
}

// The bench's camera (drawPart's): where point p falls on a side² frame, in pixels (x right, y down; pixel centres at
// +0.5); false when p is not in front of the eye.
bool projectPoint(const Vec& p, int side, double& x, double& y) {
  const BenchCamera camera;
  const Vec d{p[0] - camera.eye[0], p[1] - camera.eye[1], p[2] - camera.eye[2]};
  auto dot = [](const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  const double depth = dot(d, camera.forward);
  if (depth <= 1e-9) return false;
  const double u = dot(d, camera.right) / depth / camera.halfView, v = dot(d, camera.up) / depth / camera.halfView;
  x = (u + 1) / 2 * side, y = (1 - v) / 2 * side;
  return true;
}

// The rectangle of a size² frame the box can touch (as SortLastParts::footprint: the box's corners projected, grown
// by a margin), here with the margin the bilinear scaling from the drawn side adds.
render::PixelRect boxFootprint(const Box& box, int size) {
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
  for (int c = 0; c < 8; ++c) {
    const Vec p{(c & 1) ? box.hi[0] : box.lo[0], (c & 2) ? box.hi[1] : box.lo[1], (c & 4) ? box.hi[2] : box.lo[2]};
    double x = 0, y = 0;
    if (!projectPoint(p, size, x, y)) return {0, 0, size, size};
    lo[0] = std::min(lo[0], x), hi[0] = std::max(hi[0], x), lo[1] = std::min(lo[1], y), hi[1] = std::max(hi[1], y);
  }
  const int margin = 2 + (size + 255) / 256;
  auto clamp = [size](double v) { return int(std::clamp(v, 0.0, double(size))); };
  return {clamp(std::floor(lo[0]) - margin), clamp(std::floor(lo[1]) - margin), clamp(std::ceil(hi[0]) + margin),
          clamp(std::ceil(hi[1]) + margin)};
}

// What a renderer draws of a part (FrameStats::drawnBox): the box of the bricks of a 16³ grid over the volume that
// meet the part and hold a density the transfer function keeps (>= 0.2, at any of 9³ points of the brick), empty
// when none does.
Box drawnBricks(const Box& part) {
  constexpr int kBricks = 16, kSamples = 9;
  const double edge = 1.0 / kBricks;
  Box drawn{{1, 1, 1}, {-1, -1, -1}};
  for (int k = 0; k < kBricks; ++k) {
    for (int j = 0; j < kBricks; ++j) {
      for (int i = 0; i < kBricks; ++i) {
        const Vec lo{-0.5 + i * edge, -0.5 + j * edge, -0.5 + k * edge};
        bool meets = true;  // a brick the part's box cuts is drawn by the part too
        for (size_t a = 0; a < 3; ++a) meets = meets && lo[a] < part.hi[a] && lo[a] + edge > part.lo[a];
        if (!meets) continue;
        bool kept = false;
        for (int n = 0; n < kSamples * kSamples * kSamples && !kept; ++n) {
          const Vec p{lo[0] + edge * (n % kSamples) / (kSamples - 1), lo[1] + edge * (n / kSamples % kSamples) / (kSamples - 1),
                      lo[2] + edge * (n / (kSamples * kSamples)) / (kSamples - 1)};
          kept = density(p) >= 0.2;
        }
        if (!kept) continue;
        for (size_t a = 0; a < 3; ++a) {
          drawn.lo[a] = drawn.lo[a] > drawn.hi[a] ? lo[a] : std::min(drawn.lo[a], lo[a]);
          drawn.hi[a] = std::max(drawn.hi[a], lo[a] + edge);
        }
      }
    }
  }
  return drawn;
}

// The part drawn at 256² (drawing every pixel of 2048² on every rank would take minutes) and scaled up bilinearly:
// smooth colour and the part's silhouette, with its empty pixels exactly empty.
image::ImageF partFrame(const Box& box, int size) {
  const int side = std::min(size, 256);
  const image::ImageF small = drawPart(box, side);
  if (side == size) return small;
  image::ImageF image{size, size, std::vector<float>(size_t(size) * size_t(size) * 4, 0.0f)};
  const double scale = double(side) / size;
  for (int y = 0; y < size; ++y) {
    const double sy = std::clamp((y + 0.5) * scale - 0.5, 0.0, side - 1.0);
    const int y0 = int(sy), y1 = std::min(y0 + 1, side - 1);
    const float fy = float(sy - y0);
    for (int x = 0; x < size; ++x) {
      const double sx = std::clamp((x + 0.5) * scale - 0.5, 0.0, side - 1.0);
      const int x0 = int(sx), x1 = std::min(x0 + 1, side - 1);
      const float fx = float(sx - x0);
      const float *a = small.pixel(x0, y0), *b = small.pixel(x1, y0), *c = small.pixel(x0, y1),
                  *d = small.pixel(x1, y1);
      float* out = image.pixel(x, y);
      for (int i = 0; i < 4; ++i) {
        out[i] = (a[i] * (1 - fx) + b[i] * fx) * (1 - fy) + (c[i] * (1 - fx) + d[i] * fx) * fy;
      }
    }
  }
  return image;
}

uint64_t digest(const image::ImageF& image) {
  uint64_t h = 1469598103934665603ull;
  const auto* bytes = reinterpret_cast<const uint8_t*>(image.rgba.data());
  for (size_t i = 0; i < image.rgba.size() * 4; ++i) h = (h ^ bytes[i]) * 1099511628211ull;
  return h;
}

std::string factorsText(const std::vector<int>& factors) {
  std::string text;
  for (size_t i = 0; i < factors.size(); ++i) text += (i ? "x" : "") + std::to_string(factors[i]);
  return text.empty() ? "-" : text;
}

double maxOver(double value) {
  double result = 0;
  MPI_Reduce(&value, &result, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
  return result;
}
double sumOver(double value) {
  double result = 0;
  MPI_Reduce(&value, &result, 1, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  distributed::MpiSession mpi;  // MPI_Finalize when main returns
  const int rank = mpi.rank(), ranks = mpi.size();
  CLI::App app{"the MPI compositor's time and bytes per frame"};
  std::vector<int> sizes{512, 1024, 2048};
  std::vector<std::string> encodings{"half"};
  std::string factorChoice = "default";
  std::vector<std::string> variants{"footprint", "whole"};
  int repeat = 10;
  std::vector<int> printFactors;
  app.add_option("--sizes", sizes, "frame sides")->delimiter(',');
  app.add_option("--print-factors", printFactors, "print radixFactors(N) as N:KxK.. for these N, and exit")
      ->delimiter(',');
  app.add_option("--repeat", repeat, "frames timed per size")->check(CLI::PositiveNumber);
  app.add_option("--encodings", encodings, "half, float")->delimiter(',');
  app.add_option("--variants", variants,
                 "radix-k: footprint (each rank reads its part's footprint only), whole (its whole frame)")
      ->delimiter(',')
      ->check(CLI::IsMember({"footprint", "whole"}));
  app.add_option("--factors", factorChoice, "radix-k factorisations: default, or all (each ordered one)")
      ->check(CLI::IsMember({"default", "all"}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return rank == 0 ? app.exit(e) : 1;
  }
  if (!printFactors.empty()) {
#ifdef VOXBRICK_BENCH_RADIX_K
    for (int n : printFactors) {
      if (rank == 0) std::printf("%d:%s\n", n, factorsText(distributed::radixFactors(n)).c_str());
    }
    return 0;
#else
    if (rank == 0) std::fprintf(stderr, "bench_composite: this compositor has no radix-k factors\n");
    return 1;
#endif
  }
  std::vector<Box> boxes;
  split({{-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}}, ranks, boxes);
  // Front to back by the boxes' centres' distance from the eye (the k-d order for this view).
  std::vector<int> order(static_cast<size_t>(ranks));
  std::iota(order.begin(), order.end(), 0);
  auto distance = [&boxes](int i) {
    const Box& b = boxes[size_t(i)];
    const Vec eye = BenchCamera().eye;
    double d = 0;
    for (size_t a = 0; a < 3; ++a) d += std::pow((b.lo[a] + b.hi[a]) / 2 - eye[a], 2);
    return d;
  };
  std::sort(order.begin(), order.end(), [&](int a, int b) { return distance(a) < distance(b); });
  std::vector<std::vector<int>> choices{{}};
#ifdef VOXBRICK_BENCH_RADIX_K
  const char* impl = "radix-k";
  if (factorChoice == "all" && ranks > 1) choices = distributed::radixFactorisations(ranks);
#else
  const char* impl = "binary-swap";
  variants = {"whole"};  // no footprints before radix-k
#endif
  render::Scene scene;
  scene.background = {0.1, 0.1, 0.15};
  if (rank == 0) {
    std::printf(
        "impl,ranks,size,encoding,factors,ms_median,ms_max,ms_composite_median,bytes_total,bytes_max_rank,"
        "active_share,union_share,inputs,footprint_share,handled_max_rank\n");
  }
  for (int size : sizes) {
    const image::ImageF partial = partFrame(boxes[size_t(rank)], size);
    // Active pixels: this part's, and the union over parts (a mask gathered by OR).
    std::vector<uint8_t> mask(size_t(size) * size_t(size)), all(mask.size());
    double active = 0;
    for (size_t i = 0; i < mask.size(); ++i) {
      const float* p = &partial.rgba[i * 4];
      mask[i] = p[0] != 0 || p[1] != 0 || p[2] != 0 || p[3] != 0;
      active += mask[i];
    }
    MPI_Reduce(mask.data(), all.data(), int(mask.size()), MPI_UNSIGNED_CHAR, MPI_BOR, 0, MPI_COMM_WORLD);
    const double activeAll = sumOver(active);
    const double unionShare = double(std::count(all.begin(), all.end(), uint8_t(1))) / double(mask.size());
    // This part's footprint, and a check that it holds every pixel the part drew (as the server's tests check).
    // The part's box cut to the bricks it draws, as the server cuts it (SortLastParts::footprint with the frame's
    // drawnBox); nothing drawn: an empty footprint.
    const Box bricks = drawnBricks(boxes[size_t(rank)]);
    Box cut = boxes[size_t(rank)];
    bool none = false;
    for (size_t a = 0; a < 3; ++a) {
      cut.lo[a] = std::max(cut.lo[a], bricks.lo[a]), cut.hi[a] = std::min(cut.hi[a], bricks.hi[a]);
      none = none || cut.lo[a] >= cut.hi[a];
    }
    const render::PixelRect footprint = none ? render::PixelRect{} : boxFootprint(cut, size);
    const render::PixelRect drawn = render::activeRect(partial);
    if (!drawn.empty() && (drawn.x0 < footprint.x0 || drawn.y0 < footprint.y0 || drawn.x1 > footprint.x1 ||
                           drawn.y1 > footprint.y1)) {
      std::fprintf(stderr, "bench_composite: rank %d drew [%d, %d) x [%d, %d), outside its footprint [%d, %d) x [%d, %d)\n",
                   rank, drawn.x0, drawn.x1, drawn.y0, drawn.y1, footprint.x0, footprint.x1, footprint.y0,
                   footprint.y1);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
#ifdef VOXBRICK_BENCH_RADIX_K
    const double read = double(distributed::DenseFrame(partial, footprint).footprint.pixels());  // what is read
#else
    const double read = double(mask.size());
#endif
    const double footprintShare = sumOver(read) / (double(ranks) * double(mask.size()));
    const uint64_t own = digest(partial);
    std::vector<uint64_t> digests(static_cast<size_t>(ranks));
    MPI_Gather(&own, 1, MPI_UINT64_T, digests.data(), 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    uint64_t inputs = 1469598103934665603ull;
    for (uint64_t d : digests) inputs = (inputs ^ d) * 1099511628211ull;
    for (const auto& encodingName : encodings) {
      for (const auto& factors : choices) {
        // The variants take turns repeat by repeat, so that neither pays alone for going first.
        struct Run {
          std::string variant, name;
          distributed::CompositeOptions options;
          image::Image8 frame;  // reused from frame to frame, as a server's
          std::vector<double> times, compositing;
          double bytes = 0, maxBytes = 0, maxHandled = 0;
        };
        std::vector<Run> runs;
        for (const auto& variant : variants) {
          Run run;
          run.variant = variant;
          run.options.encoding = distributed::parsePixelEncoding(encodingName);
          run.options.timeoutSeconds = 60;
#ifdef VOXBRICK_BENCH_RADIX_K
          run.options.factors = factors;
          if (variant == "footprint") run.options.footprint = footprint;
          run.name = variant == "footprint" ? impl : std::string(impl) + "-whole";
#else
          (void)factors;
          run.name = impl;
#endif
          runs.push_back(std::move(run));
        }
        for (int i = 0; i <= repeat; ++i) {  // the first is a warm-up
          for (Run& run : runs) {
            MPI_Barrier(MPI_COMM_WORLD);
            const auto start = std::chrono::steady_clock::now();
            distributed::CompositeStats stats;
#ifdef VOXBRICK_BENCH_RADIX_K
            distributed::compositeFinished(MPI_COMM_WORLD, partial, order, scene, run.frame, run.options, &stats);
            const double composited = stats.ms;
#else
            const image::ImageF whole = distributed::composite(MPI_COMM_WORLD, partial, order, run.options, &stats);
            const double composited = stats.ms;
            if (rank == 0) {  // a new frame each time, as RankRenderer made it
              const image::Image8 frame = image::toImage8(render::finishPartial(whole, scene));
              if (frame.rgba.empty()) std::abort();
            }
#endif
            const double ms =
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
            const double slowest = maxOver(ms), slowestComposite = maxOver(composited);
            const double total = sumOver(double(stats.bytesSent)), most = maxOver(double(stats.bytesSent));
#ifdef VOXBRICK_BENCH_RADIX_K
            const double handled = maxOver(double(stats.pixelsHandled));
#else
            const double handled = 0;  // not counted before radix-k
#endif
            if (i == 0) continue;
            run.times.push_back(slowest);
            run.compositing.push_back(slowestComposite);
            run.bytes = total, run.maxBytes = most, run.maxHandled = handled;
          }
        }
        if (rank != 0) continue;
#ifdef VOXBRICK_BENCH_RADIX_K
        const std::vector<int> used = factors.empty() ? distributed::radixFactors(ranks) : factors;
#else
        const std::vector<int> used;
#endif
        for (Run& run : runs) {
          std::sort(run.times.begin(), run.times.end());
          std::sort(run.compositing.begin(), run.compositing.end());
          std::printf("%s,%d,%d,%s,%s,%.3f,%.3f,%.3f,%.0f,%.0f,%.4f,%.4f,%016llx,%.4f,%.0f\n", run.name.c_str(), ranks,
                      size, encodingName.c_str(), factorsText(used).c_str(), run.times[run.times.size() / 2],
                      run.times.back(), run.compositing[run.compositing.size() / 2], run.bytes, run.maxBytes,
                      activeAll / (double(ranks) * double(mask.size())), unionShare, (unsigned long long)inputs,
                      run.variant == "footprint" ? footprintShare : 1.0, run.maxHandled);
        }
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
