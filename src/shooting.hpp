// geardyn internal: the multiple-shooting residual of the gear model's periodic orbits, shared
// by find_orbit and the continuation (orbit.hpp, continuation.hpp).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "geardyn/orbit.hpp"
#include "geardyn/run.hpp"

namespace geardyn::detail {

// The engine's tolerance as a fraction of the orbit's Newton tolerance, so that the Jacobian
// and the residual are exact to well below what Newton is asked for (orbits, continuation).
constexpr double kEngineToleranceFraction = 1e-4;

// The Newton iteration's unknowns are scaled: delta by b, delta' by b w_n: (b, b w_n).
ode::Vector orbit_scale(const GearPairModel& model);

// One case value: its model, the exact engine, and the residual of M segments of length T / M
// over the orbit's period T = N T0. Not copyable (the solver refers to the model).
class Shooting {
 public:
  // `scale` is the unknowns' scale (empty: orbit_scale of this case; a continuation keeps its
  // first case's); `engine_tolerance` is solver.tolerance for the exact engine. Throws
  // InputError.
  Shooting(const Case& c, int periods, int segments, const ode::Vector& scale,
           double engine_tolerance);
  Shooting(const Shooting&) = delete;
  Shooting& operator=(const Shooting&) = delete;

  const GearPairModel& model() const { return model_; }
  const Solver& solver() const { return solver_; }
  double system_period_s() const { return system_period_s_; }
  double period_s() const { return period_s_; }
  int segments() const { return segments_; }
  Eigen::Index dimension() const { return Eigen::Index{2} * segments_; }

  // The flow of segment i from y (physical units) over its T / M, with its Jacobian.
  ode::FlowResult flow(int i, const ode::Vector& y) const;
  // Segment i's state of the scaled unknowns x, physical; and back.
  ode::Vector state(const ode::Vector& x, int i) const;
  ode::Vector scaled(const ode::Vector& y) const { return y.cwiseQuotient(scale_); }
  // The scaled unknowns of a first guess: y on the section, then its flow to each segment's
  // start. False with `why` when a flow fails.
  bool guess(const ode::Vector& y0, ode::Vector& x, std::string& why) const;

  // The scaled residual F(x)_i = y_{i+1} - phi_i(y_i) and, when asked, dF/dx and the segments'
  // Jacobians (physical). False with `why` when a flow fails.
  bool residual(const ode::Vector& x, ode::Vector& f, ode::Matrix* jacobian,
                std::vector<ode::Matrix>* segment_jacobians, std::string& why) const;

  // Fills an orbit's section state, monodromy (from the segments' Jacobians at x), multipliers,
  // stability, contact sequence and reading (one period flown with a RunReader). False with
  // `why` when that flow fails.
  bool read(const ode::Vector& x, const std::vector<ode::Matrix>& segment_jacobians, Orbit& orbit,
            std::string& why) const;

 private:
  GearPairModel model_;
  Solver solver_;
  double system_period_s_, period_s_;
  int segments_;
  ode::Vector scale_;
};

// The Newton matrix solve shared by the orbit and the continuation: false when singular.
bool solve_newton(const ode::Matrix& jacobian, const ode::Vector& f, ode::Vector& step);

}  // namespace geardyn::detail
