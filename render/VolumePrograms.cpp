// Building slicing programs from the embedded shaders and setting their per-frame uniforms.
#include "render/VolumePrograms.h"

#include <string>
#include <vector>

#include "render/SliceTables.h"

namespace voxbrick::render {
namespace {

ProgramSources sources(const ProgramKey& key) {
  std::vector<std::string> defines;
  if (key.exactOwnership) defines.push_back("EXACT_OWNERSHIP");
  if (key.model == FragmentModel::Roofline) defines.push_back("ROOFLINE");
  if (key.model == FragmentModel::Shaded) defines.push_back("SHADING");
  if (key.slab) defines.push_back("SLAB");
  if (key.raycast) defines.push_back("RAYCAST");
  if (key.preIntegration) defines.push_back("PRE_INTEGRATION");
  if (key.emptyTest) defines.push_back("EMPTY_TEST");
  const char* vertex = key.raycast                  ? "raycast.vert.glsl"
                       : key.slab                  ? "slab.vert.glsl"
                       : key.slicer == Slicer::Cpu ? "slice_cpu.vert.glsl"
                                                   : "slice.vert.glsl";
  return ProgramSources::fromFiles(std::string("volume/") + vertex,
                                   {{GL_VERTEX_SHADER, vertex}, {GL_FRAGMENT_SHADER, "volume.frag.glsl"}}, defines);
}

}  // namespace

VolumeProgram::VolumeProgram(const Gl& gl, const ProgramKey& key) : mProgram(gl, sources(key)) {
  if (key.slicer == Slicer::Vertex && !key.slab && !key.raycast)
    for (const SliceTableUniform& table : kSliceTableUniforms)
      mProgram.set(mProgram.requireUniform(table.name), table.values);
  auto at = [this](const char* name) { return mProgram.uniformLocation(name); };
  mAt = {at(kSliceViewProjUniform), at(kSliceNormalUniform), at(kSlicePlaneIncrUniform), at("uAtlas"),
         at("uTransfer"), at("uInvAtlasSize"), at("uInvSpacing"), at("uDims"), at("uHalfDims"), at("uWindowLo"),
         at("uWindowScale"), at("uStepOverReference"), at("uEye"), at("uViewDir"), at("uOrthographic"),
         at("uRayOrigin"), at("uRayOriginDx"), at("uRayOriginDy"), at("uRayDirection"), at("uRayDirectionDx"),
         at("uRayDirectionDy"), at("uTermination"), at("uPreIntegrated"), at("uTableResolution"),
         at("uRatioMin"), at("uLayerScale"), at("uLayers"), at("uCells"), at("uCellShift"), at("uCellCount")};
}

void VolumeProgram::setFrame(const FramePlan& plan, const BrickAtlas& atlas, const store::StoreMeta& meta) const {
  const Program& p = mProgram;
  p.set(mAt.viewProj, glm::mat4(plan.viewProj));
  p.set(mAt.planeNormal, glm::vec3(plan.planeNormal));
  p.set(mAt.planeIncr, float(plan.step));
  p.set(mAt.atlas, 0);
  p.set(mAt.transfer, 1);
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
  mProgram.set(mAt.table, 3);
  mProgram.set(mAt.tableResolution, float(spec.resolution));
  mProgram.set(mAt.ratioMin, float(spec.ratioMin));
  mProgram.set(mAt.layerScale, float(spec.layerScale()));
  mProgram.set(mAt.layers, float(spec.layers));
}

void VolumeProgram::setCells(const glm::ivec3& cells, int shift) const {
  mProgram.set(mAt.cells, 4);
  mProgram.set(mAt.cellShift, shift);
  mProgram.set(mAt.cellCount, glm::vec3(cells));
}

const VolumeProgram& VolumePrograms::get(const ProgramKey& key) {
  auto it = mPrograms.find(key);
  if (it == mPrograms.end()) it = mPrograms.try_emplace(key, mGl, key).first;
  return it->second;
}

}  // namespace voxbrick::render
