// mesh.json. The counts are repeated from the index so that a reader can check one against the other, and so that
// tools can describe a store without parsing binary.
#include "mesh/MeshMeta.h"

#include <cmath>

#include <nlohmann/json.hpp>

namespace voxbrick::mesh {
namespace {

constexpr const char* kFormatName = "voxbrick-mesh";

nlohmann::ordered_json vec(const glm::vec3& v) { return nlohmann::ordered_json::array({v.x, v.y, v.z}); }

}  // namespace

std::string meshInfoToJson(const MeshStoreInfo& info) {
  nlohmann::ordered_json j;
  j["format"] = kFormatName;
  j["version"] = kMeshIndexVersion;
  j["field"] = info.field;
  j["source"] = info.source;
  j["vertices"] = info.vertexCount;
  j["tets"] = info.tetCount;
  j["boundaryFaces"] = info.boundaryFaceCount;
  j["chunks"] = info.chunkCount;
  j["tetsPerChunk"] = info.tetsPerChunk;
  j["zstdLevel"] = info.zstdLevel;
  j["bounds"] = {{"min", vec(info.boundsMin)}, {"max", vec(info.boundsMax)}};
  j["scalarRange"] = {info.scalarMin, info.scalarMax};
  j["edgeLengths"] = {{"mean", info.meanEdgeLength}, {"longest", info.longestEdge}};
  j["bytesRaw"] = info.bytesRaw;
  j["bytesStored"] = info.bytesStored;
  // Non-ASCII in a field name or path is replaced rather than thrown on: the metadata must always be writable.
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

MeshStoreInfo meshInfoFromJson(const std::string& text, const std::string& where) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw MeshError(where + ": not a JSON object");
  if (j.value("format", std::string()) != kFormatName) throw MeshError(where + ": not a voxbrick mesh store");
  MeshStoreInfo info;
  try {
    const uint32_t version = j.at("version").get<uint32_t>();
    if (version != kMeshIndexVersion)
      throw MeshError(where + ": version " + std::to_string(version) + ", this build reads " +
                      std::to_string(kMeshIndexVersion));
    info.field = j.at("field").get<std::string>();
    info.source = j.value("source", std::string());
    info.vertexCount = j.at("vertices").get<uint64_t>();
    info.tetCount = j.at("tets").get<uint64_t>();
    info.boundaryFaceCount = j.at("boundaryFaces").get<uint64_t>();
    info.chunkCount = j.at("chunks").get<uint32_t>();
    info.tetsPerChunk = j.at("tetsPerChunk").get<uint32_t>();
    info.zstdLevel = j.at("zstdLevel").get<int>();
    if (j.contains("edgeLengths")) {  // absent in stores written before it was recorded
      info.meanEdgeLength = j.at("edgeLengths").at("mean").get<double>();
      info.longestEdge = j.at("edgeLengths").at("longest").get<double>();
      if (!(info.meanEdgeLength > 0 && info.longestEdge >= info.meanEdgeLength && std::isfinite(info.longestEdge)))
        throw MeshError(where + ": edgeLengths: a mean of " + std::to_string(info.meanEdgeLength) +
                        " and a longest of " + std::to_string(info.longestEdge) +
                        " are not the lengths of a mesh's edges");
    }
  } catch (const nlohmann::json::exception& e) {
    throw MeshError(where + ": " + e.what());
  }
  return info;
}

}  // namespace voxbrick::mesh
