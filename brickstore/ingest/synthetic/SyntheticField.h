// Analytic test volumes (Marschner–Lobb, shells, blobs, sparse spheres, high dynamic range) behind "synthetic:".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// An analytic scalar field f evaluated in double precision, placed on a box of dims * spacing voxels.
///
/// Every field is defined over the normalised cube [-1,1]^3, which is stretched onto the box: a physical position
/// p maps to u = 2 p / (dims * spacing) per axis (so the box is centred on the origin), and sample (i,j,k) sits at
/// the cell centre p = ((i + 0.5) - dims / 2) * spacing. Below, (x,y,z) are normalised coordinates and
/// r = sqrt(x² + y² + z²). Spec keys common to all fields: n (voxels per axis), nx, ny, nz (override n per axis;
/// 1..16384). The fields:
///
/// - "marschner-lobb" (n = 64; keys fm = 6, alpha = 0.25): the Marschner–Lobb test signal
///   ρ = (1 − sin(πz/2) + α(1 + ρr(sqrt(x² + y²)))) / (2(1 + α)), ρr(s) = cos(2π fM cos(πs/2)); range [0,1], 0.6 at
///   the centre.
/// - "shells" (n = 128; keys count = 3, width = 1 / (8 (count + 1))): shells at radii r_k = k / (count + 1),
///   k = 1..count, each a Gaussian of standard deviation w = width cut off at 4w and lowered to reach 0 there:
///   f = max_k g((r − r_k) / w), g(t) = (exp(−t²/2) − e^−8) / (1 − e^−8) for |t| < 4, else exactly 0. Range [0,1].
/// - "blobs" (n = 128; keys count = 8, seed = 1): f = Σ_k a_k exp(−|u − c_k|² / (2 σ_k²)), with centres c_k in
///   [−0.6,0.6]^3, σ_k in [0.08,0.2] and a_k in [0.5,1] drawn from a SplitMix64 stream seeded with `seed`.
///   Range [0, ~1] (a little above 1 only where blobs overlap).
/// - "sparse" (n = 128; keys fill = 0.03 in (0,0.2], count = 6, seed = 1): `count` disjoint balls of equal radius
///   R = cbrt(6 fill / (π count)) (together `fill` of the cube's volume), centres drawn from the seeded stream,
///   each fully inside the cube; f = 1 − (d/R)² inside a ball (d = distance to its centre), exactly 0 outside.
/// - "hdr" (n = 64; no keys): f = 10^(−6 + 12 g), g = (1 + cos(π min(r/√3, 1))) / 2; 1e6 at the centre, falling
///   smoothly to 1e-6 at the cube's corners; positive everywhere.
///
/// All fields are delivered as F32 with background 0 and default spacing 1.
class SyntheticField {
 public:
  /// Parses "NAME[,key=value...]", e.g. "shells,n=128,count=4". Throws InputError naming the spec and the problem.
  static SyntheticField parse(const std::string& spec);

  /// The field names parse() accepts.
  static std::vector<std::string> names();

  /// The field's name, e.g. "marschner-lobb".
  const std::string& name() const { return mName; }
  /// Voxels along x, y, z.
  const Vec3i& dims() const { return mDims; }
  /// Physical voxel size (default 1,1,1).
  const Vec3d& spacing() const { return mSpacing; }
  /// Changes the voxel size; the field stays stretched over the (new) box, so samples do not change.
  void setSpacing(const Vec3d& spacing);
  /// The voxel type a synthetic source delivers (always F32).
  ValueType type() const { return ValueType::F32; }
  /// The value of empty space (0 for every field).
  double background() const { return 0.0; }

  /// f at a physical position (the box is centred on the origin).
  double evaluate(double x, double y, double z) const;
  /// f at normalised coordinates, where the box is [-1,1]^3.
  double evaluateNormalised(double x, double y, double z) const;
  /// f at the centre of voxel (i,j,k).
  double sample(int64_t i, int64_t j, int64_t k) const;
  /// Row (j, k) of samples: out[i] = float(sample(i, j, k)) for i in [0, nx), bit for bit (the same operations in
  /// the same order), with what the row shares computed once: coordinates, each bump's y and z terms, and the balls
  /// that miss the row altogether. Thread-safe.
  void sampleRow(int64_t j, int64_t k, float* out) const;

 private:
  enum class Kind { MarschnerLobb, Shells, Blobs, Sparse, Hdr };

  /// A Gaussian blob or a ball, in normalised coordinates.
  struct Bump {
    double cx = 0, cy = 0, cz = 0;
    double radius = 0;  ///< σ of a blob, radius of a ball
    double amplitude = 1;
  };

  SyntheticField() = default;
  /// Fills mAxis from the dims and spacing.
  void updateAxes();
  /// The blobs: `count` bumps drawn from a SplitMix64 stream seeded with `seed`.
  void drawBlobs(int64_t count, uint64_t seed);
  /// The sparse field's balls: `count` disjoint balls filling `fill` of the cube, drawn from a SplitMix64 stream
  /// seeded with `seed`; false if they could not be placed.
  bool drawBalls(double fill, int64_t count, uint64_t seed);
  template <typename PerVoxel>
  void sampleRowWith(int64_t j, int64_t k, float* out, PerVoxel f) const;
  void blobsRow(int64_t j, int64_t k, float* out) const;
  void sparseRow(int64_t j, int64_t k, float* out) const;
  double marschnerLobb(double x, double y, double z) const;
  double shells(double x, double y, double z) const;
  double blobs(double x, double y, double z) const;
  double sparse(double x, double y, double z) const;
  static double hdr(double x, double y, double z);

  Kind mKind = Kind::MarschnerLobb;
  std::string mName;
  Vec3i mDims;
  Vec3d mSpacing;
  double mFm = 6.0, mAlpha = 0.25;  // marschner-lobb
  int64_t mCount = 0;               // shells
  double mWidth = 0.0;              // shells
  std::vector<Bump> mBumps;         // blobs, sparse
  std::vector<double> mAxis[3];     // normalised coordinate of every sample index along x, y, z
};

}  // namespace voxbrick::store
