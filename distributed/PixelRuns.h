// Run-length encoded pixel ranges, the form partial frames take while they are composited (Compositor.h): a range of
// a frame's pixels in row-major order as alternating runs of empty pixels (every channel zero, skipped) and of
// active ones (kept, premultiplied RGBA), the message that carries a range between ranks, the over operator on two
// ranges that touches only their active pixels, and the finishing of a range into 8-bit output pixels. Neither MPI
// nor GL: the kernels are tested on buffers. The blending and the half-float conversions have a SIMD path (AVX2 and
// F16C, chosen at run time) and a portable scalar one that gives the same bits.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <type_traits>
#include <variant>
#include <vector>

#include "image/Image.h"
#include "render/core/PartialFrame.h"
#include "render/core/Scene.h"

namespace voxbrick::distributed {

/// How pixels travel between ranks.
enum class PixelEncoding {
  Half,   ///< 16-bit IEEE half floats per channel (round to nearest even): half the bytes, error below 1/2048
  Float,  ///< 32-bit floats per channel, exact
};

/// Which kernels blend and convert: the fastest the processor has, or the portable scalar ones (the same results).
enum class Kernels { Best, Scalar };

/// Whether this processor runs the SIMD kernels (AVX2 and F16C); Kernels::Best falls back to scalar otherwise.
bool simdKernelsAvailable();

/// A buffer that only grows and is never filled for nothing: clear() keeps the storage, so that buffers are reused
/// from frame to frame, and reserve() takes address space whose pages are touched only when written (a worst-case
/// reservation costs nothing until used).
template <typename T>
class GrowingBuffer {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  void clear() { mSize = 0; }
  size_t size() const { return mSize; }
  T* data() { return mStore.get(); }
  const T* data() const { return mStore.get(); }
  /// Room for `capacity` values in all, keeping the current ones.
  void reserve(size_t capacity) {
    if (capacity <= mCapacity) return;
    std::unique_ptr<T[]> store(new T[capacity]);  // default-initialised: not written
    if (mSize > 0) std::memcpy(store.get(), mStore.get(), mSize * sizeof(T));
    mStore = std::move(store);
    mCapacity = capacity;
  }
  /// Makes room for `count` more values after the current ones and returns where they go (not initialised).
  T* extend(size_t count) {
    if (mSize + count > mCapacity) reserve(std::max(mSize + count, mCapacity * 3 / 2));
    T* out = mStore.get() + mSize;
    mSize += count;
    return out;
  }
  void push(T value) { *extend(1) = value; }

 private:
  std::unique_ptr<T[]> mStore;
  size_t mSize = 0, mCapacity = 0;
};

/// Pixels [begin, end) of a frame (row-major index y·width + x) as runs: runs holds pairs (empty pixels skipped,
/// active pixels that follow), in order; pixels the active ones' premultiplied RGBA, 4 floats each. What the runs do
/// not cover up to `end` is empty. A pixel is empty when every channel is zero (as render::activeRect).
struct PixelRuns {
  uint32_t begin = 0, end = 0;
  GrowingBuffer<uint32_t> runs;
  GrowingBuffer<float> pixels;

  /// Empties the runs for the range [rangeBegin, rangeEnd), with room for all of its pixels active.
  void reset(uint32_t rangeBegin, uint32_t rangeEnd) {
    begin = rangeBegin, end = rangeEnd;
    runs.clear();
    pixels.clear();
    runs.reserve((size_t(end - begin) / 2 + 1) * 2);
    pixels.reserve(size_t(end - begin) * 4);
  }
  size_t runCount() const { return runs.size() / 2; }
  size_t activePixels() const { return pixels.size() / 4; }
};

/// A dense premultiplied partial frame whose pixels outside a footprint are known to be empty (the renderer leaves
/// them so): they are taken as empty, so that a rank whose part covers a corner of the frame scans that corner only.
/// The rows above and below the footprint are never read, nor the pixels left and right of a footprint narrower
/// than two fifths of the frame; a wider one is read as whole rows (streaming past its sides is cheaper than a jump
/// on every row). Made from a frame alone, the footprint is the whole frame.
struct DenseFrame {
  const image::ImageF* frame = nullptr;
  render::PixelRect footprint;  ///< what is read: the footprint given, clipped to the frame, widened as above

  DenseFrame(const image::ImageF& whole)  // NOLINT(google-explicit-constructor): a frame is a dense frame
      : frame(&whole), footprint{0, 0, whole.width, whole.height} {}
  DenseFrame(const image::ImageF& partial, const render::PixelRect& within);
  /// The footprint's pixels among [begin, end) (what reading that range of the frame reads).
  uint64_t pixelsWithin(uint32_t begin, uint32_t end) const;
};

/// `out` = pixels [begin, end) of `frame` (a premultiplied partial frame) as runs. Requires begin <= end <= the
/// frame's pixel count (throws std::invalid_argument otherwise).
void encodeRuns(const DenseFrame& frame, uint32_t begin, uint32_t end, PixelRuns& out);

/// A message carrying pixels [begin, end) as runs, little-endian (the ranks run the same build on the same kind of
/// machine):
///
///     offset          size            field
///          0             4            begin        first pixel of the range (row-major index)
///          4             4            end          one past the last pixel
///          8             4            runCount     number of run pairs
///         12             4            activeCount  number of active pixels (the sum of the runs' active counts)
///         16             activeCount·4·c           the active pixels' RGBA, c = 2 (Half) or 4 (Float) bytes each
///         16 + that      8·runCount                the runs: pairs {uint32 empty skipped, uint32 active following}
///
/// The total is 16 + activeCount·4·c + 8·runCount bytes; the pixels come first so that a range is packed in one
/// pass (its runs are known only at its end), and the runs stay 8-byte aligned.
constexpr size_t kRunsHeaderBytes = 16;

/// The bytes of a message holding `runCount` runs and `activePixels` pixels.
size_t runsMessageBytes(size_t runCount, size_t activePixels, PixelEncoding encoding);

/// Writes into `out` (cleared first) the message for pixels [begin, end) of `in`, a sub-range of in's range (throws
/// std::invalid_argument otherwise).
void packRuns(const PixelRuns& in, uint32_t begin, uint32_t end, PixelEncoding encoding, GrowingBuffer<uint8_t>& out,
              Kernels kernels = Kernels::Best);
/// The same from a dense premultiplied frame (its empty pixels found while packing); [begin, end) within the frame.
void packRuns(const DenseFrame& frame, uint32_t begin, uint32_t end, PixelEncoding encoding,
              GrowingBuffer<uint8_t>& out, Kernels kernels = Kernels::Best);

/// A received message checked: its range must be [begin, end) and its runs must fit the range and the bytes.
/// Throws std::runtime_error saying what is wrong (the caller names the peer).
void checkRunsMessage(std::span<const uint8_t> message, uint32_t begin, uint32_t end, PixelEncoding encoding);

/// `out` = the message's pixels as runs (checkRunsMessage first).
void unpackRuns(std::span<const uint8_t> message, PixelEncoding encoding, PixelRuns& out,
                Kernels kernels = Kernels::Best);

/// `out` = pixels [begin, end) of `in`, a sub-range of in's range (throws std::invalid_argument otherwise).
void sliceRuns(const PixelRuns& in, uint32_t begin, uint32_t end, PixelRuns& out);

/// `out` = front over back (render::compositeOver's operator, c = c_f + (1 − a_f)·c_b per channel), touching only
/// pixels active in either: where one is empty the other is copied. Both cover the same range (throws
/// std::invalid_argument otherwise); `out` must be neither of them.
void overRuns(const PixelRuns& front, const PixelRuns& back, PixelRuns& out, Kernels kernels = Kernels::Best);

/// A received message (packRuns) to read in place: its pixels are converted as they are blended.
struct PixelMessage {
  std::span<const uint8_t> bytes;
  PixelEncoding encoding;
};
/// Pixels to read: runs, a dense premultiplied frame, or a message.
using PixelSource = std::variant<const PixelRuns*, DenseFrame, PixelMessage>;
/// `out` = pixels [begin, end) of front over the same pixels of back, as above; each side must hold the range (runs
/// whose range contains it, a frame that does, or a message for exactly that range: checkRunsMessage's errors),
/// else std::invalid_argument. Nothing is copied to take the range or to read a message.
void overRuns(PixelSource front, PixelSource back, uint32_t begin, uint32_t end, PixelRuns& out,
              Kernels kernels = Kernels::Best);

/// Writes the runs' active pixels into `frame` (whose other pixels are left alone) at their places.
void scatterRuns(const PixelRuns& in, image::ImageF& frame);

/// The finished 8-bit pixels of the range, 4 bytes each from `out` on: each pixel through view.output (over the
/// background, or straight colour and alpha) and rounded as image::toImage8, so that a frame finished range by range
/// equals toImage8(render::finishPartial(frame, scene)).
void finishRuns(const PixelRuns& in, const render::SceneView& view, uint8_t* out, Kernels kernels = Kernels::Best);
/// The same for pixels [begin, end) of a dense premultiplied frame.
void finishRuns(const DenseFrame& frame, uint32_t begin, uint32_t end, const render::SceneView& view, uint8_t* out,
                Kernels kernels = Kernels::Best);

}  // namespace voxbrick::distributed
