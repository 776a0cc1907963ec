// Damaged inputs given to the real `voxbrick`: each is refused with status 1 and one line on stderr naming the file
// and the field, never accepted with a guessed value, and a store given with --force is left as it was.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support/TestSupport.h"

namespace voxbrick {
namespace {

namespace fs = std::filesystem;
using test::ScratchDir;

/// `voxbrick ARGS` with its standard output discarded: the exit status and standard error alone.
test::CommandResult stderrOf(const std::string& args) {
  return test::runShell("{ " + test::voxbrickExe() + " " + args + " 2>&1 >/dev/null; }");
}

/// Lines in `text`, a last one without its newline counted.
int lineCount(const std::string& text) {
  return int(std::count(text.begin(), text.end(), '\n')) + (!text.empty() && text.back() != '\n' ? 1 : 0);
}

/// Status 1 and one line on stderr that holds every one of `words`.
void expectRefusal(const test::CommandResult& r, const std::vector<std::string>& words) {
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_EQ(lineCount(r.output), 1) << r.output;
  for (const std::string& w : words)
    EXPECT_NE(r.output.find(w), std::string::npos) << "no '" << w << "' in " << r.output;
}

/// Every file of a store directory with its bytes.
std::map<std::string, std::vector<char>> storeFiles(const fs::path& dir) {
  std::map<std::string, std::vector<char>> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = test::readFile(e.path());
  return files;
}

/// Expects `prep INPUT --force` onto a good store in `dir` to be refused with `words`, leaving that store untouched.
void expectPrepRefused(const ScratchDir& dir, const fs::path& input, const std::vector<std::string>& words,
                       const std::string& options = "") {
  const fs::path kept = dir / "kept";
  if (!fs::exists(kept)) {
    ASSERT_EQ(test::runVoxbrick("prep synthetic:blobs,n=16 --brick 8 -q -o " + kept.string()).exitCode, 0);
  }
  const auto before = storeFiles(kept);
  std::vector<std::string> all{input.string()};
  all.insert(all.end(), words.begin(), words.end());
  expectRefusal(stderrOf("prep " + input.string() + " " + options + " --force -q -o " + kept.string()), all);
  EXPECT_TRUE(storeFiles(kept) == before) << "prep changed the store it was refused for";
}

/// An attached NRRD of 4x4x4 u8 zeros with `extra` header lines.
fs::path nrrd(const ScratchDir& dir, const std::string& name, const std::string& extra) {
  const fs::path path = dir / name;
  test::writeFile(path, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n" + extra + "\n" +
                            std::string(64, '\0'));
  return path;
}

TEST(DamagedInputs, NrrdSpacingsOutOfRangeAreRefused) {
  ScratchDir dir;
  expectPrepRefused(dir, nrrd(dir, "nan.nrrd", "spacings: nan 1 1.5\n"), {"'spacings' of spatial axis 0 is nan"});
  expectPrepRefused(dir, nrrd(dir, "neg.nrrd", "spacings: 1 -1 1.5\n"), {"'spacings' of spatial axis 1 is -1"});
  expectPrepRefused(dir, nrrd(dir, "huge.nrrd", "spacings: 1 1 1e308\n"), {"'spacings' of spatial axis 2 is 1e+308"});
  expectPrepRefused(dir, nrrd(dir, "dirs.nrrd", "space directions: (1e100,0,0) (0,1,0) (0,0,1)\n"),
                    {"'space directions' of spatial axis 0 is 1e+100"});
  // --spacing replaces the header's, so a file with a damaged one can still be read; an absurd --spacing cannot.
  EXPECT_EQ(
      test::runVoxbrick("prep " + (dir / "nan.nrrd").string() + " --spacing 1,1,1.5 -q -o " + (dir / "fixed").string())
          .exitCode,
      0);
  expectPrepRefused(dir, nrrd(dir, "good.nrrd", ""), {"--spacing", "[1e-12, 1e12]"}, "--spacing 1e308,1,1");
}

/// A single-file NIfTI-1 of 4x4x4 u8 zeros with pixdim[1..3] = `pixdim` and neither sform nor qform.
fs::path nifti(const ScratchDir& dir, const std::string& name, const std::vector<float>& pixdim) {
  std::vector<char> bytes(352 + 64, 0);
  auto put = [&](size_t offset, const auto& v) { std::memcpy(bytes.data() + offset, &v, sizeof v); };
  put(0, int32_t{348});
  const int16_t dim[8] = {3, 4, 4, 4, 1, 1, 1, 1};
  put(40, dim);
  put(70, int16_t{2});  // datatype uint8
  put(72, int16_t{8});  // bitpix
  const float pix[4] = {1, pixdim[0], pixdim[1], pixdim[2]};
  put(76, pix);
  put(108, float{352});  // vox_offset
  std::memcpy(bytes.data() + 344, "n+1", 4);
  const fs::path path = dir / name;
  test::writeFile(path, bytes.data(), bytes.size());
  return path;
}

TEST(DamagedInputs, NiftiPixdimOutOfRangeIsRefused) {
  ScratchDir dir;
  const float inf = std::numeric_limits<float>::infinity();
  expectPrepRefused(dir, nifti(dir, "nan.nii", {std::nanf(""), 1, 1}), {"pixdim[1] is nan"});
  expectPrepRefused(dir, nifti(dir, "zero.nii", {1, 0, 1}), {"pixdim[2] is 0"});
  expectPrepRefused(dir, nifti(dir, "neg.nii", {1, 1, -1}), {"pixdim[3] is -1"});
  expectPrepRefused(dir, nifti(dir, "inf.nii", {inf, 1, 1}), {"pixdim[1] is inf"});
  EXPECT_EQ(
      test::runVoxbrick("prep " + nifti(dir, "good.nii", {1, 2, 3}).string() + " -q -o " + (dir / "good").string())
          .exitCode,
      0);
}

/// Three 4x2 u8 pages, the `from`th page's next-page (IFD) offset pointing at page `to`'s (pages from 0).
fs::path loopingTiff(const ScratchDir& dir, const std::string& name, int from, int to) {
  const fs::path path = dir / name;
  TIFF* t = TIFFOpen(path.c_str(), "w");
  unsigned char row[4] = {1, 2, 3, 4};
  for (int p = 0; p < 3; ++p) {
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, 4);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, 2);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 8);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
    for (uint32_t y = 0; y < 2; ++y) TIFFWriteScanline(t, row, y, 0);
    TIFFWriteDirectory(t);
  }
  TIFFClose(t);
  std::vector<uint32_t> offsets;
  t = TIFFOpen(path.c_str(), "r");
  do offsets.push_back(uint32_t(TIFFCurrentDirOffset(t)));
  while (TIFFReadDirectory(t));
  TIFFClose(t);
  // A classic little-endian TIFF: a directory is a 2-byte entry count, 12 bytes an entry, then the next offset.
  std::vector<char> bytes = test::readFile(path);
  uint16_t entries;
  std::memcpy(&entries, bytes.data() + offsets.at(size_t(from)), 2);
  std::memcpy(bytes.data() + offsets[size_t(from)] + 2 + 12 * entries, &offsets.at(size_t(to)), 4);
  test::writeFile(path, bytes.data(), bytes.size());
  return path;
}

TEST(DamagedInputs, TiffPageChainThatLoopsIsRefused) {
  ScratchDir dir;
  expectPrepRefused(dir, loopingTiff(dir, "self.tif", 1, 1), {"page 2", "next-page (IFD) offset", "back to page 2"});
  expectPrepRefused(dir, loopingTiff(dir, "first.tif", 2, 0), {"page 3", "next-page (IFD) offset", "back to page 1"});
}

TEST(DamagedInputs, DetachedNrrdNamesTheHeaderAndTheDataFile) {
  ScratchDir dir;
  const std::string header = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\n";
  test::writeFile(dir / "short.raw", std::string(10, '\0'));
  test::writeFile(dir / "short.nhdr", header + "encoding: raw\ndata file: short.raw\n");
  expectPrepRefused(dir, dir / "short.nhdr", {"short.raw", "truncated"});
  // Gzip data is read only after the open: the error then comes from the data file's stream.
  test::writeFile(dir / "bad.raw.gz", std::string("\x1f\x8b\x08\x00 not really gzip data", 26));
  test::writeFile(dir / "bad.nhdr", header + "encoding: gzip\ndata file: bad.raw.gz\n");
  expectPrepRefused(dir, dir / "bad.nhdr", {"bad.raw.gz"});
}

TEST(DamagedInputs, DeclaredSizeBeyondMemoryNamesTheFile) {
  ScratchDir dir;
  const std::vector<char> data = test::gzipBytes("some voxels", 11);
  test::writeFile(dir / "big.nrrd",
                  "NRRD0004\ntype: float\ndimension: 3\nsizes: 32767 32767 2\nencoding: gzip\n"
                  "endian: little\n\n" +
                      std::string(data.begin(), data.end()));
  // Refused when the header is read, naming the field, before a slice of it is allocated.
  expectPrepRefused(dir, dir / "big.nrrd",
                    {"'sizes' declares slices of 32767x32767 voxels of 4 bytes", "--memory 1024 MB is too small"},
                    "--memory 1024");
}

/// A tetrahedron and a triangle in legacy ASCII VTK, with point scalars `scalars`.
fs::path vtk(const ScratchDir& dir, const std::string& name, const std::string& scalars) {
  const fs::path path = dir / name;
  test::writeFile(path,
                  "# vtk DataFile Version 3.0\ntet\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n"
                  "0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 2 9\n4 0 1 2 3\n3 0 1 2\nCELL_TYPES 2\n10\n5\n"
                  "POINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n" +
                      scalars + "\n");
  return path;
}

TEST(DamagedInputs, MeshRefusalsNameTheFileAndDroppedCellsAreSaid) {
  ScratchDir dir;
  expectPrepRefused(dir, vtk(dir, "nan.vtk", "nan 1 2 3"), {"vertex 0 has a non-finite scalar"});
  // The triangle is a boundary, not a volume: left out, and said so in one line.
  const test::CommandResult r =
      stderrOf("prep " + vtk(dir, "tri.vtk", "0 1 2 3").string() + " -q -o " + (dir / "mesh").string());
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(lineCount(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("tri.vtk: dropped 1 x triangle (VTK type 5)"), std::string::npos) << r.output;
}

/// A copy of a good store whose store.json has `key` set to `value`; its store.json's path.
fs::path editedStore(const ScratchDir& dir, const std::string& name, const std::string& key,
                     const nlohmann::json& value) {
  const fs::path good = dir / "good";
  if (!fs::exists(good)) {
    EXPECT_EQ(test::runVoxbrick("prep synthetic:blobs,n=16 --brick 8 -q -o " + good.string()).exitCode, 0);
  }
  fs::copy(good, dir / name, fs::copy_options::recursive);
  const std::vector<char> text = test::readFile(dir / name / "store.json");
  nlohmann::json j = nlohmann::json::parse(text.begin(), text.end());
  j[key] = value;
  test::writeFile(dir / name / "store.json", j.dump(2));
  return dir / name / "store.json";
}

TEST(DamagedInputs, StoreMetadataOutOfRangeIsRefused) {
  ScratchDir dir;
  auto expectInfoRefused = [&](const std::string& name, const std::string& key, const nlohmann::json& value,
                               const std::string& words) {
    const fs::path meta = editedStore(dir, name, key, value);
    expectRefusal(stderrOf("info " + (dir / name).string()), {meta.string(), words});
  };
  expectInfoRefused("spacing", "spacing", {0, 1, 1}, "key 'spacing' has 0");
  expectInfoRefused("huge", "spacing", {1, 1e300, 1}, "key 'spacing' has 1e+300");
  expectInfoRefused("range", "value_range", {1000, 0}, "key 'value_range' is [1000, 0]: lo > hi");
  expectInfoRefused("brick", "brick_size", 12, "key 'brick_size' is 12, not a power of two");
  expectInfoRefused("levels", "dims", {16, 16, 200}, "key 'levels' has 2 levels");
  expectInfoRefused("null", "bytes_vdb", nullptr, "key 'bytes_vdb' is not an integer");
  expectInfoRefused("active", "active_voxels", 1 << 20, "key 'active_voxels' is 1048576, outside [0, 4096]");
  expectInfoRefused("raw", "bytes_raw", 7, "key 'bytes_raw' is 7, expected 16384");
  // A level's counts against its index records (the ingest fuzzer's find: they were read and never compared).
  const fs::path meta = editedStore(dir, "level", "format", "voxbrick-store");
  const std::vector<char> text = test::readFile(meta);
  nlohmann::json j = nlohmann::json::parse(text.begin(), text.end());
  j["levels"][1]["bytes_stored"] = 4294967295u;
  test::writeFile(meta, j.dump(2));
  expectRefusal(stderrOf("info " + (dir / "level").string()),
                {meta.string(), "key 'levels' level 1 says 1 bricks and 4294967295 bytes stored; the index holds 1"});
}

}  // namespace
}  // namespace voxbrick
