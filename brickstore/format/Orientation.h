// Where a volume lies in the world: the index-to-world transform read at ingest (NIfTI qform/sform, NRRD space
// directions and origin, DICOM image position and orientation), kept in store.json and used by the renderer, so that
// flipped, permuted and oblique acquisitions show the same anatomy in the same place.
#pragma once

#include <array>
#include <string>

#include "brickstore/format/Types.h"

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
  Vec origin{0, 0, 0};                                         ///< world position of voxel (0, 0, 0)'s centre
  /// True when the input stated a patient frame: named views and the default up then mean anatomy (superior up).
  bool patient = false;

  bool operator==(const Orientation&) const = default;
};

/// An index-to-world transform as files give it: the world (RAS) step of one voxel along i, j and k (columns, so
/// their lengths are the spacing) and the world position of voxel (0, 0, 0). fromDirections splits it into unit axes
/// and spacing. Shear: axes whose pairwise angles are within kShearTolerance radians of 90 degrees (the round-off
/// of float headers) are made orthonormal silently (Gram-Schmidt in i, j, k order); a larger shear is refused,
/// since the optical model places voxels on an orthogonal grid: resample the input first.
struct Directions {
  std::array<Orientation::Vec, 3> columns{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  Orientation::Vec origin{0, 0, 0};
  bool patient = true;
};

/// The largest deviation from orthogonality (radians, about 0.06 degrees) that fromDirections corrects silently.
inline constexpr double kShearTolerance = 1e-3;

/// The orientation of `d` and its spacing (the columns' lengths) in `spacing`. Throws InputError naming `what` for a
/// non-finite origin or column, a zero column, parallel columns, or a shear beyond kShearTolerance (naming the angle).
Orientation fromDirections(const Directions& d, const std::string& what, Vec3d& spacing);

/// The axes as three letters, one per index axis, naming the direction it increases towards: R/L, A/P, S/I
/// ("RAS", "LPI", "ASR"); "oblique" when an axis is more than 1e-4 off a world axis.
std::string axesLetters(const Orientation& o);

/// One line for logs and `voxbrick info`: "RAS, origin (x, y, z)" plus ", no patient frame" when !patient.
std::string orientationText(const Orientation& o);

}  // namespace voxbrick::store
