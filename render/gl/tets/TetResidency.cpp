// The tets on the GPU: the frame's working set and the budget it is held in.
#include "render/gl/tets/TetResidency.h"

#include <algorithm>
#include <string>

#include "render/core/RenderErrors.h"
#include "render/gl/PreIntegrationTexture.h"

namespace voxbrick::render {

size_t TetResidency::tableBytes() {
  return size_t(PreIntegrationTexture::kResolution) * PreIntegrationTexture::kResolution * 64 * 16;
}

size_t TetResidency::bytesFor(size_t tets) { return tets * (kBytesPerTet + 4) + tableBytes(); }

size_t TetResidency::minimumBytes() { return kMinBatchTets * (kBytesPerTet + 4) + tableBytes(); }

TetResidency::TetResidency(const Gl& gl, std::shared_ptr<const TetMeshSource> source, size_t gpuBudgetBytes)
    : mGl(gl), mSource(std::move(source)), mGpuBudget(gpuBudgetBytes) {
  if (gpuBudgetBytes < minimumBytes())
    throw RenderInputError("tet mesh: a GPU budget of " + std::to_string(gpuBudgetBytes) +
                           " bytes holds no batch of tets (the pre-integration table and " +
                           std::to_string(kMinBatchTets) + " tets take " + std::to_string(minimumBytes()) + ")");
}

TetResidency::~TetResidency() = default;

bool TetResidency::hold(std::shared_ptr<const TetMeshData> data) {
  const bool fresh = data->id != mUploaded;
  mData = std::move(data);
  if (!fresh) return false;
  mRayCaster.reset();
  mUploaded = 0;
  const size_t tets = mData->mesh.tets.size();
  // Resident: every tet uploaded once. Streamed: batches of tets in visibility order, as many as the budget holds.
  mStreamed = bytesFor(tets) > mGpuBudget;
  mBatchTets = mStreamed ? std::max(kMinBatchTets, (mGpuBudget - tableBytes()) / (kBytesPerTet + 4)) : tets;
  return true;
}

void TetResidency::release() {
  if (mSource->paged()) mData.reset();
}

size_t TetResidency::gpuBytes() const {
  return mBatchTets * (kBytesPerTet + 4) + tableBytes() + (mRayCaster ? mRayCaster->gpuBytes() : 0);
}

TetRayCaster* TetResidency::rayCaster() {
  if (mStreamed) return nullptr;
  if (!mRayCaster) {
    const size_t tets = mData->mesh.tets.size();
    if (tets > TetRayCaster::kMaxTets ||
        gpuBytes() + TetRayCaster::bytesFor(tets, mData->topology.boundary.size()) > mGpuBudget)
      return nullptr;
    mRayCaster = std::make_unique<TetRayCaster>(mGl, *mData);
  }
  return mRayCaster.get();
}

}  // namespace voxbrick::render
