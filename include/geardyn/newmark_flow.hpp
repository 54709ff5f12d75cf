// geardyn: the paper's Newmark-beta integrator (Park 2010, eqs. 13-17) for the piecewise-linear
// systems of linear_system.hpp, beside the exact engine (engine.hpp) and the adaptive
// integrator (adaptive.hpp), with their observer interface. Nothing here knows of gears.
//
// The system must be of second order: y = (q, v), n = 2N, every region's first N rows of
// A_r(t) the constant [0 I] and of u_r(t) zero, so that
//
//     a = q'' = P_r(t) q + R_r(t) v + s_r(t)        (the last N rows: [P_r R_r], s_r).
//
// A step of length h from (q0, v0, a0) predicts qp = q0 + h v0 + (1/2 - beta) h^2 a0 and
// vp = v0 + (1 - gamma) h a0 and solves the end's equation for a1 (acceleration form: a linear
// region's Newton-Raphson lands in one update, here written as the solve)
//
//     (I - beta h^2 P(t1) - gamma h R(t1)) a1 = P(t1) qp + R(t1) vp + s(t1),
//     q1 = qp + beta h^2 a1,   v1 = vp + gamma h a1.
//
// The steps lie on the uniform grid t0 + k dt, dt = (t1 - t0) / ceil((t1 - t0) / time_step_s),
// as integrate_newmark's (integrator.hpp), the one-degree model's own. A step whose end leaves
// the region (a guard below its slack, kGuardSlack) is split where the guard crosses: the
// crossing is located by TOMS 748 on the sub-step's length to kTransitionBits, the sub-step up
// to it is solved in the old region, the rest of the step in the new one, so the method keeps
// its second order through every contact change (at most max_transitions_per_step of them in a
// step; the rest of such a step is taken unsplit, counted in FlowResult::unsplit_steps). a is
// recomputed from the equation at the start and after every region change (it is the state's
// function in a linear system). Samples are the cubic Hermite interpolants of q (with v) and of v
// (with a) over the step that holds them.
//
// Average acceleration (beta 1/4, gamma 1/2, the default) is unconditionally stable and of
// second order, and keeps the energy of an undamped linear system with constant coefficients
// exactly (to rounding). on_cell and needs_detail are never called: an observer reads its
// extremes at step ends, events and samples (the adaptive integrator gives points inside its
// steps too, on_point; Newmark has no dense output to give them).
#pragma once

#include "geardyn/engine.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn::ode {

// Empty when every region of s (a lazy system's: the regions built so far, and each later as
// the flow enters it) is of second order as above; otherwise which row is not.
std::string second_order_form_error(const LinearSwitchedSystem& s, int region);

// Flows from (t0, y0) in `region` to t1 with steps of at most time_step_s (> 0), as
// ExactEngine::flow does (the same observer calls but on_cell and needs_detail; FlowResult::cells
// counts the steps and sub-steps). The options' beta, gamma, max_transitions_per_step and
// progress_interval_steps are used (the Newton fields are not: every region is linear).
// Throws std::invalid_argument unless check_flow_arguments accepts the arguments, time_step_s
// is positive and finite and every region the flow enters is of second order. A numerical
// failure (a non-finite state, a singular step matrix) or a cancellation is reported in the
// result, never thrown.
FlowResult newmark_flow(const LinearSwitchedSystem& system, double t0_s, const Vector& y0,
                        int region, double t1_s, double time_step_s, const OutputGrid& output,
                        FlowObserver& observer, const NewmarkOptions& options = {});

}  // namespace geardyn::ode
