// geardyn: the nearest allowed word to a mistyped one, for messages that refuse a key.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace geardyn {

// A word this many edits or fewer from an allowed one (a letter added, dropped, changed, or two
// swapped) is taken for a typing slip of it; further off, no guess is offered.
inline constexpr int kMaxSuggestionEdits = 2;

// " (did you mean 'backlash_um'?)" for "backlash_mu" among `allowed`, the nearest by the optimal
// string alignment distance within kMaxSuggestionEdits (and below the word's own length); ""
// when none is that near. Ties go to the first allowed.
std::string did_you_mean(std::string_view word, const std::vector<std::string>& allowed);

}  // namespace geardyn
