// The benchmarks' measures: the largest difference of two sample series and the best wall time
// of repeated runs.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

namespace bench {

// max |a_i - b_i|; infinity when the lengths differ (a run that stopped early).
inline double max_error(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return std::numeric_limits<double>::infinity();
  double e = 0;
  for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, std::abs(a[i] - b[i]));
  return e;
}

// The shortest of `repeat` wall times of f(), s.
template <class F>
double best_time(int repeat, F&& f) {
  using Clock = std::chrono::steady_clock;
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  return best;
}

// The shortest wall time of each of several functions over `repeat` rounds, the functions
// taken in turn within a round, so that a machine whose speed drifts (a shared one) slows
// all of them alike and their ratios hold; s, in the order given.
template <class... F>
std::vector<double> best_times_interleaved(int repeat, F&&... f) {
  using Clock = std::chrono::steady_clock;
  std::vector<double> best(sizeof...(F), std::numeric_limits<double>::infinity());
  for (int r = 0; r < repeat; ++r) {
    std::size_t i = 0;
    const auto time_one = [&](auto& g) {
      const auto t0 = Clock::now();
      g();
      best[i] = std::min(best[i], std::chrono::duration<double>(Clock::now() - t0).count());
      ++i;
    };
    (time_one(f), ...);
  }
  return best;
}

}  // namespace bench
