// Radix-k over run-length encoded pixel ranges in visibility order, then a gather to the root (Compositor.h).
#include "distributed/Compositor.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>
#include <memory>
#include <stdexcept>

namespace voxbrick::distributed {
namespace {

using Clock = std::chrono::steady_clock;
using Bytes = GrowingBuffer<uint8_t>;

// The frame is a row-major sequence of pixels; each rank's region is a range of it. Ranges (rather than rectangles)
// split evenly into any k, keep a run-length encoding simple, and make the 8-bit gather a receive in place.
struct Range {
  uint32_t begin = 0, end = 0;
  uint32_t size() const { return end - begin; }
};

// Piece j of k of a range (as even as whole pixels allow).
Range pieceOf(const Range& range, int j, int k) {
  const uint64_t length = range.size();
  return {range.begin + uint32_t(length * uint64_t(j) / uint64_t(k)),
          range.begin + uint32_t(length * uint64_t(j + 1) / uint64_t(k))};
}

// Who takes part and in which order, checked on this rank.
struct Plan {
  std::vector<int> ranks;    // the communicator's rank of each part
  std::vector<int> order;    // parts, nearest first
  std::vector<int> factors;  // k of each round
  int position = 0;          // this rank's place in visibility order
  int root = 0;
  int self = 0;  // this rank
  uint32_t pixels = 0;

  int rankAt(int p) const { return ranks[size_t(order[size_t(p)])]; }
  int parts() const { return int(order.size()); }
  // Position p's digit in round r (mixed radix, round 0 the least significant digit) and the distance between
  // group members in that round: round r's group is the positions that differ from p in digit r only, which are
  // neighbours in visibility order once the earlier rounds have joined their blocks.
  int stride(size_t round) const {
    int s = 1;
    for (size_t r = 0; r < round; ++r) s *= factors[r];
    return s;
  }
  int digit(int p, size_t round) const { return p / stride(round) % factors[round]; }
  // Position p's region after `rounds` rounds.
  Range region(int p, size_t rounds) const {
    Range range{0, pixels};
    for (size_t r = 0; r < rounds; ++r) range = pieceOf(range, digit(p, r), factors[r]);
    return range;
  }
};

std::string listText(const std::vector<int>& values, const char* separator) {
  std::string text;
  for (size_t i = 0; i < values.size(); ++i) text += (i ? separator : "") + std::to_string(values[i]);
  return text;
}

Plan makePlan(MPI_Comm comm, const image::ImageF& partial, const std::vector<int>& frontToBack,
              const CompositeOptions& options) {
  int size = 0, rank = 0;
  MPI_Comm_size(comm, &size);
  MPI_Comm_rank(comm, &rank);
  Plan plan;
  plan.ranks = options.ranks;
  if (plan.ranks.empty()) {
    for (int r = 0; r < size; ++r) plan.ranks.push_back(r);
  }
  std::vector<bool> seen(size_t(size), false);
  for (int r : plan.ranks) {
    if (r < 0 || r >= size || seen[size_t(r)]) {
      throw std::invalid_argument("compositing ranks [" + listText(plan.ranks, ", ") +
                                  "] are not distinct ranks of a communicator of " + std::to_string(size));
    }
    seen[size_t(r)] = true;
  }
  const int parts = int(plan.ranks.size());
  std::vector<bool> named(size_t(parts), false);
  if (int(frontToBack.size()) != parts) {
    throw std::invalid_argument("compositing order names " + std::to_string(frontToBack.size()) + " parts, not the " +
                                std::to_string(parts) + " participating ranks");
  }
  for (int part : frontToBack) {
    if (part < 0 || part >= parts || named[size_t(part)]) {
      throw std::invalid_argument("compositing order [" + listText(frontToBack, ", ") +
                                  "] is not a permutation of the parts 0.." + std::to_string(parts - 1));
    }
    named[size_t(part)] = true;
  }
  plan.order = frontToBack;
  plan.factors = options.factors.empty() ? radixFactors(parts) : options.factors;
  long long product = 1;
  for (int k : plan.factors) {
    if (k < 2) throw std::invalid_argument("radix-k factor " + std::to_string(k) + " is below 2");
    product *= k;
    if (product > parts) break;
  }
  if (product != parts) {
    throw std::invalid_argument("radix-k factors " + listText(plan.factors, "x") + " do not multiply to the " +
                                std::to_string(parts) + " participating ranks");
  }
  const auto self = std::find(plan.ranks.begin(), plan.ranks.end(), rank);
  if (self == plan.ranks.end()) {
    throw std::invalid_argument("rank " + std::to_string(rank) + " is not among the compositing ranks [" +
                                listText(plan.ranks, ", ") + "]");
  }
  const int part = int(self - plan.ranks.begin());
  plan.position = int(std::find(plan.order.begin(), plan.order.end(), part) - plan.order.begin());
  if (std::find(plan.ranks.begin(), plan.ranks.end(), options.root) == plan.ranks.end()) {
    throw std::invalid_argument("compositing root " + std::to_string(options.root) +
                                " is not among the compositing ranks [" + listText(plan.ranks, ", ") + "]");
  }
  plan.root = options.root;
  plan.self = rank;
  const uint64_t pixels = uint64_t(std::max(partial.width, 0)) * uint64_t(std::max(partial.height, 0));
  if (partial.width < 0 || partial.height < 0 || partial.rgba.size() != pixels * 4) {
    throw std::invalid_argument("partial frame's pixels do not match its size " + std::to_string(partial.width) + "x" +
                                std::to_string(partial.height));
  }
  if (pixels > UINT32_MAX) throw std::invalid_argument("partial frame of " + std::to_string(pixels) + " pixels");
  plan.pixels = uint32_t(pixels);
  return plan;
}

// What stays from frame to frame on a thread: the runs and the message buffers, so that a frame allocates only when
// it needs more than an earlier one did. A message buffer is reused only when nothing else holds it (a transfer
// abandoned after a failure keeps its buffer, which MPI may still write).
struct Workspace {
  PixelRuns own, joined, scratch;  // this rank's runs; the join's result and its next output
  PixelRuns piece;                 // a received region unpacked (composite's float gather)
  std::vector<std::shared_ptr<Bytes>> buffers;

  // A buffer nobody else holds (the caller keeps it until it is done with it, so the next call gives another).
  std::shared_ptr<Bytes> buffer() {
    for (auto& b : buffers) {
      if (b.use_count() == 1) return b;
    }
    buffers.push_back(std::make_shared<Bytes>());
    return buffers.back();
  }
};

Workspace& workspace() {
  thread_local Workspace space;
  return space;
}

// Waits until a message from each of `peers` with `tag` has arrived and returns their sizes in bytes, polling with
// MPI_Iprobe against the deadline (as Transfers waits): the size of a run-length encoded piece is not known before.
std::vector<size_t> probeSizes(MPI_Comm comm, const std::vector<int>& peers, int tag, double timeoutSeconds,
                               const char* what) {
  std::vector<size_t> sizes(peers.size(), 0);
  std::vector<bool> found(peers.size(), false);
  size_t left = peers.size();
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeoutSeconds);
  int idle = 0;
  while (left > 0) {
    bool progressed = false;
    for (size_t i = 0; i < peers.size(); ++i) {
      if (found[i]) continue;
      int flag = 0;
      MPI_Status status;
      const int code = MPI_Iprobe(peers[i], tag, comm, &flag, &status);
      if (code != MPI_SUCCESS) {
        throw PeerError(peers[i], std::string("receiving ") + what + " from rank " + std::to_string(peers[i]) +
                                      " failed: " + mpiErrorText(code));
      }
      if (!flag) continue;
      int count = 0;
      MPI_Get_count(&status, MPI_BYTE, &count);
      sizes[i] = size_t(count);
      found[i] = true;
      --left;
      progressed = true;
    }
    if (left == 0) break;
    if (progressed) {
      idle = 0;
    } else if (Clock::now() > deadline) {
      for (size_t i = 0; i < peers.size(); ++i) {
        if (found[i]) continue;
        throw PeerError(peers[i], "rank " + std::to_string(peers[i]) + " did not answer within " +
                                      std::to_string(int(timeoutSeconds * 1000)) + " ms (receiving " + what + ")");
      }
    } else {
      pauseBetweenPolls(idle);
    }
  }
  return sizes;
}

struct Context {
  MPI_Comm comm;
  const CompositeOptions& options;
  const Plan& plan;
  CompositeStats& stats;
  Workspace& space;
};

// A received piece, checked: a piece that is not the range due is the sender's fault, named by rank.
void checkFrom(int from, std::span<const uint8_t> message, const Range& due, PixelEncoding encoding) {
  try {
    checkRunsMessage(message, due.begin, due.end, encoding);
  } catch (const std::runtime_error& error) {
    throw PeerError(from, "rank " + std::to_string(from) + " sent a piece that was not due: " + error.what());
  }
}

// Sends `messages` (one per peer in `to`), then receives one run-length encoded message from each of `from` and
// returns them, all against the deadline.
std::vector<std::shared_ptr<Bytes>> exchange(Context& c, const std::vector<int>& to,
                                             const std::vector<std::shared_ptr<Bytes>>& messages,
                                             const std::vector<int>& from, int tag, const char* what) {
  Transfers transfers(c.comm, c.options.timeoutSeconds);
  for (size_t i = 0; i < to.size(); ++i) {
    transfers.send(to[i], tag, messages[i]->data(), messages[i]->size(), messages[i], what);
    c.stats.bytesSent += messages[i]->size();
  }
  std::vector<std::shared_ptr<Bytes>> received;
  const std::vector<size_t> sizes = probeSizes(c.comm, from, tag, c.options.timeoutSeconds, what);
  for (size_t i = 0; i < from.size(); ++i) {
    auto buffer = c.space.buffer();
    received.push_back(buffer);  // held here, so that buffer() hands out another one next
    buffer->clear();
    buffer->extend(sizes[i]);
    transfers.receive(from[i], tag, buffer->data(), sizes[i], buffer, what);
    c.stats.bytesReceived += sizes[i];
  }
  transfers.wait();
  ++c.stats.rounds;
  return received;
}

// One radix-k round: the group (the positions differing from this one in this round's digit only) splits the
// region into k pieces; each member keeps the piece of its digit, sends every other piece of its runs to the member
// keeping it, and joins the k versions of its own piece in the members' visibility order.
// In the first round the rank's pixels are still its dense partial frame (`dense`): the pieces are packed and its
// own piece joined straight from it, so that the frame is read once and no pixel is copied that is not sent or kept.
void radixRound(Context& c, size_t round, Range& region, const DenseFrame* dense) {
  const Plan& plan = c.plan;
  const int k = plan.factors[round], stride = plan.stride(round), digit = plan.digit(plan.position, round);
  const int base = plan.position - digit * stride;
  std::vector<int> peers;
  std::vector<std::shared_ptr<Bytes>> messages;
  for (int j = 0; j < k; ++j) {
    if (j == digit) continue;
    peers.push_back(plan.rankAt(base + j * stride));
    const Range piece = pieceOf(region, j, k);
    auto message = c.space.buffer();
    messages.push_back(message);
    if (dense) {
      packRuns(*dense, piece.begin, piece.end, c.options.encoding, *message, c.options.kernels);
    } else {
      packRuns(c.space.own, piece.begin, piece.end, c.options.encoding, *message, c.options.kernels);
    }
  }
  const auto received = exchange(c, peers, messages, peers, c.options.tag + 1, "a piece of a frame");
  const Range kept = pieceOf(region, digit, k);
  c.stats.pixelsHandled += dense ? dense->pixelsWithin(region.begin, region.end) : c.space.own.activePixels();
  // Front to back: member j's piece (the received one, or this rank's own) joined under what is before it. This
  // rank's piece is read where it lies: its dense frame in the first round, its runs after.
  Workspace& space = c.space;
  auto source = [&](int j) -> PixelSource {
    if (j == digit) return dense ? PixelSource(*dense) : PixelSource(&space.own);
    const int peer = j < digit ? j : j - 1;
    const auto& message = *received[size_t(peer)];
    const std::span<const uint8_t> bytes(message.data(), message.size());
    checkFrom(peers[size_t(peer)], bytes, kept, c.options.encoding);
    uint32_t activeCount = 0;  // the header's, checked
    std::memcpy(&activeCount, message.data() + 12, sizeof activeCount);
    c.stats.pixelsHandled += activeCount;
    return PixelMessage{bytes, c.options.encoding};  // read in place, converted as it is joined
  };
  PixelSource front = source(0);
  for (int j = 1; j < k; ++j) {
    overRuns(front, source(j), kept.begin, kept.end, space.scratch, c.options.kernels);
    std::swap(space.joined, space.scratch);  // the buffers move, nothing is copied
    front = &space.joined;
  }
  std::swap(space.own, space.joined);
  region = kept;
}

// The rounds, from this rank's partial frame to its final region's runs in space.own (at least one round); returns
// that region.
Range runRounds(Context& c, const DenseFrame& partial) {
  Range region{0, c.plan.pixels};
  for (size_t round = 0; round < c.plan.factors.size(); ++round) {
    radixRound(c, round, region, round == 0 ? &partial : nullptr);
  }
  c.stats.pixelsHandled += region.size();  // finished or sent
  return region;
}

// The partial frame within the footprint the options give.
DenseFrame denseOf(const image::ImageF& partial, const CompositeOptions& options) {
  return options.footprint ? DenseFrame(partial, *options.footprint) : DenseFrame(partial);
}

// The participants other than the root, with their final regions.
std::vector<std::pair<int, Range>> othersFinal(const Plan& plan) {
  std::vector<std::pair<int, Range>> others;
  for (int p = 0; p < plan.parts(); ++p) {
    if (plan.rankAt(p) != plan.root) others.emplace_back(plan.rankAt(p), plan.region(p, plan.factors.size()));
  }
  return others;
}

template <typename Result, typename Body>
Result timed(CompositeStats* statsOut, Body body) {
  const auto start = Clock::now();
  CompositeStats stats;
  Result result = body(stats);
  stats.ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  if (statsOut) *statsOut = stats;
  return result;
}

}  // namespace

image::ImageF composite(MPI_Comm comm, image::ImageF partial, const std::vector<int>& frontToBack,
                        const CompositeOptions& options, CompositeStats* statsOut) {
  return timed<image::ImageF>(statsOut, [&](CompositeStats& stats) -> image::ImageF {
    const Plan plan = makePlan(comm, partial, frontToBack, options);
    if (plan.parts() == 1) {  // nothing to exchange: the frame is the part, empty outside its footprint
      const DenseFrame dense = denseOf(partial, options);
      const render::PixelRect& f = dense.footprint;
      for (int y = 0; y < partial.height; ++y) {
        float* row = partial.pixel(0, y);
        if (y < f.y0 || y >= f.y1) {
          std::fill(row, row + size_t(partial.width) * 4, 0.0f);
          continue;
        }
        std::fill(row, row + size_t(f.x0) * 4, 0.0f);
        std::fill(row + size_t(f.x1) * 4, row + size_t(partial.width) * 4, 0.0f);
      }
      stats.pixelsHandled = uint64_t(f.pixels());
      return std::move(partial);
    }
    Context c{comm, options, plan, stats, workspace()};
    const Range region = runRounds(c, denseOf(partial, options));
    const int tag = options.tag + 2;
    if (plan.self != plan.root) {
      auto message = c.space.buffer();
      packRuns(c.space.own, region.begin, region.end, options.encoding, *message, options.kernels);
      exchange(c, {plan.root}, {message}, {}, tag, "a finished region");
      return {};
    }
    // The root: its own region, then every other one at its place over zeros.
    image::ImageF frame{partial.width, partial.height, std::vector<float>(size_t(plan.pixels) * 4, 0.0f)};
    scatterRuns(c.space.own, frame);
    const auto others = othersFinal(plan);
    std::vector<int> from;
    for (const auto& other : others) from.push_back(other.first);
    const auto received = exchange(c, {}, {}, from, tag, "a finished region");
    for (size_t i = 0; i < others.size(); ++i) {
      const std::span<const uint8_t> bytes(received[i]->data(), received[i]->size());
      checkFrom(others[i].first, bytes, others[i].second, options.encoding);
      unpackRuns(bytes, options.encoding, c.space.piece, options.kernels);
      scatterRuns(c.space.piece, frame);
    }
    return frame;
  });
}

void compositeFinished(MPI_Comm comm, const image::ImageF& partial, const std::vector<int>& frontToBack,
                       const render::SceneView& view, image::Image8& frame, const CompositeOptions& options,
                       CompositeStats* statsOut) {
  timed<int>(statsOut, [&](CompositeStats& stats) {
    const Plan plan = makePlan(comm, partial, frontToBack, options);
    const int tag = options.tag + 3;
    // The frame's pixels are held by a shared pointer while a transfer may write them: one abandoned after a failure
    // keeps them (and the caller's frame is left empty).
    auto rgba = std::make_shared<std::vector<uint8_t>>();
    if (plan.self == plan.root) {
      std::swap(*rgba, frame.rgba);
      rgba->resize(size_t(plan.pixels) * 4);  // the storage of the caller's last frame, when it has the size
    }
    frame = {};
    const DenseFrame dense = denseOf(partial, options);
    if (plan.parts() == 1) {
      finishRuns(dense, 0, plan.pixels, view, rgba->data(), options.kernels);
      stats.pixelsHandled = dense.pixelsWithin(0, plan.pixels) + plan.pixels;
      frame = {partial.width, partial.height, std::move(*rgba)};
      return 0;
    }
    Context c{comm, options, plan, stats, workspace()};
    const Range region = runRounds(c, dense);
    if (plan.self != plan.root) {
      auto message = c.space.buffer();
      message->clear();
      finishRuns(c.space.own, view, message->extend(size_t(region.size()) * 4), options.kernels);
      Transfers transfers(comm, options.timeoutSeconds);
      transfers.send(plan.root, tag, message->data(), message->size(), message, "a finished region");
      stats.bytesSent += message->size();
      transfers.wait();
      ++stats.rounds;
      return 0;
    }
    // The root finishes its own region in place and receives the others' straight into theirs.
    finishRuns(c.space.own, view, rgba->data() + size_t(region.begin) * 4, options.kernels);
    Transfers transfers(comm, options.timeoutSeconds);
    for (const auto& [from, range] : othersFinal(plan)) {
      transfers.receive(from, tag, rgba->data() + size_t(range.begin) * 4, size_t(range.size()) * 4, rgba,
                        "a finished region");
      stats.bytesReceived += size_t(range.size()) * 4;
    }
    transfers.wait();
    ++stats.rounds;
    frame = {partial.width, partial.height, std::move(*rgba)};
    return 0;
  });
}

image::Image8 compositeFinished(MPI_Comm comm, const image::ImageF& partial, const std::vector<int>& frontToBack,
                                const render::SceneView& view, const CompositeOptions& options, CompositeStats* stats) {
  image::Image8 frame;
  compositeFinished(comm, partial, frontToBack, view, frame, options, stats);
  return frame;
}

std::vector<std::vector<int>> radixFactorisations(int ranks) {
  if (ranks < 1) throw std::invalid_argument("radixFactorisations: " + std::to_string(ranks) + " ranks");
  std::vector<std::vector<int>> out;
  std::vector<int> prefix;
  const std::function<void(int)> extend = [&](int n) {
    if (n == 1) {
      if (!prefix.empty()) out.push_back(prefix);
      return;
    }
    for (int k = 2; k <= n; ++k) {
      if (n % k) continue;
      prefix.push_back(k);
      extend(n / k);
      prefix.pop_back();
    }
  };
  extend(ranks);
  return out;
}

std::vector<int> radixFactors(int ranks) {
  if (ranks < 1) throw std::invalid_argument("radixFactors: " + std::to_string(ranks) + " ranks");
  if (ranks == 1) return {};
  // Measured for 2 to 8 ranks (bench/results/mpi/mpi.md, every ordered factorisation, on one machine): one round
  // of k = N was the fastest at 2048² for every count (at 1024² the order changed from run to run), and it rounds
  // each pixel to half floats least often.
  if (ranks <= 8) return {ranks};
  // Beyond: the prime factors, largest first, joined into rounds while k stays <= 8; a larger prime is one round.
  std::vector<int> primes;
  int rest = ranks;
  for (int p = 2; p * p <= rest; ++p) {
    while (rest % p == 0) primes.push_back(p), rest /= p;
  }
  if (rest > 1) primes.push_back(rest);
  std::sort(primes.rbegin(), primes.rend());
  std::vector<int> factors;
  for (int p : primes) {
    if (!factors.empty() && factors.back() * p <= 8) {
      factors.back() *= p;
    } else {
      factors.push_back(p);
    }
  }
  return factors;
}

PixelEncoding parsePixelEncoding(const std::string& name) {
  if (name == "half") return PixelEncoding::Half;
  if (name == "float") return PixelEncoding::Float;
  throw std::invalid_argument("pixel encoding '" + name + "' is not half or float");
}

const char* pixelEncodingName(PixelEncoding encoding) { return encoding == PixelEncoding::Half ? "half" : "float"; }

}  // namespace voxbrick::distributed
