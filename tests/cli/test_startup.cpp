// What a command loads: Mesa's libOSMesa (and with it LLVM) only when it makes an OSMesa context; OpenVDB and GDCM
// only through voxbrick's modules (common/Modules.h), when it reads or writes a .vdb or reads DICOM; libcurl only
// when it fetches from a DICOMweb service (dicomweb.Orthanc fetches through it).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "cli/CliRun.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

/// The dynamic loader's trace of the libraries a command opens (LD_DEBUG=libs writes it to standard error).
const std::string kTraceLibraries = "export LD_DEBUG=libs;";

std::string startupBlobs() { return test::preppedStore("synthetic:blobs,n=32", "--brick 16"); }

TEST(Startup, ACommandThatDrawsNothingDoesNotLoadOsMesa) {
  for (const std::string& args : std::vector<std::string>{"--version", "info " + startupBlobs() + " --json"}) {
    const auto r = test::runSplit(args, 120, kTraceLibraries);
    ASSERT_EQ(r.exitCode, 0) << args << ": " << r.err.substr(0, 2000);
    EXPECT_NE(r.err.find("libzstd"), std::string::npos) << args << ": no loader trace, so nothing was checked";
    EXPECT_EQ(r.err.find("libOSMesa"), std::string::npos) << args << " loaded libOSMesa";
    EXPECT_EQ(r.err.find("libLLVM"), std::string::npos) << args << " loaded LLVM";
  }
}

TEST(Startup, ACommandThatReadsNoVdbAndNoDicomLoadsNeitherOpenVdbNorGdcmNorCurl) {
  test::ScratchDir dir;
  for (const std::string& args :
       std::vector<std::string>{"--version", "info " + startupBlobs() + " --json",
                                "prep synthetic:sparse,n=32 --brick 16 --no-vdb -q -o " + (dir / "s").string(),
                                "render -q " + startupBlobs() + " --size 32x32 -o " + (dir / "f.png").string()}) {
    const auto r = test::runSplit(args, 120, kTraceLibraries);
    ASSERT_EQ(r.exitCode, 0) << args << ": " << r.err.substr(0, 2000);
    EXPECT_NE(r.err.find("libzstd"), std::string::npos) << args << ": no loader trace, so nothing was checked";
    for (const char* library : {"libopenvdb", "libgdcm", "libvoxbrick_", "libcurl"})
      EXPECT_EQ(r.err.find(library), std::string::npos) << args << " loaded " << library;
  }
}

TEST(Startup, AVdbIsReadAndWrittenThroughTheOpenVdbModule) {
  test::ScratchDir dir;
  const std::string store = (dir / "with-grid").string();
  const auto prep = test::runSplit("prep synthetic:sparse,n=32 --brick 16 -q -o " + store, 120, kTraceLibraries);
  ASSERT_EQ(prep.exitCode, 0) << prep.err.substr(0, 2000);
  EXPECT_NE(prep.err.find("libvoxbrick_openvdb.so"), std::string::npos) << "the grid written without the module";
  ASSERT_TRUE(std::filesystem::exists(dir / "with-grid" / "vdb" / "level0-z00000.vdb"));
  const auto info = test::runSplit("info " + store + "/vdb/level0-z00000.vdb", 120, kTraceLibraries);
  ASSERT_EQ(info.exitCode, 0) << info.err.substr(0, 2000);
  EXPECT_NE(info.out.find("read live"), std::string::npos) << info.out;
  EXPECT_NE(info.err.find("libvoxbrick_openvdb.so"), std::string::npos) << "a .vdb read without the module";
  EXPECT_NE(info.err.find("libopenvdb"), std::string::npos) << "the module without OpenVDB";
  EXPECT_EQ(info.err.find("libgdcm"), std::string::npos) << "a .vdb loaded GDCM";
}

TEST(Startup, AModuleThatCannotBeFoundIsNamedAndNothingIsHarmed) {
  test::ScratchDir dir;
  std::filesystem::create_directories(dir / "no-modules");
  const std::string only = "export VOXBRICK_MODULE_DIR=" + (dir / "no-modules").string() + ";";
  // A store with its grid, made with the modules; then read, and another one made, where none can be found.
  const std::string store = (dir / "with-grid").string();
  ASSERT_EQ(test::runSplit("prep synthetic:sparse,n=32 --brick 16 -q -o " + store).exitCode, 0);
  const auto info = test::runSplit("info " + store + "/vdb/level0-z00000.vdb", 120, only);
  EXPECT_EQ(info.exitCode, 1) << info.out << info.err;
  const std::string wanted = (dir / "no-modules" / "libvoxbrick_openvdb.so").string();
  EXPECT_NE(info.err.find(wanted), std::string::npos) << info.err;
  EXPECT_NE(info.err.find("VOXBRICK_MODULE_DIR"), std::string::npos) << info.err;
  const auto prep = test::runSplit("prep synthetic:sparse,n=32 --brick 16 -q -o " + (dir / "new").string(), 120, only);
  EXPECT_EQ(prep.exitCode, 1) << prep.err;
  EXPECT_NE(prep.err.find(wanted), std::string::npos) << prep.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "new"));
  // The store is as it was, and one without a grid is read and made without any module.
  EXPECT_EQ(test::runSplit("info " + store, 120, only).exitCode, 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "with-grid" / "vdb" / "level0-z00000.vdb"));
  const auto plain =
      test::runSplit("prep synthetic:sparse,n=32 --brick 16 --no-vdb -q -o " + (dir / "s").string(), 120, only);
  EXPECT_EQ(plain.exitCode, 0) << plain.err;
  // A file there that is no module: the loader's reason, after the file's name.
  test::writeFile(dir / "no-modules" / "libvoxbrick_openvdb.so", std::string("not a shared library"));
  const auto damaged = test::runSplit("info " + store + "/vdb/level0-z00000.vdb", 120, only);
  EXPECT_EQ(damaged.exitCode, 1) << damaged.err;
  EXPECT_NE(damaged.err.find("libvoxbrick_openvdb.so: " + wanted + ": "), std::string::npos) << damaged.err;
}

TEST(Startup, AnOsMesaFrameLoadsItWhenTheContextIsMade) {
  test::ScratchDir dir;
  const auto r =
      test::runSplit("render -q " + startupBlobs() + " --backend osmesa --size 32x32 -o " + (dir / "f.png").string(),
                     120, kTraceLibraries);
  ASSERT_EQ(r.exitCode, 0) << r.err.substr(r.err.size() > 4000 ? r.err.size() - 4000 : 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "f.png"));
  EXPECT_NE(r.err.find("libOSMesa.so.8"), std::string::npos) << "an OSMesa frame without loading libOSMesa";
}

}  // namespace
}  // namespace voxbrick
