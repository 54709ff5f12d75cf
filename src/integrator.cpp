#include "geardyn/integrator.hpp"

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

}  // namespace geardyn::ode
