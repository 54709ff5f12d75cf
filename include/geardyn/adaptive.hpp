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
// events and samples). Its accuracy is the tolerance's, relative and absolute on every state
// component as Boost.Odeint's controlled stepper takes them.
#pragma once

#include <cstdint>

#include "geardyn/engine.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn::ode {

struct AdaptiveOptions {
  double tolerance = 1e-8;  // relative and absolute error per step
  // Events in a row that each advance time by less than 1e-12 of the window before the flow
  // ends with kNoProgress (a chattering contact), never a hang.
  int max_stalled_events = 64;
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
