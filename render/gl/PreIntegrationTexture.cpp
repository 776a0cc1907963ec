// Building and uploading the pre-integration table when the transfer function or the segment lengths change.
#include "render/gl/PreIntegrationTexture.h"

#include <chrono>

namespace voxbrick::render {
namespace {

bool samePoints(const std::vector<TransferFunction::Point>& a, const std::vector<TransferFunction::Point>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].x != b[i].x || a[i].rgba != b[i].rgba) return false;
  return true;
}

}  // namespace

double PreIntegrationTexture::update(const TransferFunction& tf, double ratioMin, double ratioMax, int unit) {
  mTexture.bind(unit);
  if (mBuilt && mSpec.ratioMin == ratioMin && mSpec.ratioMax == ratioMax && mReferenceLength == tf.referenceLength() &&
      samePoints(mPoints, tf.points()))
    return 0;
  const auto start = std::chrono::steady_clock::now();
  PreIntegrationSpec spec;
  spec.resolution = kResolution;
  spec.ratioMin = ratioMin;
  spec.ratioMax = ratioMax;
  spec.layers = PreIntegrationSpec::layersFor(ratioMin, ratioMax, kMaxLayerError);
  const std::vector<glm::vec4> texels = buildPreIntegrationTable(tf, spec);
  // Storage is immutable: a new texture whenever the layer count changes.
  if (!mBuilt || spec.layers != mSpec.layers) {
    mTexture = Texture(mGl, GL_TEXTURE_3D);
    mTexture.bind(unit);
    mGl.glTexStorage3D(GL_TEXTURE_3D, 1, GL_RGBA32F, spec.resolution, spec.resolution, spec.layers);
    for (GLenum filter : {GL_TEXTURE_MIN_FILTER, GL_TEXTURE_MAG_FILTER})
      mGl.glTexParameteri(GL_TEXTURE_3D, filter, GL_LINEAR);
    for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
      mGl.glTexParameteri(GL_TEXTURE_3D, wrap, GL_CLAMP_TO_EDGE);
  }
  mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, spec.resolution, spec.resolution, spec.layers, GL_RGBA, GL_FLOAT,
                      texels.data());
  checkGlError(mGl, "PreIntegrationTexture::update");
  mSpec = spec;
  mPoints = tf.points();
  mReferenceLength = tf.referenceLength();
  mBuilt = true;
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace voxbrick::render
