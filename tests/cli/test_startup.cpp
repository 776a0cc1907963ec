// What a command loads: Mesa's libOSMesa (and with it LLVM) only when it makes an OSMesa context.
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

TEST(Startup, AnOsMesaFrameLoadsItWhenTheContextIsMade) {
  test::ScratchDir dir;
  const auto r = test::runSplit("render -q " + startupBlobs() + " --backend osmesa --size 32x32 -o " +
                                    (dir / "f.png").string(),
                                120, kTraceLibraries);
  ASSERT_EQ(r.exitCode, 0) << r.err.substr(r.err.size() > 4000 ? r.err.size() - 4000 : 0);
  EXPECT_TRUE(std::filesystem::exists(dir / "f.png"));
  EXPECT_NE(r.err.find("libOSMesa.so.8"), std::string::npos) << "an OSMesa frame without loading libOSMesa";
}

}  // namespace
}  // namespace voxbrick
