#include "mesh/SyntheticMesh.h"

#include <charconv>
#include <cmath>
#include <map>

namespace voxbrick::mesh {

namespace {

constexpr int kMaxCells = 256;  // 6 * 256^3 = 100 M tets, 1.6 GB of indices: as large as a test machine allows

struct Options {
  std::string shape;
  int n = 16;
  std::string field = "blobs";
};

Options parseSpec(const std::string& spec) {
  auto fail = [&](const std::string& problem) -> void { throw MeshError("synthetic mesh '" + spec + "': " + problem); };
  std::vector<std::string> parts;
  for (size_t start = 0;;) {
    const size_t comma = spec.find(',', start);
    parts.push_back(spec.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  Options options;
  options.shape = parts[0];
  if (options.shape != "box" && options.shape != "ball")
    fail("unknown shape '" + options.shape + "' (known: box, ball; form SHAPE[,n=N][,field=NAME])");
  std::map<std::string, std::string> values;
  for (size_t p = 1; p < parts.size(); ++p) {
    const size_t eq = parts[p].find('=');
    if (eq == std::string::npos || eq == 0) fail("expected key=value, got '" + parts[p] + "'");
    const std::string key = parts[p].substr(0, eq);
    if (key != "n" && key != "field") fail("unknown key '" + key + "' (known: n, field)");
    if (!values.emplace(key, parts[p].substr(eq + 1)).second) fail("key '" + key + "' is given twice");
  }
  if (auto it = values.find("n"); it != values.end()) {
    const std::string& text = it->second;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), options.n);
    if (ec != std::errc() || end != text.data() + text.size() || options.n < 1 || options.n > kMaxCells)
      fail("key 'n': expected an integer in [1, " + std::to_string(kMaxCells) + "], got '" + text + "'");
  }
  if (auto it = values.find("field"); it != values.end()) {
    options.field = it->second;
    if (options.field != "blobs" && options.field != "linear")
      fail("key 'field': unknown field '" + options.field + "' (known: blobs, linear)");
  }
  return options;
}

// The six tets of the unit cell as corner masks (bit 0: +x, bit 1: +y, bit 2: +z): each walks from corner 0 to
// corner 7 along one permutation of the axes. Every cell face is cut along the diagonal through its lowest and
// highest corner, the same from both sides, so the tets of neighbouring cells share whole faces.
std::vector<std::array<int, 4>> kuhnTets() {
  const int permutations[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  auto corner = [](int mask) { return glm::dvec3(mask & 1, (mask >> 1) & 1, (mask >> 2) & 1); };
  std::vector<std::array<int, 4>> tets;
  for (const auto& axes : permutations) {
    std::array<int, 4> tet{0, 1 << axes[0], (1 << axes[0]) | (1 << axes[1]), 7};
    const glm::dvec3 p0 = corner(tet[0]);
    const double volume6 = glm::dot(glm::cross(corner(tet[1]) - p0, corner(tet[2]) - p0), corner(tet[3]) - p0);
    if (volume6 < 0) std::swap(tet[2], tet[3]);  // odd permutations come out inverted
    tets.push_back(tet);
  }
  return tets;
}

}  // namespace

float blobsField(const glm::vec3& p) {
  struct Blob {
    float x, y, z, sigma, weight;
  };
  static constexpr Blob kBlobs[] = {
      {0.35f, 0.2f, -0.1f, 0.35f, 1.0f}, {-0.4f, -0.3f, 0.3f, 0.25f, 0.8f}, {0.05f, -0.45f, -0.45f, 0.3f, 0.6f}};
  float sum = 0.0f;
  for (const Blob& b : kBlobs) {
    const glm::vec3 d = p - glm::vec3(b.x, b.y, b.z);
    sum += b.weight * std::exp(-glm::dot(d, d) / (2.0f * b.sigma * b.sigma));
  }
  // A smooth saturation rather than a clamp: values spread over most of [0, 1) with no kink where blobs overlap.
  return 1.0f - std::exp(-2.5f * sum);
}

TetMesh syntheticMesh(const std::string& spec) {
  const Options options = parseSpec(spec);
  const uint32_t n = static_cast<uint32_t>(options.n);
  const uint32_t m = n + 1;  // vertices per axis
  auto coordinate = [&](uint32_t i) { return -1.0 + 2.0 * static_cast<double>(i) / static_cast<double>(n); };

  TetMesh mesh;
  mesh.points.resize(static_cast<size_t>(m) * m * m);
  for (uint32_t k = 0; k < m; ++k)
    for (uint32_t j = 0; j < m; ++j)
      for (uint32_t i = 0; i < m; ++i)
        mesh.points[i + m * (j + static_cast<size_t>(m) * k)] = glm::vec3(
            static_cast<float>(coordinate(i)), static_cast<float>(coordinate(j)), static_cast<float>(coordinate(k)));

  const std::vector<std::array<int, 4>> cellTets = kuhnTets();
  auto cornerOffset = [&](int mask) {
    return static_cast<uint32_t>((mask & 1) + m * (((mask >> 1) & 1) + m * ((mask >> 2) & 1)));
  };
  std::vector<uint8_t> inside;
  if (options.shape == "ball") {
    inside.resize(mesh.points.size());
    for (size_t v = 0; v < mesh.points.size(); ++v) {
      const uint32_t i = static_cast<uint32_t>(v % m), j = static_cast<uint32_t>(v / m % m),
                     k = static_cast<uint32_t>(v / m / m);
      const double r2 = coordinate(i) * coordinate(i) + coordinate(j) * coordinate(j) + coordinate(k) * coordinate(k);
      inside[v] = r2 <= 1.0 + 1e-12;  // on the sphere counts as inside, whatever the rounding of the coordinates
    }
  }
  mesh.tets.reserve(inside.empty() ? 6 * static_cast<size_t>(n) * n * n : 0);
  for (uint32_t k = 0; k < n; ++k)
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        const uint32_t base = i + m * (j + m * k);
        for (const std::array<int, 4>& corners : cellTets) {
          const Tet tet{base + cornerOffset(corners[0]), base + cornerOffset(corners[1]),
                        base + cornerOffset(corners[2]), base + cornerOffset(corners[3])};
          if (!inside.empty() && !(inside[tet[0]] && inside[tet[1]] && inside[tet[2]] && inside[tet[3]])) continue;
          mesh.tets.push_back(tet);
        }
      }
  if (mesh.tets.empty()) throw MeshError("synthetic mesh '" + spec + "': no tetrahedra (a larger n keeps some)");

  if (!inside.empty()) {
    // Drop the vertices no tet uses, keeping the others in grid order.
    std::vector<uint32_t> remap(mesh.points.size(), UINT32_MAX);
    for (const Tet& tet : mesh.tets)
      for (uint32_t v : tet) remap[v] = 0;
    std::vector<glm::vec3> kept;
    for (size_t v = 0; v < mesh.points.size(); ++v)
      if (remap[v] == 0) {
        remap[v] = static_cast<uint32_t>(kept.size());
        kept.push_back(mesh.points[v]);
      }
    for (Tet& tet : mesh.tets)
      for (uint32_t& v : tet) v = remap[v];
    mesh.points = std::move(kept);
  }

  mesh.field = options.field;
  mesh.scalars.resize(mesh.points.size());
  for (size_t v = 0; v < mesh.points.size(); ++v)
    mesh.scalars[v] = options.field == "blobs" ? blobsField(mesh.points[v]) : (mesh.points[v].x + 1.0f) * 0.5f;
  return mesh;
}

}  // namespace voxbrick::mesh
