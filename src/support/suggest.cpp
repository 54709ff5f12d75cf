#include "geardyn/suggest.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace geardyn {
namespace {

// The optimal string alignment distance: insertions, deletions, substitutions and the
// transposition of two neighbours, each one edit.
int edits(std::string_view a, std::string_view b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<int>> d(n + 1, std::vector<int>(m + 1, 0));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = static_cast<int>(i);
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = static_cast<int>(j);
  for (std::size_t i = 1; i <= n; ++i)
    for (std::size_t j = 1; j <= m; ++j) {
      const int cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[n][m];
}

}  // namespace

std::string did_you_mean(std::string_view word, const std::vector<std::string>& allowed) {
  const std::string* best = nullptr;
  int fewest = kMaxSuggestionEdits + 1;
  for (const std::string& a : allowed) {
    const int e = edits(word, a);
    if (e < fewest) {
      fewest = e;
      best = &a;
    }
  }
  if (!best || fewest >= static_cast<int>(word.size())) return "";
  return fmt::format(" (did you mean '{}'?)", *best);
}

}  // namespace geardyn
