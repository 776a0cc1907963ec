// DatasetRegistry: which names it lists and opens, and that a name is never a path.
#include <gtest/gtest.h>

#include "TestDatasets.h"
#include "render/volume/BrickStoreDataset.h"
#include "server/Datasets.h"
#include "support/TestSupport.h"

namespace voxbrick::server {
namespace {

/// A datasets directory with one real store ("sparse", copied from the shared one), a directory without a
/// store.json, a plain file and a store whose store.json is broken. Real stores also lie where only a name that is
/// a path, or has odd characters, would reach them: in the datasets directory itself, beside it ("outside"), and
/// under names the check refuses. So only the name check keeps those names from opening something.
class DatasetRegistryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::filesystem::create_directories(datasets);
    for (const std::filesystem::path& where : {datasets / "sparse", dir / "outside", datasets / "odd name",
                                               datasets / "sp*rse", datasets / "sp\xC3\xA4rse", datasets / "sparse\n"})
      copyStore(where);
    for (const auto& entry : std::filesystem::directory_iterator(test::testDatasets() / "sparse"))
      std::filesystem::copy(entry.path(), datasets / entry.path().filename());  // "." and "sparse/.." are stores
    std::filesystem::create_directories(datasets / "no-store");
    test::writeFile(datasets / "no-store" / "README", std::string("not a store"));
    test::writeFile(datasets / "file.json", std::string("{}"));
    std::filesystem::create_directories(datasets / "broken");
    test::writeFile(datasets / "broken" / "store.json", std::string("{"));
  }
  static void copyStore(const std::filesystem::path& to) {
    std::filesystem::copy(test::testDatasets() / "sparse", to, std::filesystem::copy_options::recursive);
  }

  test::ScratchDir dir;
  const std::filesystem::path datasets = dir / "datasets";
  DatasetRegistry registry{datasets, size_t(16) << 20};
};

TEST_F(DatasetRegistryTest, ListsOnlyDirectoriesWithAStore) {
  EXPECT_EQ(registry.names(), (std::vector<std::string>{"broken", "sparse"}));
  // Scanned on every call: a store added later appears.
  copyStore(datasets / "later");
  EXPECT_EQ(registry.names(), (std::vector<std::string>{"broken", "later", "sparse"}));
}

TEST_F(DatasetRegistryTest, OpensAValidNameOnceAndSharesIt) {
  const auto a = registry.open("sparse");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->name(), "sparse");
  EXPECT_EQ(a->kind(), "brick-store");
  EXPECT_EQ(registry.open("sparse"), a);
  ASSERT_EQ(registry.opened().size(), 1u);
  EXPECT_EQ(registry.opened()[0], a);
}

TEST_F(DatasetRegistryTest, TheDatasetsOpenShareOneHostBudget) {
  copyStore(datasets / "second");
  copyStore(datasets / "third");
  DatasetRegistry shared(datasets, size_t(90) << 20);
  const auto a = shared.open("sparse");
  EXPECT_EQ(a->cacheStats().budgetBytes, size_t(90) << 20);
  const auto b = shared.open("second");
  EXPECT_EQ(a->cacheStats().budgetBytes, size_t(45) << 20);
  const auto c = shared.open("third");
  for (const auto& d : {a, b, c}) EXPECT_EQ(d->cacheStats().budgetBytes, size_t(30) << 20) << d->name();
}

TEST_F(DatasetRegistryTest, NamesThatAreNotDatasetsAreNotFound) {
  const std::string tooLong(256, 'a');
  for (const std::string& name :
       {std::string("."), std::string(".."), std::string(""), std::string("../outside"), std::string("sparse/"),
        std::string("sparse/.."), std::string("sparse/../sparse"), (dir / "outside").string(), tooLong,
        std::string("odd name"), std::string("sparse\n"), std::string("sp*rse"), std::string("sp\xC3\xA4rse"),
        std::string("no-store"), std::string("file.json"), std::string("missing")})
    EXPECT_THROW(registry.open(name), DatasetNotFound) << "'" << name << "'";
  EXPECT_TRUE(registry.opened().empty());
}

TEST_F(DatasetRegistryTest, TheNameCheckAllowsOnlyPlainNames) {
  for (const char* name : {"sparse", "a-b_c.1", "a..", "CT.2024-01"})
    EXPECT_TRUE(DatasetRegistry::validName(name)) << name;
  EXPECT_TRUE(DatasetRegistry::validName(std::string(255, 'x')));
  for (const std::string& name :
       {std::string(""), std::string("."), std::string(".."), std::string("..."), std::string(".hidden"),
        std::string(".upload-sparse-x1Yz2w"), std::string(256, 'x'), std::string("a/b"),
        std::string("a\\b"), std::string("a b"), std::string("a:b"), std::string("a\0b", 3), std::string("\xC3\xA4")})
    EXPECT_FALSE(DatasetRegistry::validName(name)) << name;
}

/// Expects opening `name` to fail with the dataset's own error (not DatasetNotFound), whose message holds `text`.
void expectOpenFails(DatasetRegistry& registry, const std::string& name, const std::string& text) {
  try {
    registry.open(name);
    ADD_FAILURE() << name << " opened";
  } catch (const DatasetNotFound& e) {
    ADD_FAILURE() << name << " reported as not found: " << e.what();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}

TEST_F(DatasetRegistryTest, AStoreThatCannotBeOpenedIsNotANotFound) {
  // Listed (it has a store.json), but opening it is the store's error, which the client sees as Internal.
  expectOpenFails(registry, "broken", "store.json");
  EXPECT_TRUE(registry.opened().empty());
}

/// A .vdb file (the OpenVDB grid prep writes beside a store) is a dataset of the directory under its file name,
/// read live; a broken one is listed and fails to open with its own error; a directory named like one is not a .vdb.
TEST(DatasetRegistryVdb, ListsAndOpensVdbFiles) {
  test::ScratchDir dir;
  const auto r = test::runVoxbrick("prep synthetic:sparse,n=32 --brick 16 -q -o '" + (dir / "withvdb").string() + "'");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const std::filesystem::path datasets = dir / "datasets";
  std::filesystem::create_directories(datasets / "folder.vdb");
  std::filesystem::copy_file(dir / "withvdb" / "vdb" / "level0-z00000.vdb", datasets / "sparse.vdb");
  test::writeFile(datasets / "broken.vdb", std::string("not an OpenVDB file"));
  DatasetRegistry registry(datasets, size_t(16) << 20);
  EXPECT_EQ(registry.names(), (std::vector<std::string>{"broken.vdb", "sparse.vdb"}));

  const auto live = registry.open("sparse.vdb");
  EXPECT_EQ(live->kind(), "brick-store");
  const auto* grid = dynamic_cast<const render::BrickStoreDataset*>(live.get());
  ASSERT_NE(grid, nullptr);
  EXPECT_EQ(grid->store()->backing(), store::StoreBacking::VdbFile);
  EXPECT_EQ(grid->store()->brickSize(), 32);
  EXPECT_NE(live->infoJson().find("OpenVDB grid 'density'"), std::string::npos) << live->infoJson();
  EXPECT_EQ(registry.open("sparse.vdb"), live);

  expectOpenFails(registry, "broken.vdb", "broken.vdb: not a readable OpenVDB file");
  EXPECT_THROW(registry.open("folder.vdb"), DatasetNotFound);
}

}  // namespace
}  // namespace voxbrick::server
