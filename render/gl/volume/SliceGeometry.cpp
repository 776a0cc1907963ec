// The slicers' vertex layouts, queues and draws.
#include "render/gl/volume/SliceGeometry.h"

#include <algorithm>
#include <string>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

/// Attribute `location` of the bound vertex array: `n` values of `type` (GL_FLOAT, or GL_INT read as integers) at
/// byte `at` of each `stride`-byte element of the bound GL_ARRAY_BUFFER, one element per instance when `perInstance`.
void attribute(const Gl& gl, int location, int n, GLenum type, GLsizei stride, size_t at, bool perInstance) {
  const auto index = GLuint(location);
  gl.glEnableVertexAttribArray(index);
  if (type == GL_FLOAT)
    gl.glVertexAttribPointer(index, n, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(at));
  else
    gl.glVertexAttribIPointer(index, n, type, stride, reinterpret_cast<void*>(at));
  gl.glVertexAttribDivisor(index, perInstance ? 1 : 0);
}

}  // namespace

SliceGeometry::SliceGeometry(const Gl& gl) : mGl(gl), mBuffer(gl), mLayout(gl) {
  mLayout.bind();
  mBuffer.allocate(GL_ARRAY_BUFFER, 0, nullptr, GL_STREAM_DRAW);
}

void SliceGeometry::upload(const void* data, size_t bytes) {
  mLayout.bind();
  mBuffer.allocate(GL_ARRAY_BUFFER, bytes, data, GL_STREAM_DRAW);
}

SliceDraw sliceDraw(Slicer slicer) {
  switch (slicer) {
    case Slicer::Vertex:
    case Slicer::VertexLean: return {GL_TRIANGLES, kSliceVerticesPerPolygon};
    case Slicer::Geometry: return {GL_POINTS, kSlicePointVerticesPerPlane};
    case Slicer::VertexGeometry: return {GL_TRIANGLES, kSliceEvenVerticesPerPlane};
    case Slicer::Cpu: break;
  }
  throw RenderInputError(std::string("sliceDraw: the '") + slicerName(slicer) +
                         "' slicer draws no instances (CpuSliceGeometry)");
}

GpuSliceGeometry::GpuSliceGeometry(const Gl& gl, Slicer slicer) : SliceGeometry(gl), mDraw(sliceDraw(slicer)) {
  const GLsizei stride = sizeof(SliceInstance);
  attribute(gl, kSliceBoxMinLocation, 3, GL_FLOAT, stride, offsetof(SliceInstance, boxMin), true);
  attribute(gl, kSliceBoxMaxLocation, 3, GL_FLOAT, stride, offsetof(SliceInstance, boxMax), true);
  attribute(gl, kSlicePlaneDistanceLocation, 1, GL_FLOAT, stride, offsetof(SliceInstance, planeDistance), true);
  attribute(gl, kSlicePayloadLocation, 4, GL_INT, stride, offsetof(SliceInstance, payload), true);
  attribute(gl, kSliceFirstPlaneLocation, 1, GL_INT, stride, offsetof(SliceInstance, firstPlane), true);
  attribute(gl, kSliceOwnLoLocation, 3, GL_INT, stride, offsetof(SliceInstance, ownLo), true);
  attribute(gl, kSliceOwnHiLocation, 3, GL_INT, stride, offsetof(SliceInstance, ownHi), true);
}

PlaneIndexRange GpuSliceGeometry::planes(const Box& box, const FramePlan& plan) const {
  return slicerPlaneRange(box.min, box.max, plan.planeNormal, plan.step);
}

void GpuSliceGeometry::add(const Box& box, const PlaneIndexRange& planes, const glm::ivec4& payload,
                           const glm::ivec3& ownLo, const glm::ivec3& ownHi, const FramePlan&) {
  mInstances.push_back({glm::vec3(box.min), glm::vec3(box.max), 0.0f, payload, int32_t(planes.begin), ownLo, ownHi});
  mMaxPlanes = std::max(mMaxPlanes, planes.count());
}

void GpuSliceGeometry::draw() {
  if (mInstances.empty()) return;
  upload(mInstances.data(), mInstances.size() * sizeof(SliceInstance));
  mGl.glDrawArraysInstanced(mDraw.primitive, 0, GLsizei(mDraw.verticesPerPlane * mMaxPlanes),
                            GLsizei(mInstances.size()));
  mInstances.clear();
  mMaxPlanes = 0;
}

CpuSliceGeometry::CpuSliceGeometry(const Gl& gl) : SliceGeometry(gl) {
  const GLsizei stride = sizeof(SliceVertex);
  attribute(gl, kSliceVertexWorldLocation, 3, GL_FLOAT, stride, offsetof(SliceVertex, world), false);
  attribute(gl, kSliceVertexPayloadLocation, 4, GL_INT, stride, offsetof(SliceVertex, payload), false);
  attribute(gl, kSliceVertexPlaneLocation, 1, GL_INT, stride, offsetof(SliceVertex, plane), false);
  attribute(gl, kSliceVertexOwnLoLocation, 3, GL_INT, stride, offsetof(SliceVertex, ownLo), false);
  attribute(gl, kSliceVertexOwnHiLocation, 3, GL_INT, stride, offsetof(SliceVertex, ownHi), false);
}

PlaneIndexRange CpuSliceGeometry::planes(const Box& box, const FramePlan& plan) const {
  return planeIndexRange(box.min, box.max, plan.planeNormal, plan.step);
}

void CpuSliceGeometry::add(const Box& box, const PlaneIndexRange& planes, const glm::ivec4& payload,
                           const glm::ivec3& ownLo, const glm::ivec3& ownHi, const FramePlan& plan) {
  for (int64_t k = planes.begin; k < planes.end; ++k) {
    const auto polygon = rezkSalamaPolygon(box.min, box.max, plan.planeNormal, double(k) * plan.step);
    for (int corner : kSliceFan) {
      SliceVertex v{};
      for (int a = 0; a < 3; ++a) {
        v.world[a] = float(polygon[size_t(corner)][a]);
        v.ownLo[a] = ownLo[a], v.ownHi[a] = ownHi[a];
      }
      for (int a = 0; a < 4; ++a) v.payload[a] = payload[a];
      v.plane = int32_t(k);
      mVertices.push_back(v);
    }
  }
}

void CpuSliceGeometry::draw() {
  if (mVertices.empty()) return;
  upload(mVertices.data(), mVertices.size() * sizeof(SliceVertex));
  mGl.glDrawArrays(GL_TRIANGLES, 0, GLsizei(mVertices.size()));
  mVertices.clear();
}

SlabGeometry::SlabGeometry(const Gl& gl) : SliceGeometry(gl) {
  const GLsizei stride = sizeof(SlabInstance);
  attribute(gl, kSliceBoxMinLocation, 3, GL_FLOAT, stride, offsetof(SlabInstance, boxMin), true);
  attribute(gl, kSliceBoxMaxLocation, 3, GL_FLOAT, stride, offsetof(SlabInstance, boxMax), true);
  attribute(gl, kSlicePayloadLocation, 4, GL_INT, stride, offsetof(SlabInstance, payload), true);
  attribute(gl, kSliceFirstPlaneLocation, 1, GL_INT, stride, offsetof(SlabInstance, firstPlane), true);
  attribute(gl, kSliceOwnLoLocation, 3, GL_INT, stride, offsetof(SlabInstance, ownLo), true);
  attribute(gl, kSliceOwnHiLocation, 3, GL_INT, stride, offsetof(SlabInstance, ownHi), true);
  attribute(gl, kSlabPlaneCountLocation, 1, GL_INT, stride, offsetof(SlabInstance, planeCount), true);
}

PlaneIndexRange SlabGeometry::planes(const Box& box, const FramePlan& plan) const {
  return slicerPlaneRange(box.min, box.max, plan.planeNormal, plan.step);
}

void SlabGeometry::add(const Box& box, const PlaneIndexRange& planes, const glm::ivec4& payload,
                       const glm::ivec3& ownLo, const glm::ivec3& ownHi, const FramePlan& plan) {
  const int64_t n = std::max(plan.slab, 1);
  for (int64_t first = planes.begin; first < planes.end; first += n)
    mInstances.push_back({glm::vec3(box.min), glm::vec3(box.max), payload, int32_t(first), ownLo, ownHi,
                          int32_t(std::min(n, planes.end - first))});
}

void SlabGeometry::draw() {
  drawKeep();
  mInstances.clear();
  mUploaded = false;
}

void SlabGeometry::drawKeep() {
  if (mInstances.empty()) return;
  if (!mUploaded) upload(mInstances.data(), mInstances.size() * sizeof(SlabInstance));
  mUploaded = true;
  mLayout.bind();
  // Back faces only: each pixel whose ray crosses the box gets one fragment per slab. Depth clamping keeps back
  // faces beyond the far plane: boxes are drawn larger than the volume, whose far side the far plane touches.
  mGl.glEnable(GL_CULL_FACE);
  mGl.glCullFace(GL_FRONT);
  mGl.glEnable(GL_DEPTH_CLAMP);
  mGl.glEnable(GL_CLIP_DISTANCE0);
  mGl.glDrawArraysInstanced(GL_TRIANGLES, 0, kSlabVerticesPerBox, GLsizei(mInstances.size()));
  mGl.glDisable(GL_CLIP_DISTANCE0);
  mGl.glDisable(GL_DEPTH_CLAMP);
  mGl.glDisable(GL_CULL_FACE);
}

}  // namespace voxbrick::render
