// Quantisation of prep's input: the linear map, its option parsing, and the source that applies it slice by slice.
#include "brickstore/Quantise.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>

#include "brickstore/Errors.h"

namespace voxbrick::store {

double Quantisation::quantise(double v) const { return std::clamp(std::floor(toSteps(v) + 0.5), 0.0, steps()); }

void Quantisation::validate() const {
  if (type != ValueType::U8 && type != ValueType::U16)
    throw InputError("--quantise: type " + std::string(valueTypeName(type)) + " is not u8 or u16");
  if (!std::isfinite(lo) || !std::isfinite(hi))
    throw InputError("--quantise-range " + std::to_string(lo) + "," + std::to_string(hi) + ": not finite");
  if (!(lo < hi))
    throw InputError("--quantise-range " + std::to_string(lo) + "," + std::to_string(hi) + ": lo must be below hi");
}

ValueType parseQuantiseType(const std::string& text) {
  if (text == "u8") return ValueType::U8;
  if (text == "u16") return ValueType::U16;
  throw InputError("--quantise '" + text + "': expected u8 or u16");
}

void parseQuantiseRange(const std::string& text, Quantisation& q) {
  const size_t comma = text.find(',');
  double values[2] = {0, 0};
  bool ok = comma != std::string::npos;
  for (int i = 0; ok && i < 2; ++i) {
    const char* first = text.data() + (i == 0 ? 0 : comma + 1);
    const char* last = text.data() + (i == 0 ? comma : text.size());
    auto [end, ec] = std::from_chars(first, last, values[i]);
    ok = ec == std::errc() && end == last && first != last;
  }
  if (!ok) throw InputError("--quantise-range '" + text + "': expected two numbers lo,hi");
  if (!std::isfinite(values[0]) || !std::isfinite(values[1]))
    throw InputError("--quantise-range '" + text + "': lo and hi must be finite");
  if (!(values[0] < values[1])) throw InputError("--quantise-range '" + text + "': lo must be below hi");
  q.lo = values[0];
  q.hi = values[1];
}

QuantisingSource::QuantisingSource(VolumeSource& inner, const Quantisation& q, double background,
                                   NonFinitePolicy policy)
    : mInner(inner), mQ(q), mInfo(inner.info()), mStats(inner.info(), background, policy) {
  mQ.validate();
  mInfo.type = q.type;
  mInfo.background = mQ.quantise(background);
  mInfo.description = inner.info().description + ", quantised to " + std::string(valueTypeName(q.type));
  mStaging.resize(static_cast<size_t>(mInfo.dims.x * mInfo.dims.y) * valueSize(inner.info().type));
}

void QuantisingSource::readSlices(int64_t count, void* dst) {
  const int64_t sliceValues = mInfo.dims.x * mInfo.dims.y;
  for (int64_t s = 0; s < count; ++s, ++mNextZ) {
    mInner.readSlices(1, mStaging.data());
    mStats.observe(mNextZ, 1, mStaging.data());
    dispatchType(mInner.info().type, [&](auto inTag) {
      using In = decltype(inTag);
      const In* in = reinterpret_cast<const In*>(mStaging.data());
      dispatchType(mQ.type, [&](auto outTag) {
        using Out = decltype(outTag);
        Out* out = static_cast<Out*>(dst) + s * sliceValues;
        const Quantisation q = mQ;  // a local, so that stores through `out` cannot alias it
        mClamped += tbb::parallel_reduce(
            tbb::blocked_range<int64_t>(0, sliceValues, 4096), int64_t{0},
            [&](const tbb::blocked_range<int64_t>& r, int64_t clamped) {
              for (int64_t n = r.begin(); n != r.end(); ++n) {
                const double v = double(in[n]);
                clamped += v < q.lo || v > q.hi;
                out[n] = static_cast<Out>(q.quantise(v));
              }
              return clamped;
            },
            [](int64_t a, int64_t b) { return a + b; });
      });
    });
  }
}

}  // namespace voxbrick::store
