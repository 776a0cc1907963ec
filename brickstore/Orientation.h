// Where a volume lies in the world: the index-to-world transform read at ingest (NIfTI qform/sform, NRRD space
// directions and origin, DICOM image position and orientation), kept in store.json and used by the renderer, so that
// flipped, permuted and oblique acquisitions show the same anatomy in the same place.
#pragma once

#include <array>
#include <string>

#include "brickstore/Types.h"

namespace voxbrick::store {

/// The world frame is RAS, as in NIfTI and 3D Slicer: +x towards the patient's Right, +y Anterior, +z Superior,
/// in millimetres (or the input's unit). Inputs in LPS (DICOM, NRRD "left-posterior-superior") are converted by
/// negating x and y. Data without a patient frame (raw, synthetic, OpenVDB, NRRD without "space") keep the identity
/// axes and patient = false.
///
/// Voxel (i, j, k) has its centre at origin + i * spacing.x * axes[0] + j * spacing.y * axes[1] + k * spacing.z *
/// axes[2]. The axes are unit and mutually orthogonal (a determinant of -1 is a mirrored acquisition, allowed).
struct Orientation {
  using Vec = std::array<double, 3>;
  std::array<Vec, 3> axes{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};  ///< world direction of index axes i, j, k (RAS)
  Vec origin{0, 0, 0};  ///< world position of voxel (0, 0, 0)'s centre
  /// True when the input stated a patient frame: named views and the default up then mean anatomy (superior up).
  bool patient = false;

  bool operator==(const Orientation&) const = default;
};

}  // namespace voxbrick::store
