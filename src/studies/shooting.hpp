// geardyn internal: the multiple-shooting residual of periodic orbits and Newton's method on
// it, for any flow of the exact engine (the one-degree model's, the coupled model's and a gear
// train's), shared by find_orbit, find_coupled_orbit, find_train_orbit and the continuation
// (orbit.hpp, coupled_orbit.hpp, train_orbit.hpp, continuation.hpp). The coupled model's own
// shooting is coupled_orbit.cpp's: no other path takes it.
#pragma once

#include <Eigen/Core>
#include <complex>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "geardyn/orbit.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_orbit.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn::detail {

// The engine's tolerance as a fraction of the orbit's Newton tolerance, so that the Jacobian
// and the residual are exact to well below what Newton is asked for (orbits, continuation).
constexpr double kEngineToleranceFraction = 1e-4;

// Below this solver.tolerance the exact engine's own tolerance is the rounding limit
// (run.hpp's kExactToleranceFraction of it): exact_case gives no finer one, and the case stays
// one that validate() accepts.
constexpr double kFinestEngineCaseTolerance = ode::kRoundingLimit / kExactToleranceFraction;
// The case as a shooting integrates it: the exact engine at engine_tolerance.
Case exact_case(const Case& c, double engine_tolerance);

// M segments of a period T of any flow: the unknowns are the scaled states at the segments'
// starts, x_i = y_i / scale (state dimension d = scale.size()), and the residual is
// F(x)_i = phi_i(y_i) / scale - x_{i+1} (i + 1 mod M).
class Segments {
 public:
  // The flow of segment i from y (physical units) over its T / M, with its Jacobian.
  using Flow = std::function<ode::FlowResult(int i, const ode::Vector& y)>;
  Segments(Flow flow, int segments, ode::Vector scale)
      : flow_(std::move(flow)), segments_(segments), scale_(std::move(scale)) {}

  int segments() const { return segments_; }
  const ode::Vector& scale() const { return scale_; }
  Eigen::Index state_dimension() const { return scale_.size(); }
  Eigen::Index dimension() const { return scale_.size() * segments_; }
  ode::FlowResult flow(int i, const ode::Vector& y) const { return flow_(i, y); }
  // Segment i's state of the scaled unknowns x, physical; and back.
  ode::Vector state(const ode::Vector& x, int i) const;
  ode::Vector scaled(const ode::Vector& y) const { return y.cwiseQuotient(scale_); }
  // The scaled unknowns of a first guess: y on the section, then its flow to each segment's
  // start. False with `why` when a flow fails.
  bool guess(const ode::Vector& y0, ode::Vector& x, std::string& why) const;
  // The scaled residual and, when asked, dF/dx and the segments' Jacobians (physical). False
  // with `why` when a flow fails.
  bool residual(const ode::Vector& x, ode::Vector& f, ode::Matrix* jacobian,
                std::vector<ode::Matrix>* segment_jacobians, std::string& why) const;

 private:
  Flow flow_;
  int segments_;
  ode::Vector scale_;
};

// Newton's method with backtracking on the residual's largest entry, from x (left at the
// last accepted iterate), to options.tolerance in at most options.max_iterations.
struct NewtonOutcome {
  bool converged = false;
  int iterations = 0;
  double residual = 0;
  std::string message;                 // why not, or how
  std::vector<ode::Matrix> jacobians;  // the segments' at x, when converged
};
NewtonOutcome solve_periodic(const Segments& s, ode::Vector& x, const OrbitOptions& options);

// solve_periodic from x, then, while it fails and options.starts allow, from the next settled
// state (OrbitOptions::starts): next(x, why) sets x to the unknowns of the state one orbit
// period after the last start, or says why it cannot (a failed flow ends the starts). The
// iterations are those of every start; the message says from which start it converged, or
// that every start failed.
NewtonOutcome solve_periodic_from_settled(
    const Segments& s, ode::Vector& x, const OrbitOptions& options,
    const std::function<bool(ode::Vector& x, std::string& why)>& next);

// Why a settling simulation (the first guess's, or the next start's) failed, in an orbit's
// message.
std::string settling_failed(ode::Termination termination, const std::string& message);

// The periodic solution s of `shooting` (its segments, shooting.shooting(), and its reading,
// shooting.read(x, jacobians, s, why)) from the section state `first` (as the segments' flow
// takes it): Newton from there (solve_periodic_from_settled), each further start the section
// state next(y, why) gives (false, with why, when its flow fails; with `one_start` none). s's
// iterations, residual and message are Newton's; when it converged s is read at its unknowns
// and converged, unless that reading fails (its message then why). Every orbit finder's
// common end (trains', and the references').
template <class Shooting, class Solution>
void find_periodic(const Shooting& shooting, const ode::Vector& first, const OrbitOptions& options,
                   bool one_start,
                   const std::function<bool(ode::Vector& y, std::string& why)>& next, Solution& s) {
  const Segments& segments = shooting.shooting();
  ode::Vector x;
  std::string why;
  if (!segments.guess(first, x, why)) {
    s.message = why;
    return;
  }
  OrbitOptions once = options;
  if (one_start) once.starts = 1;
  const NewtonOutcome newton = solve_periodic_from_settled(
      segments, x, once, [&](ode::Vector& next_x, std::string& next_why) {
        ode::Vector y;
        return next(y, next_why) && segments.guess(y, next_x, next_why);
      });
  s.iterations = newton.iterations;
  s.residual = newton.residual;
  s.message = newton.message;
  if (!newton.converged) return;
  if (!shooting.read(x, newton.jacobians, s, why)) {
    s.message = why;
    return;
  }
  s.converged = true;
}

// The monodromy matrix (the product of the segments' Jacobians, last on the left) and its
// eigenvalues, largest modulus first.
void floquet(const std::vector<ode::Matrix>& segment_jacobians, ode::Matrix& monodromy,
             std::vector<std::complex<double>>& multipliers);

// The keys every orbit's JSON shares: converged, message, iterations, residual, period_s,
// periods, system_period_s, segments, floquet_multipliers [[re, im], ...], max_multiplier,
// stable and monodromy (row by row).
nlohmann::json periodic_json(const PeriodicSolution& o);

// A gear train's counterpart (train_orbit.hpp). Its unknowns z are coordinates and rates of
// the state y, which z gives as y = F z + g(t) and takes back as z = R y (R F = I, R g = 0):
// - with a prescribed speed, those of the bodies whose speed is not prescribed (a prescribed
//   body's state at any time is its prescription's, g);
// - turning freely (no prescribed speed), the train's orbits are periodic modulo its rigid
//   rotation, which no force of the train changes: the reference's angle is taken as 0 (each
//   other angle counted from the rigid turn that keeps it so, theta_i - (r_i / r_ref)
//   theta_ref, and each other rate from the rigid rate that goes with the reference's,
//   theta_i' - (r_i / r_ref) theta_ref'), and,
//   when no viscous drag acts, the rigid momentum p = r^T J theta' is not an unknown either:
//   the torques alone change it, p' = r^T T(t), and the phase condition that the train turns at
//   its nominal speed on average (the mean of p over the period 0) fixes it, p(t) = sum r_q
//   (A / w) sin(w t + phi) over the torques' harmonics, carried by the rigid rate
//   r p(t) / (r^T J r) of every body. With a
//   viscous drag the reference's rate stays an unknown (the drag damps the rigid rate).
// Not copyable (the flow refers to the solver).
class TrainShooting {
 public:
  // `scale` as for Shooting (empty: each free coordinate as train_state_scale measures it).
  // Throws InputError for a case that is no train, a freely turning one whose mean
  // torques do not balance (it speeds up or slows down), one with no common period
  // (quasi-periodic) or in which nothing varies. `stiffness` as for TrainSolver (a pair form's
  // mesh stiffness computed beforehand; a train's meshes carry their own).
  TrainShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                double engine_tolerance, const MeshStiffness* stiffness = nullptr);
  TrainShooting(const TrainShooting&) = delete;
  TrainShooting& operator=(const TrainShooting&) = delete;

  const TrainSolver& solver() const { return solver_; }
  double system_period_s() const { return system_period_s_; }
  double period_s() const { return period_s_; }
  const Segments& shooting() const { return segments_; }
  // The unknowns' names: each free coordinate's (<body>_rad, <body>_x_m, ...), then its rate's
  // (the same with _s).
  const std::vector<std::string>& coordinates() const { return names_; }
  // The whole state (q, q') at t_s from the unknowns z (physical), and back.
  ode::Vector full(double t_s, const ode::Vector& z) const;
  ode::Vector reduce(const ode::Vector& y) const;
  // Whether the train turns freely (its unknowns taken modulo the rigid rotation).
  bool turns_freely() const { return free_turning_; }
  // A one-degree form's (model.form "gear_pair" or "nondimensional": its train is the two gears
  // on one mesh): the one-degree model's section state (x, x') = (d - e, d' - e') at t = 0 of
  // the unknowns z, affine in z, and the unknowns of such a state (which throws InputError
  // naming `what` for a train whose unknowns are not two, or which x does not determine).
  ode::Vector one_degree_state(const ode::Vector& z) const;
  ode::Vector one_degree_unknowns(const ode::Vector& x, const std::string& what) const;

  // Fills an orbit's coordinates, section state (the unknowns' and every body's), monodromy,
  // multipliers, stability and each mesh's reading over one period (flown and read). False with
  // `why` when that flow fails.
  bool read(const ode::Vector& x, const std::vector<ode::Matrix>& segment_jacobians,
            TrainOrbit& orbit, std::string& why) const;

 private:
  // Segment i's flow from the unknowns z, with their Jacobian.
  ode::FlowResult flow(int i, const ode::Vector& z) const;
  TrainSolver solver_;
  std::vector<Eigen::Index> free_;  // indices into (q, q') of the unknowns
  ode::Matrix lift_, project_;      // F and R above
  bool free_turning_ = false;
  int momentum_row_ = -1;         // the state's index that carries p(t) (the reference's rate)
  HarmonicSeries momentum_rate_;  // p(t) r_ref / (r^T J r): the reference's rate at z' = 0
  Eigen::VectorXd rigid_rates_;   // r / r_ref: each rate's share of the reference's rigid rate
  std::vector<std::string> names_;
  int periods_;
  double system_period_s_ = 0, period_s_ = 0;
  Segments segments_;
};

// A one-degree form's orbit (orbit.hpp) read from its train's, t found by shooting s: the
// periodic solution's numbers, the monodromy in (x, x') (S M S^-1, S = dx/dz), the section
// state (x, x', x'' and the mesh's region), the mesh's contact sequence and its reading in the
// one-degree units (b, b k_m).
Orbit one_degree_orbit(const TrainShooting& s, const TrainOrbit& t);

// The Newton matrix solve shared by the orbit and the continuation: false when singular.
bool solve_newton(const ode::Matrix& jacobian, const ode::Vector& f, ode::Vector& step);

}  // namespace geardyn::detail
