// The one-degree model's multiple shooting (one_degree_orbit.cpp), a reference implementation
// beside the shooting of trains (src/studies/shooting.hpp, whose segments and Newton iteration it
// uses).
#pragma once

#include <string>
#include <vector>

#include "geardyn/one_degree_run.hpp"
#include "geardyn/orbit.hpp"
#include "studies/shooting.hpp"

namespace geardyn::detail {

// The Newton iteration's unknowns are scaled: delta by b, delta' by b w_n: (b, b w_n).
ode::Vector orbit_scale(const GearPairModel& model);

// One case value: its model, the exact engine, and the residual of M segments of length T / M
// over the orbit's period T = N T0. Not copyable (the solver refers to the model).
class Shooting {
 public:
  // `scale` is the unknowns' scale (empty: orbit_scale of this case; a continuation keeps its
  // first case's); `engine_tolerance` is solver.tolerance for the exact engine; `stiffness`, when
  // given, is the case's mesh stiffness (shared_stiffness: a continuation computes it once).
  // Throws InputError.
  Shooting(const Case& c, int periods, int segments, const ode::Vector& scale,
           double engine_tolerance, const MeshStiffness* stiffness = nullptr);
  Shooting(const Shooting&) = delete;
  Shooting& operator=(const Shooting&) = delete;

  const GearPairModel& model() const { return model_; }
  const Solver& solver() const { return solver_; }
  double system_period_s() const { return system_period_s_; }
  double period_s() const { return period_s_; }
  int segments() const { return segments_.segments(); }
  Eigen::Index dimension() const { return segments_.dimension(); }
  // The multiple shooting of this case's flow (Segments above).
  const Segments& shooting() const { return segments_; }

  // The flow of segment i from y (physical units) over its T / M, with its Jacobian.
  ode::FlowResult flow(int i, const ode::Vector& y) const;
  ode::Vector state(const ode::Vector& x, int i) const { return segments_.state(x, i); }
  ode::Vector scaled(const ode::Vector& y) const { return segments_.scaled(y); }
  bool guess(const ode::Vector& y0, ode::Vector& x, std::string& why) const {
    return segments_.guess(y0, x, why);
  }
  bool residual(const ode::Vector& x, ode::Vector& f, ode::Matrix* jacobian,
                std::vector<ode::Matrix>* segment_jacobians, std::string& why) const {
    return segments_.residual(x, f, jacobian, segment_jacobians, why);
  }

  // Fills an orbit's section state, monodromy (from the segments' Jacobians at x), multipliers,
  // stability, contact sequence and reading (one period flown with a RunReader). False with
  // `why` when that flow fails.
  bool read(const ode::Vector& x, const std::vector<ode::Matrix>& segment_jacobians, Orbit& orbit,
            std::string& why) const;

 private:
  GearPairModel model_;
  Solver solver_;
  double system_period_s_, period_s_;
  Segments segments_;
};

}  // namespace geardyn::detail
