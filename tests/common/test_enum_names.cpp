// One table per enum: its names both ways, its aliases, its list for messages and options, and an unknown name
// answered with the closest.
#include <gtest/gtest.h>

#include <span>
#include <stdexcept>
#include <string>

#include "common/EnumNames.h"

namespace voxbrick::common {
namespace {

enum class Fruit { Apple, Pear, Quince };
inline constexpr EnumName<Fruit> kFruitNames[] = {
    {Fruit::Apple, "apple"}, {Fruit::Pear, "pear"}, {Fruit::Quince, "quince"}, {Fruit::Apple, "malus"}};
constexpr std::span<const EnumName<Fruit>> enumNames(Fruit) { return kFruitNames; }

enum class Missing { Listed, Unlisted };
inline constexpr EnumName<Missing> kMissingNames[] = {{Missing::Listed, "listed"}};
constexpr std::span<const EnumName<Missing>> enumNames(Missing) { return kMissingNames; }

static_assert(std::string_view(nameOf(Fruit::Pear)) == "pear");
static_assert(valueOf<Fruit>("malus") == Fruit::Apple);

TEST(EnumNames, NamesBothWaysWithAliases) {
  EXPECT_STREQ(nameOf(Fruit::Apple), "apple");
  EXPECT_STREQ(nameOf(Fruit::Quince), "quince");
  EXPECT_EQ(valueOf<Fruit>("quince"), Fruit::Quince);
  EXPECT_EQ(valueOf<Fruit>("malus"), Fruit::Apple);
  EXPECT_FALSE(valueOf<Fruit>("Apple"));
  EXPECT_FALSE(valueOf<Fruit>(""));
  EXPECT_STREQ(nameOf(Missing::Unlisted), "?");
}

TEST(EnumNames, ListsEachValueOnceInTheTablesOrder) {
  EXPECT_EQ(enumNameList<Fruit>(), (std::vector<std::string>{"apple", "pear", "quince"}));
  EXPECT_EQ(enumNamesText<Fruit>(), "apple, pear or quince");
  EXPECT_EQ(enumNamesText<Fruit>(", ", " and ", "\""), "\"apple\", \"pear\" and \"quince\"");
  EXPECT_EQ(enumNamesText<Missing>(), "listed");
}

TEST(EnumNames, AnUnknownNameGetsTheClosestAndTheChoices) {
  EXPECT_EQ((parseName<Fruit, std::invalid_argument>("pear", "fruit")), Fruit::Pear);
  try {
    parseName<Fruit, std::invalid_argument>("quinse", "fruit", "--fruit");
    FAIL() << "an unknown name must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "--fruit: " + unknownName("fruit", "quinse", {"apple", "pear", "quince"}));
    EXPECT_NE(std::string(e.what()).find("'quince'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace voxbrick::common
