// geardyn: the one-degree model's own periodic orbits and flow sensitivities
// (one_degree_orbit.cpp), a reference implementation in the geardyn_reference library
// (reference/): a pair form's orbits are its train's (train_orbit.hpp), held to these by the
// tests and `geardyn validate`.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "geardyn/case.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/orbit.hpp"

namespace geardyn {

// The flow map of a case from y0 = (delta, delta') at t0 to t1 and its sensitivities:
// dy(t1)/dy(t0) exact (the engine's Jacobian: the cells' transition matrices and a saltation
// matrix at every contact event), and dy(t1)/dp for a numeric case key p by central
// differences of the exact flow with Richardson extrapolation (steps h = kKeyStep |p| and
// 2h; the key may change the model's coefficients and frequencies alike). The flows run the
// exact engine at solver.tolerance.
struct FlowSensitivity {
  ode::Vector state;        // y(t1)
  ode::Matrix d_state;      // dy(t1)/dy(t0)
  ode::Vector d_key;        // dy(t1)/dp (empty without a key)
  double key_step = 0;      // h
  double d_key_error = 0;   // |D(h) - D(2h)| / 3, largest entry: the extrapolation's error
  std::int64_t events = 0;  // contact events of the nominal flow
};

// Relative step of the key's central differences (absolute when p = 0).
constexpr double kKeyStep = 1e-3;

// Throws InputError on a bad key; std::runtime_error when a flow fails or the events of the
// five flows (p, p +- h, p +- 2h) differ in number (a grazing within the steps: the
// derivative does not exist there).
FlowSensitivity flow_sensitivity(const Case& c, const ode::State& y0, double t1_s,
                                 const std::string& key = {});

// The orbit find_orbit finds (train_orbit.hpp) found by the one-degree model's own shooting (its
// state (x, x'), its exact engine): the independent reference the tests hold find_orbit and the
// continuation to.
Orbit find_one_degree_orbit(const Case& c, const OrbitOptions& options,
                            const std::optional<ode::State>& start = std::nullopt);

}  // namespace geardyn
