// Binary swap in visibility order with a fold, then a gather to rank 0 (Compositor.h).
#include "distributed/Compositor.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "common/Half.h"

namespace voxbrick::distributed {
namespace {

using render::PixelRect;

PixelRect intersect(const PixelRect& a, const PixelRect& b) {
  PixelRect r{std::max(a.x0, b.x0), std::max(a.y0, b.y0), std::min(a.x1, b.x1), std::min(a.y1, b.y1)};
  return r.empty() ? PixelRect{} : r;
}

PixelRect unite(const PixelRect& a, const PixelRect& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return {std::min(a.x0, b.x0), std::min(a.y0, b.y0), std::max(a.x1, b.x1), std::max(a.y1, b.y1)};
}

// The two halves of a region, split across its longer side.
std::pair<PixelRect, PixelRect> halves(const PixelRect& region) {
  if (region.x1 - region.x0 >= region.y1 - region.y0) {
    int middle = region.x0 + (region.x1 - region.x0) / 2;
    return {{region.x0, region.y0, middle, region.y1}, {middle, region.y0, region.x1, region.y1}};
  }
  int middle = region.y0 + (region.y1 - region.y0) / 2;
  return {{region.x0, region.y0, region.x1, middle}, {region.x0, middle, region.x1, region.y1}};
}

constexpr size_t kHeaderBytes = 4 * sizeof(int32_t);

size_t channelBytes(PixelEncoding encoding) { return encoding == PixelEncoding::Half ? 2 : 4; }

size_t messageBytes(const PixelRect& rect, PixelEncoding encoding) {
  return kHeaderBytes + size_t(rect.pixels()) * 4 * channelBytes(encoding);
}

using Buffer = std::vector<uint8_t>;

// A message: the rectangle, then its pixels row by row in the encoding.
std::shared_ptr<Buffer> pack(const image::ImageF& image, const PixelRect& rect, PixelEncoding encoding) {
  auto buffer = std::make_shared<Buffer>(messageBytes(rect, encoding));
  int32_t header[4] = {rect.x0, rect.y0, rect.x1, rect.y1};
  std::memcpy(buffer->data(), header, kHeaderBytes);
  uint8_t* out = buffer->data() + kHeaderBytes;
  int rowFloats = 4 * (rect.x1 - rect.x0);
  for (int y = rect.y0; y < rect.y1 && !rect.empty(); ++y) {
    const float* row = image.pixel(rect.x0, y);
    if (encoding == PixelEncoding::Float) {
      std::memcpy(out, row, size_t(rowFloats) * 4);
      out += size_t(rowFloats) * 4;
    } else {
      common::floatsToHalves(row, reinterpret_cast<uint16_t*>(out), size_t(rowFloats));
      out += size_t(rowFloats) * 2;
    }
  }
  return buffer;
}

// The rectangle a received message holds, checked against the region it must lie in and the bytes that came.
PixelRect messageRect(const Buffer& buffer, const PixelRect& region, PixelEncoding encoding, int from) {
  int32_t header[4];
  std::memcpy(header, buffer.data(), kHeaderBytes);
  PixelRect rect{header[0], header[1], header[2], header[3]};
  if (rect.empty()) return {};
  if (!(intersect(rect, region) == rect) || messageBytes(rect, encoding) > buffer.size()) {
    throw PeerError(from, "rank " + std::to_string(from) + " sent a piece outside the region it was due");
  }
  return rect;
}

// Joins a received piece into `image`: received over image when `receivedInFront`, else image over received.
void blend(image::ImageF& image, const Buffer& buffer, const PixelRect& rect, PixelEncoding encoding,
           bool receivedInFront) {
  const uint8_t* in = buffer.data() + kHeaderBytes;
  int rowFloats = 4 * (rect.x1 - rect.x0);
  std::vector<float> row(size_t(std::max(rowFloats, 0)));
  for (int y = rect.y0; y < rect.y1; ++y) {
    if (encoding == PixelEncoding::Float) {
      std::memcpy(row.data(), in, row.size() * 4);
      in += row.size() * 4;
    } else {
      common::halvesToFloats(reinterpret_cast<const uint16_t*>(in), row.data(), row.size());
      in += row.size() * 2;
    }
    float* pixels = image.pixel(rect.x0, y);
    for (int i = 0; i < rowFloats; i += 4) {
      const float* front = receivedInFront ? &row[size_t(i)] : pixels + i;
      const float* back = receivedInFront ? pixels + i : &row[size_t(i)];
      float keep = 1.0f - front[3];
      float out[4];
      for (int c = 0; c < 4; ++c) out[c] = front[c] + keep * back[c];
      std::memcpy(pixels + i, out, sizeof out);
    }
  }
}

struct Exchange {
  MPI_Comm comm;
  const CompositeOptions& options;
  CompositeStats& stats;
};

// Sends `sendRect` of `image` to `to` (if to >= 0) and receives into a buffer from `from` (if from >= 0) a piece
// lying in `receiveRegion`; returns the received buffer (empty if none).
std::shared_ptr<Buffer> exchange(Exchange& ex, const image::ImageF& image, int to, const PixelRect& sendRect, int from,
                                 const PixelRect& receiveRegion, int tag, const char* what) {
  Transfers transfers(ex.comm, ex.options.timeoutSeconds);
  std::shared_ptr<Buffer> received;
  if (from >= 0) {
    received = std::make_shared<Buffer>(messageBytes(receiveRegion, ex.options.encoding));
    transfers.receive(from, tag, received->data(), received->size(), received, what);
  }
  if (to >= 0) {
    auto message = pack(image, sendRect, ex.options.encoding);
    transfers.send(to, tag, message->data(), message->size(), message, what);
    ex.stats.bytesSent += message->size();
  }
  transfers.wait();
  ++ex.stats.rounds;
  return received;
}

void checkOrder(const std::vector<int>& frontToBack, int size, int rank) {
  std::vector<bool> seen(size_t(size), false);
  for (int r : frontToBack) {
    if (r < 0 || r >= size || seen[size_t(r)]) {
      throw std::invalid_argument("compositing order names a rank twice or one outside the communicator");
    }
    seen[size_t(r)] = true;
  }
  if (frontToBack.empty() || !seen[0] || !seen[size_t(rank)]) {
    throw std::invalid_argument("compositing order does not name rank 0 and the calling rank " + std::to_string(rank));
  }
}

}  // namespace

namespace {

// Where each rank stands: its position in visibility order, and the ranks of the power of two left after the fold.
struct Layout {
  const std::vector<int>& frontToBack;
  int size = 1, pos = 0, powerOfTwo = 1, extra = 0;
  Layout(const std::vector<int>& order, int rank) : frontToBack(order), size(int(order.size())) {
    pos = int(std::find(order.begin(), order.end(), rank) - order.begin());
    while (powerOfTwo * 2 <= size) powerOfTwo *= 2;
    extra = size - powerOfTwo;
  }
  bool foldedAway() const { return pos < 2 * extra && pos % 2 == 1; }
  int virtualPos() const { return pos < 2 * extra ? pos / 2 : pos - extra; }
  int rankAt(int v) const { return v < extra ? frontToBack[size_t(2 * v)] : frontToBack[size_t(v + extra)]; }
};

// What a rank holds while compositing: its frame, the rectangle of it that carries anything, and its region.
struct Piece {
  image::ImageF image;
  PixelRect active, region;
};

// Receives a piece lying in `region` from `from` and joins it into `piece` (received in front or behind).
void joinReceived(Exchange& ex, Piece& piece, const Buffer& buffer, const PixelRect& region, int from,
                  bool receivedInFront) {
  PixelRect rect = messageRect(buffer, region, ex.options.encoding, from);
  ex.stats.bytesReceived += messageBytes(rect, ex.options.encoding);
  blend(piece.image, buffer, rect, ex.options.encoding, receivedInFront);
  piece.active = unite(piece.active, rect);
}

// The fold: of each of the first `extra` pairs of neighbours in visibility order, the back one hands its frame to
// the front one.
void fold(Exchange& ex, const Layout& layout, Piece& piece) {
  if (layout.pos >= 2 * layout.extra) return;
  const int tag = ex.options.tag;
  if (layout.foldedAway()) {
    exchange(ex, piece.image, layout.frontToBack[size_t(layout.pos - 1)], piece.active, -1, {}, tag,
             "the folded frame");
    return;
  }
  int from = layout.frontToBack[size_t(layout.pos + 1)];
  auto buffer = exchange(ex, piece.image, -1, {}, from, piece.region, tag, "the folded frame");
  joinReceived(ex, piece, *buffer, piece.region, from, false);
}

// Binary swap: in the round of `bit`, groups of `bit` neighbours pair up; the nearer group keeps the first half.
void swap(Exchange& ex, const Layout& layout, Piece& piece) {
  const int virtualPos = layout.virtualPos();
  for (int bit = 1; bit < layout.powerOfTwo; bit <<= 1) {
    int partnerPos = virtualPos ^ bit;
    int partner = layout.rankAt(partnerPos);
    bool nearer = virtualPos < partnerPos;
    auto [first, second] = halves(piece.region);
    PixelRect kept = nearer ? first : second;
    PixelRect given = nearer ? second : first;
    auto buffer = exchange(ex, piece.image, partner, intersect(piece.active, given), partner, kept, ex.options.tag + 1,
                           "a swapped half");
    piece.active = intersect(piece.active, kept);
    piece.region = kept;
    joinReceived(ex, piece, *buffer, kept, partner, !nearer);
  }
}

// The gather on rank 0: its own region (if it kept one) and every other region of the finished frame.
image::ImageF gather(Exchange& ex, const Layout& layout, const Piece* own, int width, int height) {
  image::ImageF result{width, height, std::vector<float>(size_t(width) * size_t(height) * 4, 0.0f)};
  const PixelRect whole{0, 0, width, height};
  if (own) {
    PixelRect rect = intersect(own->active, own->region);
    for (int y = rect.y0; y < rect.y1; ++y) {
      std::memcpy(result.pixel(rect.x0, y), own->image.pixel(rect.x0, y), size_t(rect.x1 - rect.x0) * 16);
    }
  }
  Transfers transfers(ex.comm, ex.options.timeoutSeconds);
  std::vector<std::pair<int, std::shared_ptr<Buffer>>> pieces;
  for (int v = 0; v < layout.powerOfTwo; ++v) {
    int from = layout.rankAt(v);
    if (from == 0) continue;
    auto buffer = std::make_shared<Buffer>(messageBytes(whole, ex.options.encoding));
    transfers.receive(from, ex.options.tag + 2, buffer->data(), buffer->size(), buffer, "a finished region");
    pieces.emplace_back(from, buffer);
  }
  transfers.wait();
  if (!pieces.empty()) ++ex.stats.rounds;
  for (auto& [from, buffer] : pieces) {
    PixelRect rect = messageRect(*buffer, whole, ex.options.encoding, from);
    ex.stats.bytesReceived += messageBytes(rect, ex.options.encoding);
    blend(result, *buffer, rect, ex.options.encoding, true);  // over zeros: a copy
  }
  return result;
}

}  // namespace

image::ImageF composite(MPI_Comm comm, image::ImageF partial, const std::vector<int>& frontToBack,
                        const CompositeOptions& options, CompositeStats* statsOut) {
  auto start = std::chrono::steady_clock::now();
  int size = 0, rank = 0;
  MPI_Comm_size(comm, &size);
  MPI_Comm_rank(comm, &rank);
  checkOrder(frontToBack, size, rank);
  if (partial.rgba.size() != size_t(partial.width) * size_t(partial.height) * 4) {
    throw std::invalid_argument("partial frame's pixels do not match its size");
  }
  CompositeStats stats;
  image::ImageF result;
  if (frontToBack.size() == 1) {
    result = std::move(partial);  // nothing to exchange: the frame is the part
  } else {
    Exchange ex{comm, options, stats};
    const Layout layout(frontToBack, rank);
    const int width = partial.width, height = partial.height;
    const PixelRect active = render::activeRect(partial);
    Piece piece{std::move(partial), active, {0, 0, width, height}};
    fold(ex, layout, piece);
    const bool inSwap = !layout.foldedAway();
    if (inSwap) swap(ex, layout, piece);
    if (inSwap && rank != 0) {
      exchange(ex, piece.image, 0, intersect(piece.active, piece.region), -1, {}, options.tag + 2, "a finished region");
    }
    if (rank == 0) result = gather(ex, layout, inSwap ? &piece : nullptr, width, height);
  }
  stats.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (statsOut) *statsOut = stats;
  return result;
}

PixelEncoding parsePixelEncoding(const std::string& name) {
  if (name == "half") return PixelEncoding::Half;
  if (name == "float") return PixelEncoding::Float;
  throw std::invalid_argument("pixel encoding '" + name + "' is not half or float");
}

const char* pixelEncodingName(PixelEncoding encoding) { return encoding == PixelEncoding::Half ? "half" : "float"; }

}  // namespace voxbrick::distributed
