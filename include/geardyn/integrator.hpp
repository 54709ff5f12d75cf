// geardyn: integrators for switched second-order systems, pipeline stage 5.
//
// Nothing here knows of gears. A *switched second-order system* is
//
//     m q'' = f_r(t, q, q'),   r = the current region (an int),
//
// smooth inside each region, with the regions separated by guard surfaces. The system type S
// provides (see the SwitchedSystem concept):
//
//   S::Drive                      the time-dependent inputs at one instant (opaque here)
//   S::kPiecewiseLinear           true when every f_r is affine in (q, q'): one Newton
//                                 iteration is then exact
//   double mass() const           m > 0
//   Drive drive(double t) const   the inputs at any t
//   DriveGrid drive_grid(t0, dt)  an object whose next() returns the inputs at t0 + dt,
//                                 t0 + 2 dt, ... in sequence (cheaper than drive(t))
//   Force force(d, q, v, r)       f_r and its partial derivatives d/dq and d/dv
//   Guards guards(d, q, v, r)     the guard functions of region r: each value is >= 0 while the
//                                 state stays in r and turns negative when it leaves for target
//
// Drivers follow Boost.Odeint's split: the stepper advances, the driver loops, and everything
// that looks at the solution is an Observer with
//
//   void on_step(const State& end, const Drive& d)   after every step and sub-step
//   void on_transition(const State& s, int from)     at every located region change; s is
//                                                    already in the new region
//   void on_sample(const State& s)                   at t0 + k * output_interval, interpolated
//   bool on_progress(double t)                       now and then; false cancels the run
#pragma once

#include <algorithm>
#include <array>
#include <boost/math/tools/toms748_solve.hpp>
#include <boost/numeric/odeint.hpp>
#include <cassert>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <string>

namespace geardyn::ode {

// Value and partial derivatives of f_r(t, q, q') at one instant.
struct Force {
  double value;
  double d_dq;
  double d_dv;
};

// One guard function of a region: >= 0 inside, < 0 once the state has left for `target`.
struct Guard {
  double value;
  int target;
};

struct Guards {
  static constexpr int kMax = 2;
  std::array<Guard, kMax> items;  // only the first `count` are set
  int count = 0;
  void add(double value, int target) { items[count++] = {value, target}; }
};

// The state of the system at time t: q, q', q'' and the region it is in.
struct State {
  double t;
  double q;
  double v;
  double a;
  int region;
};

template <class S>
concept SwitchedSystem = requires(const S& s, const typename S::Drive& d, double x, int r) {
  { S::kPiecewiseLinear } -> std::convertible_to<bool>;
  { s.mass() } -> std::convertible_to<double>;
  { s.drive(x) } -> std::same_as<typename S::Drive>;
  { s.drive_grid(x, x).next() } -> std::same_as<typename S::Drive>;
  { s.force(d, x, x, r) } -> std::same_as<Force>;
  { s.guards(d, x, x, r) } -> std::same_as<Guards>;
};

enum class Termination {
  kCompleted,      // reached the end time
  kDiverged,       // the state became non-finite
  kNewtonFailed,   // Newton-Raphson did not converge within its iteration limit
  kStepUnderflow,  // the adaptive step fell below what the end time can resolve
  kCancelled,      // the observer asked to stop
  kNoProgress,     // region changes kept coming without time advancing (a chattering contact)
};

const char* to_string(Termination t);

// The outcome of one integration (Ceres-style: a termination type and a message).
struct IntegrationSummary {
  Termination termination = Termination::kCompleted;
  std::string message;
  std::int64_t steps = 0;        // accepted steps, sub-steps of split steps included
  std::int64_t transitions = 0;  // located region changes
  // Grid steps that met more region changes than kMaxTransitionsPerStep; the rest of such a
  // step is taken without splitting (only a chattering contact does this).
  std::int64_t unsplit_steps = 0;
  double end_time_s = 0;
  State end_state{};  // the state where the integration stopped (to continue from it)
  bool ok() const { return termination == Termination::kCompleted; }
};

// Uniform output times t0 + (first + k) * interval, k = 0 .. count-1: with `first`, a stretch
// of a longer grid whose times are bit for bit the longer grid's (a run integrated in pieces).
struct OutputGrid {
  double t0_s = 0;
  double interval_s = 0;
  std::int64_t count = 0;
  std::int64_t first = 0;
  double time(std::int64_t k) const { return t0_s + static_cast<double>(first + k) * interval_s; }
  // The stretch of this grid from index i0 (of this grid) to before i1.
  OutputGrid stretch(std::int64_t i0, std::int64_t i1) const {
    return {t0_s, interval_s, i1 - i0, first + i0};
  }
  // How many of this grid's times are at or before t_s.
  std::int64_t count_until(double t_s) const;
};

// Output times every `interval_s` from t0 up to t1 inclusive (to within a rounding error).
// Requires interval_s > 0 and t1_s >= t0_s (asserted in debug builds).
OutputGrid make_output_grid(double t0_s, double t1_s, double interval_s);

struct NewmarkOptions {
  double beta = 0.25;  // average acceleration: unconditionally stable, second order
  double gamma = 0.5;
  // Newton-Raphson on a nonlinear region stops when the acceleration update is below this
  // fraction of the acceleration: a few ulps above double rounding.
  double newton_relative_tolerance = 1e-13;
  int newton_max_iterations = 50;
  // Region changes located within one grid step before the rest of it is taken unsplit: far
  // above the 1 or 2 of an impact, low enough to stop a Zeno cascade.
  int max_transitions_per_step = 16;
  // Steps between calls of on_progress.
  std::int64_t progress_interval_steps = std::int64_t{1} << 20;
};

// Bits of accuracy to which a region change is located inside a step: the crossing time to
// ~1e-14 of the step, far below the O(dt^3) local error of the method.
constexpr int kTransitionBits = 46;
constexpr std::uintmax_t kTransitionMaxIterations = 100;

namespace detail {

// Cubic Hermite interpolation of y on [0, h] from end values and slopes, at s in [0, h].
inline double hermite(double y0, double dy0, double y1, double dy1, double h, double s) {
  const double x = s / h;
  const double x2 = x * x, x3 = x2 * x;
  return (2 * x3 - 3 * x2 + 1) * y0 + (x3 - 2 * x2 + x) * h * dy0 + (-2 * x3 + 3 * x2) * y1 +
         (x3 - x2) * h * dy1;
}

inline State interpolate(const State& s0, const State& s1, double t) {
  const double h = s1.t - s0.t;
  if (!(h > 0)) return s1;
  const double s = t - s0.t;
  State out;
  out.t = t;
  out.q = hermite(s0.q, s0.v, s1.q, s1.v, h, s);
  out.v = hermite(s0.v, s0.a, s1.v, s1.a, h, s);
  out.a = s0.a + (s1.a - s0.a) * (s / h);
  out.region = s1.region;
  return out;
}

}  // namespace detail

// The coefficients of a Newmark-beta step of size h.
struct NewmarkStep {
  double h;    // step size
  double bh2;  // beta h^2
  double gh;   // gamma h
  double qa;   // (1/2 - beta) h^2
  double va;   // (1 - gamma) h
  NewmarkStep(double h_s, const NewmarkOptions& o)
      : h(h_s),
        bh2(o.beta * h_s * h_s),
        gh(o.gamma * h_s),
        qa((0.5 - o.beta) * h_s * h_s),
        va((1.0 - o.gamma) * h_s) {}
};

// One Newmark-beta step in a fixed region, solved for the end acceleration by Newton-Raphson
// (the paper's eqs. 13-17 in acceleration form: the unknown a_{n+1} keeps the iteration well
// conditioned for the tiny sub-steps at a transition). m is sys.mass().
// Returns false if Newton-Raphson did not converge. Always inlined: it is the hot loop's body.
template <SwitchedSystem S>
[[gnu::always_inline]] inline bool newmark_substep(const S& sys, double m, const State& s0,
                                                   const NewmarkStep& k,
                                                   const typename S::Drive& d1,
                                                   const NewmarkOptions& o, State& s1) {
  const double qp = s0.q + k.h * s0.v + k.qa * s0.a;
  const double vp = s0.v + k.va * s0.a;
  double a = s0.a;
  bool converged = false;
  if constexpr (S::kPiecewiseLinear) {
    // Affine region, f = f(0, 0) + f_q q + f_v v: Newton-Raphson lands on the root in one
    // update from any start; written in closed form, everything but the last line depends on
    // the drive alone, which keeps it off the chain of dependent operations between steps.
    const Force f = sys.force(d1, 0.0, 0.0, s0.region);
    const double inv_tangent = 1.0 / (m - f.d_dq * k.bh2 - f.d_dv * k.gh);
    a = (f.value + f.d_dq * qp + f.d_dv * vp) * inv_tangent;
    converged = true;
  }
  for (int it = 0; !S::kPiecewiseLinear && it < o.newton_max_iterations; ++it) {
    const Force f = sys.force(d1, qp + k.bh2 * a, vp + k.gh * a, s0.region);
    const double residual = m * a - f.value;
    // The tangent does not depend on the state: its reciprocal is computed off the chain of
    // dependent operations that limits the step rate.
    const double inv_tangent = 1.0 / (m - f.d_dq * k.bh2 - f.d_dv * k.gh);
    const double da = -residual * inv_tangent;
    a += da;
    if (std::abs(da) <= o.newton_relative_tolerance * (std::abs(a) + std::abs(s0.a))) {
      converged = true;
      break;
    }
  }
  s1.t = s0.t + k.h;
  s1.q = qp + k.bh2 * a;
  s1.v = vp + k.gh * a;
  s1.a = a;
  s1.region = s0.region;
  return converged;
}

namespace detail {

struct Crossing {
  double h;    // time from the step's start to the guard surface
  int target;  // the region on the other side
  State at;    // the state there, still in the old region
};

// Locates the earliest zero among the guards of `s.region` that are negative at the end of a
// step of size h from s. Kept out of line (and s taken by value) so that the hot loop's state
// stays in registers.
template <SwitchedSystem S>
[[gnu::noinline]] Crossing locate_crossing(const S& sys, double m, State s, double h,
                                           const Guards& at_end, const NewmarkOptions& o) {
  Crossing c{h, s.region, s};
  bool found = false;
  for (int i = 0; i < at_end.count; ++i) {
    if (!(at_end.items[i].value < 0)) continue;
    State sub;
    auto guard_after = [&](double hh) {
      const typename S::Drive d = sys.drive(s.t + hh);
      newmark_substep(sys, m, s, NewmarkStep(hh, o), d, o, sub);
      return sys.guards(d, sub.q, sub.v, s.region).items[i].value;
    };
    const double g0 = sys.guards(sys.drive(s.t), s.q, s.v, s.region).items[i].value;
    double hi = 0.0;  // a guard already on its surface at the start crosses at once
    if (g0 > 0) {
      std::uintmax_t iterations = kTransitionMaxIterations;
      hi = boost::math::tools::toms748_solve(
               guard_after, 0.0, h, g0, at_end.items[i].value,
               boost::math::tools::eps_tolerance<double>(kTransitionBits), iterations)
               .second;  // the side on which the guard has turned negative
    }
    if (!found || hi < c.h) {
      found = true;
      c.h = hi;
      c.target = at_end.items[i].target;
    }
  }
  if (c.h > 0) newmark_substep(sys, m, s, NewmarkStep(c.h, o), sys.drive(s.t + c.h), o, c.at);
  c.at.t = s.t + c.h;
  return c;
}

}  // namespace detail

// Integrates from `initial` (its a is recomputed from the equation) to t1 on the uniform grid
// t0 + n dt, dt = (t1 - t0) / ceil((t1 - t0) / dt_max). A step whose end lies in another region
// is split at the located crossing: the sub-step up to the guard surface is solved in the old
// region, the rest in the new one, so the method keeps its second order through every
// transition.
template <SwitchedSystem S, class Observer>
IntegrationSummary integrate_newmark(const S& sys, State initial, double t1, double dt_max,
                                     const OutputGrid& output, Observer& obs,
                                     const NewmarkOptions& o = {}) {
  assert(dt_max > 0 && t1 >= initial.t && output.interval_s >= 0);
  IntegrationSummary sum;
  const double t0 = initial.t;
  const std::int64_t n_steps =
      std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil((t1 - t0) / dt_max - 1e-9)));
  const double dt = (t1 - t0) / static_cast<double>(n_steps);
  const double m = sys.mass();

  State s = initial;
  s.a = sys.force(sys.drive(s.t), s.q, s.v, s.region).value / m;
  constexpr double kNever = std::numeric_limits<double>::infinity();
  std::int64_t next_sample = 0;
  double next_sample_t = output.count > 0 ? output.time(0) : kNever;
  auto emit_samples = [&next_sample, &next_sample_t, &output, &obs](const State& a,
                                                                    const State& b) {
    while (next_sample_t <= b.t) {
      obs.on_sample(detail::interpolate(a, b, std::max(next_sample_t, a.t)));
      ++next_sample;
      next_sample_t = next_sample < output.count ? output.time(next_sample) : kNever;
    }
  };
  emit_samples(s, s);

  // The state is passed by value: a reference capture would keep the loop's state in memory.
  auto fail = [&sum](Termination t, State at, const std::string& what) {
    sum.termination = t;
    sum.message = what + " at t = " + std::to_string(at.t) + " s";
    sum.end_time_s = at.t;
    sum.end_state = at;
    return sum;
  };

  // Loop invariants in locals: the observer's stores could otherwise alias them.
  const NewmarkStep full_step(dt, o);
  const std::int64_t progress_mask = o.progress_interval_steps - 1;
  const int max_transitions = o.max_transitions_per_step;

  auto grid = sys.drive_grid(t0, dt);
  State trial;
  for (std::int64_t n = 1; n <= n_steps; ++n) {
    const double t_end = (n == n_steps) ? t1 : t0 + static_cast<double>(n) * dt;
    const typename S::Drive d_end = grid.next();
    int transitions = 0;
    for (;;) {
      // A whole grid step uses the precomputed coefficients; the rest of a split step its own.
      const bool whole = transitions == 0;
      const double h = whole ? dt : t_end - s.t;
      if (!newmark_substep(sys, m, s, whole ? full_step : NewmarkStep(h, o), d_end, o, trial))
        return fail(Termination::kNewtonFailed, s,
                    "Newton-Raphson did not converge in " +
                        std::to_string(o.newton_max_iterations) + " iterations");
      trial.t = t_end;
      const Guards g = sys.guards(d_end, trial.q, trial.v, s.region);
      bool crossed = false;
      for (int i = 0; i < g.count; ++i) crossed |= g.items[i].value < 0;
      if (!crossed) break;
      if (transitions >= max_transitions) {
        ++sum.unsplit_steps;
        break;
      }
      const detail::Crossing c = detail::locate_crossing(sys, m, s, h, g, o);
      if (c.h > 0) {
        ++sum.steps;
        emit_samples(s, c.at);
        obs.on_step(c.at, sys.drive(c.at.t));
      }
      const int from = s.region;
      s = c.at;
      s.region = c.target;
      s.a = sys.force(sys.drive(s.t), s.q, s.v, s.region).value / m;
      ++sum.transitions;
      ++transitions;
      obs.on_transition(s, from);
    }
    if (!std::isfinite(trial.q) || !std::isfinite(trial.v))
      return fail(Termination::kDiverged, trial, "the solution became non-finite");
    ++sum.steps;
    emit_samples(s, trial);
    s = trial;
    obs.on_step(s, d_end);
    if ((n & progress_mask) == 0 && !obs.on_progress(s.t))
      return fail(Termination::kCancelled, s, "cancelled");
  }
  sum.end_time_s = s.t;
  sum.end_state = s;
  return sum;
}

struct Dopri5Options {
  double relative_tolerance = 1e-10;
  double absolute_tolerance = 1e-10;  // in the units of q and q' scaled by the caller
  double initial_step_s = 1e-7;
  double max_step_s = std::numeric_limits<double>::infinity();
  std::int64_t max_steps = std::int64_t{1} << 34;
  std::int64_t progress_interval_steps = std::int64_t{1} << 16;
  // Points inside every step at which the guards are checked on the dense output besides its
  // end, so that a contact entered and left within one step is seen (no step cap needed).
  int in_step_checks = 4;
  // Region changes in a row that each advance time by less than min_progress_s before the
  // run ends with kNoProgress (a chattering contact).
  int max_stalled_transitions = 64;
  double min_progress_s = 0;  // 0: 1e-12 of the window
};

// Integrates with the Dormand-Prince 5(4) pair and its dense output (Boost.Odeint). Inside a
// region the right-hand side is smooth; after every step the guards are checked at points
// inside it and at its end (Dopri5Options::in_step_checks), a crossing is located on the dense
// output by TOMS 748 (Boost.Math), and the stepper restarts there in the new region. The
// step is not capped. A run whose region changes stop advancing time ends with kNoProgress.
// The system's kPiecewiseLinear and drive_grid are not used.
template <SwitchedSystem S, class Observer>
IntegrationSummary integrate_dopri5(const S& sys, State initial, double t1,
                                    const OutputGrid& output, Observer& obs,
                                    const Dopri5Options& o = {}) {
  assert(t1 >= initial.t && o.relative_tolerance > 0 && o.absolute_tolerance > 0);
  namespace odeint = boost::numeric::odeint;
  using X = std::array<double, 2>;
  IntegrationSummary sum;
  const double m = sys.mass();
  int region = initial.region;
  auto rhs = [&](const X& x, X& dxdt, double t) {
    dxdt[0] = x[1];
    dxdt[1] = sys.force(sys.drive(t), x[0], x[1], region).value / m;
  };
  auto state_at = [&](const X& x, double t) {
    return State{t, x[0], x[1], sys.force(sys.drive(t), x[0], x[1], region).value / m, region};
  };
  auto stepper = odeint::make_dense_output(o.absolute_tolerance, o.relative_tolerance, o.max_step_s,
                                           odeint::runge_kutta_dopri5<X>());
  X x{initial.q, initial.v};
  double t = initial.t;
  stepper.initialize(x, t, std::min(o.initial_step_s, o.max_step_s));

  std::int64_t next_sample = 0;
  auto emit_samples = [&](double upto) {
    while (next_sample < output.count && output.time(next_sample) <= upto) {
      const double ts = std::max(output.time(next_sample), stepper.previous_time());
      X xs;
      if (ts <= t) {
        xs = x;  // at the restart point itself
      } else {
        stepper.calc_state(ts, xs);
      }
      obs.on_sample(state_at(xs, ts));
      ++next_sample;
    }
  };
  while (next_sample < output.count && output.time(next_sample) <= t) {
    obs.on_sample(state_at(x, t));
    ++next_sample;
  }

  const double min_progress = o.min_progress_s > 0 ? o.min_progress_s : 1e-12 * (t1 - t);
  int stalled = 0;
  while (t < t1) {
    if (sum.steps >= o.max_steps) {
      sum.termination = Termination::kStepUnderflow;
      sum.message = "more than " + std::to_string(o.max_steps) + " steps";
      break;
    }
    const auto [ta, tb] = stepper.do_step(rhs);
    ++sum.steps;
    if (!(tb > ta) || ta + (tb - ta) == ta) {
      sum.termination = Termination::kStepUnderflow;
      sum.message = "the step size fell below the resolution of t = " + std::to_string(ta) + " s";
      break;
    }
    const double te = std::min(tb, t1);
    X xe;
    if (te == tb) {
      xe = stepper.current_state();
    } else {
      stepper.calc_state(te, xe);
    }
    if (!std::isfinite(xe[0]) || !std::isfinite(xe[1])) {
      sum.termination = Termination::kDiverged;
      sum.message = "the solution became non-finite at t = " + std::to_string(te) + " s";
      break;
    }
    // The guards at in_step_checks points inside the step and at its end: the first
    // sub-interval at whose end one is negative holds the crossing.
    double t_cross = te;
    int target = region;
    const int checks = std::max(0, o.in_step_checks) + 1;
    double tb_prev = ta;
    for (int j = 1; j <= checks && target == region; ++j) {
      const double tj = j == checks ? te : ta + (te - ta) * j / checks;
      X xj;
      if (j == checks) {
        xj = xe;
      } else {
        stepper.calc_state(tj, xj);
      }
      const Guards g = sys.guards(sys.drive(tj), xj[0], xj[1], region);
      for (int i = 0; i < g.count; ++i) {
        if (!(g.items[i].value < 0)) continue;
        auto guard_at = [&](double tt) {
          X xx;
          stepper.calc_state(tt, xx);
          return sys.guards(sys.drive(tt), xx[0], xx[1], region).items[i].value;
        };
        const double ga = guard_at(tb_prev);
        double hi = tb_prev;
        if (ga > 0) {
          std::uintmax_t iters = kTransitionMaxIterations;
          hi = boost::math::tools::toms748_solve(
                   guard_at, tb_prev, tj, ga, g.items[i].value,
                   boost::math::tools::eps_tolerance<double>(kTransitionBits), iters)
                   .second;
        }
        if (hi <= t_cross) {
          t_cross = hi;
          target = g.items[i].target;
        }
      }
      tb_prev = tj;
    }
    if (target != region) {
      X xc;
      stepper.calc_state(t_cross, xc);
      emit_samples(t_cross);
      obs.on_step(state_at(xc, t_cross), sys.drive(t_cross));
      const int from = region;
      region = target;
      stalled = (t_cross - t <= min_progress) ? stalled + 1 : 0;
      x = xc;
      t = t_cross;
      ++sum.transitions;
      if (stalled > o.max_stalled_transitions) {
        sum.termination = Termination::kNoProgress;
        sum.message = std::to_string(stalled) +
                      " region changes without time advancing at t = " + std::to_string(t) +
                      " s (a chattering contact)";
        break;
      }
      obs.on_transition(state_at(x, t), from);
      stepper.initialize(x, t, std::min(stepper.current_time_step(), o.max_step_s));
      continue;
    }
    emit_samples(te);
    x = xe;
    t = te;
    obs.on_step(state_at(x, t), sys.drive(t));
    if (sum.steps % o.progress_interval_steps == 0 && !obs.on_progress(t)) {
      sum.termination = Termination::kCancelled;
      sum.message = "cancelled at t = " + std::to_string(t) + " s";
      break;
    }
  }
  sum.end_time_s = t;
  sum.end_state = state_at(x, t);
  return sum;
}

}  // namespace geardyn::ode
