// An enum's values and their names in one table: the name of a value, the value of a name, the list of names for a
// message or an option's choices, and a name that is none of them answered with the closest (Names.h). An enum takes
// part with a table and a function beside it, found by argument-dependent lookup:
//
//   inline constexpr common::EnumName<Slicer> kSlicerNames[] = {{Slicer::Vertex, "vertex"}, {Slicer::Cpu, "cpu"}};
//   constexpr std::span<const common::EnumName<Slicer>> enumNames(Slicer) { return kSlicerNames; }
//
// A value may have several names (aliases, as "uint8" beside "u8"): its first is the one nameOf gives and lists show.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/Names.h"

namespace voxbrick::common {

template <typename E>
struct EnumName {
  E value;
  const char* name;  ///< a string literal: printf can take it, and it outlives every caller
};

/// The name of `value` (its first in the table); "?" for a value the table lacks.
template <typename E>
constexpr const char* nameOf(E value) {
  for (const EnumName<E>& entry : enumNames(E{}))
    if (entry.value == value) return entry.name;
  return "?";
}

/// The value named `name` (exactly, any of its names); none when no value is.
template <typename E>
constexpr std::optional<E> valueOf(std::string_view name) {
  for (const EnumName<E>& entry : enumNames(E{}))
    if (name == entry.name) return entry.value;
  return std::nullopt;
}

/// Every value's name (its first), in the table's order: the choices of an option, the list of a message.
template <typename E>
std::vector<std::string> enumNameList() {
  std::vector<std::string> names;
  for (const EnumName<E>& entry : enumNames(E{}))
    if (std::string_view(nameOf(entry.value)) == entry.name) names.emplace_back(entry.name);
  return names;
}

/// The names as a message lists them, each between `quote`s: "a, b or c" by default (`separator`, then `last`
/// before the last one).
template <typename E>
std::string enumNamesText(std::string_view separator = ", ", std::string_view last = " or ",
                          std::string_view quote = "") {
  const std::vector<std::string> names = enumNameList<E>();
  std::string text;
  for (size_t n = 0; n < names.size(); ++n) {
    if (n > 0) text += n + 1 == names.size() ? last : separator;
    text.append(quote).append(names[n]).append(quote);
  }
  return text;
}

/// The value named `text`, else throws Error("WHERE: no WHAT 'TEXT'; did you mean 'CLOSEST'? (one of: ...)")
/// (unknownName; no "WHERE: " when `where` is empty).
template <typename E, typename Error>
E parseName(std::string_view text, std::string_view what, std::string_view where = {}) {
  if (const std::optional<E> value = valueOf<E>(text)) return *value;
  throw Error((where.empty() ? std::string() : std::string(where) + ": ") + unknownName(what, text, enumNameList<E>()));
}

}  // namespace voxbrick::common
