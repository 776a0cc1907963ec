// DICOM as hospitals export it, from files other tools wrote: pydicom's own test files and files written at test
// time by pydicom (tests/brickstore/dicom_cases.py, run with Debian's /usr/bin/python3): a study folder with plans,
// structure sets, reports and a second series; a DICOMDIR; an enhanced multi-frame volume against the same volume as
// single slices; RT dose grids against pydicom's pixel_array x DoseGridScaling; files without a meta header.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "InputRefusals.h"
#include "brickstore/format/Errors.h"
#include "brickstore/ingest/Sources.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

namespace fs = std::filesystem;
using test::expectRefused;
using test::runVoxbrick;
using test::ScratchDir;

const std::string kCtSeries = "1.2.826.0.1.3680043.8.498.7001";  // the study's CT series (dicom_cases.py)

/// The words of the row holding `part` in a listing of series (a prep refusing a folder of several image series
/// lists them as a table: UID, modality, description, size, slices, files); empty when no line holds it.
std::vector<std::string> seriesRow(const std::string& output, const std::string& part) {
  const size_t at = output.find(part);
  if (at == std::string::npos) return {};
  const size_t start = output.rfind('\n', at) + 1;
  std::istringstream line(output.substr(start, output.find('\n', at) - start));
  std::vector<std::string> words;
  for (std::string w; line >> w;) words.push_back(w);
  return words;
}

/// Writes one case of dicom_cases.py into `dir` with Debian's python3 (pydicom 2.3, numpy).
void writeCase(const std::string& kind, const fs::path& dir) {
  const fs::path script = fs::path(VOXBRICK_SOURCE_DIR) / "tests" / "brickstore" / "dicom_cases.py";
  const auto r = test::runShell("/usr/bin/python3 '" + script.string() + "' " + kind + " '" + dir.string() + "' 2>&1");
  ASSERT_EQ(r.exitCode, 0) << "dicom_cases.py " << kind << " (needs Debian's python3-pydicom and numpy):\n" << r.output;
}

/// The same volume: dims, spacing, type, orientation and every voxel.
void expectSameVolume(const std::string& a, const std::string& b, const store::SourceOptions& options = {}) {
  auto x = store::openSource(a, options), y = store::openSource(b, options);
  const store::VolumeInfo &p = x->info(), &q = y->info();
  ASSERT_EQ(p.dims, q.dims) << a << " against " << b;
  EXPECT_EQ(p.type, q.type);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR((&p.spacing.x)[i], (&q.spacing.x)[i], 1e-9) << "spacing " << i;
    EXPECT_NEAR(p.orientation.origin[size_t(i)], q.orientation.origin[size_t(i)], 1e-6) << "origin " << i;
    for (size_t k = 0; k < 3; ++k)
      EXPECT_NEAR(p.orientation.axes[size_t(i)][k], q.orientation.axes[size_t(i)][k], 1e-9);
  }
  EXPECT_EQ(p.orientation.patient, q.orientation.patient);
  const std::vector<double> u = test::readValues(*x), v = test::readValues(*y);
  ASSERT_EQ(u.size(), v.size());
  size_t differ = 0;
  for (size_t i = 0; i < u.size(); ++i) differ += u[i] != v[i];
  EXPECT_EQ(differ, 0u) << "voxels of " << a << " that differ from " << b;
}

nlohmann::json infoJson(const fs::path& store) {
  const auto r = runVoxbrick("info --json '" + store.string() + "'");
  EXPECT_EQ(r.exitCode, 0) << r.output;
  return nlohmann::json::parse(r.output);
}

/// The suite's cases of dicom_cases.py, each written once (on first use) into a scratch folder the suite's tests
/// share and only read: what a test writes (stores, copies it changes) goes to its own ScratchDir.
class DicomHospital : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { sCases = new ScratchDir; }
  static void TearDownTestSuite() {
    delete sCases;
    sCases = nullptr;
  }

  /// The folder case `kind` is written to.
  static fs::path caseDir(const std::string& kind) {
    const fs::path dir = *sCases / kind;
    if (fs::exists(dir)) return dir;
    writeCase(kind, dir);
    if (HasFatalFailure()) fs::remove_all(dir);  // the next test tries again, and says why it fails
    return dir;
  }

 private:
  static ScratchDir* sCases;
};

ScratchDir* DicomHospital::sCases = nullptr;

TEST_F(DicomHospital, StudyFolderSkipsNonImagesAndListsItsImageSeries) {
  ScratchDir dir;
  fs::copy(caseDir("study"), dir / "study", fs::copy_options::recursive);  // a copy: the test changes its files
  const std::string study = (dir / "study").string(), out = " -q -o '" + (dir / "s").string() + "'";
  auto r = runVoxbrick("prep '" + study + "'" + out);
  EXPECT_EQ(r.exitCode, 1) << r.output;
  for (const std::string& w : std::vector<std::string>{
           "holds 2 DICOM image series", "--series", "rtplan.dcm (RT plan)", "rtstruct.dcm (RT structure set)",
           "test-SR.dcm (structured report)", "gsps.dcm (presentation state)", "waveform_ecg.dcm (waveform)"})
    EXPECT_NE(r.output.find(w), std::string::npos) << "missing '" << w << "' in: " << r.output;
  // The series as a table, one per line under its header: UID, modality, description, size, slices, files.
  EXPECT_FALSE(seriesRow(r.output, "UID").empty()) << r.output;
  const std::vector<std::string> ct = seriesRow(r.output, kCtSeries), mr = seriesRow(r.output, "  MR  ");
  ASSERT_GE(ct.size(), 6u) << r.output;
  EXPECT_EQ(ct[1], "CT");
  EXPECT_EQ(std::vector<std::string>(ct.end() - 3, ct.end()), (std::vector<std::string>{"16x16", "5", "5"}))
      << "16x16, 5 slices in 5 files: " << r.output;
  ASSERT_GE(mr.size(), 6u) << r.output;
  EXPECT_EQ(std::vector<std::string>(mr.end() - 3, mr.end()), (std::vector<std::string>{"64x64", "1", "1"}))
      << "64x64, 1 slice in 1 file: " << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 4)
      << "the error line, the header, two series: " << r.output;

  // One CT file stands for its series; the plan, structure set and reports beside it are not read as images.
  r = runVoxbrick("prep '" + study + "/ct002.dcm' --brick 8" + out);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(infoJson(dir / "s")["dims"], nlohmann::json({16, 16, 5}));
  r = runVoxbrick("prep '" + study + "' --series " + kCtSeries + " --brick 8 --force" + out);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(infoJson(dir / "s")["dims"], nlohmann::json({16, 16, 5}));
  r = runVoxbrick("prep '" + study + "' --series 1.3.6.1.4.1.5962.1.3.4.1.20040826185059.5457 --force" + out);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(infoJson(dir / "s")["dims"], nlohmann::json({64, 64, 1}));

  // A damaged file beside the one named (pydicom's truncated RT plan) is skipped and named in the store's source;
  // the folder alone, where it could be of any series, is refused naming it.
  fs::copy_file("/usr/lib/python3/dist-packages/pydicom/data/test_files/rtplan_truncated.dcm",
                dir / "study" / "rtplan_truncated.dcm");
  r = runVoxbrick("prep '" + study + "/ct002.dcm' --brick 8 --force" + out);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const std::string source = infoJson(dir / "s")["source"];
  EXPECT_NE(source.find("skipped 1 damaged file(s) beside it: rtplan_truncated.dcm"), std::string::npos) << source;
  r = runVoxbrick("prep '" + study + "' --force" + out);
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("rtplan_truncated.dcm: truncated DICOM file"), std::string::npos) << r.output;
  fs::remove(dir / "study" / "rtplan_truncated.dcm");

  r = runVoxbrick("prep '" + study + "/rtplan.dcm' --force" + out);
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("rtplan.dcm: is a DICOM RT plan, not an image"), std::string::npos) << r.output;
  r = runVoxbrick("prep '" + study + "' --series " + std::string("1.2.333.444.55.6.7777.8888") + " --force" + out);
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("holds no image (rtplan.dcm is a RT plan)"), std::string::npos) << r.output;
}

TEST_F(DicomHospital, DicomDirListsAndOpensItsSeries) {
  ScratchDir dir;
  fs::copy(caseDir("study"), dir / "study", fs::copy_options::recursive);  // a copy: the test changes its files
  const fs::path medium = dir / "study" / "medium";
  const std::string out = " -q --brick 8 -o '" + (dir / "s").string() + "'";
  for (const fs::path& input : {medium / "DICOMDIR", medium}) {
    auto r = runVoxbrick("prep '" + input.string() + "'" + out);
    EXPECT_EQ(r.exitCode, 1) << r.output;
    const std::vector<std::string> ct = seriesRow(r.output, kCtSeries);
    ASSERT_GE(ct.size(), 6u) << r.output;
    EXPECT_EQ(ct[1], "CT");
    EXPECT_EQ(std::vector<std::string>(ct.end() - 3, ct.end()), (std::vector<std::string>{"16x16", "5", "5"}))
        << r.output;
    r = runVoxbrick("prep '" + input.string() + "' --series " + kCtSeries + " --force" + out);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_EQ(infoJson(dir / "s")["dims"], nlohmann::json({16, 16, 5}));
  }
  // The same volume as the folder's files.
  store::SourceOptions ct;
  ct.seriesUid = kCtSeries;
  expectSameVolume((dir / "study" / "ct000.dcm").string(), (medium / "DICOMDIR").string(), ct);

  // Copied to a case-sensitive disk with its names in lower case: the records' upper-case IDs still find them.
  std::vector<fs::path> entries;
  for (const auto& e : fs::recursive_directory_iterator(medium)) entries.push_back(e.path());
  std::sort(entries.rbegin(), entries.rend());  // children before their directories
  for (const fs::path& e : entries) {
    std::string name = e.filename().string();
    if (name == "DICOMDIR") continue;
    std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    fs::rename(e, e.parent_path() / name);
  }
  ASSERT_FALSE(fs::exists(medium / "PT000000"));
  expectSameVolume((dir / "study" / "ct000.dcm").string(), (medium / "DICOMDIR").string(), ct);

  // pydicom's DICOMDIR written by DCMTK (three patients, CR, CT and MR series): its 5-slice CT series.
  const std::string dcmtk = "/usr/lib/python3/dist-packages/pydicom/data/test_files/dicomdirtests/DICOMDIR";
  auto r = runVoxbrick("prep " + dcmtk + " --series 1.3.6.1.4.1.5962.1.1.0.0.0.1194734704.16302.0.6 --force" + out);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const auto j = infoJson(dir / "s");
  EXPECT_EQ(j["dims"], nlohmann::json({16, 16, 5}));
  EXPECT_NEAR(j["spacing"][2].get<double>(), 2.5, 1e-6);
}

TEST_F(DicomHospital, EnhancedMultiFrameIsTheSameVolumeAsItsSingleSlices) {
  ScratchDir out;
  const fs::path dir = caseDir("enhanced");
  expectSameVolume((dir / "enhanced.dcm").string(), (dir / "slices").string());
  expectSameVolume((dir / "enhanced_mr.dcm").string(), (dir / "mr").string());
  EXPECT_EQ(store::openSource((dir / "enhanced_mr.dcm").string(), {})->info().type, store::ValueType::U16);
  auto source = store::openSource((dir / "enhanced.dcm").string(), {});
  EXPECT_EQ(source->info().dims, (store::Vec3i{7, 5, 6}));
  EXPECT_NE(source->info().description.find("multi-frame"), std::string::npos) << source->info().description;

  // From one command, the same store geometry as the slices'.
  auto r = runVoxbrick("prep '" + (dir / "enhanced.dcm").string() + "' -q -o '" + (out / "a").string() + "'");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = runVoxbrick("prep '" + (dir / "slices").string() + "' -q -o '" + (out / "b").string() + "'");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const auto a = infoJson(out / "a"), b = infoJson(out / "b");
  for (const char* key : {"dims", "spacing", "type", "orientation", "value_range", "histogram", "bytes_raw"})
    EXPECT_EQ(a[key], b[key]) << key;
}

TEST_F(DicomHospital, MultiFrameFilesThatAreNotOneVolumeAreRefusedSayingWhy) {
  const fs::path dir = caseDir("enhanced");
  auto refused = [&](const std::string& file, const std::vector<std::string>& words) {
    SCOPED_TRACE(file);
    std::vector<std::string> all = words;
    all.push_back(file);
    expectRefused(test::openAndRead(dir / "bad" / file), all);
  };
  refused("timeseries.dcm", {"not one volume", "time series", "2 temporal positions", "TemporalPositionIndex"});
  refused("stacks.dcm", {"not one volume", "2 stacks", "StackID"});
  refused("gap.dcm", {"uneven slice spacing", "gap.dcm frame 3 to", "frame 4", "5 mm", "2.5 mm"});
  refused("duplicate.dcm", {"duplicate slice position", "frame 3", "frame 4"});
  refused("nogroups.dcm", {"multi-frame image without per-frame positions", "NumberOfFrames 6"});
  // Frame count x frame size against the pixel data, before anything is allocated from NumberOfFrames.
  refused("shortpixels.dcm", {"PixelData holds 420 bytes", "needs 490", "NumberOfFrames 7"});
  refused("manyframes.dcm", {"PerFrameFunctionalGroupsSequence (5200,9230) holds 6 items for NumberOfFrames 1000000"});
  refused("hugeframes.dcm", {"NumberOfFrames (0028,0008) is not a count: '999999999999'"});
}

TEST_F(DicomHospital, EveryTruncationOfAMultiFrameFileIsAnInputError) {
  ScratchDir dir;
  for (const fs::path& file : {caseDir("enhanced") / "enhanced.dcm", caseDir("dose") / "real" / "rtdose.dcm"}) {
    const std::vector<char> bytes = test::readFile(file);
    const fs::path victim = dir / "cut" / file.filename();
    fs::create_directories(victim.parent_path());
    // Every byte of the headers and sequences (the first 2100 bytes hold them), then every 61st of the pixels.
    for (size_t cut = 0; cut < bytes.size(); cut += cut < 2100 ? 1 : 61) {
      test::writeFile(victim, bytes.data(), cut);
      SCOPED_TRACE("cut at " + std::to_string(cut) + " of " + std::to_string(bytes.size()));
      expectRefused(test::openAndRead(victim), {victim.filename().string()});
    }
    test::writeFile(victim, bytes.data(), bytes.size());
    EXPECT_NO_THROW(test::openAndRead(victim)());
    fs::remove(victim);
  }
}

TEST_F(DicomHospital, DoseGridsHoldPydicomsValuesInGy) {
  ScratchDir out;
  const fs::path dir = caseDir("dose");
  for (const std::string& name : std::vector<std::string>{"dose32", "dose16", "rtdose"}) {
    SCOPED_TRACE(name);
    const fs::path file = name == "rtdose" ? dir / "real" / "rtdose.dcm" : dir / (name + ".dcm");
    std::ifstream in(dir / (name + ".json"));
    const auto want = nlohmann::json::parse(in);
    const std::vector<char> raw = test::readFile(dir / (name + ".f64"));
    std::vector<double> expected(raw.size() / sizeof(double));
    std::memcpy(expected.data(), raw.data(), raw.size());

    auto source = store::openSource(file.string(), {});
    const store::VolumeInfo& info = source->info();
    EXPECT_EQ(info.type, store::ValueType::F32);
    EXPECT_EQ((nlohmann::json{info.dims.x, info.dims.y, info.dims.z}), want["dims"]);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR((&info.spacing.x)[i], want["spacing"][size_t(i)].get<double>(), 1e-9) << "spacing " << i;
      EXPECT_NEAR(info.orientation.origin[size_t(i)], want["origin"][size_t(i)].get<double>(), 1e-6) << "origin " << i;
    }
    const std::vector<double> got = test::readValues(*source);
    ASSERT_EQ(got.size(), expected.size());
    size_t bad = 0;
    double top = 0;
    for (size_t i = 0; i < got.size(); ++i) {
      bad += std::fabs(got[i] - expected[i]) > 1e-6 * std::fabs(expected[i]) + 1e-12;
      top = std::max(top, expected[i]);
    }
    EXPECT_EQ(bad, 0u) << "voxels off pydicom's pixel_array x DoseGridScaling";
    EXPECT_GT(top, 0.0);
  }
  // The real file from one command.
  const auto r =
      runVoxbrick("prep '" + (dir / "real" / "rtdose.dcm").string() + "' -q -o '" + (out / "s").string() + "'");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(infoJson(out / "s")["dims"], nlohmann::json({10, 10, 15}));
  // Two dose grids of one series in a folder: each is a volume of its own, so the file is named.
  fs::create_directories(out / "two");
  fs::copy_file(dir / "real" / "rtdose.dcm", out / "two" / "rtdose.dcm");
  fs::copy_file(dir / "dose16.dcm", out / "two" / "dose16.dcm");
  const auto py = test::runShell("/usr/bin/python3 -c \"import pydicom; d = pydicom.dcmread('" +
                                 (out / "two" / "dose16.dcm").string() +
                                 "'); d.SeriesInstanceUID = '1.2.777.777.77.7.7777.7777'; d.save_as('" +
                                 (out / "two" / "dose16.dcm").string() + "')\" 2>&1");
  ASSERT_EQ(py.exitCode, 0) << py.output;
  expectRefused(test::openAndRead(out / "two"),
                {"dose16.dcm: an RT dose grid (NumberOfFrames 5), a volume of its own", "name the file to read"});
  EXPECT_NO_THROW(test::openAndRead(out / "two" / "dose16.dcm")());
  expectRefused(test::openAndRead(dir / "bad" / "offsets.dcm"),
                {"offsets.dcm", "GridFrameOffsetVector (3004,000C) holds 2 offsets for NumberOfFrames 3"});
  // One frame and an offset vector of only spaces: refused by name, not read past its (empty) end.
  expectRefused(test::openAndRead(dir / "bad" / "blankoffsets.dcm"),
                {"blankoffsets.dcm", "GridFrameOffsetVector (3004,000C) is not numeric"});
}

TEST_F(DicomHospital, MrSmallInEveryTransferSyntaxHoldsPydicomsPixels) {
  const fs::path dir = caseDir("pixels");
  const std::vector<char> raw = test::readFile(dir / "MR_small.f64");
  std::vector<double> expected(raw.size() / sizeof(double));
  std::memcpy(expected.data(), raw.data(), raw.size());
  auto source = store::openSource((dir / "MR_small").string(), {});
  EXPECT_EQ(test::readValues(*source), expected);
  for (const char* name : {"MR_small_RLE", "MR_small_bigendian", "MR_small_expb", "MR_small_implicit",
                           "MR_small_jp2klossless", "MR_small_jpeg_ls_lossless"})
    expectSameVolume((dir / name).string(), (dir / "MR_small").string());
  // In pydicom's own folder, beside its copies in other syntaxes and its damaged files: the file named.
  const std::string inPlace = "/usr/lib/python3/dist-packages/pydicom/data/test_files/MR_small_RLE.dcm";
  source = store::openSource(inPlace, {});
  EXPECT_EQ(test::readValues(*source), expected);
  EXPECT_NE(source->info().description.find("damaged file(s) beside it"), std::string::npos)
      << source->info().description;
}

// A named file that is a volume of its own (an RT dose grid) is read alone: in pydicom's folder, beside damaged
// files of other series, none of them is read, so none is skipped or named.
TEST_F(DicomHospital, AFileThatIsAVolumeOfItsOwnIsReadWithoutTheFilesBesideIt) {
  const std::string rtdose = "/usr/lib/python3/dist-packages/pydicom/data/test_files/rtdose.dcm";
  auto source = store::openSource(rtdose, {});
  const std::string description = source->info().description;
  EXPECT_NE(description.find("RT dose grid"), std::string::npos) << description;
  EXPECT_EQ(description.find("beside"), std::string::npos) << description;
  EXPECT_EQ(description.find("skipped"), std::string::npos) << description;
}

TEST_F(DicomHospital, FilesWithoutPreambleOrMetaHeaderAreReadAsTheyAre) {
  ScratchDir out;
  const fs::path dir = caseDir("nometa");
  const std::string original = (dir / "ct_small.dcm").string();
  expectSameVolume((dir / "bare" / "ct_small.dcm").string(), original);
  expectSameVolume((dir / "nopreamble" / "ct_small.dcm").string(), original);
  // Named as archives name them, without ".dcm": told by their first elements, in a folder or alone.
  fs::create_directories(out / "archive");
  fs::copy_file(dir / "bare" / "ct_small.dcm", out / "archive" / "IM000001");
  expectSameVolume((out / "archive").string(), original);
  expectSameVolume((out / "archive" / "IM000001").string(), original);
  // pydicom's no_meta.dcm is really damaged: a stray byte before the first element.
  expectRefused(test::openAndRead(dir / "damaged" / "no_meta.dcm"),
                {"no_meta.dcm", "not a DICOM file", "no 128-byte preamble", "20 08 00 05"});
}

TEST_F(DicomHospital, PydicomsNonImageFilesAreToldApartWithoutMetaHeaders) {
  // rtstruct.dcm has no preamble or meta header, ExplVR_BigEndNoMeta.dcm is explicit VR big endian without one.
  const std::string files = "/usr/lib/python3/dist-packages/pydicom/data/test_files/";
  ScratchDir dir;
  for (const char* name : {"rtstruct.dcm", "ExplVR_BigEndNoMeta.dcm", "rtplan.dcm"}) {
    fs::copy_file(files + name, dir / name);
    expectRefused(test::openAndRead(dir / name), {name, "not an image"});
  }
  expectRefused(test::openAndRead(dir.path()), {"holds no DICOM image series", "rtstruct.dcm (RT structure set)",
                                                "ExplVR_BigEndNoMeta.dcm (RT plan)"});
  // A CT slice beside them and a structured report: the folder, the slice, and the slice's series all read it.
  fs::copy_file(files + "CT_small.dcm", dir / "CT_small.dcm");
  fs::copy_file(files + "test-SR.dcm", dir / "test-SR.dcm");
  store::SourceOptions ct;
  ct.seriesUid = "1.3.6.1.4.1.5962.1.3.1.1.20040119072730.12322";
  for (const auto& [input, options] : std::vector<std::pair<fs::path, store::SourceOptions>>{
           {dir.path(), {}}, {dir / "CT_small.dcm", {}}, {dir.path(), ct}, {dir / "CT_small.dcm", ct}}) {
    auto source = store::openSource(input.string(), options);
    EXPECT_EQ(source->info().dims, (store::Vec3i{128, 128, 1})) << input;
    EXPECT_EQ(test::readValues(*source).size(), 128u * 128u);
  }
}

}  // namespace
}  // namespace voxbrick
