// The geometry stage: boxes and runs of global planes in, slice polygons (or slab proxies) on the GPU out, behind one
// interface with one implementation per kind of input (the slicers in GL programs: the vertex program of Rezk-Salama &
// Kolb and Zellmann & Lang's variants; the CPU mirror; slabs). Each owns its vertex array, whose layout is set once,
// next to the struct it describes (render/volume/SliceTables.h).
#pragma once

#include <memory>
#include <vector>

#include "render/gl/GlObjects.h"
#include "render/volume/FramePlan.h"
#include "render/volume/SliceTables.h"
#include "render/volume/Slicing.h"

namespace voxbrick::render {

class SliceGeometry {
 public:
  virtual ~SliceGeometry() = default;
  SliceGeometry(const SliceGeometry&) = delete;
  SliceGeometry& operator=(const SliceGeometry&) = delete;
  /// The global plane indices to submit for drawn box `box` under `plan`.
  virtual PlaneIndexRange planes(const Box& box, const FramePlan& plan) const = 0;
  /// Queues the polygons of `planes` through `box`; `payload` and the owned voxels [ownLo, ownHi) go to the fragment
  /// stage unchanged.
  virtual void add(const Box& box, const PlaneIndexRange& planes, const glm::ivec4& payload, const glm::ivec3& ownLo,
                   const glm::ivec3& ownHi, const FramePlan& plan) = 0;
  /// True when nothing is queued.
  virtual bool empty() const = 0;
  /// Draws what is queued with the program in use, then empties the queue.
  virtual void draw() = 0;
  /// Empties the queue without drawing (a frame given up part way).
  virtual void clear() = 0;

 protected:
  /// Makes the buffer and the vertex array (bound, for the subclass to describe its layout).
  explicit SliceGeometry(const Gl& gl);
  /// Binds the vertex array and replaces the buffer's contents with `bytes` bytes of `data`.
  void upload(const void* data, size_t bytes);

  const Gl& mGl;
  Buffer mBuffer;
  VertexArray mLayout;
};

/// How a slicer in GL programs draws: the primitive, and the vertices per plane of an instance.
struct SliceDraw {
  GLenum primitive = GL_TRIANGLES;
  int verticesPerPlane = kSliceVerticesPerPolygon;
};
/// The draw of `slicer` (see GpuSliceGeometry); throws RenderInputError for Slicer::Cpu.
SliceDraw sliceDraw(Slicer slicer);

/// The slicers in GL programs: one SliceInstance per box, and per plane the vertices the slicer's program expects:
/// 12 as triangles for the vertex programs (Slicer::Vertex: slice.vert.glsl; Slicer::VertexLean:
/// slice_lean.vert.glsl), one point for the geometry program (Slicer::Geometry: slice.geom.glsl), the triangle
/// P0, P2, P4 for the vertex-geometry pair (Slicer::VertexGeometry: slice_odd.geom.glsl). The programs decide plane
/// membership in float, so each box is given one extra plane each side (slicerPlaneRange).
class GpuSliceGeometry final : public SliceGeometry {
 public:
  /// Throws RenderInputError for Slicer::Cpu (CpuSliceGeometry).
  GpuSliceGeometry(const Gl& gl, Slicer slicer);
  PlaneIndexRange planes(const Box& box, const FramePlan& plan) const override;
  void add(const Box& box, const PlaneIndexRange& planes, const glm::ivec4& payload, const glm::ivec3& ownLo,
           const glm::ivec3& ownHi, const FramePlan& plan) override;
  bool empty() const override { return mInstances.empty(); }
  void draw() override;
  void clear() override { mInstances.clear(); }

 private:
  std::vector<SliceInstance> mInstances;
  int64_t mMaxPlanes = 0;
  SliceDraw mDraw;
};

/// The CPU mirror: polygons from rezkSalamaPolygon over the exact plane range, drawn as triangles
/// (slice_cpu.vert.glsl).
class CpuSliceGeometry final : public SliceGeometry {
 public:
  explicit CpuSliceGeometry(const Gl& gl);
  PlaneIndexRange planes(const Box& box, const FramePlan& plan) const override;
  void add(const Box& box, const PlaneIndexRange& planes, const glm::ivec4& payload, const glm::ivec3& ownLo,
           const glm::ivec3& ownHi, const FramePlan& plan) override;
  bool empty() const override { return mVertices.empty(); }
  void draw() override;
  void clear() override { mVertices.clear(); }

 private:
  std::vector<SliceVertex> mVertices;
};

/// Texture slabs: each box is drawn once per slab of plan.slab consecutive planes, as its back faces (slab.vert.glsl),
/// and the fragment program marches the slab's planes along its pixel's ray. The plane range is widened by one
/// plane each side, as for the vertex slicer: the ownership test on the ray's points decides.
class SlabGeometry final : public SliceGeometry {
 public:
  explicit SlabGeometry(const Gl& gl);
  PlaneIndexRange planes(const Box& box, const FramePlan& plan) const override;
  void add(const Box& box, const PlaneIndexRange& planes, const glm::ivec4& payload, const glm::ivec3& ownLo,
           const glm::ivec3& ownHi, const FramePlan& plan) override;
  bool empty() const override { return mInstances.empty(); }
  void draw() override;
  void clear() override {
    mInstances.clear();
    mUploaded = false;
  }
  /// Draws what is queued and keeps it queued (uploaded once), for a second pass over the same slab.
  void drawKeep();

 private:
  std::vector<SlabInstance> mInstances;
  bool mUploaded = false;  // mInstances are in the buffer
};

}  // namespace voxbrick::render
