// A mesh input into a mesh store: read, validate, match faces, write.
#include "mesh/MeshPrep.h"

#include <algorithm>
#include <cctype>
#include <chrono>

#include "mesh/MeshReaders.h"
#include "mesh/SyntheticMesh.h"
#include "mesh/Topology.h"

namespace voxbrick::mesh {
namespace {

constexpr std::string_view kSynthetic = "synthetic-mesh:";

}  // namespace

bool isMeshInput(const std::string& input) {
  std::string lower = input;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  auto endsWith = [&](const std::string& tail) {
    return lower.size() >= tail.size() && lower.compare(lower.size() - tail.size(), tail.size(), tail) == 0;
  };
  return endsWith(".vtk") || endsWith(".msh") || lower.rfind(kSynthetic, 0) == 0;
}

TetMesh readMeshInput(const std::string& input, const std::string& field) {
  if (input.rfind(kSynthetic, 0) == 0) return syntheticMesh(input.substr(kSynthetic.size()));
  return readMesh(input, field);
}

MeshPrepSummary prepMeshStore(const std::string& input, const std::filesystem::path& output,
                              const MeshPrepOptions& options,
                              const std::function<void(const MeshPrepProgress&)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  auto report = [&](const std::string& stage, const TetMesh* mesh, const MeshWriteProgress* write) {
    if (progress) progress({stage, mesh, write});
  };
  TetMesh mesh = readMeshInput(input, options.field);
  report("read", &mesh, nullptr);
  MeshPrepSummary summary;
  summary.repairs = validateMesh(mesh);
  report("validated", &mesh, nullptr);
  const Topology topology = buildTopology(mesh);
  report("topology", &mesh, nullptr);
  MeshStoreOptions store = options.store;
  store.source = input;
  store.progress = [&](const MeshWriteProgress& p) {
    if (options.store.progress) options.store.progress(p);
    report(p.stage, nullptr, &p);
  };
  summary.info = writeMeshStore(mesh, topology, output, store);
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace voxbrick::mesh
