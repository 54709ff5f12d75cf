// geardyn: an adaptive integrator for the piecewise-linear systems of linear_system.hpp, beside
// the exact engine (engine.hpp) and with its observer interface. Nothing here knows of gears.
//
// Dormand-Prince 5(4) with dense output (Boost.Odeint) steps y' = A_r(t) y + u_r(t); after every
// step the guards of the current region are evaluated at its end, and where one has turned
// negative the earliest crossing is located by TOMS 748 on the dense output, the observer told
// (on_step, then on_event) and the stepper restarted in the guard's target region from there.
// Samples are the dense output at the grid's times.
//
// What it is for: a system whose coefficient period holds many cells and a window of few such
// periods, where the exact engine's cells (each a Taylor series of the time-varying A_r, costly
// for n of ten and more) are built once and hardly used again; there a step costs a few
// products A_r(t) y. What it gives up: the exact engine's bounds, so a guard that goes negative
// and back within one step is not seen (the step length, set by the tolerance, is the
// resolution), and on_cell is never called (an observer reads its extremes at step ends,
// events, samples and AdaptiveOptions::points_per_step points of the dense output inside each
// step, on_point). Its accuracy is the tolerance's, relative and absolute on every state
// component as Boost.Odeint's controlled stepper takes them.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

#include "geardyn/engine.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn::ode {

// A non-zero entry of the varying part counts as this many dense multiply-adds when choosing
// how RegionDerivative evaluates it (an entry's cosine and sine terms, its scattered reads).
constexpr double kSparseEntryCost = 4.0;
// The shared row space is used only where it gives every varying matrix back to this fraction
// of its largest entry (it does to rounding where the rank is structural).
constexpr double kLowRankTolerance = 1e-13;

// y' = A_r(t) y + u_r(t) of one region, as adaptive_flow evaluates it at every stage of every
// step: equal to derivative() (linear_system.hpp) to rounding, in fewer operations.
// - A row of A0 that copies one state entry (a coordinate's rate: the [0 I] of y = (q, q')) and
//   has no varying term is a copy; the other rows of A0 are one dense product.
// - The varying part sum_f (Ac_f cos(w_f t) + As_f sin(w_f t)) is kept as its non-zero entries
//   or, where that is cheaper, through the row space its matrices share: with Q (n x r)
//   orthonormal and Ac_f = Ac_f Q Q^T to rounding (a mesh's stiffness acts through its one
//   deflection, so r is at most the count of varying meshes whatever the count of frequencies),
//   sum_f (...) y = sum_f (cos Ac_f Q + sin As_f Q) (Q^T y), one dense product of width 2 F r.
// - The forcing's varying part as its non-zero entries.
// The system must outlive it; one flow's own (it keeps scratch: not for two threads at once).
class RegionDerivative {
 public:
  RegionDerivative(const LinearSwitchedSystem& s, int region);
  // dy = y'(t); both of the system's dimension, not aliased.
  void operator()(const double* y, double* dy, double t_s) const;
  // Whether the varying part is evaluated through its shared row space, and its rank there.
  bool low_rank() const { return q_.cols() > 0; }
  Eigen::Index rank() const { return q_.cols(); }

 private:
  struct Entry {
    Eigen::Index i, j;
    double c, s;
  };
  struct Terms {
    std::size_t f;  // the frequency's index
    std::vector<Entry> matrix, forcing;
  };
  const LinearRegion& r_;
  Eigen::Index n_;
  std::vector<std::pair<Eigen::Index, Eigen::Index>> copies_;  // dy(i) = y(j)
  std::vector<Eigen::Index> rows_;                             // the other rows
  Matrix a0_rows_;                                             // A0's other rows
  std::vector<Terms> terms_;  // per frequency: entries (when not low rank), forcing
  Matrix q_;                  // Q, n x r (r = 0: entries)
  Matrix b_rows_;             // [Ac_f Q, As_f Q] per low-rank frequency, on the other rows
  std::vector<std::size_t> low_rank_f_;  // the frequencies of b_rows_'s column pairs
  std::vector<std::size_t> used_;        // every frequency read
  std::vector<double> w_;
  mutable std::vector<double> cos_, sin_;
  mutable Vector qy_, product_, phases_;  // scratch
};

struct AdaptiveOptions {
  double tolerance = 1e-8;  // relative and absolute error per step
  // Events in a row that each advance time by less than 1e-12 of the window before the flow
  // ends with kNoProgress (a chattering contact), never a hang.
  int max_stalled_events = 64;
  // Points of the dense output inside every step handed to FlowObserver::on_point, evenly
  // spaced: a crest between step ends is read to (1 + points)^-2 of the step ends' error at
  // most. One (the midpoint) by default: more cost a train's run more than they gain
  // (docs/performance.md, "dopri5's extremes inside its steps").
  int points_per_step = 1;
  std::int64_t max_steps = 2'000'000'000;       // kStepUnderflow past it
  std::int64_t progress_interval_steps = 4096;  // steps between calls of on_progress
};

// Flows from (t0, y0) in `region` to t1, as ExactEngine::flow does (the same observer calls but
// on_cell and needs_detail; FlowResult::cells counts the steps). Requires a valid system
// (validate() empty, asserted in debug builds); throws std::invalid_argument unless
// check_flow_arguments accepts the other arguments. A numerical failure or cancellation is
// reported in the result, never thrown.
FlowResult adaptive_flow(const LinearSwitchedSystem& system, double t0_s, const Vector& y0,
                         int region, double t1_s, const OutputGrid& output, FlowObserver& observer,
                         const AdaptiveOptions& options = {});

}  // namespace geardyn::ode
