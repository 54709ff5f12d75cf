// geardyn: periodic orbits and their Floquet stability, pipeline stage 6 beside analysis.hpp
// (model -> exact engine -> orbits).
//
// The gear model is periodic in time with the system period T0 (the common period of the mesh
// stiffness and the torque). A periodic motion of period T = N T0 is a fixed point of the
// stroboscopic (Poincare) map P: y(t0) -> y(t0 + T), y = (delta, delta'). find_orbit (on the
// pair's train, train_orbit.hpp, read back in y) and find_one_degree_orbit (on y) solve
// P(y) = y by Newton's method with the exact engine's Jacobian (the product of the cells'
// transition matrices and of a saltation matrix at every contact event), on M shooting
// segments of length T / M (multiple shooting: unknowns y_0 .. y_{M-1}, residuals
// y_{i+1} - phi_i(y_i)), so that an orbit whose one period holds many impacts or a strongly
// unstable one keeps a well-conditioned Newton matrix. The monodromy matrix, the product of
// the segments' Jacobians, has the Floquet multipliers as its eigenvalues: the orbit is stable
// when all of them lie inside the unit circle.
//
// The one-degree shooting scales its state for the Newton residual: delta by the backlash b,
// delta' by b w_n (w_n the linearised contact natural frequency); the tolerance is on that
// scaled residual (the train's: train_state_scale, which for the pair is the same measure over
// the mesh's lever).
#pragma once

#include <complex>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/analysis.hpp"
#include "geardyn/case.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/model.hpp"

namespace geardyn {

struct OrbitOptions {
  int periods = 1;  // N: the orbit's period in system periods T0, >= 1
  // Shooting segments; 0: one per system period (N segments).
  int segments = 0;
  // Without a start state: system periods simulated from the case's initial condition to get
  // the first guess.
  int settle_periods = 100;
  // Settled states Newton starts from at most: when Newton from the settled state fails, it
  // starts again from the state one orbit period later, and so on. A rattle that settles on a
  // chaotic motion passes near its unstable orbits at some periods and not at others. Only
  // with settling (settle_periods > 0 and no start state given).
  int starts = 16;
  double tolerance = 1e-10;  // on the scaled residual max |y_{i+1} - phi_i(y_i)| (see above)
  int max_iterations = 40;   // Newton iterations at most
  // Empty when valid; otherwise the offending option, its value and the allowed range.
  std::string validate() const;
};

// What every periodic orbit found by shooting reports (the one-degree model's below, the
// coupled model's in coupled_orbit.hpp).
struct PeriodicSolution {
  bool converged = false;
  std::string message;  // why not, when not converged; how, when converged
  int iterations = 0;
  double residual = 0;  // the scaled residual reached
  double system_period_s = 0;
  double period_s = 0;  // N T0
  int periods = 1;
  int segments = 1;
  ode::Matrix monodromy;                          // dy(T)/dy(0), with saltation at every event
  std::vector<std::complex<double>> multipliers;  // its eigenvalues, largest modulus first
  bool stable = false;                            // every multiplier inside the unit circle
  double max_multiplier() const;                  // the largest modulus (0 when none)
};

// An orbit of the one-degree model; the contact events of one period, times from the section.
struct Orbit : PeriodicSolution {
  ode::State state{};  // on the section t = 0 (mod T): delta (m), delta' (m/s); zero unconverged
  std::vector<ContactEvent> sequence;  // the contact events of one period, in order
  RunReading reading;                  // impacts, extremes of delta_bar and F_bar
};

// The orbit as `geardyn orbit --json` prints it: converged, message, iterations, residual,
// period_s, periods, system_period_s, segments, state [delta (m), delta' (m/s)], state_region,
// floquet_multipliers [[re, im], ...] (largest first), max_multiplier, stable,
// impacts_per_period, backside_impacts_per_period, separations_per_period, min_delta_bar,
// max_delta_bar, min_force_bar, max_force_bar, sequence [{t_s, event, velocity_m_s}], and
// monodromy [[...], ...] (row by row).
std::string orbit_json(const Orbit& o, int indent = 2);

// Balances m in place by a diagonal similarity, m <- D^-1 m D, D's entries powers of 2 (so
// exact), until no such scaling of a row and its column reduces their off-diagonal sums by 5 %
// (Parlett and Reinsch's iteration, as LAPACK's gebal does before an eigenvalue problem);
// returns D's diagonal. Stopped early by its sweep limit, it still leaves an exact similarity. A
// monodromy's positions and rates differ in scale by the system's frequencies (1e4 and more);
// unbalanced, its eigenvalues carry errors of about 1e-9, enough to move an undamped system's
// multipliers off the unit circle.
ode::Vector balance(ode::Matrix& m);

// The Floquet multipliers of a monodromy matrix (its eigenvalues, on the balanced matrix),
// largest modulus first.
std::vector<std::complex<double>> floquet_multipliers(const ode::Matrix& monodromy);

}  // namespace geardyn
