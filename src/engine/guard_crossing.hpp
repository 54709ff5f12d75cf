// geardyn: the earliest guard crossing inside one step of a flow that can give its state anywhere
// in the step (adaptive.hpp's dense output, newmark_flow.hpp's sub-steps), shared by both.
#pragma once

#include <boost/math/tools/toms748_solve.hpp>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "geardyn/engine.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn::ode {

struct GuardCrossing {
  int guard = -1;  // its index among the region's guards; -1: none crossed
  double at = 0;   // where on the step's parameter: the side on which the guard has turned
};

// Of a region's `guards`, those whose value at the step's end (`end_values`) is below their
// slack (crossed_below) are located inside the step [a, b] of a parameter s (a time, or a
// sub-step's length), each by TOMS 748 to `bits` bits in at most `max_iterations` evaluations,
// and the earliest is returned. `state_at(s, y)` fills y with the state at s and returns its
// time. A guard already below its slack at a is crossed at a (the region is left there).
template <class StateAt>
GuardCrossing earliest_crossing(const LinearSwitchedSystem& system,
                                const std::vector<LinearGuard>& guards,
                                const std::vector<double>& end_values, double a, double b,
                                StateAt&& state_at, int bits, std::uintmax_t max_iterations) {
  GuardCrossing first;
  Vector y;
  std::vector<double> v;
  for (std::size_t i = 0; i < guards.size(); ++i) {
    const double slack = crossed_below(guards[i]);
    if (!(end_values[i] < slack)) continue;
    const std::vector<LinearGuard> single = {guards[i]};
    const FunctionalValues one(system, single);
    const auto g = [&](double s) {
      const double t = state_at(s, y);
      one(t, y, v);
      return v[0] - slack;
    };
    double at = a;
    if (const double ga = g(a); ga > 0) {
      std::uintmax_t iterations = max_iterations;
      at = boost::math::tools::toms748_solve(g, a, b, ga, end_values[i] - slack,
                                             boost::math::tools::eps_tolerance<double>(bits),
                                             iterations)
               .second;
    }
    if (first.guard < 0 || at < first.at) first = {static_cast<int>(i), at};
  }
  return first;
}

}  // namespace geardyn::ode
