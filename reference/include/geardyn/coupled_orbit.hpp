// geardyn: periodic orbits of the coupled model and their Floquet stability, beside orbit.hpp
// (the one-degree model's), on the same multiple shooting and Newton iteration.
//
// The coupled model is periodic with the system period T0 of its gear pair (the common period
// of the mesh stiffness, the torque and the transmission error). A periodic motion of period
// T = N T0 is a fixed point y = (q, q') of the stroboscopic map over T; find_coupled_orbit
// solves it by Newton's method with the exact engine's Jacobian (the cells' transition
// matrices and a saltation matrix at every event of the mesh and of each clearance bearing),
// on M segments. The monodromy matrix's eigenvalues are the Floquet multipliers: 2n of them
// for n coordinates.
//
// The unknowns are scaled for the Newton residual: a coordinate in m by the backlash b, one in
// rad by b / R_b1, a rate by the same times the one-degree contact natural frequency w_n; the
// tolerance is on that scaled residual.
//
// A reference implementation: in the geardyn_reference library (reference/), linked by the tests,
// the benchmarks and `geardyn validate` alone; a coupled case's orbits are its train's
// (train_orbit.hpp).
#pragma once

#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/coupled_run.hpp"
#include "geardyn/orbit.hpp"

namespace geardyn {

struct CoupledOrbit : PeriodicSolution {
  std::vector<Coordinate> coordinates;
  ode::Vector state;  // (q, q') on the section t = 0, SI
  // One period flown from the state and read: the mesh's and each clearance bearing's
  // impacts and separations per period, the exact extremes of (d - e)/b, F_n and the bearing
  // forces.
  CoupledRunResult reading;
};

// The orbit as `geardyn orbit --json` prints it for a coupled case: converged, message,
// iterations, residual, period_s, periods, system_period_s, segments, coordinates, state
// [q..., q'...] (SI), floquet_multipliers [[re, im], ...] (largest first), max_multiplier,
// stable, impacts_per_period, backside_impacts_per_period, separations_per_period (of the
// mesh), min_delta_bar, max_delta_bar ((d - e)/b), min_force_bar, max_force_bar (F_n / (b
// k_m)), bearings [{gear, impacts_per_period, separations_per_period, max_line_force_n}] and
// monodromy [[...], ...].
std::string coupled_orbit_json(const CoupledOrbit& o, int indent = 2);

// Finds the periodic orbit of period N T0 of a coupled case from `start` (a state (q, q') on
// the section t = 0, 2n values) or, without it, from the state after settle_periods of
// simulation from solver.initial. Runs the exact engine at min(solver.tolerance, 1e-4 x the
// Newton tolerance). Throws InputError on bad input (a case of another form, bad options, a
// start of the wrong size); a failure to converge is reported in the result.
CoupledOrbit find_coupled_orbit(const Case& c, const OrbitOptions& options,
                                const std::optional<ode::Vector>& start = std::nullopt);

}  // namespace geardyn
