// The source that quantises prep's input slice by slice.
#include "brickstore/prep/QuantisingSource.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <string>

namespace voxbrick::store {

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
