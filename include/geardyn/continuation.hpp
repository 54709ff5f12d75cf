// geardyn: continuation of periodic orbits in a case key, with their bifurcations, pipeline
// stage 6 beside orbit.hpp.
//
// A branch of periodic orbits is followed in a numeric case key p by pseudo-arclength
// continuation: the unknowns Z = (x, p / p_scale) (x the scaled shooting unknowns of
// orbit.hpp, p_scale = |to - from|) solve the shooting residual F(x, p) = 0 and
// t . (Z - Z_pred) = 0, t the unit tangent of the branch, so that the branch is followed
// through folds and its unstable parts appear. dF/dx is the exact engine's Jacobian;
// dF/dp is a central difference of the exact residual (step kParamStep p_scale; one-sided at a
// bound of the key), taken at each correction's first iterate and kept through its later ones. The
// step in arclength grows after easy corrections and is halved after failed ones, after a
// sharp turn of the tangent, and where the key moves between two points against the tangent's
// direction at both (two folds inside the step, where det(M - I) changes sign twice).
//
// Between two points the continuation looks for:
//   fold             det(M - I) changes sign and the branch turns back in p
//   branch point     det(M - I) changes sign and the branch goes on (transcritical or
//                    symmetry-breaking)
//   period doubling  det(M + I) changes sign (a multiplier through -1)
//   Neimark-Sacker   a complex pair of multipliers crosses the unit circle
//   grazing          the contact sequence of one period changes (an impact or a separation
//                    appears or vanishes)
// M the monodromy. Each is located by bisection along the branch, re-correcting at every
// trial point, to a width in p of kLocateWidth p_scale.
//
// Every form is continued on one shooting, its train's (train_orbit.hpp; the gear pair's forms
// as their train: train_form_of), its unknowns the train's free coordinates and rates (modulo
// the rigid rotation where it turns freely). A train's grazing is a change in the impacts or
// separations per period of any mesh or clearance direction (its readings are one mesh's:
// ContinuationOptions::mesh). The one-degree forms ("gear_pair", "nondimensional") are kept
// and written in the one-degree model's terms, as find_orbit reads them: their state (delta,
// delta'), their grazing a change in the mesh's contact sequence.
#pragma once

#include <complex>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/orbit.hpp"

namespace geardyn {

// Period doublings switched from at most (follow_period_doubling).
constexpr int kMaxBranchSwitches = 4;

// Central-difference step of dF/dp, relative to p_scale.
constexpr double kParamStep = 1e-7;
// The width in p, relative to p_scale, to which a bifurcation is located.
constexpr double kLocateWidth = 1e-10;

enum class BifurcationType { kFold, kBranchPoint, kPeriodDoubling, kNeimarkSacker, kGrazing };
const char* to_string(BifurcationType t);

// What the continuation keeps of an orbit, of either model.
// Its periodic solution (monodromy, multipliers) is in the unknowns.
struct BranchOrbit : PeriodicSolution {
  ode::Vector state;  // on the section t = 0, SI: (delta, delta'), or a train's unknowns
  // The shooting's unknowns on the section (TrainOrbit::unknowns): a train's are its state; a
  // one-degree form's are its train's, which `state` reads as (delta, delta').
  ode::Vector unknowns;
  // The mesh's over one period: impacts, separations, extremes of delta_bar ((d - e)/b in a
  // train) and of F_bar.
  RunReading reading;
  // Which contacts are entered and left in one period, the grazing test: the one-degree
  // model's contact sequence (cyclic: the least of its rotations); a train's impacts, back-side
  // impacts and separations of each mesh, then impacts and separations of each clearance
  // direction.
  std::vector<std::int64_t> signature;
  // Impacts and separations per period of each nonlinearity: the one-degree mesh (name ""), or
  // each "mesh <name>" and each "clearance <bearing>_x" or "_y".
  struct Contacts {
    std::string name;
    std::int64_t impacts = 0, separations = 0;
  };
  std::vector<Contacts> contacts;
};

struct BranchPoint {
  double param = 0;
  int branch = 0;     // 0: the branch followed; 1, 2, ...: period-doubled branches switched to
  int periods = 1;    // the orbit's period in system periods
  BranchOrbit orbit;  // converged: section state, multipliers, stability, reading
  // (max - min) / 2 of delta_bar over one period.
  double amplitude() const {
    return 0.5 * (orbit.reading.max_delta_bar - orbit.reading.min_delta_bar);
  }
};

struct Bifurcation {
  BifurcationType type = BifurcationType::kFold;
  double param = 0;
  int branch = 0;          // the branch it was found on
  BranchOrbit orbit;       // the orbit at the located point
  std::string orbit_json;  // the same as `geardyn orbit --json` prints it (compact)
  std::string detail;      // e.g. "impacts 0 -> 1, separations 0 -> 1 per period"
};

struct ContinuationOptions {
  std::string key;  // a numeric case key, e.g. model.omega
  double from = 0, to = 0;
  OrbitOptions orbit;  // periods, segments, settle_periods and Newton tolerance
  // Steps in arclength of the scaled unknowns (state over b and b w_n, p over p_scale).
  double initial_step = 0.01;
  double max_step = 0.02;
  double min_step = 1e-8;
  int max_points = 5000;  // on each branch
  // A state on the section at `from` to start Newton from, in place of the settled simulation:
  // (delta, delta'), or a train's (and the coupled pair's) unknowns (state_names), SI.
  std::optional<ode::Vector> start;
  // A gear train's mesh whose reading the branch's points carry (amplitude, force, contact
  // counts in the one-degree units of its b and mean stiffness): empty for the first. Every
  // mesh's contact counts mark grazings whichever is read.
  std::string mesh;
  // At each period doubling of the first branch (up to kMaxBranchSwitches), switch to the
  // period-doubled branch and follow it to the end of the range it heads for.
  bool follow_period_doubling = false;
  // Called after every point with p and the points so far; false stops the continuation
  // (cancelled, the points kept).
  std::function<bool(double, std::size_t)> progress;
  // Empty when valid; otherwise the offending option, its value and the allowed range.
  std::string validate() const;
};

struct ContinuationResult {
  // The names of the state's entries, as branch.csv heads their columns: delta_m,
  // velocity_m_s; or a train's (and the coupled pair's) free coordinates (<body>_rad, a planar
  // body's <body>_x_m, <body>_y_m), then their rates (the same with _s).
  std::vector<std::string> state_names;
  std::string mesh;  // a train's mesh read (ContinuationOptions::mesh), empty for one degree
  std::vector<BranchPoint> points;
  std::vector<Bifurcation> bifurcations;
  bool completed = false;  // the branch reached `to`
  bool cancelled = false;
  std::string message;  // why it stopped
  double wall_time_s = 0;
};

// Follows the branch of the orbit found at p = from (find_orbit, or find_train_orbit for a
// train and the coupled pair, with options.orbit, from options.start when given) towards `to`; with
// follow_period_doubling also the period-doubled branches (the switch: Newton on the doubled period
// from the period-doubling orbit displaced along the eigenvector of its multiplier -1, just beyond
// the located parameter). A period-doubled branch ends where it meets a period-N orbit again
// (its half-period difference turns to its opposite); that orbit's own period doubling there is
// located (its multiplier through -1, shot with period N) and listed as a bifurcation of the
// doubled branch. Throws InputError on bad input (a key that is not numeric, a bad range);
// a branch that is lost or turns back past `from` ends the result with its reason, the points kept.
ContinuationResult continuation(const Case& c, const ContinuationOptions& options);

}  // namespace geardyn
