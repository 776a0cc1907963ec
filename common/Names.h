// Telling a user about a name that is not one of the choices: the closest choice ("did you mean"), and one way to
// say it for every kind of name (datasets, presets, views, subcommands).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace voxbrick::common {

/// The choice a mistyped `name` most likely meant: one equal to it but for case, else the one that is `name` and an
/// extension ("mri" for "mri.vbs", case ignored) if only one is, else the one fewest edits away
/// (Levenshtein, case ignored) if that is at most max(2, |name| / 3) edits; none when nothing is that close or two
/// choices are equally close.
std::optional<std::string> closestName(std::string_view name, const std::vector<std::string>& choices);

/// The choice equal to `name` but for case, if exactly one is.
std::optional<std::string> sameButForCase(std::string_view name, const std::vector<std::string>& choices);

/// "no WHAT 'NAME'; did you mean 'CLOSEST'? (one of: A, B, C)": the closest choice when there is one, and the
/// choices (the first `listed` of them, then how many more), or "(there are none)" when there are none.
std::string unknownName(std::string_view what, std::string_view name, const std::vector<std::string>& choices,
                        size_t listed = 24);

}  // namespace voxbrick::common
