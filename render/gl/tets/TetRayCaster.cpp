// The adjacency ray caster: the tets as the ray walks them, the boundary faces, and a frame's entry and ray passes.
#include "render/gl/tets/TetRayCaster.h"

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "render/core/RenderErrors.h"
#include "render/gl/Bindings.h"
#include "render/gl/Checkpoints.h"

namespace voxbrick::render {
namespace {

constexpr size_t kBytesPerBoundaryFace = 3 * sizeof(glm::vec4) + sizeof(uint32_t);

/// A tet and one of its faces as the shaders read them: tet * 8 + 4 if its stored order is negatively oriented + the
/// face (in the stored order).
int32_t code(uint32_t tet, uint8_t reversed, uint8_t face) { return int32_t(tet * 8 + reversed * 4u + face); }

/// Whether tet `t` of `m` is negatively oriented (validation orients every tet positively; this does not rely on it).
bool negative(const mesh::TetMesh& m, size_t t) {
  const mesh::Tet& tet = m.tets[t];
  const glm::dvec3 v0(m.points[tet[0]]);
  return glm::dot(glm::cross(glm::dvec3(m.points[tet[1]]) - v0, glm::dvec3(m.points[tet[2]]) - v0),
                  glm::dvec3(m.points[tet[3]]) - v0) < 0;
}

/// Passes a frame takes at most: each pass's entries lie beyond the last pass's (the ray pass stores an exit beyond
/// the entry pass's own t), so the passes end by themselves, after as many as a ray enters the mesh; a guard.
constexpr int64_t kMaxPasses = 1024;

/// Tets one pass of a ray walks at most: far beyond any real mesh's (a ray crosses about 200 tets of a million-tet
/// ball); a guard against a cycle that round-off might make.
constexpr int kMaxSteps = 1 << 16;

std::vector<std::string> rayDefines(bool shaded, bool part) {
  std::vector<std::string> defines{"TET_RAY"};
  if (shaded) defines.push_back("SHADING");
  if (part) defines.push_back("PART_CLIP");
  return defines;
}

/// The entry pass's program.
Program entryProgram(const Gl& gl) {
  return Program(
      gl, ProgramSources::fromFiles(
              "tet-entry", {{GL_VERTEX_SHADER, "tet_entry.vert.glsl"}, {GL_FRAGMENT_SHADER, "tet_entry.frag.glsl"}},
              rayDefines(false, false), "tet.glsl"));
}

/// A ray pass's program: the fragment kernel (a full-screen triangle) or the compute kernel, over the walk.
Program rayProgram(const Gl& gl, bool shaded, bool part, bool compute) {
  const std::string name =
      std::string(compute ? "tet-ray-compute" : "tet-ray") + (shaded ? "-shaded" : "") + (part ? "-part" : "");
  std::vector<std::pair<GLenum, std::string>> stages;
  std::vector<std::string> libraries{"tet.glsl", "tet_walk.glsl"};
  if (compute) {
    stages = {{GL_COMPUTE_SHADER, "tet_ray.comp.glsl"}};
    libraries.push_back("compute_tile.glsl");
  } else {
    stages = {{GL_VERTEX_SHADER, "raycast.vert.glsl"}, {GL_FRAGMENT_SHADER, "tet_ray.frag.glsl"}};
  }
  return Program(gl, ProgramSources::fromFiles(name, std::move(stages), rayDefines(shaded, part), libraries));
}

}  // namespace

void setTetUniforms(const Program& p, const TetFrameUniforms& u) {
  p.set(p.uniformLocation("uViewProj"), glm::mat4(u.viewProj));
  p.set(p.uniformLocation("uWindowLo"), float(u.windowLo));
  p.set(p.uniformLocation("uWindowScale"), float(u.windowScale));
  p.set(p.uniformLocation("uViewport"), glm::vec2(float(u.width), float(u.height)));
  p.set(p.uniformLocation("uWidth"), u.width);
  p.set(p.uniformLocation("uRayOrigin"), glm::vec3(u.rays.origin));
  p.set(p.uniformLocation("uRayOriginDx"), glm::vec3(u.rays.originDx));
  p.set(p.uniformLocation("uRayOriginDy"), glm::vec3(u.rays.originDy));
  p.set(p.uniformLocation("uRayDirection"), glm::vec3(u.rays.direction));
  p.set(p.uniformLocation("uRayDirectionDx"), glm::vec3(u.rays.directionDx));
  p.set(p.uniformLocation("uRayDirectionDy"), glm::vec3(u.rays.directionDy));
  p.set(p.uniformLocation("uInvReference"), float(1.0 / u.reference));
  p.set(p.uniformLocation("uTableResolution"), float(u.table.resolution));
  p.set(p.uniformLocation("uRatioMin"), float(u.table.ratioMin));
  p.set(p.uniformLocation("uLayerScale"), float(u.table.layerScale()));
  p.set(p.uniformLocation("uLayers"), float(u.table.layers));
  if (u.part) {
    p.set(p.uniformLocation("uPartLo"), glm::vec3(u.partLo));
    p.set(p.uniformLocation("uPartHi"), glm::vec3(u.partHi));
  }
}

size_t TetRayCaster::bytesFor(size_t tets, size_t boundaryFaces) {
  return tets * (4 * sizeof(glm::vec4) + sizeof(glm::ivec4)) + boundaryFaces * kBytesPerBoundaryFace;
}

TetRayCaster::TetRayCaster(const Gl& gl, const TetMeshData& data)
    : mGl(gl),
      mTets(data.mesh.tets.size()),
      mBoundaryFaces(data.topology.boundary.size()),
      mVertices(gl),
      mNeighbours(gl),
      mCorners(gl),
      mFaces(gl),
      mExits(gl),
      mEntryCount(gl),
      mEntryProgram(entryProgram(gl)),
      mEmpty(gl),
      mCounters(gl) {
  if (mTets > kMaxTets)
    throw RenderInputError("tet mesh: " + std::to_string(mTets) + " tets are more than the ray caster addresses (" +
                           std::to_string(kMaxTets) + "); draw it projected");
  // newIndex: where each of a tet's vertices (and so the face opposite it) went in the order the ray caster reads
  // them; reversed: 1 where that order is negatively oriented.
  std::vector<std::array<uint8_t, 4>> newIndex(mTets);
  std::vector<uint8_t> reversed(mTets);
  uploadVertices(data, newIndex, reversed);
  uploadNeighbours(data.topology, newIndex, reversed);
  uploadBoundary(data, newIndex, reversed);
  mEntryCount.allocate(GL_SHADER_STORAGE_BUFFER, sizeof(uint32_t), nullptr, GL_DYNAMIC_COPY);
  mBytes = bytesFor(mTets, mBoundaryFaces);
  // The whole frame's fragment kernels at once, as before (a failing driver says so when the mesh is opened).
  rayProgramFor(false, false, false);
  rayProgramFor(true, false, false);
  checkGlError(mGl, "TetRayCaster: uploading the mesh");
}

void TetRayCaster::uploadVertices(const TetMeshData& data, std::vector<std::array<uint8_t, 4>>& newIndex,
                                  std::vector<uint8_t>& reversed) {
  const mesh::TetMesh& m = data.mesh;
  // Each tet's vertices in the order of their indices in the mesh (tet_ray.frag.glsl computes each edge from its
  // lower vertex to its higher), positions relative to the box's centre as the projected tets have them.
  const glm::dvec3 centre = data.bounds.center();
  std::vector<glm::vec4> vertices(4 * mTets);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mTets, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      const mesh::Tet& tet = m.tets[t];
      std::array<uint8_t, 4> order{0, 1, 2, 3};
      std::sort(order.begin(), order.end(), [&](uint8_t a, uint8_t b) { return tet[a] < tet[b]; });
      int inversions = negative(m, t) ? 1 : 0;
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) inversions += order[i] > order[j] ? 1 : 0;
      reversed[t] = uint8_t(inversions & 1);
      for (uint8_t i = 0; i < 4; ++i) {
        const uint32_t point = tet[order[i]];
        vertices[4 * t + i] = glm::vec4(glm::vec3(glm::dvec3(m.points[point]) - centre), m.scalars[point]);
        newIndex[t][order[i]] = i;
      }
    }
  });
  mVertices.allocate(GL_SHADER_STORAGE_BUFFER, vertices.size() * sizeof(glm::vec4), vertices.data(), GL_STATIC_DRAW);
}

void TetRayCaster::uploadNeighbours(const mesh::Topology& topology, const std::vector<std::array<uint8_t, 4>>& newIndex,
                                    const std::vector<uint8_t>& reversed) {
  // Across each face (in the new order), the neighbour and which of its faces it is.
  std::vector<glm::ivec4> next(mTets);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, mTets, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t)
      for (int i = 0; i < 4; ++i) {
        const int32_t neighbour = topology.neighbours[t][i];
        int32_t across = -1;
        if (neighbour != mesh::Topology::kBoundary)
          for (int j = 0; j < 4; ++j)
            if (topology.neighbours[size_t(neighbour)][j] == int32_t(t))
              across = code(uint32_t(neighbour), reversed[size_t(neighbour)], newIndex[size_t(neighbour)][j]);
        next[t][newIndex[t][i]] = across;
      }
  });
  mNeighbours.allocate(GL_SHADER_STORAGE_BUFFER, next.size() * sizeof(glm::ivec4), next.data(), GL_STATIC_DRAW);
}

void TetRayCaster::uploadBoundary(const TetMeshData& data, const std::vector<std::array<uint8_t, 4>>& newIndex,
                                  const std::vector<uint8_t>& reversed) {
  const mesh::TetMesh& m = data.mesh;
  const mesh::Topology& topology = data.topology;
  const glm::dvec3 centre = data.bounds.center();
  // The boundary faces' corners counter-clockwise seen from outside (for a positively oriented tet, faces 0 and 2 are
  // k+1, k+2, k+3 so, faces 1 and 3 the other way), and each face coded (code()) in the new order.
  std::vector<glm::vec4> corners(3 * mBoundaryFaces);
  std::vector<uint32_t> faces(mBoundaryFaces);
  for (size_t f = 0; f < mBoundaryFaces; ++f) {
    const mesh::BoundaryFace& face = topology.boundary[f];
    const int k0 = face.face;
    const std::array<int, 3> order = ((k0 & 1) == 0) != negative(m, face.tet)
                                         ? std::array<int, 3>{(k0 + 1) & 3, (k0 + 2) & 3, (k0 + 3) & 3}
                                         : std::array<int, 3>{(k0 + 1) & 3, (k0 + 3) & 3, (k0 + 2) & 3};
    for (int k = 0; k < 3; ++k) {
      const uint32_t point = m.tets[face.tet][order[k]];
      corners[3 * f + k] = glm::vec4(glm::vec3(glm::dvec3(m.points[point]) - centre), 1.0f);
    }
    faces[f] = code(face.tet, reversed[face.tet], newIndex[face.tet][face.face]);
  }
  mCorners.allocate(GL_SHADER_STORAGE_BUFFER, std::max<size_t>(1, corners.size()) * sizeof(glm::vec4),
                    corners.empty() ? nullptr : corners.data(), GL_STATIC_DRAW);
  mFaces.allocate(GL_SHADER_STORAGE_BUFFER, std::max<size_t>(1, faces.size()) * sizeof(uint32_t),
                  faces.empty() ? nullptr : faces.data(), GL_STATIC_DRAW);
}

TetRayCaster::~TetRayCaster() = default;

void TetRayCaster::prepareTargets(int width, int height) {
  if (width == mWidth && height == mHeight) return;
  mEntryTexture = Texture(mGl, GL_TEXTURE_2D);
  mGl.glBindTexture(GL_TEXTURE_2D, mEntryTexture.id());
  mGl.glTexStorage2D(GL_TEXTURE_2D, 1, GL_R32UI, width, height);
  mGl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  mGl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  mEntryDepth = Texture(mGl, GL_TEXTURE_2D);
  mGl.glBindTexture(GL_TEXTURE_2D, mEntryDepth.id());
  mGl.glTexStorage2D(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT32F, width, height);
  mGl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  mGl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  mEntryTarget = Framebuffer(mGl);
  mGl.glBindFramebuffer(GL_FRAMEBUFFER, mEntryTarget.id());
  mGl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, mEntryTexture.id(), 0);
  mGl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, mEntryDepth.id(), 0);
  mEntryTarget.checkComplete("TetRayCaster: entry target");
  mBeforeMesh.assign(size_t(width) * size_t(height), -1.0f);
  mExits.allocate(GL_SHADER_STORAGE_BUFFER, mBeforeMesh.size() * sizeof(float), nullptr, GL_DYNAMIC_COPY);
  mWidth = width;
  mHeight = height;
}

void TetRayCaster::draw(const TetFrameUniforms& uniforms, double termination, bool shading, bool compute,
                        Compositor& compositor, FrameStats& stats, const std::function<bool()>& cancelled,
                        double checkpointSamples) {
  prepareTargets(uniforms.width, uniforms.height);
  // Every ray starts before the mesh (mBeforeMesh: -1 for each pixel, made with the target).
  mExits.bind(GL_SHADER_STORAGE_BUFFER);
  mGl.glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(mBeforeMesh.size() * sizeof(float)), mBeforeMesh.data());
  mCounters.reset();
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_VERTICES, mVertices.id());
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_TET_NEIGHBOURS, mNeighbours.id());
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_BOUNDARY_CORNERS, mCorners.id());
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_BOUNDARY_FACES, mFaces.id());
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_RAY_EXITS, mExits.id());
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_ENTRY_COUNT, mEntryCount.id());
  const Program& ray = rayProgramFor(shading, uniforms.part, compute);
  setTetUniforms(mEntryProgram, uniforms);
  setTetUniforms(ray, uniforms);
  ray.set(ray.uniformLocation("uTermination"), termination > 0 ? float(termination) : 2.0f);
  ray.set(ray.uniformLocation("uMaxSteps"), kMaxSteps);
  mEmpty.bind();
  const uint32_t noEntry = 0xffffffffu;
  const float farthest = 1.0f;
  Checkpoints checkpoints(mGl, cancelled, checkpointSamples);
  // Pixels near the middle walk more tets than the frame's mean: bands sized for three times the mean.
  const double samplesPerPixel = 3 * stats.samplesEstimated / std::max(1.0, double(mWidth) * mHeight);
  for (;;) {
    checkpoints.poll();
    stats.tetRayPasses += 1;
    const uint32_t zero = 0;
    mEntryCount.bind(GL_SHADER_STORAGE_BUFFER);
    mGl.glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, sizeof(zero), &zero);
    mGl.glBindFramebuffer(GL_FRAMEBUFFER, mEntryTarget.id());
    mGl.glViewport(0, 0, mWidth, mHeight);
    mGl.glDisable(GL_BLEND);
    mGl.glEnable(GL_DEPTH_TEST);
    mGl.glDepthFunc(GL_LESS);
    mGl.glDepthMask(GL_TRUE);
    mGl.glClearBufferuiv(GL_COLOR, 0, &noEntry);
    mGl.glClearBufferfv(GL_DEPTH, 0, &farthest);
    mEntryProgram.use();
    mGl.glDrawArrays(GL_TRIANGLES, 0, GLsizei(6 * mBoundaryFaces));
    mGl.glDepthMask(GL_FALSE);
    mGl.glDisable(GL_DEPTH_TEST);
    mGl.glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
    uint32_t entries = 0;
    mEntryCount.read(0, sizeof(entries), &entries);
    if (entries == 0 || stats.tetRayPasses > kMaxPasses) break;
    mEntryTexture.bind(VB_UNIT_TET_ENTRY);
    mEntryDepth.bind(VB_UNIT_TET_ENTRY_DEPTH);
    ray.use();
    if (compute) {
      compositor.bindImage(VB_IMAGE_ACCUMULATED);
      const GLint tile = ray.uniformLocation("uTile");
      dispatchInTiles(mGl, mWidth, mHeight, checkpoints, samplesPerPixel,
                      [&](const glm::ivec4& pixels) { ray.set(tile, pixels); });
    } else {
      compositor.bindTarget();
      mGl.glEnable(GL_BLEND);
      drawInBands(mGl, mWidth, mHeight, checkpoints, samplesPerPixel);
      mGl.glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    }
  }
  compositor.bindTarget();
  mGl.glEnable(GL_BLEND);
  checkGlError(mGl, "TetRayCaster: drawing");
}

void TetRayCaster::readCounters(FrameStats& stats) const { mCounters.read(stats); }

const Program& TetRayCaster::rayProgramFor(bool shading, bool part, bool compute) {
  Program& program = mRayPrograms[compute][part][shading];
  if (!program) program = rayProgram(mGl, shading, part, compute);
  return program;
}

}  // namespace voxbrick::render
