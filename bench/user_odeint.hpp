// The baseline of the benchmarks: a plain Boost.Odeint program for the gear pair with backlash,
// written as a user would write it. The model is written out by hand (k(t) and F(t) with
// std::cos), dopri5 with dense output steps it, the guards are checked at every step end, a
// crossing is located by TOMS 748 on the dense output and the stepper restarts there. Nothing
// of geardyn's integrators is used; the parameters come from geardyn's model so that both
// solve the same equation.
#pragma once

#include <array>
#include <boost/math/tools/toms748_solve.hpp>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <vector>

#include "geardyn/model.hpp"

namespace bench {

struct UserModel {
  double m, cb2, b, c, c_free;
  double k_m;
  std::vector<std::array<double, 3>> k_terms;  // amplitude, omega, phase
  double F_m;
  std::vector<std::array<double, 3>> F_terms;
};

inline UserModel user_model(const geardyn::GearPairParameters& p) {
  UserModel u;
  u.m = p.equivalent_mass_kg;
  u.cb2 = p.cos_base_helix * p.cos_base_helix;
  u.b = p.backlash_m;
  u.c = p.damping_n_s_per_m;
  u.c_free = p.damping == geardyn::DampingForm::kAlways ? u.c : 0.0;
  u.k_m = p.stiffness_n_per_m.offset;
  for (const auto& h : p.stiffness_n_per_m.terms)
    u.k_terms.push_back({h.amplitude, h.angular_frequency_rad_s, h.phase_rad});
  u.F_m = p.force_n.offset;
  for (const auto& h : p.force_n.terms)
    u.F_terms.push_back({h.amplitude, h.angular_frequency_rad_s, h.phase_rad});
  return u;
}

// Where a run ended: delta / b, delta' / b, and the contact side (1 drive, 0 apart, -1 back);
// `stalled` when it gave up (see user_odeint).
struct UserState {
  double x = 0, v = 0;
  int side = 0;
  bool stalled = false;
};

// Events in a row that each advance time by less than 1e-12 of the run before the program gives
// up: at loose tolerances a grazing contact can chatter without end (as a user would stop it).
constexpr int kUserMaxStalledEvents = 1000;

// The event loop a user writes around Boost.Odeint: dopri5 with dense output steps `rhs`
// (which reads `side`), `guard(x)` (>= 0 while in `side`) is checked at every step end, a
// crossing is located by TOMS 748 on the dense output, `next_side(x)` gives the side entered and
// the stepper restarts there. `read(x)` is appended to `out` at each of `times` in [t0, t1].
// Returns true when it gave up on chattering events (see kUserMaxStalledEvents).
template <class X, class Rhs, class Guard, class NextSide, class Read>
bool user_event_loop(Rhs&& rhs, Guard&& guard, NextSide&& next_side, Read&& read, int& side, X& x,
                     double t0, double t1, const std::vector<double>& times, double tol,
                     std::vector<double>& out) {
  namespace odeint = boost::numeric::odeint;
  auto stepper = odeint::make_dense_output(tol, tol, odeint::runge_kutta_dopri5<X>());
  double t = t0;
  stepper.initialize(x, t, 1e-6 * (t1 - t0));
  std::size_t next = 0;
  while (next < times.size() && times[next] < t0) ++next;
  while (next < times.size() && times[next] <= t) {
    out.push_back(read(x));
    ++next;
  }
  int stalled = 0;
  X xs = x, xe = x;
  auto sample_until = [&](double te) {
    while (next < times.size() && times[next] <= te) {
      stepper.calc_state(times[next], xs);
      out.push_back(read(xs));
      ++next;
    }
  };
  while (t < t1) {
    stepper.do_step(rhs);
    double te = std::min(stepper.current_time(), t1);
    stepper.calc_state(te, xe);
    if (guard(xe) < 0) {  // locate the crossing on the dense output
      auto g = [&](double tt) {
        stepper.calc_state(tt, xs);
        return guard(xs);
      };
      std::uintmax_t it = 100;
      const double ta = stepper.previous_time();
      te = boost::math::tools::toms748_solve(g, ta, te,
                                             boost::math::tools::eps_tolerance<double>(50), it)
               .second;
      stepper.calc_state(te, xe);
      sample_until(te);
      stalled = (te - t < 1e-12 * (t1 - t0)) ? stalled + 1 : 0;
      x = xe;
      if (stalled > kUserMaxStalledEvents) return true;
      side = next_side(xe);
      t = te;
      stepper.initialize(x, t, stepper.current_time_step());
      continue;
    }
    sample_until(te);
    x = xe;
    t = te;
  }
  return false;
}

// Integrates from `start` at t0 to t1 with tolerance `tol` (relative and absolute, on
// delta / b), appending delta / b at each of `times` inside [t0, t1] to `out`.
inline UserState user_odeint(const UserModel& u, UserState start, double t0, double t1,
                             const std::vector<double>& times, double tol,
                             std::vector<double>& out) {
  using X = std::array<double, 2>;
  int side = start.side;
  auto rhs = [&](const X& x, X& dx, double t) {
    double k = u.k_m, F = u.F_m;
    for (const auto& h : u.k_terms) k += h[0] * std::cos(h[1] * t + h[2]);
    for (const auto& h : u.F_terms) F += h[0] * std::cos(h[1] * t + h[2]);
    double fg = u.c_free * x[1];  // per unit b
    if (side == 1) fg = k * (x[0] - 1) + u.c * x[1];
    if (side == -1) fg = k * (x[0] + 1) + u.c * x[1];
    dx[0] = x[1];
    dx[1] = (F / u.b - u.cb2 * fg) / u.m;
  };
  auto guard = [&](const X& x) {  // >= 0 while in `side`
    if (side == 1) return x[0] - 1;
    if (side == -1) return -1 - x[0];
    return std::min(1 - x[0], x[0] + 1);
  };
  auto next_side = [&](const X& x) { return side != 0 ? 0 : (x[0] > 0 ? 1 : -1); };
  X x{start.x, start.v};
  const bool stalled = user_event_loop<X>(
      rhs, guard, next_side, [](const X& y) { return y[0]; }, side, x, t0, t1, times, tol, out);
  return {x[0], x[1], side, stalled};
}

// The whole window from the middle of the backlash at rest, samples only.
inline std::vector<double> user_odeint(const UserModel& u, double t1,
                                       const std::vector<double>& times, double tol) {
  std::vector<double> out;
  user_odeint(u, UserState{}, 0.0, t1, times, tol, out);
  return out;
}

}  // namespace bench
