// The MPI compositor against the serial reference, run under mpirun by ctest (tests/distributed/CMakeLists.txt):
// every rank makes the same random partial frames from one seed (sparse ones: random active rectangles with holes,
// some parts empty; dense ones: every pixel active), random visibility orders and sizes, a random subset of the
// ranks taking part with a random root, and every radix-k factorisation of the participants' count; each rank
// composites its own part, and the root compares the result with render::compositeSerial (float: up to rounding
// order; half: within 2^-11 per quantisation, one per round and one for the gather), the finished 8-bit frame with
// toImage8(finishPartial(reference)) within one step of 1/255, and the scalar kernels' frame with the SIMD kernels'
// bit for bit. Exits 0 only if every case matches on every root.
//   --kernels: the run-length kernels alone (one process): encoding, slicing, packing, the over operator, finishing
//              and corrupted messages, against the dense reference, SIMD against scalar.
//   --fault exit|stop RANK: that rank dies (_exit) or stops (SIGSTOP) before compositing, and the test passes only if
//              rank 0 reports an error naming it within the deadline and the survivors then composite among
//              themselves (CompositeOptions::ranks) to the serial reference.
#include <mpi.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <random>
#include <string>

#include "common/Half.h"
#include "distributed/Cluster.h"
#include "distributed/Compositor.h"

using namespace voxbrick;

namespace {

image::ImageF emptyFrame(int width, int height) {
  return {width, height, std::vector<float>(size_t(width) * size_t(height) * 4, 0.0f)};
}

// Alpha at least 1/50, so that straight colour (c / a, the transparent background's output) stays within half
// floats' precision of the reference.
void paint(std::mt19937& random, float* p) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const float alpha = 0.02f + 0.98f * unit(random);
  for (int c = 0; c < 3; ++c) p[c] = alpha * unit(random);
  p[3] = alpha;
}

// Sparse: a random rectangle with holes, or nothing. Dense: every pixel. `painted`: the rectangle (empty for an
// empty part, the whole frame for a dense one).
image::ImageF randomPartial(std::mt19937& random, int width, int height, bool dense,
                            render::PixelRect* painted = nullptr) {
  image::ImageF image = emptyFrame(width, height);
  if (painted) *painted = {};
  if (dense) {
    for (size_t i = 0; i < image.rgba.size(); i += 4) paint(random, &image.rgba[i]);
    if (painted) *painted = {0, 0, width, height};
    return image;
  }
  if (random() % 4 == 0) return image;  // an empty part
  int x0 = int(random() % unsigned(width)), y0 = int(random() % unsigned(height));
  int x1 = x0 + 1 + int(random() % unsigned(width - x0)), y1 = y0 + 1 + int(random() % unsigned(height - y0));
  if (painted) *painted = {x0, y0, x1, y1};
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      if (random() % 10 == 0) continue;  // holes inside the rectangle
      paint(random, image.pixel(x, y));
    }
  }
  return image;
}

double maxDifference(const image::ImageF& a, const image::ImageF& b) {
  if (a.width != b.width || a.height != b.height || a.rgba.size() != b.rgba.size()) return 1e9;
  double worst = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) worst = std::max(worst, double(std::fabs(a.rgba[i] - b.rgba[i])));
  return worst;
}

int maxStepDifference(const image::Image8& a, const image::Image8& b) {
  if (a.width != b.width || a.height != b.height || a.rgba.size() != b.rgba.size()) return 1000;
  int worst = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) worst = std::max(worst, std::abs(int(a.rgba[i]) - int(b.rgba[i])));
  return worst;
}

// Garbage (active pixels) painted where the compositor must never read with `footprint`: the rows above and below
// it, and left and right of it when it is narrower than two fifths of the frame (a wider one is read as whole
// rows: DenseFrame).
void paintUnread(std::mt19937& random, image::ImageF& frame, const render::PixelRect& footprint) {
  const distributed::DenseFrame read(frame, footprint);
  for (int y = 0; y < frame.height; ++y) {
    for (int x = 0; x < frame.width; ++x) {
      const render::PixelRect& f = read.footprint;
      if (!(x >= f.x0 && x < f.x1 && y >= f.y0 && y < f.y1)) paint(random, frame.pixel(x, y));
    }
  }
}

// A footprint around `painted`: grown by up to 3 pixels a side (past the frame's edges at times, which the
// compositor clips), with garbage painted where it is not read.
render::PixelRect dirtyOutside(std::mt19937& random, image::ImageF& frame, const render::PixelRect& painted) {
  render::PixelRect footprint = painted;
  if (!painted.empty()) {
    footprint.x0 -= int(random() % 4), footprint.y0 -= int(random() % 4);
    footprint.x1 += int(random() % 4), footprint.y1 += int(random() % 4);
  }
  paintUnread(random, frame, footprint);
  return footprint;
}

std::string listText(const std::vector<int>& values) {
  std::string text;
  for (size_t i = 0; i < values.size(); ++i) text += (i ? "x" : "") + std::to_string(values[i]);
  return text.empty() ? "default" : text;
}

int runCases(int rank, int size) {
  int failures = 0, checked = 0;
  for (int seed = 1; seed <= 24; ++seed) {
    std::mt19937 random(unsigned(seed * 7919 + size));
    int width = 1 + int(random() % 97), height = 1 + int(random() % 61);
    if (seed == 1) width = height = 1;
    const bool dense = seed % 5 == 0;
    // Participants: every rank by default (part i on rank i) for the first seeds, every rank in a random part order
    // for the next, then a random subset in random part order.
    std::vector<int> ranks(static_cast<size_t>(size));
    std::iota(ranks.begin(), ranks.end(), 0);
    if (seed > 3) std::shuffle(ranks.begin(), ranks.end(), random);
    if (seed > 6) ranks.resize(1 + random() % unsigned(size));
    const int parts = int(ranks.size());
    std::vector<image::ImageF> frames;
    std::vector<render::PixelRect> painted(static_cast<size_t>(parts));
    for (int i = 0; i < parts; ++i) frames.push_back(randomPartial(random, width, height, dense, &painted[size_t(i)]));
    if (seed == 2) {
      for (auto& frame : frames) frame = emptyFrame(width, height);  // nothing drawn anywhere
      for (auto& rect : painted) rect = {};
    }
    // Every other case: each part with a footprint around what it painted and garbage outside it (its own frame;
    // the reference composites the clean ones).
    const bool footprints = seed % 2 == 0;
    std::vector<image::ImageF> own = frames;
    std::vector<render::PixelRect> footprint(static_cast<size_t>(parts));
    if (footprints) {
      for (int i = 0; i < parts; ++i) footprint[size_t(i)] = dirtyOutside(random, own[size_t(i)], painted[size_t(i)]);
    }
    std::vector<int> order(static_cast<size_t>(parts));
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), random);
    const int root = seed <= 6 ? 0 : ranks[random() % unsigned(parts)];
    render::SceneView view;
    view.background = {0.1 * (seed % 7), 0.3, 0.9};
    view.transparent = seed % 3 == 0;
    const auto part = std::find(ranks.begin(), ranks.end(), rank);
    if (part == ranks.end() && seed <= 6) std::abort();  // every rank takes part in the first cases
    if (part == ranks.end()) continue;                   // not taking part in this case
    const size_t index = size_t(part - ranks.begin());
    const image::ImageF& mine = own[index];
    const image::ImageF reference = render::compositeSerial(frames, order);
    std::vector<std::vector<int>> choices{{}};
    for (auto& factors : distributed::radixFactorisations(parts)) choices.push_back(std::move(factors));
    for (const auto& factors : choices) {
      for (auto encoding : {distributed::PixelEncoding::Float, distributed::PixelEncoding::Half}) {
        distributed::CompositeOptions options;
        options.encoding = encoding;
        if (seed > 3) options.ranks = ranks;
        options.root = root;
        options.factors = factors;
        if (footprints) options.footprint = footprint[index];
        distributed::CompositeStats stats;
        const image::ImageF result = distributed::composite(MPI_COMM_WORLD, mine, order, options, &stats);
        options.kernels = distributed::Kernels::Scalar;
        const image::ImageF scalar = distributed::composite(MPI_COMM_WORLD, mine, order, options);
        options.kernels = distributed::Kernels::Best;
        static image::Image8 finished;  // reused from case to case, of other sizes
        distributed::compositeFinished(MPI_COMM_WORLD, mine, order, view, finished, options);
        if (rank != root) {
          if (!result.rgba.empty() || !finished.rgba.empty()) {
            std::fprintf(stderr, "case %d: rank %d is no root but returned a frame\n", seed, rank);
            ++failures;
          }
          continue;
        }
        ++checked;
        const int quantisations = int((factors.empty() ? distributed::radixFactors(parts) : factors).size()) + 1;
        const double tolerance =
            encoding == distributed::PixelEncoding::Float ? 1e-5 : quantisations * std::ldexp(1.0, -11);
        const double difference = maxDifference(result, reference);
        render::Scene scene;
        static_cast<render::SceneView&>(scene) = view;
        const int steps = maxStepDifference(finished, image::toImage8(render::finishPartial(reference, scene)));
        const bool bitwise = scalar.rgba == result.rgba;
        if (difference > tolerance || steps > 1 || !bitwise) {
          std::fprintf(stderr,
                       "case %d (%dx%d, %s%s, %s, %d of %d ranks, root %d, factors %s): max difference %g (allowed "
                       "%g), 8-bit steps %d, scalar %s SIMD\n",
                       seed, width, height, dense ? "dense" : "sparse", footprints ? " in footprints" : "",
                       distributed::pixelEncodingName(encoding), parts,
                       size, root, listText(factors).c_str(), difference, tolerance, steps,
                       bitwise ? "equals" : "differs from");
          ++failures;
        }
      }
    }
  }
  std::printf("rank %d: %d cases checked as root, %d failing\n", rank, checked, failures);
  return failures;
}

// The kernels on buffers, one process.
int runKernels() {
  using distributed::Kernels;
  int failures = 0;
  auto fail = [&failures](const std::string& what) {
    std::fprintf(stderr, "kernels: %s\n", what.c_str());
    ++failures;
  };
  // The message layout (PixelRuns.h), every offset: pixels 10..19 of a frame, active at 12, 13 and 17.
  {
    image::ImageF frame = emptyFrame(8, 4);
    for (int x : {12, 13, 17}) std::fill_n(frame.rgba.begin() + x * 4, 4, 0.25f * float(x % 4 + 1));
    distributed::PixelRuns runs;
    distributed::encodeRuns(frame, 10, 20, runs);
    distributed::GrowingBuffer<uint8_t> message;
    distributed::packRuns(runs, 10, 20, distributed::PixelEncoding::Half, message);
    auto word = [&message](size_t offset) {
      uint32_t value;
      std::memcpy(&value, message.data() + offset, 4);
      return value;
    };
    auto half = [&message](size_t offset) {
      uint16_t value;
      std::memcpy(&value, message.data() + offset, 2);
      return value;
    };
    const bool header = word(0) == 10 && word(4) == 20 && word(8) == 2 && word(12) == 3;
    const bool pixels = half(16) == common::floatToHalf(0.25f) && half(16 + 8) == common::floatToHalf(0.5f) &&
                        half(16 + 16 + 6) == common::floatToHalf(0.5f);
    const bool pairs = word(40) == 2 && word(44) == 2 && word(48) == 3 && word(52) == 1;
    if (distributed::kRunsHeaderBytes != 16 || message.size() != 56 ||
        distributed::runsMessageBytes(2, 3, distributed::PixelEncoding::Half) != 56 ||
        distributed::runsMessageBytes(2, 3, distributed::PixelEncoding::Float) != 80 || !header || !pixels || !pairs) {
      fail("the message layout moved");
    }
  }
  std::printf("SIMD kernels %s\n", distributed::simdKernelsAvailable() ? "available" : "NOT available (scalar only)");
  for (int seed = 1; seed <= 40; ++seed) {
    std::mt19937 random{unsigned(seed)};
    const int width = 1 + int(random() % 70), height = 1 + int(random() % 40);
    const image::ImageF front = randomPartial(random, width, height, seed % 4 == 0);
    const image::ImageF back = randomPartial(random, width, height, seed % 6 == 0);
    const uint32_t pixels = uint32_t(width * height);
    distributed::PixelRuns a, b, joined, scalarJoined, slice, unpacked;
    distributed::encodeRuns(front, 0, pixels, a);
    distributed::encodeRuns(back, 0, pixels, b);
    image::ImageF scattered = emptyFrame(width, height);
    distributed::scatterRuns(a, scattered);
    if (scattered.rgba != front.rgba) fail("encode then scatter is not the frame, seed " + std::to_string(seed));
    size_t active = 0;
    for (size_t i = 0; i < front.rgba.size(); i += 4) {
      active += front.rgba[i] != 0 || front.rgba[i + 1] != 0 || front.rgba[i + 2] != 0 || front.rgba[i + 3] != 0;
    }
    if (a.activePixels() != active) fail("active pixels counted wrong, seed " + std::to_string(seed));
    // A footprint: what lies outside it is never read. The front frame cut to a random rectangle, garbage painted
    // around it, reads (encoded, packed, joined, finished) as the cut frame; pixelsWithin counts as a scan would.
    {
      int x0 = int(random() % unsigned(width + 1)) - 1, y0 = int(random() % unsigned(height + 1)) - 1;
      render::PixelRect rect{x0, y0, x0 + int(random() % unsigned(width + 2)), y0 + int(random() % unsigned(height + 2))};
      image::ImageF cut = front;
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
          if (x < rect.x0 || x >= rect.x1 || y < rect.y0 || y >= rect.y1) std::fill_n(cut.pixel(x, y), 4, 0.0f);
        }
      }
      image::ImageF dirty = cut;
      paintUnread(random, dirty, rect);
      const distributed::DenseFrame footprinted(dirty, rect);
      const render::PixelRect within = footprinted.footprint;  // what is read
      distributed::PixelRuns fromCut, fromFootprint;
      const uint32_t r0 = uint32_t(random() % (pixels + 1)), r1 = r0 + uint32_t(random() % (pixels - r0 + 1));
      distributed::encodeRuns(cut, r0, r1, fromCut);
      distributed::encodeRuns(footprinted, r0, r1, fromFootprint);
      image::ImageF x = emptyFrame(width, height), y = emptyFrame(width, height);
      distributed::scatterRuns(fromCut, x);
      distributed::scatterRuns(fromFootprint, y);
      if (x.rgba != y.rgba || fromCut.runCount() != fromFootprint.runCount())
        fail("a footprint's frame is not read as the frame cut to it, seed " + std::to_string(seed));
      distributed::GrowingBuffer<uint8_t> m1, m2;
      distributed::packRuns(cut, r0, r1, distributed::PixelEncoding::Half, m1);
      distributed::packRuns(footprinted, r0, r1, distributed::PixelEncoding::Half, m2);
      if (std::vector<uint8_t>(m1.data(), m1.data() + m1.size()) != std::vector<uint8_t>(m2.data(), m2.data() + m2.size()))
        fail("a footprint's frame packs differently from the frame cut to it, seed " + std::to_string(seed));
      distributed::PixelRuns j1, j2;
      distributed::overRuns(distributed::DenseFrame(cut), &b, r0, r1, j1);
      distributed::overRuns(footprinted, &b, r0, r1, j2);
      image::ImageF o1 = emptyFrame(width, height), o2 = emptyFrame(width, height);
      distributed::scatterRuns(j1, o1);
      distributed::scatterRuns(j2, o2);
      if (o1.rgba != o2.rgba) fail("a footprint's frame joins differently, seed " + std::to_string(seed));
      render::Scene scene;
      scene.background = {0.2, 0.4, 0.6};
      std::vector<uint8_t> f1(size_t(pixels) * 4), f2(size_t(pixels) * 4);
      distributed::finishRuns(cut, 0, pixels, scene, f1.data());
      distributed::finishRuns(footprinted, 0, pixels, scene, f2.data());
      if (f1 != f2) fail("a footprint's frame finishes differently, seed " + std::to_string(seed));
      uint64_t counted = 0;
      for (uint32_t i = r0; i < r1; ++i) {
        const int px = int(i % uint32_t(width)), py = int(i / uint32_t(width));
        counted += px >= within.x0 && px < within.x1 && py >= within.y0 && py < within.y1;
      }
      if (footprinted.pixelsWithin(r0, r1) != counted)
        fail("pixelsWithin counts " + std::to_string(footprinted.pixelsWithin(r0, r1)) + ", not " +
             std::to_string(counted) + ", seed " + std::to_string(seed));
    }
    // Over: the dense reference, bit for bit (the same two operations per channel), SIMD and scalar alike.
    image::ImageF expected = front;
    render::compositeOver(expected, back);
    distributed::overRuns(a, b, joined, Kernels::Best);
    distributed::overRuns(a, b, scalarJoined, Kernels::Scalar);
    image::ImageF got = emptyFrame(width, height), gotScalar = emptyFrame(width, height);
    distributed::scatterRuns(joined, got);
    distributed::scatterRuns(scalarJoined, gotScalar);
    if (got.rgba != expected.rgba) fail("overRuns differs from compositeOver, seed " + std::to_string(seed));
    if (gotScalar.rgba != got.rgba) fail("scalar overRuns differs from SIMD, seed " + std::to_string(seed));
    // A slice, packed and unpacked: float exact, half as floatToHalf rounds, SIMD and scalar the same bytes.
    const uint32_t s0 = uint32_t(random() % (pixels + 1)), s1 = s0 + uint32_t(random() % (pixels - s0 + 1));
    distributed::sliceRuns(joined, s0, s1, slice);
    // Over on a sub-range, each side dense or runs read in place, is the slice of the whole over.
    for (int sides = 0; sides < 4; ++sides) {
      distributed::PixelRuns part;
      const distributed::PixelSource f =
          sides & 1 ? distributed::PixelSource(distributed::DenseFrame(front)) : distributed::PixelSource(&a);
      const distributed::PixelSource g =
          sides & 2 ? distributed::PixelSource(distributed::DenseFrame(back)) : distributed::PixelSource(&b);
      distributed::overRuns(f, g, s0, s1, part, sides < 2 ? Kernels::Best : Kernels::Scalar);
      image::ImageF gotPart = emptyFrame(width, height), slicePart = emptyFrame(width, height);
      distributed::scatterRuns(part, gotPart);
      distributed::scatterRuns(slice, slicePart);
      if (gotPart.rgba != slicePart.rgba || part.begin != s0 || part.end != s1) {
        fail("overRuns on a sub-range (sides " + std::to_string(sides) + ") is not the slice, seed " +
             std::to_string(seed));
      }
    }
    // A received message read in place, in front or behind: the same bits as its unpacked runs, SIMD and scalar.
    for (auto encoding : {distributed::PixelEncoding::Float, distributed::PixelEncoding::Half}) {
      distributed::GrowingBuffer<uint8_t> packed;
      distributed::packRuns(b, s0, s1, encoding, packed);
      const std::span<const uint8_t> bytes(packed.data(), packed.size());
      distributed::PixelRuns backRuns, expectedRuns, inPlace;
      distributed::unpackRuns(bytes, encoding, backRuns);
      for (bool messageInFront : {false, true}) {
        const distributed::PixelSource runs = &backRuns, message = distributed::PixelMessage{bytes, encoding};
        const distributed::PixelSource other = distributed::DenseFrame(front);
        distributed::overRuns(messageInFront ? runs : other, messageInFront ? other : runs, s0, s1, expectedRuns);
        for (Kernels kernels : {Kernels::Best, Kernels::Scalar}) {
          distributed::overRuns(messageInFront ? message : other, messageInFront ? other : message, s0, s1, inPlace,
                                kernels);
          image::ImageF x = emptyFrame(width, height), y = emptyFrame(width, height);
          distributed::scatterRuns(expectedRuns, x);
          distributed::scatterRuns(inPlace, y);
          if (x.rgba != y.rgba) fail("over a message read in place differs, seed " + std::to_string(seed));
        }
      }
    }
    for (auto encoding : {distributed::PixelEncoding::Float, distributed::PixelEncoding::Half}) {
      distributed::GrowingBuffer<uint8_t> message, scalarMessage;
      distributed::packRuns(joined, s0, s1, encoding, message, Kernels::Best);
      distributed::packRuns(joined, s0, s1, encoding, scalarMessage, Kernels::Scalar);
      const std::vector<uint8_t> bytes(message.data(), message.data() + message.size());
      if (std::vector<uint8_t>(scalarMessage.data(), scalarMessage.data() + scalarMessage.size()) != bytes) {
        fail("scalar packing differs from SIMD, seed " + std::to_string(seed));
      }
      if (bytes.size() != distributed::runsMessageBytes(slice.runCount(), slice.activePixels(), encoding)) {
        fail("message size is not runsMessageBytes, seed " + std::to_string(seed));
      }
      distributed::checkRunsMessage(bytes, s0, s1, encoding);
      distributed::GrowingBuffer<uint8_t> fromDense;
      image::ImageF dense = emptyFrame(width, height);
      distributed::scatterRuns(joined, dense);
      distributed::packRuns(dense, s0, s1, encoding, fromDense, Kernels::Best);
      if (std::vector<uint8_t>(fromDense.data(), fromDense.data() + fromDense.size()) != bytes) {
        fail("packing a dense frame differs from packing its runs, seed " + std::to_string(seed));
      }
      distributed::unpackRuns(bytes, encoding, unpacked, Kernels::Best);
      image::ImageF whole = emptyFrame(width, height), sliced = emptyFrame(width, height);
      distributed::scatterRuns(unpacked, whole);
      distributed::scatterRuns(slice, sliced);
      if (encoding == distributed::PixelEncoding::Half) {
        for (float& v : sliced.rgba) v = common::halfToFloat(common::floatToHalf(v));
      }
      if (whole.rgba != sliced.rgba) fail("pack then unpack is not the slice, seed " + std::to_string(seed));
      // Every truncated message and a wrong range are refused with an error, never read past.
      for (size_t length = 0; length < bytes.size(); ++length) {
        try {
          distributed::checkRunsMessage(std::span(bytes.data(), length), s0, s1, encoding);
          fail("a message cut to " + std::to_string(length) + " bytes was accepted");
        } catch (const std::runtime_error&) {
        }
      }
      try {
        distributed::checkRunsMessage(bytes, s0, s1 + 1, encoding);
        fail("a message for another range was accepted");
      } catch (const std::runtime_error&) {
      }
      if (slice.runCount() > 0) {
        std::vector<uint8_t> bad = bytes;
        std::memset(&bad[bytes.size() - slice.runCount() * 8], 0xff, 4);  // the first run's skip: past any range
        try {
          distributed::checkRunsMessage(bad, s0, s1, encoding);
          fail("a message whose runs pass its range was accepted");
        } catch (const std::runtime_error&) {
        }
      }
    }
    // Finishing: toImage8(finishPartial(frame)) exactly, over an opaque and a transparent background.
    for (bool transparent : {false, true}) {
      render::Scene scene;
      scene.background = {0.2, 0.5 + 0.01 * seed, 0.7};
      scene.transparent = transparent;
      image::Image8 finished{width, height, std::vector<uint8_t>(size_t(pixels) * 4)};
      distributed::finishRuns(joined, scene, finished.rgba.data());
      const image::Image8 reference = image::toImage8(render::finishPartial(expected, scene));
      if (finished.rgba != reference.rgba) {
        fail("finishRuns differs from toImage8(finishPartial), seed " + std::to_string(seed));
      }
      distributed::finishRuns(joined, scene, finished.rgba.data(), Kernels::Scalar);
      if (finished.rgba != reference.rgba) {
        fail("scalar finishRuns differs from toImage8(finishPartial), seed " + std::to_string(seed));
      }
      std::vector<uint8_t> fromDense(size_t(pixels) * 4);
      distributed::finishRuns(expected, 0, pixels, scene, fromDense.data());
      if (fromDense != finished.rgba)
        fail("finishing a dense frame differs from its runs, seed " + std::to_string(seed));
    }
  }
  // Finishing near the rounding boundaries: channels whose output·255 + 0.5 is a whole number give or take a few
  // float steps (colour c = (k − 0.5)/255 − (1 − a)·background, or a·(k − 0.5)/255 for straight colour), where
  // floats and doubles can round apart, over opaque and transparent backgrounds, SIMD and scalar against
  // toImage8(finishPartial).
  {
    const int count = 1 << 17;
    const glm::dvec3 background{0.3, 1.0 / 3, 0.71};
    std::mt19937 random{7u};
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (bool transparent : {false, true}) {
      image::ImageF edges = emptyFrame(count, 1);
      for (int i = 0; i < count; ++i) {
        float* p = edges.pixel(i, 0);
        const double a = 0.05 + 0.95 * unit(random);
        for (int c = 0; c < 3; ++c) {
          const double target = (1 + int(random() % 254) - 0.5) / 255;
          double value = transparent ? target * a : target - (1 - a) * background[size_t(c)];
          if (value < 0) value = target * a;
          float v = float(value);
          for (int step = int(random() % 7) - 3; step != 0; step += step < 0 ? 1 : -1) {
            v = std::nextafter(v, step < 0 ? 0.0f : 2.0f);
          }
          p[c] = v;
        }
        p[3] = float(a);
      }
      distributed::PixelRuns runs;
      distributed::encodeRuns(edges, 0, count, runs);
      render::Scene scene;
      scene.background = background;
      scene.transparent = transparent;
      const image::Image8 expected = image::toImage8(render::finishPartial(edges, scene));
      for (Kernels kernels : {Kernels::Best, Kernels::Scalar}) {
        std::vector<uint8_t> got(size_t(count) * 4);
        distributed::finishRuns(runs, scene, got.data(), kernels);
        if (got != expected.rgba) fail("finishing at the rounding boundaries differs from toImage8(finishPartial)");
      }
    }
  }
  std::printf("kernels: %d failing checks\n", failures);
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
    // A stopped rank would keep mpirun waiting: the test ends it (all ranks share this host under ctest).
    if (rank == 0 && kind == "stop") kill(pid_t(pids[size_t(victim)]), SIGKILL);
    // The survivors go on compositing among themselves (their own tags: the failed frame's messages may linger).
    std::vector<int> survivors, parts;
    std::vector<image::ImageF> frames;
    for (int r = 0; r < size; ++r) {
      if (r == victim) continue;
      survivors.push_back(r);
      std::mt19937 random{unsigned(r + 1)};
      frames.push_back(randomPartial(random, 33, 21, false));
    }
    std::vector<int> survivorOrder(survivors.size());
    std::iota(survivorOrder.rbegin(), survivorOrder.rend(), 0);
    distributed::CompositeOptions after = options;
    after.ranks = survivors;
    after.tag = options.tag + 100;
    const size_t own = size_t(std::find(survivors.begin(), survivors.end(), rank) - survivors.begin());
    bool composited = false;
    try {
      const image::ImageF frame = distributed::composite(MPI_COMM_WORLD, frames[own], survivorOrder, after);
      composited = rank != 0 || maxDifference(frame, render::compositeSerial(frames, survivorOrder)) <= 1.0 / 512;
    } catch (const std::exception& later) {
      std::printf("rank %d: the survivors' compositing failed: %s\n", rank, later.what());
    }
    if (rank == 0) {
      const bool ok = named && seconds < 5 && composited;
      if (ok) std::printf("fault named: rank %d; the survivors composited\n", victim);
      std::fflush(stdout);
      _exit(ok ? 0 : 1);
    }
    _exit(composited ? 0 : 1);
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
  if (argc == 2 && std::strcmp(argv[1], "--kernels") == 0) return runKernels() == 0 ? 0 : 1;
  const int failures = runCases(rank, size);
  int total = 0;
  MPI_Allreduce(&failures, &total, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  if (rank == 0) std::printf("%d ranks: %d failing cases\n", size, total);
  return total == 0 ? 0 : 1;
}
