// The dense streaming source of the raw, NRRD and NIfTI readers: file values converted in bounded chunks.
#include "brickstore/ingest/raw/DenseSource.h"

#include <algorithm>
#include <utility>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

// Conversion works through a bounded staging buffer so that memory does not grow with the slices asked for.
constexpr size_t kStagingBytes = size_t(1) << 20;

}  // namespace

DenseSource::DenseSource(VolumeInfo info, std::unique_ptr<ByteStream> stream, Conversion conversion, std::string file)
    : mInfo(std::move(info)), mStream(std::move(stream)), mConversion(conversion), mFile(std::move(file)) {
  if (mInfo.type != mConversion.to()) {
    throw StoreError(mFile + ": internal error: source type " + std::string(valueTypeName(mInfo.type)) +
                     " does not match the conversion's " + std::string(valueTypeName(mConversion.to())));
  }
}

void DenseSource::readSlices(int64_t count, void* dst) {
  if (count < 0) throw InputError(mFile + ": negative slice count " + std::to_string(count));
  if (count > mInfo.dims.z - mNextZ) {
    throw InputError(mFile + ": read past the end of the volume: asked for z-slices " + std::to_string(mNextZ) + ".." +
                     std::to_string(mNextZ + count - 1) + " but dims.z is " + std::to_string(mInfo.dims.z));
  }
  const size_t values = static_cast<size_t>(count * mInfo.dims.x * mInfo.dims.y);
  const size_t inSize = fileValueSize(mConversion.from);
  const size_t outSize = valueSize(mInfo.type);
  auto* out = static_cast<unsigned char*>(dst);
  // A short read reports what the whole rest of the volume lacks, not just this chunk.
  auto readOrThrow = [&](void* into, size_t bytes, size_t doneBytes) {
    size_t got = mStream->readUpTo(into, bytes);
    if (got == bytes) return;
    const int64_t remaining = (mInfo.dims.z - mNextZ) * mInfo.dims.x * mInfo.dims.y * static_cast<int64_t>(inSize);
    throw InputError(mFile + ": truncated: expected " + std::to_string(remaining) + " more bytes of voxel data, got " +
                     std::to_string(doneBytes + got));
  };
  if (mConversion.isIdentity()) {
    readOrThrow(out, values * inSize, 0);
  } else {
    const size_t chunk = std::max<size_t>(1, kStagingBytes / inSize);
    mBuffer.resize(std::min(values, chunk) * inSize);
    for (size_t done = 0; done < values;) {
      size_t n = std::min(values - done, chunk);
      readOrThrow(mBuffer.data(), n * inSize, done * inSize);
      mConversion.apply(mBuffer.data(), out + done * outSize, n);
      done += n;
    }
  }
  mNextZ += count;
  if (mNextZ == mInfo.dims.z) mStream->verifyEnd();
}

}  // namespace voxbrick::store
