#include "geardyn/integrator.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace geardyn::ode {

const char* to_string(Termination t) {
  switch (t) {
    case Termination::kCompleted:
      return "completed";
    case Termination::kDiverged:
      return "diverged";
    case Termination::kNewtonFailed:
      return "newton_failed";
    case Termination::kStepUnderflow:
      return "step_underflow";
    case Termination::kCancelled:
      return "cancelled";
    case Termination::kNoProgress:
      return "no_progress";
  }
  return "?";
}

OutputGrid make_output_grid(double t0_s, double t1_s, double interval_s) {
  // A sample within a rounding error of t1 still belongs to the window.
  constexpr double kEndSlack = 1e-9;
  assert(interval_s > 0 && t1_s >= t0_s);
  OutputGrid g;
  g.t0_s = t0_s;
  g.interval_s = interval_s;
  g.count = static_cast<std::int64_t>(std::floor((t1_s - t0_s) / interval_s + kEndSlack)) + 1;
  return g;
}

std::int64_t OutputGrid::count_until(double t_s) const {
  if (count == 0 || !(time(0) <= t_s)) return 0;
  // The estimate from the division, corrected with the times themselves, which decide.
  auto n = std::min<std::int64_t>(
      count, static_cast<std::int64_t>(std::floor((t_s - t0_s) / interval_s)) - first + 1);
  n = std::max<std::int64_t>(n, 1);
  while (n < count && time(n) <= t_s) ++n;
  while (n > 1 && time(n - 1) > t_s) --n;
  return n;
}

}  // namespace geardyn::ode
