// A chunk of level 0 cut into OpenVDB leaves as the slices arrive, and its .vdb file written from them: the bytes
// io::File writes (Archive::write and writeGrid, Tree/RootNode/InternalNode/LeafNode::writeTopology and writeBuffers
// of OpenVDB 10), with the tree's structure made from the chunk's cells instead of a tree.
#include "brickstore/vdb/VdbLeafChunk.h"

#include <fcntl.h>
#include <unistd.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ostream>
#include <stdexcept>
#include <streambuf>
#include <string>
#include <utility>

#include <boost/uuid/random_generator.hpp>
#include <boost/uuid/uuid_io.hpp>
#include <openvdb/io/Compression.h>
#include <openvdb/io/DelayedLoadMetadata.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/io.h>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

using Leaf = openvdb::FloatTree::LeafNodeType;
using Node5 = openvdb::FloatTree::RootNodeType::ChildNodeType;
using Node4 = Node5::ChildNodeType;
using LeafMask = Leaf::NodeMaskType;

constexpr int64_t kLeafValues = 512;
constexpr uint32_t kMaskBytes = 64;
/// A kept leaf: its value mask, the mask-compression byte (NO_MASK_OR_INACTIVE_VALS: every inactive value is the
/// background) and its active values.
constexpr uint32_t kLeafHeader = kMaskBytes + 1;
/// Room a kept leaf has beyond its bytes: blosc's size word and, where it does not shrink the values, its 16-byte
/// header (BLOSC_MAX_OVERHEAD), so that a leaf is compressed in place.
constexpr uint32_t kBloscRoom = 8 + 16;

/// A stream buffer appending to a vector.
class AppendBuffer : public std::streambuf {
 public:
  std::vector<char> bytes;

 protected:
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    bytes.insert(bytes.end(), s, s + n);
    return n;
  }
  int_type overflow(int_type c) override {
    if (!traits_type::eq_int_type(c, traits_type::eof())) bytes.push_back(traits_type::to_char_type(c));
    return traits_type::not_eof(c);
  }
};

/// A stream over an AppendBuffer, tagged as OpenVDB tags the stream it writes a grid to: the data compression and
/// the grid's background (what io::writeCompressedValues reads).
struct TaggedStream {
  AppendBuffer buffer;
  std::ostream os{&buffer};
  TaggedStream(uint32_t compression, const float* background) {
    openvdb::io::setDataCompression(os, compression);
    openvdb::io::setGridBackgroundValuePtr(os, background);
  }
};

/// The median that tools::pruneTiles gives a constant node: std::nth_element at (n - 1) / 2 over its values in
/// table order (they are all equal but for the sign of a zero).
float pruneValue(std::vector<float>& values) {
  const size_t mid = (values.size() - 1) >> 1;
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(mid), values.end());
  return values[mid];
}

/// A file written through 2 MB of staging, with O_DIRECT where the file system takes it. On this kind of
/// virtual machine every page the page cache takes afresh costs the writer a copy at a few hundred MB/s (the host
/// backs it again); from the staging buffer, reused, the bytes go to the disk without it. Gathering matters too:
/// writing each kept leaf from where it was cut (writev, a 2 KiB segment a leaf) copied 5x slower than MB writes.
class StagedFile {
 public:
  explicit StagedFile(const std::filesystem::path& path) : mPath(path) {
    mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_DIRECT, 0644);
    mDirect = mFd >= 0;
    if (!mDirect) mFd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (mFd < 0) fail(errno);
    mStaging.reset(static_cast<char*>(std::aligned_alloc(kAlign, kStaging)));
    if (!mStaging) fail(ENOMEM);
  }
  ~StagedFile() {
    if (mFd >= 0) ::close(mFd);
  }
  StagedFile(const StagedFile&) = delete;
  StagedFile& operator=(const StagedFile&) = delete;

  void append(const char* data, size_t size) {
    while (size > 0) {
      const size_t take = std::min(size, kStaging - mUsed);
      std::memcpy(mStaging.get() + mUsed, data, take);
      mUsed += take, data += take, size -= take;
      if (mUsed == kStaging) flush(kStaging);
    }
  }
  /// Writes what is left and closes the file, `size` bytes long.
  void close(uint64_t size) {
    // A direct write is whole blocks: the last one padded, and the file cut back to its size.
    const bool padding = mDirect;
    const size_t padded = padding ? (mUsed + kAlign - 1) / kAlign * kAlign : mUsed;
    std::memset(mStaging.get() + mUsed, 0, padded - mUsed);
    flush(padded);
    if (padding && ::ftruncate(mFd, off_t(size)) != 0) fail(errno);
    const int fd = std::exchange(mFd, -1);
    if (::close(fd) != 0) fail(errno);
  }

 private:
  static constexpr size_t kAlign = 4096;
  static constexpr size_t kStaging = size_t{2} << 20;
  struct Free {
    void operator()(char* p) const { std::free(p); }
  };

  void flush(size_t size) {
    const char* data = mStaging.get();
    while (size > 0) {
      const ssize_t n = ::write(mFd, data, size);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && errno == EINVAL && mDirect) {  // the file system refuses direct writes after all
        mDirect = false;
        if (::fcntl(mFd, F_SETFL, ::fcntl(mFd, F_GETFL) & ~O_DIRECT) != 0) fail(errno);
        continue;
      }
      if (n < 0) fail(errno);
      data += n;
      size -= size_t(n);
    }
    mUsed = 0;
  }
  [[noreturn]] void fail(int error) const {
    throw IoError("cannot write " + mPath.string() + ": " + std::strerror(error));
  }

  std::filesystem::path mPath;
  int mFd = -1;
  bool mDirect = false;
  std::unique_ptr<char, Free> mStaging;
  size_t mUsed = 0;
};

/// A whole 8^3 block (x fastest in memory, rows `rowStride` and slices `sliceStride` apart) into `leaf` in leaf
/// order (offset x << 6 | y << 3 | z), when none of its voxels is the background: true then. Copied in the source's
/// order first, so that the test and the copy run 8 values at a time, then transposed; false (with `leaf` to be
/// filled again) for a block with a background voxel or a NaN, which need the value mask.
template <typename T>
bool cutActiveLeaf(const T* block, int64_t rowStride, int64_t sliceStride, float background, float* leaf) {
  alignas(64) float copy[512];
  bool anyBackground = false;
  for (int z = 0; z < 8; ++z)
    for (int y = 0; y < 8; ++y) {
      const T* row = block + z * sliceStride + y * rowStride;
      float* out = copy + (z << 6) + (y << 3);
      for (int x = 0; x < 8; ++x) {
        out[x] = static_cast<float>(row[x]);
        anyBackground |= !(std::abs(background - out[x]) > 0.0f);
      }
    }
  if (anyBackground) return false;
  for (int y = 0; y < 8; ++y)
    for (int z = 0; z < 8; ++z)
      for (int x = 0; x < 8; ++x) leaf[(x << 6) | (y << 3) | z] = copy[(z << 6) | (y << 3) | x];
  return true;
}

template <typename NodeT>
int64_t internalNodeBytes() {
  // What tools::memUsage counts for an internal node (MemUsageOp), its children apart.
  return int64_t(NodeT::NUM_VALUES * sizeof(typename NodeT::UnionType) +
                 typename NodeT::NodeMaskType().memUsage() * 2 + sizeof(openvdb::Coord));
}

}  // namespace

/// Per-thread room to cut a row of leaves: their values in leaf order and value masks.
struct ScratchSet {
  struct Scratch {
    std::vector<float> values;
    std::vector<uint64_t> words;
  };
  tbb::enumerable_thread_specific<Scratch> local;
};

/// The tree of a complete chunk, as tools::pruneTiles leaves it: root tiles and level-5 nodes in the root's order
/// (coordinates, x first), each node's children in offset order, and the leaves in the order they are written.
struct VdbLeafChunk::Layout {
  struct Child4 {
    uint32_t pos = 0;     ///< offset in its level-5 node
    bool tile = false;    ///< pruned to an active tile of `value`
    float value = 0;
    std::vector<std::pair<uint32_t, uint32_t>> cells;  ///< (offset in the node, cell index) of its leaves and tiles
  };
  struct Child5 {
    openvdb::Coord origin;
    bool tile = false;
    float value = 0;
    std::vector<Child4> children;
  };
  std::vector<Child5> nodes;
  std::vector<uint32_t> leaves;  ///< cell indices in the tree's leaf order
  int64_t nodes4 = 0;
};

VdbLeafChunk::VdbLeafChunk(const Vec3i& dims, float background)
    : mDims(dims),
      mBackground(background),
      mLeavesX(divUp(dims.x, 8)),
      mLeavesY(divUp(dims.y, 8)),
      mScratch(std::make_unique<ScratchSet>()) {}

VdbLeafChunk::~VdbLeafChunk() = default;

int64_t VdbLeafChunk::maxBytes(const Vec3i& dims, int64_t slices) {
  // A chunk of slices not a multiple of 8 may touch one layer more.
  const int64_t cells = divUp(dims.x, 8) * divUp(dims.y, 8) * (divUp(slices, 8) + (slices % 8 != 0 ? 1 : 0));
  return cells * (int64_t(kLeafHeader + kBloscRoom) + kLeafValues * 4 + int64_t(sizeof(Cell)));
}

void VdbLeafChunk::begin(int64_t z0, int64_t z1) {
  if (z0 < 0 || z1 <= z0 || z1 > mDims.z) throw std::logic_error("VdbLeafChunk: bad chunk");
  mZ0 = z0, mZ1 = z1, mNextZ = z0;
  mFirstLayer = z0 >> 3;
  mLayers = ((z1 - 1) >> 3) - mFirstLayer + 1;
  mCells.assign(size_t(mLeavesX * mLeavesY * mLayers), Cell{});
  const size_t capacity = size_t(mCells.size()) * (kLeafHeader + kBloscRoom + kLeafValues * 4);
  if (capacity > mPoolCapacity) {
    mPool.reset();  // untouched pages of the new pool cost nothing until a leaf is kept there
    mPool.reset(new char[capacity]);
    mPoolCapacity = capacity;
  }
  mPoolUsed = 0;
  mCarrySlices = 0;
  mLayout.reset();
}

void VdbLeafChunk::release() {
  mCells = {};
  mPool.reset();
  mPoolCapacity = 0;
  mCarry = {};
  mLayout.reset();
  mZ0 = mZ1 = mNextZ = 0;
}

template <typename T>
void VdbLeafChunk::addSlices(const T* values, int64_t z0, int64_t count) {
  if (z0 != mNextZ || count < 0 || z0 + count > mZ1) throw std::logic_error("VdbLeafChunk: slices out of order");
  const size_t sliceBytes = size_t(mDims.x * mDims.y) * sizeof(T);
  while (count > 0) {
    const int64_t layerEnd = std::min(((z0 >> 3) + 1) << 3, mZ1);
    const int64_t take = std::min(count, layerEnd - z0);
    if (mCarrySlices == 0 && take == layerEnd - z0) {
      cutLayer(values, z0, take);
    } else {
      if (mCarrySlices == 0) mCarryZ = z0;
      mCarry.resize(size_t(mCarrySlices + take) * sliceBytes);
      std::memcpy(mCarry.data() + size_t(mCarrySlices) * sliceBytes, values, size_t(take) * sliceBytes);
      mCarrySlices += take;
      if (z0 + take == layerEnd) {
        cutLayer(reinterpret_cast<const T*>(mCarry.data()), mCarryZ, mCarrySlices);
        mCarrySlices = 0;
      }
    }
    values += size_t(take) * size_t(mDims.x * mDims.y);
    z0 += take;
    count -= take;
  }
  mNextZ = z0;
}

template <typename T>
void VdbLeafChunk::cutLayer(const T* values, int64_t zs, int64_t slices) {
  const int64_t nx = mDims.x, ny = mDims.y;
  const int64_t layer = (zs >> 3) - mFirstLayer;
  const int64_t oz = (zs >> 3) << 3;
  const float background = mBackground;
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, mLeavesY), [&](const tbb::blocked_range<int64_t>& rows) {
    ScratchSet::Scratch& s = mScratch->local.local();
    s.values.resize(size_t(mLeavesX * kLeafValues));
    s.words.resize(size_t(mLeavesX * 8));
    for (int64_t ly = rows.begin(); ly != rows.end(); ++ly) {
      const int64_t y0 = ly * 8, y1 = std::min(y0 + 8, ny);
      uint64_t rowBytes = 0;
      for (int64_t lx = 0; lx < mLeavesX; ++lx) {
        const int64_t x0 = lx * 8, width = std::min<int64_t>(8, nx - x0);
        float* buf = &s.values[size_t(lx * kLeafValues)];
        uint64_t* words = &s.words[size_t(lx * 8)];
        std::fill(words, words + 8, 0);
        const bool whole = width == 8 && y1 - y0 == 8 && slices == 8;
        if (whole && cutActiveLeaf(values + (y0 * nx + x0), nx, ny * nx, background, buf)) {
          std::fill(words, words + 8, ~uint64_t{0});
        } else {
          if (!whole) std::fill(buf, buf + kLeafValues, background);
          // Leaf offset n = x << 6 | y << 3 | z, so mask word x holds bit (y << 3 | z).
          for (int64_t z = zs; z < zs + slices; ++z)
            for (int64_t y = y0; y < y1; ++y) {
              const T* row = values + ((z - zs) * ny + y) * nx + x0;
              const int bit = int(((y - y0) << 3) | (z - oz));
              for (int64_t i = 0; i < width; ++i) {
                const float v = static_cast<float>(row[i]);
                // !math::isApproxEqual(background, v, 0), as LeafNode::copyFromDense: a NaN is the background.
                const bool on = std::abs(background - v) > 0.0f;
                buf[(i << 6) | bit] = on ? v : background;
                words[i] |= uint64_t(on) << bit;
              }
            }
        }
        int count = 0;
        for (int w = 0; w < 8; ++w) count += std::popcount(words[w]);
        Cell& cell = mCells[cellIndex(lx, ly, layer)];
        cell = Cell{};
        cell.count = uint16_t(count);
        if (count == 0) continue;  // the background: no leaf, as copyFromDense leaves it
        // LeafNode::isConstant (tolerance 0): all active, every value equal to the first: a tile of it.
        bool constant = count == kLeafValues;
        for (int64_t i = 1; constant && i < kLeafValues; ++i) constant = buf[i] == buf[0];
        if (constant) {
          cell.kind = Kind::Tile;
          cell.tile = buf[0];
          continue;
        }
        cell.kind = Kind::Leaf;
        cell.size = kLeafHeader + uint32_t(count) * 4;
        rowBytes += cell.size + kBloscRoom;
      }
      const uint64_t at = mPoolUsed.fetch_add(rowBytes);
      if (at + rowBytes > mPoolCapacity) throw std::logic_error("VdbLeafChunk: pool overflow");
      uint64_t next = at;
      for (int64_t lx = 0; lx < mLeavesX; ++lx) {
        Cell& cell = mCells[cellIndex(lx, ly, layer)];
        if (cell.kind != Kind::Leaf) continue;
        cell.offset = next;
        next += cell.size + kBloscRoom;
        char* dst = mPool.get() + cell.offset;
        const uint64_t* words = &s.words[size_t(lx * 8)];
        const float* buf = &s.values[size_t(lx * kLeafValues)];
        std::memcpy(dst, words, kMaskBytes);
        dst[kMaskBytes] = char(openvdb::io::NO_MASK_OR_INACTIVE_VALS);
        float* active = reinterpret_cast<float*>(dst + kLeafHeader);
        if (cell.count == kLeafValues) {
          std::memcpy(active, buf, kLeafValues * sizeof(float));
        } else {
          size_t k = 0;
          for (size_t w = 0; w < 8; ++w)
            for (uint64_t on = words[w]; on != 0; on &= on - 1) active[k++] = buf[w * 64 + size_t(std::countr_zero(on))];
        }
      }
    }
  });
}

void VdbLeafChunk::expand(const Cell& cell, float* values) const {
  const char* src = mPool.get() + cell.offset;
  uint64_t words[8];
  std::memcpy(words, src, kMaskBytes);
  const float* active = reinterpret_cast<const float*>(src + kLeafHeader);
  std::fill(values, values + kLeafValues, mBackground);
  size_t k = 0;
  for (size_t w = 0; w < 8; ++w)
    for (uint64_t on = words[w]; on != 0; on &= on - 1) values[w * 64 + size_t(std::countr_zero(on))] = active[k++];
}

const VdbLeafChunk::Layout& VdbLeafChunk::layout() {
  if (mLayout) return *mLayout;
  if (!complete()) throw std::logic_error("VdbLeafChunk: the chunk is not complete");
  auto L = std::make_unique<Layout>();
  // Global leaf coordinates (voxel >> 3) of the chunk's cells, and the nodes above them.
  const int64_t lastLayer = mFirstLayer + mLayers - 1;
  const int64_t n5x = divUp(mLeavesX, 512), n5y = divUp(mLeavesY, 512);
  std::vector<float> values;
  for (int64_t X5 = 0; X5 < n5x; ++X5)
    for (int64_t Y5 = 0; Y5 < n5y; ++Y5)
      for (int64_t Z5 = mFirstLayer >> 9; Z5 <= lastLayer >> 9; ++Z5) {
        Layout::Child5 node;
        node.origin = openvdb::Coord(int(X5 << 12), int(Y5 << 12), int(Z5 << 12));
        for (int64_t x4 = 0; x4 < 32; ++x4)
          for (int64_t y4 = 0; y4 < 32; ++y4)
            for (int64_t z4 = 0; z4 < 32; ++z4) {
              const int64_t X4 = X5 * 32 + x4, Y4 = Y5 * 32 + y4, Z4 = Z5 * 32 + z4;
              if (X4 * 16 >= mLeavesX || Y4 * 16 >= mLeavesY) continue;
              const int64_t lz0 = std::max(Z4 * 16, mFirstLayer), lz1 = std::min(Z4 * 16 + 16, lastLayer + 1);
              if (lz0 >= lz1) continue;
              Layout::Child4 child;
              child.pos = uint32_t((x4 << 10) | (y4 << 5) | z4);
              bool allTiles = true;
              for (int64_t lx = X4 * 16; lx < std::min(X4 * 16 + 16, mLeavesX); ++lx)
                for (int64_t ly = Y4 * 16; ly < std::min(Y4 * 16 + 16, mLeavesY); ++ly)
                  for (int64_t lz = lz0; lz < lz1; ++lz) {
                    const size_t index = cellIndex(lx, ly, lz - mFirstLayer);
                    const Cell& cell = mCells[index];
                    if (cell.kind == Kind::Empty) continue;
                    allTiles = allTiles && cell.kind == Kind::Tile;
                    child.cells.emplace_back(uint32_t(((lx & 15) << 8) | ((ly & 15) << 4) | (lz & 15)),
                                             uint32_t(index));
                  }
              if (child.cells.empty()) continue;
              // InternalNode::isConstant: every entry an active tile, all within tolerance 0 of each other.
              if (allTiles && child.cells.size() == Node4::NUM_VALUES) {
                values.clear();
                for (const auto& [pos, index] : child.cells) values.push_back(mCells[index].tile);
                const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
                if (*lo == *hi) {
                  child.tile = true;
                  child.value = pruneValue(values);
                  child.cells.clear();
                }
              }
              node.children.push_back(std::move(child));
            }
        if (node.children.empty()) continue;
        if (node.children.size() == Node5::NUM_VALUES &&
            std::all_of(node.children.begin(), node.children.end(), [](const Layout::Child4& c) { return c.tile; })) {
          values.clear();
          for (const Layout::Child4& c : node.children) values.push_back(c.value);
          const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
          if (*lo == *hi) {
            node.tile = true;
            node.value = pruneValue(values);
            node.children.clear();
          }
        }
        L->nodes.push_back(std::move(node));
      }
  for (const Layout::Child5& node : L->nodes)
    for (const Layout::Child4& child : node.children) {
      if (child.tile) continue;
      ++L->nodes4;
      for (const auto& [pos, index] : child.cells)
        if (mCells[index].kind == Kind::Leaf) L->leaves.push_back(index);
    }
  mLayout = std::move(L);
  return *mLayout;
}

int64_t VdbLeafChunk::leafCount() {
  return int64_t(layout().leaves.size());
}

void VdbLeafChunk::writeLeafBuffers(const Cell& cell, std::ostream& os) const {
  // LeafNode::writeBuffers: the value mask, then the values as the stream's compression has them.
  float values[kLeafValues];
  expand(cell, values);
  LeafMask mask;
  std::memcpy(&mask.template getWord<uint64_t>(0), mPool.get() + cell.offset, kMaskBytes);
  mask.save(os);
  openvdb::io::writeCompressedValues(os, values, Leaf::SIZE, mask, LeafMask(), false);
}

bool VdbLeafChunk::bloscShrinksTo(double ratio) {
  const Layout& L = layout();
  constexpr size_t kEvery = 16;
  const size_t samples = (L.leaves.size() + kEvery - 1) / kEvery;
  if (samples == 0) return true;
  const uint32_t blosc = openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK;
  using Sizes = std::pair<size_t, size_t>;  // {with blosc, without}: sums of integers, in any order
  const Sizes sizes = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, samples, 8), Sizes{0, 0},
      [&](const tbb::blocked_range<size_t>& r, Sizes sum) {
        TaggedStream out(blosc, &mBackground);
        for (size_t i = r.begin(); i != r.end(); ++i) {
          const Cell& cell = mCells[L.leaves[i * kEvery]];
          out.buffer.bytes.clear();
          writeLeafBuffers(cell, out.os);
          sum.first += out.buffer.bytes.size();
          sum.second += cell.size;
        }
        return sum;
      },
      [](Sizes a, const Sizes& b) {
        return Sizes{a.first + b.first, a.second + b.second};
      });
  return double(sizes.first) <= ratio * double(sizes.second);
}

void VdbLeafChunk::compressLeaves(uint32_t compression) {
  const Layout& L = layout();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, L.leaves.size(), 64), [&](const tbb::blocked_range<size_t>& r) {
    TaggedStream out(compression, &mBackground);
    for (size_t i = r.begin(); i != r.end(); ++i) {
      Cell& cell = mCells[L.leaves[i]];
      out.buffer.bytes.clear();
      writeLeafBuffers(cell, out.os);
      if (out.buffer.bytes.size() > cell.size + kBloscRoom) throw std::logic_error("VdbLeafChunk: blosc overflow");
      std::memcpy(mPool.get() + cell.offset, out.buffer.bytes.data(), out.buffer.bytes.size());
      cell.size = uint32_t(out.buffer.bytes.size());
    }
  });
}

/// The bounding box of a leaf's active voxels, from its value mask (word x holds bit y << 3 | z).
static openvdb::CoordBBox activeBox(const char* maskBytes, const openvdb::Coord& origin) {
  uint64_t words[8];
  std::memcpy(words, maskBytes, kMaskBytes);
  int xlo = 8, xhi = -1;
  uint64_t any = 0;
  for (int w = 0; w < 8; ++w)
    if (words[w] != 0) xlo = std::min(xlo, w), xhi = w, any |= words[w];
  int ylo = 8, yhi = -1;
  uint8_t zs = 0;
  for (int y = 0; y < 8; ++y)
    if (const uint8_t b = uint8_t(any >> (8 * y)); b != 0) ylo = std::min(ylo, y), yhi = y, zs |= b;
  const int zlo = std::countr_zero(zs), zhi = 7 - std::countl_zero(zs);
  return {origin.offsetBy(xlo, ylo, zlo), origin.offsetBy(xhi, yhi, zhi)};
}

openvdb::MetaMap VdbLeafChunk::fileMetadata(const openvdb::FloatGrid& grid, uint32_t archiveCompression,
                                            uint32_t compression) {
  namespace io = openvdb::io;
  const Layout& L = layout();
  // GridBase::addStatsMetadata: active voxels and their bounding box (pruning keeps every voxel's state, so the
  // cells count it all: a tile its 8^3 voxels, a leaf its active ones), and the tree's memory.
  int64_t active = 0;
  openvdb::CoordBBox bbox;  // empty: what an empty tree reports
  for (int64_t layer = 0; layer < mLayers; ++layer)
    for (int64_t ly = 0; ly < mLeavesY; ++ly)
      for (int64_t lx = 0; lx < mLeavesX; ++lx) {
        const Cell& cell = mCells[cellIndex(lx, ly, layer)];
        if (cell.kind == Kind::Empty) continue;
        const openvdb::Coord origin(int(lx * 8), int(ly * 8), int((mFirstLayer + layer) * 8));
        active += cell.count;
        // the mask leads a kept leaf, blosc or not
        bbox.expand(cell.kind == Kind::Tile ? openvdb::CoordBBox::createCube(origin, 8)
                                            : activeBox(mPool.get() + cell.offset, origin));
      }
  // tools::memUsage: the tree and its root, every internal node, every leaf (its buffer allocated).
  const Leaf sample(openvdb::Coord(0), 0.0f);
  const int64_t memory = int64_t(sizeof(openvdb::FloatTree) + sizeof(openvdb::FloatTree::RootNodeType)) +
                         int64_t(std::count_if(L.nodes.begin(), L.nodes.end(), [](auto& n) { return !n.tile; })) *
                             internalNodeBytes<Node5>() +
                         L.nodes4 * internalNodeBytes<Node4>() + int64_t(L.leaves.size()) * int64_t(sample.memUsage());

  // Archive::writeGrid writes a copy of the grid's metadata with the delayed-load record and the statistics.
  openvdb::MetaMap meta(static_cast<const openvdb::MetaMap&>(grid));
  io::DelayedLoadMetadata delayed;
  if (!L.leaves.empty()) {
    delayed.resizeMask(L.leaves.size());  // every leaf NO_MASK_OR_INACTIVE_VALS (0)
    if (archiveCompression & (io::COMPRESS_BLOSC | io::COMPRESS_ZIP)) {
      delayed.resizeCompressedSize(L.leaves.size());
      for (size_t i = 0; i < L.leaves.size(); ++i)
        delayed.setCompressedSize(i, io::DelayedLoadMetadata::CompressedSizeType(mCells[L.leaves[i]].size - kLeafHeader));
    }
  }
  for (const char* name : {openvdb::GridBase::META_FILE_DELAYED_LOAD, openvdb::GridBase::META_FILE_BBOX_MIN,
                           openvdb::GridBase::META_FILE_BBOX_MAX, openvdb::GridBase::META_FILE_MEM_BYTES,
                           openvdb::GridBase::META_FILE_VOXEL_COUNT, openvdb::GridBase::META_FILE_COMPRESSION})
    meta.removeMeta(name);
  meta.insertMeta(openvdb::GridBase::META_FILE_DELAYED_LOAD, delayed);
  meta.insertMeta(openvdb::GridBase::META_FILE_BBOX_MIN, openvdb::Vec3IMetadata(bbox.min().asVec3i()));
  meta.insertMeta(openvdb::GridBase::META_FILE_BBOX_MAX, openvdb::Vec3IMetadata(bbox.max().asVec3i()));
  meta.insertMeta(openvdb::GridBase::META_FILE_MEM_BYTES, openvdb::Int64Metadata(memory));
  meta.insertMeta(openvdb::GridBase::META_FILE_VOXEL_COUNT, openvdb::Int64Metadata(active));
  meta.insertMeta(openvdb::GridBase::META_FILE_COMPRESSION,
                  openvdb::StringMetadata(io::compressionToString(compression)));
  return meta;
}

void VdbLeafChunk::writeTopology(std::ostream& os) {
  namespace io = openvdb::io;
  const Layout& L = layout();
  // TreeBase, RootNode, InternalNode and LeafNode::writeTopology.
  const int32_t bufferCount = 1;
  os.write(reinterpret_cast<const char*>(&bufferCount), sizeof bufferCount);
  os.write(reinterpret_cast<const char*>(&mBackground), sizeof mBackground);
  const auto tiles = openvdb::Index(std::count_if(L.nodes.begin(), L.nodes.end(), [](auto& n) { return n.tile; }));
  const auto children = openvdb::Index(L.nodes.size()) - tiles;
  os.write(reinterpret_cast<const char*>(&tiles), sizeof tiles);
  os.write(reinterpret_cast<const char*>(&children), sizeof children);
  for (const Layout::Child5& node : L.nodes)
    if (node.tile) {
      os.write(reinterpret_cast<const char*>(node.origin.asPointer()), 3 * sizeof(openvdb::Int32));
      os.write(reinterpret_cast<const char*>(&node.value), sizeof(float));
      const bool on = true;
      os.write(reinterpret_cast<const char*>(&on), sizeof on);
    }
  std::vector<float> values5(Node5::NUM_VALUES), values4(Node4::NUM_VALUES);
  for (const Layout::Child5& node : L.nodes) {
    if (node.tile) continue;
    os.write(reinterpret_cast<const char*>(node.origin.asPointer()), 3 * sizeof(openvdb::Int32));
    Node5::NodeMaskType childMask5, valueMask5;
    std::fill(values5.begin(), values5.end(), mBackground);
    for (const Layout::Child4& child : node.children) {
      (child.tile ? valueMask5 : childMask5).setOn(child.pos);
      values5[child.pos] = child.tile ? child.value : 0.0f;
    }
    childMask5.save(os);
    valueMask5.save(os);
    io::writeCompressedValues(os, values5.data(), Node5::NUM_VALUES, valueMask5, childMask5, false);
    for (const Layout::Child4& child : node.children) {
      if (child.tile) continue;
      Node4::NodeMaskType childMask4, valueMask4;
      std::fill(values4.begin(), values4.end(), mBackground);
      for (const auto& [pos, index] : child.cells) {
        const bool tile = mCells[index].kind == Kind::Tile;
        (tile ? valueMask4 : childMask4).setOn(pos);
        values4[pos] = tile ? mCells[index].tile : 0.0f;
      }
      childMask4.save(os);
      valueMask4.save(os);
      io::writeCompressedValues(os, values4.data(), Node4::NUM_VALUES, valueMask4, childMask4, false);
      for (const auto& [pos, index] : child.cells)
        if (mCells[index].kind == Kind::Leaf) os.write(mPool.get() + mCells[index].offset, kMaskBytes);
    }
  }
}

int64_t VdbLeafChunk::write(const std::filesystem::path& path, const openvdb::FloatGrid& grid, bool blosc) {
  namespace io = openvdb::io;
  const Layout& L = layout();
  const uint32_t archiveCompression = blosc ? io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK : io::COMPRESS_ACTIVE_MASK;
  // Archive::setGridCompression: no zip for level sets and fog volumes.
  uint32_t compression = archiveCompression;
  if (grid.getGridClass() == openvdb::GRID_LEVEL_SET || grid.getGridClass() == openvdb::GRID_FOG_VOLUME)
    compression &= ~uint32_t(io::COMPRESS_ZIP);
  if (compression & io::COMPRESS_BLOSC) compressLeaves(compression);

  // Before the grid: Archive::writeHeader (seekable), the file's (empty) metadata, the grid count, the descriptor.
  TaggedStream head(archiveCompression, &mBackground);
  {
    std::ostream& os = head.os;
    const int64_t magic = openvdb::OPENVDB_MAGIC;
    os.write(reinterpret_cast<const char*>(&magic), sizeof magic);
    for (const uint32_t v : {uint32_t(openvdb::OPENVDB_FILE_VERSION), uint32_t(openvdb::OPENVDB_LIBRARY_MAJOR_VERSION),
                             uint32_t(openvdb::OPENVDB_LIBRARY_MINOR_VERSION)})
      os.write(reinterpret_cast<const char*>(&v), sizeof v);
    os.put(char(1));  // the stream has grid offsets
    os << boost::uuids::random_generator()();
    openvdb::MetaMap().writeMeta(os);
    const int32_t gridCount = 1;
    os.write(reinterpret_cast<const char*>(&gridCount), sizeof gridCount);
  }
  // Archive::write numbers an unnamed grid.
  const std::string name = grid.getName().empty() ? io::GridDescriptor::addSuffix("", 0) : grid.getName();
  io::GridDescriptor descriptor(name, grid.type(), false);
  descriptor.writeHeader(head.os);

  // The grid: its compression, metadata, transform and topology.
  TaggedStream body(compression, &mBackground);
  body.os.write(reinterpret_cast<const char*>(&compression), sizeof compression);
  fileMetadata(grid, archiveCompression, compression).writeMeta(body.os);
  grid.transform().write(body.os);
  writeTopology(body.os);

  // Stream positions, known before anything is written: the grid after the descriptor, the leaves after the
  // topology, the end after the leaves.
  uint64_t leafBytes = 0;
  for (const uint32_t index : L.leaves) leafBytes += mCells[index].size;
  const int64_t gridPos = int64_t(head.buffer.bytes.size()) + 3 * int64_t(sizeof(int64_t));
  const int64_t blockPos = gridPos + int64_t(body.buffer.bytes.size());
  const int64_t endPos = blockPos + int64_t(leafBytes);
  descriptor.setGridPos(gridPos);
  descriptor.setBlockPos(blockPos);
  descriptor.setEndPos(endPos);
  descriptor.writeStreamPos(head.os);

  StagedFile file(path);
  file.append(head.buffer.bytes.data(), head.buffer.bytes.size());
  file.append(body.buffer.bytes.data(), body.buffer.bytes.size());
  for (const uint32_t index : L.leaves) file.append(mPool.get() + mCells[index].offset, mCells[index].size);
  file.close(uint64_t(endPos));
  return endPos;
}

template void VdbLeafChunk::addSlices(const uint8_t*, int64_t, int64_t);
template void VdbLeafChunk::addSlices(const uint16_t*, int64_t, int64_t);
template void VdbLeafChunk::addSlices(const int16_t*, int64_t, int64_t);
template void VdbLeafChunk::addSlices(const float*, int64_t, int64_t);

}  // namespace voxbrick::store
