// The shading of the optical model (ARCHITECTURE.md): a two-sided Phong headlight, computed alike by the GPU's
// programs (volume_sample.glsl, tet.glsl) and the CPU references of grids and meshes.
#pragma once

#include <cmath>

#include <glm/glm.hpp>

namespace voxbrick::render {

/// (x, y) such that a straight colour c is shaded to c x + y (a premultiplied one, with opacity a, to c x + y a), for
/// `diffuse` = |normal · direction to the eye| in [0, 1].
inline glm::dvec2 headlight(double diffuse) { return {0.3 + 0.7 * diffuse, 0.25 * std::pow(diffuse, 32.0)}; }

}  // namespace voxbrick::render
