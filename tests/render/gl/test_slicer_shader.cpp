// Tests of the GPU slicers through transform feedback (rasterizer discarded; from the geometry program where there is
// one): slice.vert.glsl's polygons against the exact ones and the CPU mirror on random and degenerate cases, several
// planes per instance, shared faces, outputs; and Zellmann & Lang's variants (vertex-lean, geometry,
// vertex-geometry) against slice.vert.glsl on the same cases, box by box and plane by plane.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <ostream>
#include <random>
#include <set>
#include <tuple>

#include <glm/gtc/matrix_transform.hpp>

#include "render/SliceCheck.h"
#include "render/gl/GlContext.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/GlObjects.h"
#include "render/gl/Shaders.h"
#include "render/gl/volume/SliceGeometry.h"
#include "render/gl/volume/VolumePrograms.h"
#include "render/volume/SliceTables.h"
#include "render/volume/Slicing.h"

namespace voxbrick::render {

/// Slicers by name in test output.
void PrintTo(Slicer slicer, std::ostream* os) { *os << slicerName(slicer); }

namespace {

using test::SliceCase;

/// Float round-off of the shader, relative to the case's scale (largest coordinate, extent or |d|) and to the edge
/// conditioning (|n| / |n[a]| for vertices on edges along axis a): the corner distances and d carry an ulp or so of
/// the scale (6e-8 to 1.2e-7 of it), which moves a vertex along its edge by that over the sine of the edge's angle
/// to the plane. 1e-6 is about 8 to 16 ulps; the worst seen is printed.
constexpr double kShaderTolerance = 1e-6;

// GCC 12.2 at -O2 and -O3 drops a double -> float -> double round trip when its SLP vectorizer groups it with
// others (reproduced outside this project; -fno-tree-slp-vectorize cures it); the volatile forces the rounding.
double roundToFloat(double x) {
  volatile float rounded = float(x);
  return rounded;
}

/// One captured vertex: the transform-feedback varyings, interleaved in this order.
struct CapturedVertex {
  float world[3];
  float boxCoord[3];
  int32_t payload[4];
  float position[4];
  float planeDistance;
};
static_assert(sizeof(CapturedVertex) == 60);

/// What a slicer drew for each instance and plane (slot instance * planes + plane): the vertices of its triangles,
/// three per triangle, as captured (the 12 of the fan for the vertex programs).
using Slots = std::vector<std::vector<CapturedVertex>>;

/// Triangles drawn per plane at most: the fan's four, or a strip's four.
constexpr size_t kMaxTrianglesPerPlane = 4;

/// The case as the GPU sees it: every input rounded to float.
SliceCase toFloat(const SliceCase& c) {
  auto round = [](const glm::dvec3& v) { return glm::dvec3(roundToFloat(v.x), roundToFloat(v.y), roundToFloat(v.z)); };
  return {round(c.boxMin), round(c.boxMax), round(c.n), roundToFloat(c.d)};
}

glm::dvec3 world(const CapturedVertex& v) { return {v.world[0], v.world[1], v.world[2]}; }

/// The six polygon vertices P0..P5 from the twelve drawn ones, after checking the fan repeats them bit for bit.
std::array<glm::dvec3, 6> polygonOf(const CapturedVertex* twelve, std::string& failure) {
  std::array<glm::dvec3, 6> polygon;
  for (int k = 0; k < 12; ++k) {
    const glm::dvec3 p = world(twelve[k]);
    const size_t index = size_t(kSliceFan[size_t(k)]);
    bool first = true;
    for (int j = 0; j < k; ++j) first = first && kSliceFan[size_t(j)] != kSliceFan[size_t(k)];
    if (first) {
      polygon[index] = p;
    } else if (polygon[index] != p) {
      failure = "drawn vertex " + std::to_string(k) + " differs from its first copy as P" + std::to_string(index);
    }
  }
  return polygon;
}

/// The triangles of a slot, in double.
std::vector<test::Triangle> trianglesOf(const std::vector<CapturedVertex>& slot) {
  std::vector<test::Triangle> out;
  for (size_t v = 0; v + 2 < slot.size(); v += 3)
    out.push_back({world(slot[v]), world(slot[v + 1]), world(slot[v + 2])});
  return out;
}

/// The 12 fan vertices of every slot, in slot order: what a vertex program draws (it draws every plane, repeating
/// one corner for a plane that misses the box).
std::vector<CapturedVertex> fanVertices(const Slots& slots) {
  std::vector<CapturedVertex> out;
  for (const auto& slot : slots) {
    EXPECT_EQ(slot.size(), size_t(kSliceVerticesPerPolygon));
    if (slot.size() != size_t(kSliceVerticesPerPolygon)) return {};
    out.insert(out.end(), slot.begin(), slot.end());
  }
  return out;
}

/// The plane distance instance `in` gives its plane `p`, in float as the programs compute it.
float planeDistanceOf(const SliceInstance& in, int p, float incr) {
  volatile float product = float(in.firstPlane + p) * incr;
  volatile float sum = in.planeDistance + product;
  return sum;
}

/// A GL context with a slicer's program, ready to capture.
class ShaderSlicer {
 public:
  explicit ShaderSlicer(Backend backend, Slicer slicer = Slicer::Vertex)
      : ShaderSlicer(std::shared_ptr<GlContext>(createContext(backend)), slicer) {}

  /// A second slicer on the context of another, to compare the two.
  ShaderSlicer(std::shared_ptr<GlContext> context, Slicer slicer)
      : mContext(std::move(context)), mSlicer(slicer), mDraw(sliceDraw(slicer)) {
    const Gl& gl = mContext->gl();
    ProgramSources sources = slicerSources(slicer, std::string("capture ") + slicerName(slicer));
    sources.feedbackVaryings = {"vWorld", "vBoxCoord", "vPayload", "gl_Position", "vPlaneDistance"};
    mProgram = Program(gl, sources);
    if (slicer == Slicer::Vertex) {
      for (const SliceTableUniform& table : kSliceTableUniforms) {
        mProgram.set(mProgram.requireUniform(table.name), table.values);
      }
    } else {
      mPaths = mProgram.requireUniform(kSlicePathsUniform);
    }
    mNormal = mProgram.requireUniform(kSliceNormalUniform);
    mIncr = mProgram.uniformLocation(kSlicePlaneIncrUniform);
    mViewProj = mProgram.requireUniform(kSliceViewProjUniform);
    mVao = VertexArray(gl);
    mInstances = Buffer(gl);
    mFeedback = Buffer(gl);
    // Even with the rasterizer discarded, a draw needs a complete framebuffer, and a surfaceless context's default
    // one is not.
    mTarget = Framebuffer::withColor(gl, 1, 1, GL_RGBA16F);
  }

  const GlContext& context() const { return *mContext; }
  const std::shared_ptr<GlContext>& sharedContext() const { return mContext; }

  /// Slices each case's box with its own plane (firstPlane 0, planeDistance d), `planes` planes per instance from
  /// there on; returns what was drawn for each case and plane.
  Slots run(const std::vector<SliceCase>& cases, int planes = 1, float incr = 0,
            const glm::mat4& viewProj = glm::mat4(1)) {
    std::vector<SliceInstance> instances;
    std::vector<glm::vec3> normals;
    for (size_t i = 0; i < cases.size(); ++i) {
      instances.push_back({glm::vec3(cases[i].boxMin), glm::vec3(cases[i].boxMax), float(cases[i].d),
                           glm::ivec4(int(i), -int(i), 7, int(i) * 3), 0, glm::ivec3(0), glm::ivec3(0)});
      normals.push_back(glm::vec3(cases[i].n));
    }
    return runInstances(instances, normals, planes, incr, viewProj);
  }

  /// Draws the instances (payload.x its index), `planes` planes each, one draw per run of equal normals (normals[i]
  /// is instance i's); returns what was drawn for each instance and plane, told apart by payload.x and the plane
  /// distance.
  Slots runInstances(const std::vector<SliceInstance>& instances, const std::vector<glm::vec3>& normals, int planes,
                     float incr, const glm::mat4& viewProj = glm::mat4(1)) {
    const Gl& gl = mContext->gl();
    mVao.bind();
    mInstances.allocate(GL_ARRAY_BUFFER, instances.size() * sizeof(SliceInstance), instances.data(), GL_STATIC_DRAW);
    auto attribute = [&](int location, int count, GLenum type, size_t offset) {
      gl.glEnableVertexAttribArray(GLuint(location));
      const void* pointer = reinterpret_cast<const void*>(offset);
      if (type == GL_FLOAT) {
        gl.glVertexAttribPointer(GLuint(location), count, type, GL_FALSE, sizeof(SliceInstance), pointer);
      } else {
        gl.glVertexAttribIPointer(GLuint(location), count, type, sizeof(SliceInstance), pointer);
      }
      gl.glVertexAttribDivisor(GLuint(location), 1);
    };
    attribute(kSliceBoxMinLocation, 3, GL_FLOAT, offsetof(SliceInstance, boxMin));
    attribute(kSliceBoxMaxLocation, 3, GL_FLOAT, offsetof(SliceInstance, boxMax));
    attribute(kSlicePlaneDistanceLocation, 1, GL_FLOAT, offsetof(SliceInstance, planeDistance));
    attribute(kSlicePayloadLocation, 4, GL_INT, offsetof(SliceInstance, payload));
    attribute(kSliceFirstPlaneLocation, 1, GL_INT, offsetof(SliceInstance, firstPlane));

    const size_t slots = instances.size() * size_t(planes);
    const size_t capacity = slots * kMaxTrianglesPerPlane * 3;
    mFeedback.allocate(GL_TRANSFORM_FEEDBACK_BUFFER, capacity * sizeof(CapturedVertex), nullptr, GL_STREAM_READ);
    gl.glBindBufferBase(GL_TRANSFORM_FEEDBACK_BUFFER, 0, mFeedback.id());
    mTarget.bind();
    mProgram.use();
    mProgram.set(mIncr, incr);
    mProgram.set(mViewProj, viewProj);
    gl.glEnable(GL_RASTERIZER_DISCARD);
    const Query written(gl);
    gl.glBeginQuery(GL_TRANSFORM_FEEDBACK_PRIMITIVES_WRITTEN, written.id());
    gl.glBeginTransformFeedback(GL_TRIANGLES);
    for (size_t begin = 0; begin < instances.size();) {
      size_t end = begin + 1;
      while (end < instances.size() && normals[end] == normals[begin]) ++end;
      mProgram.set(mNormal, normals[begin]);
      // The path table follows the front corner of the normal, as VolumeProgram::setFrame sets it.
      const glm::vec3& n = normals[begin];
      if (mPaths >= 0) {
        mProgram.set(mPaths, std::span<const int>(
                                 sliceCornerPaths(sliceFrontIndex(n.x, n.y, n.z), mSlicer == Slicer::Geometry)));
      }
      gl.glDrawArraysInstancedBaseInstance(mDraw.primitive, 0, mDraw.verticesPerPlane * planes, GLsizei(end - begin),
                                           GLuint(begin));
      begin = end;
    }
    gl.glEndTransformFeedback();
    gl.glEndQuery(GL_TRANSFORM_FEEDBACK_PRIMITIVES_WRITTEN);
    gl.glDisable(GL_RASTERIZER_DISCARD);
    const size_t vertices = size_t(written.result()) * 3;
    EXPECT_LE(vertices, capacity);
    std::vector<CapturedVertex> captured(std::min(vertices, capacity));
    mFeedback.read(0, captured.size() * sizeof(CapturedVertex), captured.data());
    checkGlError(gl, "ShaderSlicer::runInstances");

    // Primitives come out in the order of the draws' vertices: instance by instance, plane by plane.
    Slots out(slots);
    size_t slot = 0;
    auto belongs = [&](const CapturedVertex& v, size_t at) {
      const SliceInstance& in = instances[at / size_t(planes)];
      return v.payload[0] == in.payload.x && v.planeDistance == planeDistanceOf(in, int(at % size_t(planes)), incr);
    };
    for (size_t v = 0; v + 2 < captured.size(); v += 3) {
      while (slot < slots && !belongs(captured[v], slot)) ++slot;
      if (slot == slots || !belongs(captured[v + 1], slot) || !belongs(captured[v + 2], slot)) {
        ADD_FAILURE() << slicerName(mSlicer) << ": captured triangle " << v / 3 << " belongs to no instance and plane"
                      << " in order (payload " << captured[v].payload[0] << ", plane distance "
                      << captured[v].planeDistance << ")";
        break;
      }
      out[slot].insert(out[slot].end(), &captured[v], &captured[v] + 3);
    }
    return out;
  }

 private:
  std::shared_ptr<GlContext> mContext;
  Slicer mSlicer;
  SliceDraw mDraw;
  Program mProgram;
  VertexArray mVao;
  Buffer mInstances;
  Buffer mFeedback;
  Framebuffer mTarget;
  GLint mNormal = -1;
  GLint mIncr = -1;
  GLint mViewProj = -1;
  GLint mPaths = -1;
};

/// The worst vertex error seen: relative to scale x conditioning (what the tolerance bounds), and relative to the
/// box's largest extent (for a feel of what it means in a brick).
struct WorstError {
  double conditioned = 0;
  double perBoxSize = 0;
};

/// Checks every case's captured polygon (a vertex program's fan) against the exact polygon and the CPU mirror of the
/// float inputs.
WorstError expectMatches(const std::vector<SliceCase>& cases, const std::vector<CapturedVertex>& captured,
                         const char* what, Slicer slicer = Slicer::Vertex) {
  WorstError worst;
  for (size_t i = 0; i < cases.size(); ++i) {
    const SliceCase c = toFloat(cases[i]);
    std::string failure;
    const auto polygon = polygonOf(&captured[i * 12], failure);
    const auto exact = test::expectedSlice(c, true);
    // The mirror of the program's own path walk (the lean program repeats vertices elsewhere).
    const auto mirror = slicer == Slicer::VertexLean ? pathSlicePolygon(c.boxMin, c.boxMax, c.n, c.d)
                                                     : rezkSalamaPolygon(c.boxMin, c.boxMax, c.n, c.d);
    const double scale = test::caseScale(c) * test::edgeConditioning(exact, c);
    const double tol = kShaderTolerance * scale;
    const test::PolygonCheck check = test::checkPolygon(polygon, exact, c.n, tol);
    const glm::dvec3 extent = c.boxMax - c.boxMin;
    worst.conditioned = std::max(worst.conditioned, check.error / scale);
    worst.perBoxSize = std::max(worst.perBoxSize, check.error / std::max({extent.x, extent.y, extent.z}));
    if (failure.empty()) failure = check.failure;
    // Same algorithm: each Pk is the mirror's Pk, for planes that pass no corner closer than tol (near a corner,
    // float and double may pick neighbouring edges, or see the plane just inside and just outside).
    bool generic = !exact.empty();
    for (int corner = 0; corner < 8 && generic; ++corner) {
      const glm::dvec3 p(corner & 1 ? c.boxMax.x : c.boxMin.x, corner & 2 ? c.boxMax.y : c.boxMin.y,
                         corner & 4 ? c.boxMax.z : c.boxMin.z);
      generic = std::abs(glm::dot(c.n, p) - c.d) > tol * glm::length(c.n);
    }
    for (size_t k = 0; k < 6 && failure.empty() && generic; ++k) {
      if (glm::length(polygon[k] - mirror[k]) > tol) failure = std::to_string(k) + ": Pk differs from the mirror's";
    }
    if (!failure.empty()) {
      ADD_FAILURE() << what << " case " << i << ": " << test::caseText(c) << " (as float)\n  shader "
                    << test::polygonText(polygon) << "\n  mirror " << test::polygonText(mirror) << "\n  exact  "
                    << test::polygonText(exact) << "\n  " << failure << " (tol " << tol << ")";
      return worst;
    }
  }
  return worst;
}

TEST(SlicerShader, TablesComeFromSliceTablesHeader) {
  const std::string source(shaderSource("slice.vert.glsl"));
  // The fan is the one table the shader spells out; it must be kSliceFan.
  std::string fan = "int[12](";
  for (size_t k = 0; k < kSliceFan.size(); ++k) fan += (k ? ", " : "") + std::to_string(kSliceFan[k]);
  EXPECT_NE(source.find(fan + ")"), std::string::npos) << "slice.vert.glsl's kFan is not " << fan;
  // The others are uniforms filled from SliceTables.h, declared with the header's sizes.
  for (const SliceTableUniform& table : kSliceTableUniforms) {
    const std::string declaration =
        "uniform int " + std::string(table.name) + "[" + std::to_string(table.values.size()) + "];";
    EXPECT_NE(source.find(declaration), std::string::npos) << declaration;
  }
  ShaderSlicer slicer(Backend::Auto);  // requireUniform throws if the linker dropped any table
}

TEST(SlicerShader, MatchesExactPolygonsOnRandomCases) {
  ShaderSlicer slicer(Backend::Auto);
  std::mt19937_64 rng(4242);
  WorstError worst;
  constexpr int kBatches = 4, kNormalsPerBatch = 250, kCasesPerNormal = 100;  // 10^5 cases in 4 captures
  for (int batch = 0; batch < kBatches && !HasFailure(); ++batch) {
    std::vector<SliceCase> cases;
    for (int g = 0; g < kNormalsPerBatch; ++g) {
      const glm::dvec3 n = toFloat({glm::dvec3(0), glm::dvec3(1), test::randomNormal(rng), 0}).n;
      for (int k = 0; k < kCasesPerNormal; ++k) cases.push_back(test::randomSliceCase(rng, n));
    }
    const WorstError batchWorst = expectMatches(cases, fanVertices(slicer.run(cases)), "random");
    worst.conditioned = std::max(worst.conditioned, batchWorst.conditioned);
    worst.perBoxSize = std::max(worst.perBoxSize, batchWorst.perBoxSize);
  }
  std::printf(
      "[ info ] %s: worst shader error over 1e5 random cases: %.3g of scale x conditioning (tolerance "
      "%.0e), %.3g of the box size\n",
      slicer.context().describe().c_str(), worst.conditioned, kShaderTolerance, worst.perBoxSize);
}

TEST(SlicerShader, MatchesExactPolygonsOnDegenerateCases) {
  const std::vector<SliceCase> cases = test::degenerateSliceCases();
  for (Backend backend : {Backend::Egl, Backend::OsMesa}) {
    if (!test::backendExists(backend)) continue;
    ShaderSlicer slicer(backend);
    const WorstError worst = expectMatches(cases, fanVertices(slicer.run(cases)), backendName(backend));
    std::printf(
        "[ info ] %s: worst shader error over %zu degenerate cases: %.3g of scale x conditioning, %.3g of "
        "the box size\n",
        slicer.context().describe().c_str(), cases.size(), worst.conditioned, worst.perBoxSize);
  }
  test::skipMissingBackends();
}

TEST(SlicerShader, SlicesEachBoxManyTimesWithThePlaneIndexInTheVertexStream) {
  ShaderSlicer slicer(Backend::Auto);
  std::mt19937_64 rng(5);
  std::vector<SliceCase> cases;
  for (int g = 0; g < 20; ++g) {
    const glm::dvec3 n = toFloat({glm::dvec3(0), glm::dvec3(1), test::randomNormal(rng), 0}).n;
    for (int k = 0; k < 50; ++k) cases.push_back(test::randomSliceCase(rng, n));
  }
  constexpr int kPlanes = 16;
  const float incr = 0.37f;
  const std::vector<CapturedVertex> captured = fanVertices(slicer.run(cases, kPlanes, incr));
  for (size_t i = 0; i < cases.size() && !HasFailure(); ++i) {
    // Planes run from d by incr; the box size varies, so some planes cut and the rest fall past the box.
    std::vector<SliceCase> perPlane;
    std::vector<CapturedVertex> perPlaneCaptured;
    for (int p = 0; p < kPlanes; ++p) {
      SliceCase c = toFloat(cases[i]);
      c.d = roundToFloat(float(c.d) + float(p) * incr);
      perPlane.push_back(c);
      const CapturedVertex* first = &captured[(i * kPlanes + size_t(p)) * 12];
      perPlaneCaptured.insert(perPlaneCaptured.end(), first, first + 12);
    }
    expectMatches(perPlane, perPlaneCaptured, "several planes per instance");
  }
}

// Vertices strictly inside an edge of the face x = faceX (y and z: one at a bound, one strictly between).
std::set<std::tuple<float, float, float>> faceEdgeVertices(const CapturedVertex* twelve, const SliceCase& c,
                                                           float faceX) {
  std::set<std::tuple<float, float, float>> out;
  const glm::vec3 lo(c.boxMin), hi(c.boxMax);
  for (int k = 0; k < 12; ++k) {
    const float* p = twelve[k].world;
    if (p[0] != faceX) continue;
    const bool yBound = p[1] == lo.y || p[1] == hi.y, zBound = p[2] == lo.z || p[2] == hi.z;
    if (yBound != zBound) out.insert({p[0], p[1], p[2]});
  }
  return out;
}

TEST(SlicerShader, NeighbouringBoxesShareFaceVerticesBitForBit) {
  ShaderSlicer slicer(Backend::Auto);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<SliceCase> cases;  // pairs: a box, then its +x neighbour, cut by the same plane
  for (int g = 0; g < 100; ++g) {
    const glm::dvec3 n = toFloat({glm::dvec3(0), glm::dvec3(1), test::randomNormal(rng), 0}).n;
    for (int k = 0; k < 50; ++k) {
      SliceCase a = toFloat(test::randomSliceCase(rng, n));
      SliceCase b = a;
      b.boxMin.x = a.boxMax.x;
      b.boxMax.x = roundToFloat(a.boxMax.x + (a.boxMax.x - a.boxMin.x));
      double lo, hi;
      test::maxXFaceDistanceRange(a, lo, hi);
      a.d = b.d = roundToFloat(lo + (hi - lo) * unit(rng));
      cases.push_back(a);
      cases.push_back(b);
    }
  }
  const std::vector<CapturedVertex> captured = fanVertices(slicer.run(cases));
  size_t shared = 0;
  for (size_t i = 0; i < cases.size(); i += 2) {
    const float faceX = float(cases[i].boxMax.x);
    const auto fa = faceEdgeVertices(&captured[i * 12], cases[i], faceX);
    const auto fb = faceEdgeVertices(&captured[(i + 1) * 12], cases[i + 1], faceX);
    ASSERT_EQ(fa, fb) << test::caseText(cases[i]) << " and its +x neighbour " << test::caseText(cases[i + 1]);
    shared += fa.size();
  }
  EXPECT_GT(shared, cases.size() / 2);
}

/// A row of eight bricks along x, and the row whole as instance 8, sliced with the global planes of `step` along `n`
/// (already float) as a renderer would: slicerPlaneRange per box, planeDistance 0, firstPlane its first index.
struct BrickRow {
  static constexpr glm::dvec3 kMin{-30, -30, -30}, kMax{34, -22, -22};
  std::vector<SliceInstance> instances;
  std::vector<glm::vec3> normals;  // one per instance
  int planes = 0;                  // per instance: the most any box has

  BrickRow(const glm::dvec3& n, double step) {
    for (int b = 0; b <= 8; ++b) {
      const glm::dvec3 lo = b < 8 ? glm::dvec3(kMin.x + 8 * b, kMin.y, kMin.z) : kMin;
      const glm::dvec3 hi = b < 8 ? glm::dvec3(lo.x + 8, kMax.y, kMax.z) : kMax;
      const PlaneIndexRange range = slicerPlaneRange(lo, hi, n, step);
      instances.push_back(
          {glm::vec3(lo), glm::vec3(hi), 0.0f, glm::ivec4(b), int32_t(range.begin), glm::ivec3(0), glm::ivec3(0)});
      normals.push_back(glm::vec3(n));
      planes = std::max(planes, int(range.count()));
    }
  }

  /// The normals of the row tests: views along x off by 6e-17 in z, as an orbit at azimuth 90 gives, where double
  /// and float disagree about which side of a face a plane falls; along other axes; and random ones. As float.
  static std::vector<glm::dvec3> testNormals() {
    std::mt19937_64 rng(17);
    std::vector<glm::dvec3> normals = {
        {-1, 0, -6.123233995736766e-17}, {1, 0, 6.1e-17}, {1, -1e-9, 0}, {-1, 0, 0}, {0.8, 0.6, 0}, {0, 0, 1}};
    for (int i = 0; i < 6; ++i) normals.push_back(test::randomNormal(rng));
    for (glm::dvec3& n : normals) n = toFloat({kMin, kMax, n, 0}).n;
    return normals;
  }
};

TEST(SlicerShader, RowsOfBricksDrawEveryGlobalPlaneExactlyOnce) {
  // For every plane k the bricks' polygon areas must add up to the row's: a plane through a shared face drawn twice,
  // or by neither brick, shows as a whole face too much or too little.
  ShaderSlicer slicer(Backend::Auto);
  const double face = (BrickRow::kMax.y - BrickRow::kMin.y) * (BrickRow::kMax.z - BrickRow::kMin.z);
  for (const glm::dvec3& nf : BrickRow::testNormals()) {
    for (double step : {0.5, 0.3, 1.0 / 3.0}) {
      const BrickRow row(nf, step);
      const int planes = row.planes;
      const auto captured = fanVertices(slicer.runInstances(row.instances, row.normals, planes, float(step)));
      std::map<int64_t, double> bricked, whole;
      for (size_t b = 0; b < row.instances.size(); ++b) {
        for (int p = 0; p < planes; ++p) {
          std::string failure;
          const auto polygon = polygonOf(&captured[(b * size_t(planes) + size_t(p)) * 12], failure);
          ASSERT_EQ(failure, "");
          (b < 8 ? bricked : whole)[row.instances[b].firstPlane + p] += polygonArea(polygon, nf);
        }
      }
      int wholePlanes = 0;
      for (const auto& [k, area] : whole) {
        wholePlanes += area > 0.5 * face ? 1 : 0;
        ASSERT_NEAR(bricked[k], area, 1e-4 * face)
            << "plane " << k << " of step " << step << ", n " << test::vec3Text(nf) << ": bricks and the whole row";
      }
      for (const auto& [k, area] : bricked) {
        ASSERT_TRUE(whole.count(k) || area == 0) << "plane " << k << " only in the bricks, n " << test::vec3Text(nf);
      }
      ASSERT_GT(wholePlanes, 10);
    }
  }
}

/// Boxes cut through the middle, each with a camera looking along the plane normal at it: the slices must come
/// out counter-clockwise on screen, with clip positions, box coordinates and payloads as the vertex program's.
void expectOutputs(Slicer slicer) {
  ShaderSlicer shader(Backend::Auto, slicer);
  std::mt19937_64 rng(3);
  std::vector<SliceCase> cases;
  std::vector<glm::mat4> cameras;
  for (int g = 0; g < 40; ++g) {
    const glm::dvec3 n = toFloat({glm::dvec3(0), glm::dvec3(1), test::randomNormal(rng), 0}).n;
    SliceCase c = test::randomSliceCase(rng, n);
    const glm::dvec3 centre = 0.5 * (c.boxMin + c.boxMax);
    c.d = glm::dot(n, centre);  // through the middle: a proper polygon
    cases.push_back(c);
    const double radius = glm::length(c.boxMax - c.boxMin);
    const glm::dvec3 up = std::abs(n.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
    cameras.push_back(glm::mat4(glm::perspective(0.8, 1.3, 0.1 * radius, 10 * radius) *
                                glm::lookAt(centre - 3 * radius * n, centre, up)));
  }
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::vector<SliceCase> one = {cases[i]};
    const Slots slots = shader.run(one, 1, 0, cameras[i]);
    const std::vector<CapturedVertex>& captured = slots[0];
    const SliceCase c = toFloat(cases[i]);
    const glm::vec3 lo(c.boxMin), hi(c.boxMax);
    ASSERT_GE(captured.size(), 3u) << slicerName(slicer) << ": nothing drawn for " << test::caseText(c);
    double screenArea = 0;
    for (size_t k = 0; k < captured.size(); ++k) {
      const CapturedVertex& v = captured[k];
      const glm::vec3 w(v.world[0], v.world[1], v.world[2]);
      const glm::vec4 expected = cameras[i] * glm::vec4(w, 1);
      for (int a = 0; a < 4; ++a) EXPECT_NEAR(v.position[a], expected[a], 1e-5 * (1 + std::abs(expected[a])));
      for (int a = 0; a < 3; ++a) {
        EXPECT_GE(v.boxCoord[a], 0.0f);
        EXPECT_LE(v.boxCoord[a], 1.0f);
        EXPECT_NEAR(v.boxCoord[a], (w[a] - lo[a]) / (hi[a] - lo[a]), 1e-4) << test::caseText(c);
      }
      EXPECT_EQ(v.payload[0], 0);
      EXPECT_EQ(v.payload[2], 7);
      if (k % 3 == 2) {  // a triangle, in normalised device coordinates
        auto ndc = [&](size_t j) {
          const float* p = captured[j].position;
          return glm::dvec2(p[0] / p[3], p[1] / p[3]);
        };
        const glm::dvec2 a = ndc(k - 2), b = ndc(k - 1), e = ndc(k);
        const double area = 0.5 * ((b.x - a.x) * (e.y - a.y) - (b.y - a.y) * (e.x - a.x));
        EXPECT_GE(area, -1e-9) << slicerName(slicer) << ": a clockwise triangle on screen: " << test::caseText(c);
        screenArea += area;
      }
    }
    EXPECT_GT(screenArea, 0) << slicerName(slicer)
                             << ": slice is not front-facing (counter-clockwise) on screen: " << test::caseText(c);
  }
}

TEST(SlicerShader, OutputsPositionBoxCoordinatesAndPayload) { expectOutputs(Slicer::Vertex); }

// Zellmann & Lang's variants, each against the vertex program on the same instances, slot by slot.

class SlicerVariant : public ::testing::TestWithParam<Slicer> {};

/// "vertex_lean" for Slicer::VertexLean: test names take no '-'.
std::string variantName(const ::testing::TestParamInfo<Slicer>& param) {
  std::string name = slicerName(param.param);
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

INSTANTIATE_TEST_SUITE_P(Zellmann, SlicerVariant,
                         ::testing::Values(Slicer::VertexLean, Slicer::Geometry, Slicer::VertexGeometry), variantName);

/// Draws the instances with the vertex program and with the variant, and expects the variant's triangles for every
/// box and plane to tile the vertex program's polygon with the same vertices bit for bit (test::checkTiling).
/// `describe(i)` names instance i in a failure. Returns the triangles the variant drew.
size_t expectTilesVertexProgram(ShaderSlicer& vertex, ShaderSlicer& variant, Slicer slicer,
                                const std::vector<SliceInstance>& instances, const std::vector<glm::vec3>& normals,
                                int planes, float incr, const std::function<std::string(size_t)>& describe) {
  const Slots reference = vertex.runInstances(instances, normals, planes, incr);
  const Slots drawn = variant.runInstances(instances, normals, planes, incr);
  size_t triangles = 0;
  for (size_t slot = 0; slot < reference.size(); ++slot) {
    const size_t instance = slot / size_t(planes);
    std::string failure;
    if (reference[slot].size() != size_t(kSliceVerticesPerPolygon)) failure = "the vertex program drew no fan";
    const auto polygon = failure.empty() ? polygonOf(reference[slot].data(), failure) : std::array<glm::dvec3, 6>{};
    if (failure.empty()) failure = test::checkTiling(trianglesOf(drawn[slot]), polygon, glm::dvec3(normals[instance]));
    if (!failure.empty()) {
      std::vector<glm::dvec3> got;
      for (const CapturedVertex& v : drawn[slot]) got.push_back(world(v));
      ADD_FAILURE() << slicerName(slicer) << ", " << describe(instance) << ", plane " << slot % size_t(planes) << ": "
                    << failure << "\n  vertex program " << test::polygonText(polygon) << "\n  " << slicerName(slicer)
                    << " (triangles) " << test::polygonText(got);
      return triangles;
    }
    triangles += drawn[slot].size() / 3;
  }
  return triangles;
}

/// The cases as instances as ShaderSlicer::run makes them (one plane each at the case's d, payload.x the index).
std::vector<SliceInstance> caseInstances(const std::vector<SliceCase>& cases, std::vector<glm::vec3>& normals) {
  std::vector<SliceInstance> instances;
  normals.clear();
  for (size_t i = 0; i < cases.size(); ++i) {
    instances.push_back({glm::vec3(cases[i].boxMin), glm::vec3(cases[i].boxMax), float(cases[i].d),
                         glm::ivec4(int(i), -int(i), 7, int(i) * 3), 0, glm::ivec3(0), glm::ivec3(0)});
    normals.push_back(glm::vec3(cases[i].n));
  }
  return instances;
}

TEST(SlicerShader, VariantSourcesHoldTheOneTableOfTheHeader) {
  // The path table is a uniform filled from SliceTables.h (sliceCornerPaths), declared with its size; the lean
  // program's fan is kSliceFan.
  const std::string declaration = "uniform int " + std::string(kSlicePathsUniform) + "[24];";
  for (const char* file : {"slice_lean.vert.glsl", "slice.geom.glsl", "slice_even.vert.glsl", "slice_odd.geom.glsl"})
    EXPECT_NE(std::string(shaderSource(file)).find(declaration), std::string::npos) << file << ": " << declaration;
  std::string fan = "int[12](";
  for (size_t k = 0; k < kSliceFan.size(); ++k) fan += (k ? ", " : "") + std::to_string(kSliceFan[k]);
  EXPECT_NE(std::string(shaderSource("slice_lean.vert.glsl")).find(fan + ")"), std::string::npos);
  // The geometry programs emit at most the strip of kMaxTrianglesPerPlane triangles.
  for (const char* file : {"slice.geom.glsl", "slice_odd.geom.glsl"})
    EXPECT_NE(std::string(shaderSource(file)).find("max_vertices = " + std::to_string(kMaxTrianglesPerPlane + 2)),
              std::string::npos)
        << file;
}

TEST_P(SlicerVariant, TilesTheVertexProgramsPolygonsOnRandomCases) {
  const Slicer slicer = GetParam();
  ShaderSlicer vertex(Backend::Auto), variant(vertex.sharedContext(), slicer);
  std::mt19937_64 rng(4243);
  size_t triangles = 0, planes = 0;
  constexpr int kBatches = 2, kNormalsPerBatch = 200, kCasesPerNormal = 100;  // 4 * 10^4 cases
  for (int batch = 0; batch < kBatches && !HasFailure(); ++batch) {
    std::vector<SliceCase> cases;
    for (int g = 0; g < kNormalsPerBatch; ++g) {
      const glm::dvec3 n = toFloat({glm::dvec3(0), glm::dvec3(1), test::randomNormal(rng), 0}).n;
      for (int k = 0; k < kCasesPerNormal; ++k) cases.push_back(test::randomSliceCase(rng, n));
    }
    std::vector<glm::vec3> normals;
    const std::vector<SliceInstance> instances = caseInstances(cases, normals);
    triangles += expectTilesVertexProgram(vertex, variant, slicer, instances, normals, 1, 0,
                                          [&](size_t i) { return "random case " + test::caseText(toFloat(cases[i])); });
    planes += cases.size();
    // The lean program draws the fan: its P0..P5 against the exact polygon and the CPU mirror of its path walk.
    if (slicer == Slicer::VertexLean) expectMatches(cases, fanVertices(variant.run(cases)), "random", slicer);
  }
  std::printf("[ info ] %s: %zu triangles (degenerate ones included) for %zu planes\n", slicerName(slicer), triangles,
              planes);
}

TEST_P(SlicerVariant, TilesTheVertexProgramsPolygonsOnDegenerateCases) {
  // Planes through corners, edges and faces of boxes from 1e-6 to 1e6, along axes and diagonals, and just outside.
  const Slicer slicer = GetParam();
  const std::vector<SliceCase> cases = test::degenerateSliceCases();
  std::vector<glm::vec3> normals;
  const std::vector<SliceInstance> instances = caseInstances(cases, normals);
  for (Backend backend : {Backend::Egl, Backend::OsMesa}) {
    if (!test::backendExists(backend)) continue;
    ShaderSlicer vertex(backend), variant(vertex.sharedContext(), slicer);
    expectTilesVertexProgram(vertex, variant, slicer, instances, normals, 1, 0, [&](size_t i) {
      return std::string(backendName(backend)) + " degenerate case " + test::caseText(toFloat(cases[i]));
    });
    if (slicer == Slicer::VertexLean)
      expectMatches(cases, fanVertices(variant.run(cases)), backendName(backend), slicer);
  }
  test::skipMissingBackends();
}

TEST_P(SlicerVariant, SlicesEachBoxManyTimesWithThePlaneIndexInTheVertexStream) {
  const Slicer slicer = GetParam();
  ShaderSlicer vertex(Backend::Auto), variant(vertex.sharedContext(), slicer);
  std::mt19937_64 rng(5);
  std::vector<SliceCase> cases;
  for (int g = 0; g < 20; ++g) {
    const glm::dvec3 n = toFloat({glm::dvec3(0), glm::dvec3(1), test::randomNormal(rng), 0}).n;
    for (int k = 0; k < 50; ++k) cases.push_back(test::randomSliceCase(rng, n));
  }
  std::vector<glm::vec3> normals;
  const std::vector<SliceInstance> instances = caseInstances(cases, normals);
  // Planes run from d by 0.37; the box size varies, so some planes cut and the rest fall past the box.
  expectTilesVertexProgram(vertex, variant, slicer, instances, normals, 16, 0.37f,
                           [&](size_t i) { return "case " + test::caseText(toFloat(cases[i])); });
}

TEST_P(SlicerVariant, RowsOfBricksAsTheVertexProgramDrawsThem) {
  // The global planes of a brick row (slicerPlaneRange, one plane more each side, the float test deciding): every
  // brick draws what the vertex program draws for every plane, so it too draws each plane exactly once.
  const Slicer slicer = GetParam();
  ShaderSlicer vertex(Backend::Auto), variant(vertex.sharedContext(), slicer);
  for (const glm::dvec3& nf : BrickRow::testNormals()) {
    for (double step : {0.5, 0.3, 1.0 / 3.0}) {
      const BrickRow row(nf, step);
      expectTilesVertexProgram(vertex, variant, slicer, row.instances, row.normals, row.planes, float(step),
                               [&](size_t b) {
                                 return "brick " + std::to_string(b) + " of the row, step " + std::to_string(step) +
                                        ", n " + test::vec3Text(nf);
                               });
      if (HasFailure()) return;
    }
  }
}

TEST_P(SlicerVariant, OutputsPositionBoxCoordinatesAndPayload) { expectOutputs(GetParam()); }

}  // namespace
}  // namespace voxbrick::render
