// Atomic replacement of files and directories: the old content until the swap, the new after, and nothing else
// beside it whether the write succeeds or fails.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "common/AtomicReplace.h"
#include "support/TestSupport.h"

namespace voxbrick::common {
namespace {
namespace fs = std::filesystem;
using test::ScratchDir;

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void writeText(const fs::path& path, const std::string& text) { test::writeFile(path, text); }

/// The names in `dir`, sorted.
std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// Every file below `dir` as "relative path=content", sorted.
std::vector<std::string> tree(const fs::path& dir) {
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files.push_back(fs::relative(e.path(), dir).string() + "=" + readText(e.path()));
  std::sort(files.begin(), files.end());
  return files;
}

struct Injected : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Runs `replace`, which must throw a ReplaceError whose message names `path` and holds `reason`.
void expectErrorNaming(const std::function<void()>& replace, const fs::path& path, const std::string& reason) {
  try {
    replace();
    ADD_FAILURE() << "no error";
  } catch (const ReplaceError& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
  }
}

std::span<const uint8_t> bytesOf(const std::string& text) {
  return {reinterpret_cast<const uint8_t*>(text.data()), text.size()};
}

TEST(ReplaceFile, OldContentUntilTheRenameNewAfter) {
  ScratchDir scratch;
  const fs::path file = scratch / "f.txt";
  writeText(file, "old");
  fs::path seen;
  replaceFile(file, [&](const fs::path& temporary) {
    EXPECT_EQ(readText(file), "old");
    EXPECT_EQ(temporary.parent_path(), scratch.path());
    EXPECT_EQ(temporary.filename().string().rfind(".f.txt.tmp-", 0), 0u) << temporary;
    EXPECT_TRUE(fs::is_regular_file(temporary));
    writeText(temporary, "new");
    seen = temporary;
  });
  EXPECT_EQ(readText(file), "new");
  EXPECT_FALSE(fs::exists(seen));
  EXPECT_EQ(entries(scratch.path()), std::vector<std::string>{"f.txt"});
}

TEST(ReplaceFile, BytesWhereNothingWasWithTheUsualMode) {
  ScratchDir scratch;
  const std::string text("binary\0bytes\n", 13);
  replaceFile(scratch / "f.bin", bytesOf(text));
  EXPECT_EQ(readText(scratch / "f.bin"), text);
  // The mode a plain create gives (0666 less the umask), not mkstemp's 0600.
  writeText(scratch / "plain", "x");
  EXPECT_EQ(fs::status(scratch / "f.bin").permissions(), fs::status(scratch / "plain").permissions());
  replaceFile(scratch / "empty", std::span<const uint8_t>{});
  EXPECT_EQ(fs::file_size(scratch / "empty"), 0u);
  EXPECT_EQ(entries(scratch.path()), (std::vector<std::string>{"empty", "f.bin", "plain"}));
}

TEST(ReplaceFile, AFailedWriteLeavesTheOldFileAndNoTemporary) {
  ScratchDir scratch;
  const fs::path file = scratch / "f.txt";
  writeText(file, "old");
  EXPECT_THROW(replaceFile(file,
                           [&](const fs::path& temporary) {
                             writeText(temporary, "half");
                             throw Injected("disk full");
                           }),
               Injected);
  EXPECT_EQ(readText(file), "old");
  EXPECT_EQ(entries(scratch.path()), std::vector<std::string>{"f.txt"});
  // Nothing was there: nothing is.
  EXPECT_THROW(replaceFile(scratch / "g.txt", [](const fs::path&) { throw Injected("no"); }), Injected);
  EXPECT_EQ(entries(scratch.path()), std::vector<std::string>{"f.txt"});
}

TEST(ReplaceFile, AMissingParentIsAnErrorNamingThePath) {
  ScratchDir scratch;
  const fs::path file = scratch / "missing" / "f.txt";
  bool called = false;
  expectErrorNaming([&] { replaceFile(file, [&](const fs::path&) { called = true; }); }, file,
                    "No such file or directory");
  EXPECT_FALSE(called);
  EXPECT_TRUE(entries(scratch.path()).empty());
}

TEST(ReplaceFile, ADirectoryAtThePathIsAnErrorAndStays) {
  ScratchDir scratch;
  fs::create_directory(scratch / "d");
  writeText(scratch / "d" / "keep", "kept");
  expectErrorNaming([&] { replaceFile(scratch / "d", bytesOf("new")); }, scratch / "d", "Is a directory");
  EXPECT_EQ(tree(scratch / "d"), std::vector<std::string>{"keep=kept"});
  EXPECT_EQ(entries(scratch.path()), std::vector<std::string>{"d"});
}

class ReplaceDirectory : public testing::TestWithParam<DirectorySwap> {};

TEST_P(ReplaceDirectory, OldTreeUntilTheSwapNewAfter) {
  ScratchDir scratch;
  const fs::path dir = scratch / "store";
  fs::create_directories(dir / "sub");
  writeText(dir / "a", "old a");
  writeText(dir / "sub" / "b", "old b");
  replaceDirectory(
      dir,
      [&](const fs::path& staging) {
        EXPECT_EQ(tree(dir), (std::vector<std::string>{"a=old a", "sub/b=old b"}));
        EXPECT_EQ(staging.parent_path(), scratch.path());
        EXPECT_EQ(staging.filename().string().rfind(".store.tmp-", 0), 0u) << staging;
        EXPECT_TRUE(fs::is_empty(staging));
        fs::create_directory(staging / "vdb");
        writeText(staging / "c", "new c");
        writeText(staging / "vdb" / "d", "new d");
      },
      GetParam());
  EXPECT_EQ(tree(dir), (std::vector<std::string>{"c=new c", "vdb/d=new d"}));
  EXPECT_EQ(entries(scratch.path()), std::vector<std::string>{"store"});
}

TEST_P(ReplaceDirectory, WhereNothingWasAndThroughATrailingSlash) {
  ScratchDir scratch;
  replaceDirectory(
      scratch / "store", [](const fs::path& staging) { writeText(staging / "x", "1"); }, GetParam());
  EXPECT_EQ(tree(scratch / "store"), std::vector<std::string>{"x=1"});
  replaceDirectory(
      scratch.path() / "store/", [](const fs::path& staging) { writeText(staging / "y", "2"); }, GetParam());
  EXPECT_EQ(tree(scratch / "store"), std::vector<std::string>{"y=2"});
  EXPECT_EQ(entries(scratch.path()), std::vector<std::string>{"store"});
}

TEST_P(ReplaceDirectory, AFailedWriteLeavesTheOldTreeAndNoTemporary) {
  ScratchDir scratch;
  const fs::path dir = scratch / "store";
  fs::create_directory(dir);
  writeText(dir / "a", "old a");
  EXPECT_THROW(replaceDirectory(
                   dir,
                   [](const fs::path& staging) {
                     fs::create_directory(staging / "half");
                     writeText(staging / "half" / "b", "half written");
                     throw Injected("disk full");
                   },
                   GetParam()),
               Injected);
  EXPECT_EQ(tree(dir), std::vector<std::string>{"a=old a"});
  EXPECT_EQ(entries(scratch.path()), std::vector<std::string>{"store"});
}

TEST_P(ReplaceDirectory, AMissingParentIsAnErrorNamingThePath) {
  ScratchDir scratch;
  const fs::path dir = scratch / "missing" / "store";
  bool called = false;
  expectErrorNaming(
      [&] {
        replaceDirectory(
            dir, [&](const fs::path&) { called = true; }, GetParam());
      },
      dir, "No such file or directory");
  EXPECT_FALSE(called);
  EXPECT_TRUE(entries(scratch.path()).empty());
}

INSTANTIATE_TEST_SUITE_P(Swaps, ReplaceDirectory, testing::Values(DirectorySwap::Exchange, DirectorySwap::MoveAside),
                         [](const testing::TestParamInfo<DirectorySwap>& param) {
                           return param.param == DirectorySwap::Exchange ? "Exchange" : "MoveAside";
                         });

/// The exchange's promise, watched from another thread: every look at the path finds a whole store, old or new.
TEST(ReplaceDirectoryExchange, AReaderNeverFindsThePathEmpty) {
  ScratchDir scratch;
  const fs::path dir = scratch / "store";
  replaceDirectory(dir, [](const fs::path& staging) { writeText(staging / "marker", "0"); });
  std::atomic<bool> done{false};
  std::atomic<int> looks{0}, missing{0};
  std::thread reader([&] {
    while (!done) {
      struct stat st {};
      if (::stat((dir / "marker").c_str(), &st) != 0) ++missing;
      ++looks;
    }
  });
  for (int i = 1; i <= 40; ++i)
    replaceDirectory(dir, [i](const fs::path& staging) { writeText(staging / "marker", std::to_string(i)); });
  done = true;
  reader.join();
  EXPECT_GT(looks.load(), 0);
  EXPECT_EQ(missing.load(), 0) << "of " << looks.load() << " looks";
  EXPECT_EQ(readText(dir / "marker"), "40");
  EXPECT_EQ(entries(scratch.path()), std::vector<std::string>{"store"});
}

}  // namespace
}  // namespace voxbrick::common
