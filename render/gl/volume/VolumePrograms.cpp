// Building the grid programs (slicing, slabs, the ray caster's two kernels) from the embedded shaders and setting their per-frame uniforms.
#include "render/gl/volume/VolumePrograms.h"

#include <string>
#include <vector>

#include "render/core/RenderErrors.h"
#include "render/gl/Shaders.h"
#include "render/volume/SliceTables.h"

namespace voxbrick::render {
namespace {

/// The helpers every slicer in GL programs shares.
constexpr const char* kLibrary = "slicer.glsl";

/// True when `key` slices (neither slabs nor the ray caster), so that its slicer's stages apply.
bool slices(const ProgramKey& key) { return !key.slab && !key.raycast; }

ProgramSources sources(const ProgramKey& key) {
  std::vector<std::string> defines;
  if (key.exactOwnership) defines.push_back("EXACT_OWNERSHIP");
  if (key.model == FragmentModel::Roofline) defines.push_back("ROOFLINE");
  if (key.model == FragmentModel::Shaded) defines.push_back("SHADING");
  if (key.preIntegration) defines.push_back("PRE_INTEGRATION");
  if (key.emptyTest) defines.push_back("EMPTY_TEST");
  if (key.multiOriented) defines.push_back("MULTI_ORIENTED");
  if (key.pagedCells) defines.push_back("PAGED_CELLS");
  if (key.rayRequests) defines.push_back("RAY_REQUESTS");
  // The grid programs' libraries (after the slicer's, if any); the ray caster's kernels share their march.
  std::vector<std::string> libraries{"volume_sample.glsl", "volume_ownership.glsl", "volume_ray.glsl"};
  if (!slices(key)) libraries.push_back("volume_counters.glsl");
  if (key.raycast) libraries.push_back("volume_march.glsl");
  // The compute ray caster is one stage.
  if (key.raycast && key.compute) {
    libraries.push_back("compute_tile.glsl");
    return ProgramSources::fromFiles("volume/raycast.comp.glsl", {{GL_COMPUTE_SHADER, "raycast.comp.glsl"}},
                                     std::move(defines), libraries);
  }
  // The stages before the fragment program: the proxy of slabs or the ray caster, or the slicer's.
  ProgramSources program = key.raycast ? ProgramSources::fromFiles({}, {{GL_VERTEX_SHADER, "raycast.vert.glsl"}})
                           : key.slab  ? ProgramSources::fromFiles({}, {{GL_VERTEX_SHADER, "slab.vert.glsl"}})
                                       : slicerSources(key.slicer, {});
  // The technique's fragment program.
  const char* fragment = key.raycast ? "raycast.frag.glsl" : key.slab ? "slab.frag.glsl" : "slice.frag.glsl";
  for (const std::string& file : libraries) program.libraries.push_back({file, std::string(shaderSource(file))});
  program.name = "volume/";
  for (const ShaderStage& stage : program.stages) program.name += stage.name + "+";
  program.name += fragment;
  program.stages.push_back({GL_FRAGMENT_SHADER, fragment, std::string(shaderSource(fragment))});
  program.defines = std::move(defines);
  return program;
}

/// Builds the variant; a slicer's program that the context cannot build names the slicer (a geometry program needs
/// GL 3.2 or later; a driver may still refuse one).
Program build(const Gl& gl, const ProgramKey& key) {
  try {
    return Program(gl, sources(key));
  } catch (const RenderError& e) {
    if (!slices(key)) throw;
    throw RenderError(std::string("the '") + slicerName(key.slicer) +
                      "' slicer cannot be built on this context: " + e.what());
  }
}

}  // namespace

ProgramSources slicerSources(Slicer slicer, std::string name) {
  using Stages = std::vector<std::pair<GLenum, std::string>>;
  switch (slicer) {
    case Slicer::Vertex: return ProgramSources::fromFiles(name, {{GL_VERTEX_SHADER, "slice.vert.glsl"}}, {}, kLibrary);
    case Slicer::Cpu: return ProgramSources::fromFiles(name, {{GL_VERTEX_SHADER, "slice_cpu.vert.glsl"}});
    case Slicer::VertexLean:
      return ProgramSources::fromFiles(name, {{GL_VERTEX_SHADER, "slice_lean.vert.glsl"}}, {}, kLibrary);
    case Slicer::Geometry:
      return ProgramSources::fromFiles(
          name, Stages{{GL_VERTEX_SHADER, "slice_point.vert.glsl"}, {GL_GEOMETRY_SHADER, "slice.geom.glsl"}}, {},
          kLibrary);
    case Slicer::VertexGeometry:
      return ProgramSources::fromFiles(
          name, Stages{{GL_VERTEX_SHADER, "slice_even.vert.glsl"}, {GL_GEOMETRY_SHADER, "slice_odd.geom.glsl"}}, {},
          kLibrary);
  }
  throw RenderInputError("slicerSources: unknown slicer " + std::to_string(int(slicer)));
}

VolumeProgram::VolumeProgram(const Gl& gl, const ProgramKey& key)
    : mProgram(build(gl, key)), mCompute(key.raycast && key.compute) {
  if (mCompute) mTile = mProgram.requireUniform("uTile");
  if (key.rayRequests) mRequestGrid = mProgram.requireUniform("uRequestGrid");
  if (key.slicer == Slicer::Vertex && slices(key))
    for (const SliceTableUniform& table : kSliceTableUniforms)
      mProgram.set(mProgram.requireUniform(table.name), table.values);
  // The path table follows the view direction, set per frame (setFrame); the strip of the geometry program wants its
  // rows in strip order.
  if (slices(key) &&
      (key.slicer == Slicer::VertexLean || key.slicer == Slicer::Geometry || key.slicer == Slicer::VertexGeometry)) {
    mPaths = mProgram.requireUniform(kSlicePathsUniform);
    mStripOrder = key.slicer == Slicer::Geometry;
  }
  auto at = [this](const char* name) { return mProgram.uniformLocation(name); };
  mAt = {at(kSliceViewProjUniform),
         at(kSliceNormalUniform),
         at(kSlicePlaneIncrUniform),
         at("uInvAtlasSize"),
         at("uInvSpacing"),
         at("uDims"),
         at("uHalfDims"),
         at("uWindowLo"),
         at("uWindowScale"),
         at("uStepOverReference"),
         at("uEye"),
         at("uViewDir"),
         at("uOrthographic"),
         at("uRayOrigin"),
         at("uRayOriginDx"),
         at("uRayOriginDy"),
         at("uRayDirection"),
         at("uRayDirectionDx"),
         at("uRayDirectionDy"),
         at("uTermination"),
         at("uTableResolution"),
         at("uRatioMin"),
         at("uLayerScale"),
         at("uLayers"),
         at("uCellShift"),
         at("uCellCount")};
}

void VolumeProgram::setFrame(const FramePlan& plan, const BrickAtlas& atlas, const store::StoreMeta& meta) const {
  const Program& p = mProgram;
  p.set(mAt.viewProj, glm::mat4(plan.viewProj));
  p.set(mAt.planeNormal, glm::vec3(plan.planeNormal));
  p.set(mAt.planeIncr, float(plan.step));
  if (mPaths >= 0) {
    // The front corner of the normal the programs see, in float, so that a component too small for a float can
    // never flip it.
    const glm::vec3 n(plan.planeNormal);
    p.set(mPaths, std::span<const int>(sliceCornerPaths(sliceFrontIndex(n.x, n.y, n.z), mStripOrder)));
  }
  p.set(mAt.invAtlasSize, atlas.inverseSize());
  p.set(mAt.invSpacing, glm::vec3(1.0 / meta.spacing.x, 1.0 / meta.spacing.y, 1.0 / meta.spacing.z));
  p.set(mAt.dims, glm::vec3(double(meta.dims.x), double(meta.dims.y), double(meta.dims.z)));
  p.set(mAt.halfDims, glm::vec3(0.5 * double(meta.dims.x), 0.5 * double(meta.dims.y), 0.5 * double(meta.dims.z)));
  // The window in the units a texture fetch returns (normalised formats return raw * valueScale).
  p.set(mAt.windowLo, float(plan.window.lo * atlas.valueScale()));
  p.set(mAt.windowScale, float(plan.window.inverseWidth / atlas.valueScale()));
  p.set(mAt.stepOverReference, float(plan.step / plan.referenceLength));
  p.set(mAt.eye, glm::vec3(plan.camera.eye));
  p.set(mAt.viewDir, glm::vec3(plan.planeNormal));
  p.set(mAt.orthographic, plan.camera.orthographic ? 1 : 0);
  p.set(mAt.rayOrigin, glm::vec3(plan.rays.origin));
  p.set(mAt.rayOriginDx, glm::vec3(plan.rays.originDx));
  p.set(mAt.rayOriginDy, glm::vec3(plan.rays.originDy));
  p.set(mAt.rayDirection, glm::vec3(plan.rays.direction));
  p.set(mAt.rayDirectionDx, glm::vec3(plan.rays.directionDx));
  p.set(mAt.rayDirectionDy, glm::vec3(plan.rays.directionDy));
  // Above any opacity when termination is off.
  p.set(mAt.termination, plan.ert > 0 ? float(plan.ert) : 2.0f);
}

void VolumeProgram::setTable(const PreIntegrationSpec& spec) const {
  mProgram.set(mAt.tableResolution, float(spec.resolution));
  mProgram.set(mAt.ratioMin, float(spec.ratioMin));
  mProgram.set(mAt.layerScale, float(spec.layerScale()));
  mProgram.set(mAt.layers, float(spec.layers));
}

void VolumeProgram::setCells(const glm::ivec3& cells, int shift) const {
  mProgram.set(mAt.cellShift, shift);
  mProgram.set(mAt.cellCount, glm::vec3(cells));
}

const VolumeProgram& VolumePrograms::get(const ProgramKey& key) {
  auto it = mPrograms.find(key);
  if (it == mPrograms.end()) it = mPrograms.try_emplace(key, mGl, key).first;
  return it->second;
}

}  // namespace voxbrick::render
