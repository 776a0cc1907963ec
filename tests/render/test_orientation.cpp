// Patient orientation end to end: one phantom defined in world (RAS) coordinates, written as NIfTI and NRRD files
// with different index-to-world transforms (identity, x flipped, permuted, oblique; RAS and LPS spaces), prepped and
// rendered with the same world camera by `voxbrick`, must give the same image. And the camera options' surprises.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "image/Image.h"
#include "support/DicomSeries.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using test::runVoxbrick;
using test::ScratchDir;

constexpr int kN = 48;              // samples per axis
constexpr double kSpacing = 1.5;    // mm
const glm::dvec3 kCentre{0, 0, 6};  // world centre of every file's box

// A smooth step from 0 (d <= -0.75) to 1 (d >= 0.75): soft edges, so that an oblique grid samples the same shapes.
double soft(double d) { return glm::clamp(d / 1.5 + 0.5, 0.0, 1.0); }

// The phantom in RAS millimetres: a ball (0.4) at the origin, a blob (1.0) on the patient's right (+x) and a bar
// (0.7) superior (+z), apart from one another.
double phantom(const glm::dvec3& p) {
  const double ball = 0.4 * soft(14 - glm::length(p));
  const double blob = 1.0 * soft(6 - glm::length(p - glm::dvec3(24, 0, 0)));
  const glm::dvec3 q = glm::abs(p - glm::dvec3(0, 0, 24));
  const double bar = 0.7 * soft(std::min({4 - q.x, 10 - q.y, 4 - q.z}));
  return std::max({ball, blob, bar});
}

// Where a file puts its voxels: voxel (i, j, k) at origin + axes * ((i, j, k) * spacing), axes' columns unit RAS.
struct Placement {
  glm::dmat3 axes{1.0};
  glm::dvec3 origin{0.0};
};

// The placement whose box is centred on kCentre.
Placement centred(const glm::dmat3& axes) { return {axes, kCentre - axes * glm::dvec3(0.5 * (kN - 1) * kSpacing)}; }

// The phantom sampled at the placement's voxel centres, x fastest.
std::vector<float> sample(const Placement& p) {
  std::vector<float> v;
  v.reserve(size_t(kN) * kN * kN);
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) v.push_back(float(phantom(p.origin + p.axes * (kSpacing * glm::dvec3(i, j, k)))));
  return v;
}

template <typename T>
void put(std::vector<char>& bytes, size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof value);
}

// A little-endian float32 NIfTI-1 file. With `quaternion` (b, c, d) the transform is a qform (code 1; the axes must
// be that quaternion's rotation), else an sform (code 1) of the placement.
void writeNifti(const std::filesystem::path& path, const Placement& p, const float* quaternion = nullptr) {
  std::vector<char> bytes(352, 0);
  put<int32_t>(bytes, 0, 348);
  const int16_t dim[8] = {3, kN, kN, kN, 1, 1, 1, 1};
  for (size_t i = 0; i < 8; ++i) put<int16_t>(bytes, 40 + 2 * i, dim[i]);
  put<int16_t>(bytes, 70, 16);  // float32
  put<int16_t>(bytes, 72, 32);
  const float pixdim[8] = {1, float(kSpacing), float(kSpacing), float(kSpacing), 1, 1, 1, 1};
  for (size_t i = 0; i < 8; ++i) put<float>(bytes, 76 + 4 * i, pixdim[i]);
  put<float>(bytes, 108, 352);
  if (quaternion) {
    put<int16_t>(bytes, 252, 1);
    for (size_t i = 0; i < 3; ++i) put<float>(bytes, 256 + 4 * i, quaternion[i]);
    for (size_t i = 0; i < 3; ++i) put<float>(bytes, 268 + 4 * i, float(p.origin[int(i)]));
  } else {
    put<int16_t>(bytes, 254, 1);
    for (int row = 0; row < 3; ++row) {
      for (int a = 0; a < 3; ++a) put<float>(bytes, size_t(280 + 16 * row + 4 * a), float(kSpacing * p.axes[a][row]));
      put<float>(bytes, size_t(280 + 16 * row + 12), float(p.origin[row]));
    }
  }
  std::memcpy(bytes.data() + 344, "n+1\0", 4);
  const std::vector<float> values = sample(p);
  const char* data = reinterpret_cast<const char*>(values.data());
  bytes.insert(bytes.end(), data, data + values.size() * sizeof(float));
  test::writeFile(path, bytes.data(), bytes.size());
}

std::string vectorText(const glm::dvec3& v) {
  char text[128];
  std::snprintf(text, sizeof text, "(%.17g,%.17g,%.17g)", v.x, v.y, v.z);
  return text;
}

// A raw float NRRD of the placement in `space` ("right-anterior-superior" or "left-posterior-superior": then the
// directions and origin are written in LPS, x and y negated).
void writeNrrd(const std::filesystem::path& path, const Placement& p, const std::string& space) {
  const glm::dvec3 toSpace = space == "left-posterior-superior" ? glm::dvec3(-1, -1, 1) : glm::dvec3(1);
  std::string header = "NRRD0004\ntype: float\ndimension: 3\nsizes: " + std::to_string(kN) + " " + std::to_string(kN) +
                       " " + std::to_string(kN) + "\nencoding: raw\nendian: little\nspace: " + space +
                       "\nspace directions:";
  for (int a = 0; a < 3; ++a) header += " " + vectorText(toSpace * (kSpacing * p.axes[a]));
  header += "\nspace origin: " + vectorText(toSpace * p.origin) + "\n\n";
  const std::vector<float> values = sample(p);
  std::vector<char> bytes(header.begin(), header.end());
  const char* data = reinterpret_cast<const char*>(values.data());
  bytes.insert(bytes.end(), data, data + values.size() * sizeof(float));
  test::writeFile(path, bytes.data(), bytes.size());
}

// The phantom as a DICOM series in `dir`, acquired coronally in DICOM's LPS frame: rows run to the patient's left,
// columns down (inferior), slices posterior; values stored as integers of 1/1000 with a rescale slope of 0.001.
void writeDicom(const std::filesystem::path& dir) {
  const glm::dmat3 axes(glm::dvec3(-1, 0, 0), glm::dvec3(0, 0, -1), glm::dvec3(0, -1, 0));  // RAS: L, I, P
  const Placement p = centred(axes);
  test::DicomSeriesSpec spec;
  spec.dims = {kN, kN, kN};
  spec.spacing = {kSpacing, kSpacing, kSpacing};
  spec.rowLps = {1, 0, 0};
  spec.columnLps = {0, 0, -1};
  spec.originLps = {-p.origin.x, -p.origin.y, p.origin.z};
  spec.slope = 0.001;
  std::filesystem::create_directories(dir);
  test::writeDicomSeries(dir, spec, [](const test::Vec3& ras) { return phantom({ras[0], ras[1], ras[2]}); });
}

// Red for the blob, green for the bar, a faint blue for the ball; nothing else.
const char* kTransferFunction = R"({"points": [[0.0, 0, 0, 0, 0], [0.3, 0, 0, 0, 0], [0.4, 0, 0, 1, 0.03],
  [0.5, 0, 0, 0, 0], [0.62, 0, 0, 0, 0], [0.7, 0, 1, 0, 0.3], [0.78, 0, 0, 0, 0], [0.9, 0, 0, 0, 0],
  [1.0, 1, 0, 0, 0.6]]})";

// Preps `input` (a file in `dir`) into INPUT.store; its path.
std::string prep(const ScratchDir& dir, const std::string& input) {
  const std::string store = (dir / (input + ".store")).string();
  const auto r = runVoxbrick("prep " + (dir / input).string() + " --brick 16 --no-vdb -q -o " + store);
  EXPECT_EQ(r.exitCode, 0) << r.output;
  return store;
}

// Renders `store` with the camera `options` (96 x 96, the phantom's transfer function); the image.
image::ImageF render(const ScratchDir& dir, const std::string& store, const std::string& options) {
  const std::string png = (dir / "frame.png").string();
  std::filesystem::remove(png);
  const auto r = runVoxbrick("render " + store + " " + options + " --size 96x96 --window 0,1 --tf " +
                             (dir / "tf.json").string() + " -q -o " + png);
  EXPECT_EQ(r.exitCode, 0) << r.output;
  return image::toImageF(image::readPng(png));
}

image::ImageF prepAndRender(const ScratchDir& dir, const std::string& input, const std::string& options) {
  return render(dir, prep(dir, input), options);
}

// The centroid of the pixels where channel `c` dominates (weighted by its excess over the other two: a feature seen
// through another's thin edge, whose values pass through its band, does not count), and the total weight.
glm::dvec3 centroid(const image::ImageF& image, int c) {
  glm::dvec3 sum(0.0);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const float* p = image.pixel(x, y);
      const double excess = double(p[c]) - double(p[(c + 1) % 3]) - double(p[(c + 2) % 3]);
      if (excess > 0) sum += excess * glm::dvec3(x, y, 1);
    }
  return {sum.x / sum.z, sum.y / sum.z, sum.z};
}

image::ImageF mirrored(image::ImageF image) {
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width / 2; ++x)
      std::swap_ranges(image.pixel(x, y), image.pixel(x, y) + 4, image.pixel(image.width - 1 - x, y));
  return image;
}

// A rotation of `degrees` about the unit `axis` as a NIfTI quaternion (b, c, d), and its matrix computed from those
// float values as a reader does.
glm::dmat3 quaternionRotation(double degrees, const glm::dvec3& axis, float bcd[3]) {
  const double half = glm::radians(degrees) / 2;
  for (int i = 0; i < 3; ++i) bcd[i] = float(std::sin(half) * axis[i]);
  const double b = bcd[0], c = bcd[1], d = bcd[2], a = std::sqrt(1 - b * b - c * c - d * d);
  return glm::transpose(glm::dmat3(a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c),
                                   2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b),
                                   2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b));
}

class OrientationPhantom : public ::testing::Test {
 protected:
  void SetUp() override { test::writeFile(mDir / "tf.json", kTransferFunction); }
  ScratchDir mDir;
};

TEST_F(OrientationPhantom, EveryFileOfTheSameWorldRendersTheSameImage) {
  const glm::dmat3 identity(1.0);
  glm::dmat3 flipX(1.0);
  flipX[0] = {-1, 0, 0};
  const glm::dmat3 permuted(glm::dvec3(0, 0, 1), glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0));  // i->S, j->R, k->P
  float bcd[3];
  const glm::dmat3 oblique = quaternionRotation(25, glm::normalize(glm::dvec3(1, 2, 0.5)), bcd);
  Placement obliquePlacement = centred(oblique);
  obliquePlacement.origin = glm::dvec3(glm::vec3(obliquePlacement.origin));  // as the float header stores it

  writeNifti(mDir / "identity.nii", centred(identity));
  writeNifti(mDir / "flipped.nii", centred(flipX));
  writeNifti(mDir / "permuted.nii", centred(permuted));
  writeNifti(mDir / "oblique.nii", obliquePlacement, bcd);
  writeNrrd(mDir / "ras.nrrd", centred(permuted), "right-anterior-superior");
  writeNrrd(mDir / "lps.nrrd", centred(flipX), "left-posterior-superior");
  writeDicom(mDir / "coronal-dicom");

  const std::string camera = "--view anterior";
  const image::ImageF reference = prepAndRender(mDir, "identity.nii", camera);
  // Anterior view, as in 3D Slicer: the patient's right (the blob) on the screen's left, superior (the bar) up.
  const glm::dvec3 blob = centroid(reference, 0), bar = centroid(reference, 1);
  // The fitted eye is 1.05 R / sin 15 = 253 mm from the centre (0, 0, 6): 67.8 mm of the world at the features'
  // depth span the image's half height of 48 pixels.
  EXPECT_NEAR(blob.x, 47.5 - 24 / 67.8 * 48, 2.5) << "the blob (patient's right) should be left of the centre";
  EXPECT_NEAR(blob.y, 47.5 + 6 / 67.8 * 48, 2.5);
  EXPECT_NEAR(bar.x, 47.5, 2.5);
  EXPECT_NEAR(bar.y, 47.5 - 18 / 67.8 * 48, 2.5) << "the bar (superior) should be above the centre";
  EXPECT_GT(blob.z, 5);  // both in sight: tens of pixels each
  EXPECT_GT(bar.z, 5);

  for (const char* file : {"flipped.nii", "permuted.nii", "ras.nrrd", "lps.nrrd", "coronal-dicom"}) {
    const image::ImageF image = prepAndRender(mDir, file, camera);
    const image::ImageError e = image::compareImages(reference, image);
    EXPECT_GT(e.psnr, 40) << file;
    EXPECT_LE(e.maxAbs, 4.0 / 255) << file;
    // The phantom is asymmetric: reading the flipped file without its orientation gives the mirror image, which
    // is far from this one.
    if (std::string(file) == "flipped.nii") {
      EXPECT_GT(image::compareImages(mirrored(reference), image).maxAbs, 0.5);
    }
  }
  const image::ImageF tilted = prepAndRender(mDir, "oblique.nii", camera);
  EXPECT_GT(image::compareImages(reference, tilted).psnr, 25);
  for (int c = 0; c < 3; ++c) {
    const glm::dvec3 a = centroid(reference, c), b = centroid(tilted, c);
    EXPECT_LT(glm::length(glm::dvec2(a) - glm::dvec2(b)), 1.5) << "channel " << c;
  }
}

TEST_F(OrientationPhantom, NamedViewsShowSuperiorUp) {
  writeNifti(mDir / "flipped.nii", centred(glm::dmat3(glm::dvec3(-1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1))));
  const std::string store = prep(mDir, "flipped.nii");
  // Seen from either side or from behind, the bar (superior) is on top, in the middle.
  for (const char* view : {"left", "right", "posterior"}) {
    const image::ImageF image = render(mDir, store, std::string("--view ") + view);
    const glm::dvec3 bar = centroid(image, 1);
    EXPECT_LT(bar.y, 40) << view << ": the bar (superior) should be above the centre";
    EXPECT_NEAR(bar.x, 47.5, 3) << view;
  }
  // Posterior: the patient's right is on the screen's right.
  const glm::dvec3 blob = centroid(render(mDir, store, "--view posterior --fit"), 0);
  EXPECT_GT(blob.x, 55);
}

TEST_F(OrientationPhantom, CameraOptionsAreAppliedOrRefused) {
  writeNifti(mDir / "v.nii", centred(glm::dmat3(1.0)));
  const std::string store = prep(mDir, "v.nii"), png = (mDir / "x.png").string();
  // --center and --up without --eye were silently ignored.
  for (const char* option : {"--center 1,2,3", "--up 0,0,1"}) {
    const auto r = runVoxbrick("render " + store + " " + option + " -q -o " + png);
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_NE(r.output.find(" needs --eye: an orbit or a view"), std::string::npos) << r.output;
  }
  // --eye over a scene keeps the scene's center and up (it reset them to 0,0,0 and +y).
  test::writeFile(mDir / "scene.json", R"({"camera": {"eye": [0, 150, 6], "center": [10, 0, 6], "up": [0, 0, 1]}})");
  const std::string scene = "--scene " + (mDir / "scene.json").string();
  const image::ImageF fromScene = render(mDir, store, scene);
  const image::ImageF withEye = render(mDir, store, scene + " --eye 0,150,6");
  EXPECT_EQ(image::compareImages(fromScene, withEye).maxAbs, 0);
  // --center over the scene's explicit camera moves its look-at point.
  EXPECT_GT(image::compareImages(fromScene, render(mDir, store, scene + " --center 0,0,6")).maxAbs, 0.1);
  const auto r = runVoxbrick("render " + store + " --view front -q -o " + png);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("--view: must be one of anterior, posterior, left, right, superior, inferior, not 'front'"),
            std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace voxbrick
