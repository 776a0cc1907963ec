// The two slicers' vertex layouts, queues and draws.
#include "render/SliceGeometry.h"

#include <algorithm>

namespace voxbrick::render {
namespace {

void* offset(size_t bytes) { return reinterpret_cast<void*>(bytes); }

}  // namespace

VertexSliceGeometry::VertexSliceGeometry(const Gl& gl) : mGl(gl), mBuffer(gl), mLayout(gl) {
  mLayout.bind();
  mBuffer.allocate(GL_ARRAY_BUFFER, 0, nullptr, GL_STREAM_DRAW);
  const GLsizei stride = sizeof(SliceInstance);
  auto floats = [&](int location, int n, size_t at) {
    mGl.glEnableVertexAttribArray(GLuint(location));
    mGl.glVertexAttribPointer(GLuint(location), n, GL_FLOAT, GL_FALSE, stride, offset(at));
    mGl.glVertexAttribDivisor(GLuint(location), 1);
  };
  auto ints = [&](int location, int n, size_t at) {
    mGl.glEnableVertexAttribArray(GLuint(location));
    mGl.glVertexAttribIPointer(GLuint(location), n, GL_INT, stride, offset(at));
    mGl.glVertexAttribDivisor(GLuint(location), 1);
  };
  floats(kSliceBoxMinLocation, 3, offsetof(SliceInstance, boxMin));
  floats(kSliceBoxMaxLocation, 3, offsetof(SliceInstance, boxMax));
  floats(kSlicePlaneDistanceLocation, 1, offsetof(SliceInstance, planeDistance));
  ints(kSlicePayloadLocation, 4, offsetof(SliceInstance, payload));
  ints(kSliceFirstPlaneLocation, 1, offsetof(SliceInstance, firstPlane));
  ints(kSliceOwnLoLocation, 3, offsetof(SliceInstance, ownLo));
  ints(kSliceOwnHiLocation, 3, offsetof(SliceInstance, ownHi));
}

PlaneIndexRange VertexSliceGeometry::planes(const Box& box, const FramePlan& plan) const {
  return slicerPlaneRange(box.min, box.max, plan.planeNormal, plan.step);
}

void VertexSliceGeometry::add(const Box& box, const PlaneIndexRange& planes, const glm::ivec4& payload,
                              const glm::ivec3& ownLo, const glm::ivec3& ownHi, const FramePlan&) {
  mInstances.push_back({glm::vec3(box.min), glm::vec3(box.max), 0.0f, payload, int32_t(planes.begin), ownLo, ownHi});
  mMaxPlanes = std::max(mMaxPlanes, planes.count());
}

void VertexSliceGeometry::draw() {
  if (mInstances.empty()) return;
  mLayout.bind();
  mBuffer.allocate(GL_ARRAY_BUFFER, mInstances.size() * sizeof(SliceInstance), mInstances.data(), GL_STREAM_DRAW);
  mGl.glDrawArraysInstanced(GL_TRIANGLES, 0, GLsizei(kSliceVerticesPerPolygon * mMaxPlanes),
                            GLsizei(mInstances.size()));
  mInstances.clear();
  mMaxPlanes = 0;
}

CpuSliceGeometry::CpuSliceGeometry(const Gl& gl) : mGl(gl), mBuffer(gl), mLayout(gl) {
  mLayout.bind();
  mBuffer.allocate(GL_ARRAY_BUFFER, 0, nullptr, GL_STREAM_DRAW);
  const GLsizei stride = sizeof(SliceVertex);
  mGl.glEnableVertexAttribArray(kSliceVertexWorldLocation);
  mGl.glVertexAttribPointer(kSliceVertexWorldLocation, 3, GL_FLOAT, GL_FALSE, stride,
                            offset(offsetof(SliceVertex, world)));
  auto ints = [&](int location, int n, size_t at) {
    mGl.glEnableVertexAttribArray(GLuint(location));
    mGl.glVertexAttribIPointer(GLuint(location), n, GL_INT, stride, offset(at));
  };
  ints(kSliceVertexPayloadLocation, 4, offsetof(SliceVertex, payload));
  ints(kSliceVertexPlaneLocation, 1, offsetof(SliceVertex, plane));
  ints(kSliceVertexOwnLoLocation, 3, offsetof(SliceVertex, ownLo));
  ints(kSliceVertexOwnHiLocation, 3, offsetof(SliceVertex, ownHi));
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
  mLayout.bind();
  mBuffer.allocate(GL_ARRAY_BUFFER, mVertices.size() * sizeof(SliceVertex), mVertices.data(), GL_STREAM_DRAW);
  mGl.glDrawArrays(GL_TRIANGLES, 0, GLsizei(mVertices.size()));
  mVertices.clear();
}

}  // namespace voxbrick::render
