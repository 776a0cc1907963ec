// Closest names and the message for an unknown one.
#include "common/Names.h"

#include <algorithm>
#include <cctype>

namespace voxbrick::common {
namespace {

char lower(char c) { return char(std::tolower(static_cast<unsigned char>(c))); }

size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

}  // namespace

std::optional<std::string> sameButForCase(std::string_view name, const std::vector<std::string>& choices) {
  std::optional<std::string> found;
  for (const std::string& choice : choices)
    if (choice.size() == name.size() && editDistance(choice, name) == 0) {
      if (found) return std::nullopt;  // two choices differ only in case: none is safe
      found = choice;
    }
  return found;
}

std::optional<std::string> closestName(std::string_view name, const std::vector<std::string>& choices) {
  if (auto same = sameButForCase(name, choices)) return same;
  // The name without the extension its choice has ("mri" for "mri.vbs"), if only one choice has it so.
  std::optional<std::string> stem;
  for (const std::string& choice : choices)
    if (choice.size() > name.size() && choice[name.size()] == '.' &&
        editDistance(std::string_view(choice).substr(0, name.size()), name) == 0) {
      if (stem) {
        stem.reset();
        break;
      }
      stem = choice;
    }
  if (stem) return stem;
  const size_t limit = std::max<size_t>(2, name.size() / 3);
  std::optional<std::string> best;
  size_t bestDistance = limit + 1;
  bool tie = false;
  for (const std::string& choice : choices) {
    const size_t d = editDistance(name, choice);
    if (d < bestDistance) {
      best = choice, bestDistance = d, tie = false;
    } else if (d == bestDistance && best && *best != choice) {
      tie = true;
    }
  }
  if (!best || tie) return std::nullopt;
  return best;
}

std::string unknownName(std::string_view what, std::string_view name, const std::vector<std::string>& choices,
                        size_t listed) {
  std::string out = "no " + std::string(what) + " '" + std::string(name) + "'";
  if (const auto closest = closestName(name, choices)) out += "; did you mean '" + *closest + "'?";
  if (choices.empty()) return out + " (there are none)";
  out += " (one of: ";
  for (size_t i = 0; i < choices.size() && i < listed; ++i) out += (i ? ", " : "") + choices[i];
  if (choices.size() > listed) out += ", and " + std::to_string(choices.size() - listed) + " more";
  return out + ")";
}

}  // namespace voxbrick::common
