// geardyn: periodic orbits of a gear train (train_case.hpp) and their Floquet multipliers, by
// the multiple shooting of orbit.hpp on the train's exact engine, with the exact Jacobian
// (saltation at every impact of every mesh).
//
// The unknowns are the coordinates and rates of the bodies whose speed is not prescribed: a
// prescribed body follows its prescription whatever the train does, so its state at the
// section is the prescription's and no unknown (its own multipliers would be 1 and 1). A train
// with no prescribed body turns freely: its orbits are periodic modulo its rigid rotation,
// which no force of the train changes (a multiplier 1 that no damping moves) and which the
// torques alone accelerate. They are taken with the reference's angle at 0 (every other angle
// counted from the rigid turn that keeps it so, every other rate from the rigid rate that goes
// with the reference's: the pair's unknowns are then the one-degree model's delta and delta'
// over the mesh's lever) and, without a viscous drag, with the rigid
// momentum fixed by the phase condition that the train turns at its nominal speed on average
// (shooting.hpp, TrainShooting): the two neutral multipliers of the rigid rotation are then
// not among the multipliers. With a viscous drag the reference's rate is an unknown and its
// multiplier, which the drag makes less than 1, is among them.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {

struct TrainOrbit : PeriodicSolution {
  std::vector<std::string> coordinates;  // the unknowns: free coordinates, then rates
  Eigen::VectorXd unknowns;              // theirs at the section t = 0, in that order
  Eigen::VectorXd state;                 // the whole (q, q') at the section t = 0
  bool modulo_rotation = false;          // a freely turning train's (above)
  std::vector<std::string> meshes;       // the meshes' names
  std::vector<std::int64_t> impacts_per_period, backside_impacts_per_period;  // per mesh
  // Each mesh over one period of the orbit: its contact history and exact extremes.
  std::vector<TrainMeshReading> readings;
  // Each joint's (train::Assembled::joints(): a bearing clearance direction, an element's
  // spring) over the period.
  std::vector<std::string> clearances;
  std::vector<ContactReading> clearance_readings;
  // The contact changes of one period, in order, their times from the section (the one-degree
  // orbit's sequence): each event's part indexes the meshes, then the clearances.
  std::vector<TrainContactEvent> sequence;
};

// Finds the periodic orbit of period N T0 of a one-degree form's case (model.form "gear_pair"
// or "nondimensional"), from `start` (x = delta and delta' on the section t = 0) or, without it,
// from the state after settle_periods of simulation. The orbit is its train's (the one path:
// find_train_orbit on train_form_of, the two gears turning freely on their mesh, modulo their
// rigid rotation) read in the one-degree model's terms: its section state
// and monodromy in (x, x'), the mesh's contact sequence and reading. Uses the exact engine,
// finer than options.tolerance, whatever solver.method says. Throws InputError on bad input
// and for the other forms; a failure to converge is reported in the result (converged false,
// message).
Orbit find_orbit(const Case& c, const OrbitOptions& options,
                 const std::optional<ode::State>& start = std::nullopt);

// The orbit of N system periods (options.periods) of a train case: from a first guess settled
// over options.settle_periods system periods from solver.initial, Newton's method on M
// segments (options.segments; 0: N) to options.tolerance on the residual scaled as
// train_state_scale measures a state (train_run.hpp). Throws InputError for a case that is
// no train, a freely turning train whose mean torques do not balance, a train whose excitations
// have no common
// period (quasi-periodic: there is no orbit to find) or none at all, bad options; a Newton
// that does not converge is reported in the result.
// With `start` (the unknowns at the section, in `coordinates` order, SI: a found orbit's
// `unknowns`) Newton starts there in place of the settled run; InputError naming --state when it
// has another size.
TrainOrbit find_train_orbit(const Case& c, const OrbitOptions& options,
                            const std::optional<ode::Vector>& start = std::nullopt);

// An orbit's unknowns (TrainOrbit::unknowns, a continuation's branch state) as the whole state
// (q, q') on the section t = 0 that TrainSolver flows, and a whole state as its unknowns
// (modulo the rigid rotation for a train that turns freely). Throws InputError as
// find_train_orbit does for a case that has no orbits.
ode::Vector train_orbit_state(const Case& c, const ode::Vector& unknowns);
ode::Vector train_orbit_unknowns(const Case& c, const ode::Vector& state);

// `geardyn orbit --json` of a train: the keys every orbit has (orbit.hpp's periodic JSON),
// "model": "train", the coordinates, the section state (every body's), the unknowns (what
// --state takes) and per mesh its impacts per period.
std::string train_orbit_json(const TrainOrbit& o, int indent = 2);

}  // namespace geardyn
