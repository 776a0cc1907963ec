// The streaming source shared by the raw, NRRD and NIfTI readers: a dense volume read from a ByteStream.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "brickstore/format/Convert.h"
#include "brickstore/source/ByteStream.h"
#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// A dense volume streamed from a ByteStream, converted to the store type in bounded chunks.
class DenseSource final : public VolumeSource {
 public:
  /// `info.type` must equal conversion.to(); `file` names the data in error messages.
  DenseSource(VolumeInfo info, std::unique_ptr<ByteStream> stream, Conversion conversion, std::string file);

  const VolumeInfo& info() const override { return mInfo; }
  void readSlices(int64_t count, void* dst) override;
  std::unique_ptr<VolumeSource> reopen() const override { return mReopen ? mReopen() : nullptr; }
  /// How reopen() opens the data again (left unset for compressed data).
  void setReopen(std::function<std::unique_ptr<VolumeSource>()> reopen) { mReopen = std::move(reopen); }

 private:
  std::function<std::unique_ptr<VolumeSource>()> mReopen;
  VolumeInfo mInfo;
  std::unique_ptr<ByteStream> mStream;
  Conversion mConversion;
  std::string mFile;
  int64_t mNextZ = 0;
  std::vector<unsigned char> mBuffer;
};

}  // namespace voxbrick::store
