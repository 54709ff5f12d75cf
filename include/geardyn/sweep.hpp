// geardyn: sweeps and maps, `geardyn sweep`.
//
// A sweep runs a case at many values of one case key (a map: of two). Each point settles, then
// measures, in whole system periods (model.hpp's system_period_s), and is read by
// its statistics, regime and stroboscopic samples. In an up or down sweep the state at the end of
// one point starts the next, as in an experiment, so jumps and hysteresis show. Independent
// sequences (the up and the down sweep, the rows of a map) run in parallel; the results do not
// depend on the number of threads.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/analysis.hpp"
#include "geardyn/case.hpp"
#include "geardyn/steady.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {

// One swept case key and its values: `points` values from `from` to `to`, evenly or (log)
// geometrically spaced.
struct SweepAxis {
  std::string key;
  double from = 0, to = 0;
  int points = 0;
  bool log = false;
  // Given values, in place of from, to, points and log (they are swept in ascending order).
  std::vector<double> explicit_values;
  std::vector<double> values() const;
};

// The values of an axis that bound all its others, each with how the user gave it, for messages:
// the two ends of a range ("--from 1e-300", "--to2 5"; `suffix` is "" or "2"), or the least and
// the largest given value ("the value 3 of mesh.backlash_um"). A study checks these before any
// work.
struct AxisValue {
  double value = 0;
  std::string origin;
};
std::vector<AxisValue> axis_ends(const SweepAxis& a, const std::string& suffix);

// Throws InputError when a swept key (`axis`, or `axis2` of a map) changes nothing in `c` at
// every corner of the axes' ends (unread_study_key, case_keys.hpp), naming the option, the key,
// where its value came from and why the case does not read it. Before any work.
void check_axes_read(const Case& c, const SweepAxis& axis, const SweepAxis* axis2);

enum class SweepDirection { kUp, kDown, kBoth };
const char* to_string(SweepDirection d);

// The most points of a map (each in both directions): a bound on the work asked for.
constexpr double kMaxMapPoints = 1e6;
// The most system periods a sweep may run: its points times (max_settle_periods +
// measure_periods). About an hour of the Table 1 pair's periods with the exact engine.
constexpr double kMaxSweepPeriods = 1e9;

struct SweepOptions {
  SweepAxis axis;
  std::optional<SweepAxis> axis2;  // a 2-D map: each value of axis2 is a row swept along axis
  SweepDirection direction = SweepDirection::kBoth;
  int settle_periods = 0;    // system periods always run before the steadiness is judged
  int measure_periods = 10;  // periods per measurement block
  // A point settles period by period on the stroboscopic section t = k T0 until it is steady
  // (below); past this many periods it is measured as it is and flagged not settled.
  int max_settle_periods = 200;
  // Steady: the distance of the section state to the periodic response (of period q T0 for the
  // smallest q <= kMaxSettledMultiple that passes), in b for delta and b w_n for delta', is
  // below this. The distance is predicted from the Poincare residuals x_k - x_(k-q): the rate
  // at which they shrink (the q-period map, fitted near the response from the last three)
  // extrapolates the rest as a geometric series; a point is steady when the prediction is
  // under half the tolerance (the prediction is within a factor 2 of the truth in the tests).
  double steady_tolerance = kSteadyTolerance;
  // Where each up and down sequence starts (and restarts after a failed point): from static
  // contact (the default: the up sweep climbs the contact branch into the resonance, the down
  // sweep descends it, so the jumps and the hysteresis between them show) or from the case's
  // solver.initial.
  bool start_static = true;
  // A gear train's mesh that the point's statistics, strobe, jumps and figures read (its name;
  // "" the first); every mesh is read beside it (SweepPoint::meshes). Only a train has one.
  std::string mesh;
  int samples_per_period = 64;  // for the statistics; the strobe takes one per period
  unsigned threads = 0;         // 0: all cores
  // Called after each point and each settling period (or window) of the points under way with
  // (done, total): the points done plus the share of each point under way (its settling periods
  // over max_settle_periods + measure_periods, at most 0.99), in increasing order, so a point
  // that takes seconds shows it moves. Returning false stops the sweep: the points under way
  // stop too and are dropped, the completed ones are kept.
  using Progress = std::function<bool(double, std::size_t)>;
  Progress progress;

  // The bounds of every option, as Ceres does: "" when valid, else what is wrong.
  std::string validate() const;
};

// One mesh of a train's sweep point over the measurement, as the point's own statistics read
// the mesh that SweepOptions::mesh names: (d - e) / b, its largest force (N, exact extremes),
// the dynamic factor (that force over the static one: NaN without a static force) and the
// contact history per system period.
struct MeshReading {
  double mean_delta_bar = 0, rms_delta_bar = 0, pp_delta_bar = 0, min_delta_bar = 0;
  double max_force_n = 0, dynamic_factor = 0;
  double separated_fraction = 0, impacts_per_period = 0, backside_impacts_per_period = 0;
  Regime regime = Regime::kNone;
  bool double_sided = false;
};

// The per-mesh columns of a train's sweep, in order: sweep.csv's <mesh>_<name> (and
// <mesh>_regime after them) and the Python result's mesh_<name> arrays.
struct MeshColumn {
  const char* name;
  double MeshReading::*member;
};
inline constexpr std::array<MeshColumn, 9> kMeshColumns{{
    {"mean_delta_bar", &MeshReading::mean_delta_bar},
    {"rms_delta_bar", &MeshReading::rms_delta_bar},
    {"pp_delta_bar", &MeshReading::pp_delta_bar},
    {"min_delta_bar", &MeshReading::min_delta_bar},
    {"max_force_n", &MeshReading::max_force_n},
    {"dynamic_factor", &MeshReading::dynamic_factor},
    {"separated_fraction", &MeshReading::separated_fraction},
    {"impacts_per_period", &MeshReading::impacts_per_period},
    {"backside_impacts_per_period", &MeshReading::backside_impacts_per_period},
}};

// A train's load-sharing group (LoadSharingGroup) over a point's measurement: its largest factor
// n max_i F_i / sum_i F_i over the samples where sum_i F_i > 0 (NaN when there is none: the
// group carried no load), and how many of its meshes left their drive flank (left_drive_flank).
struct LoadSharingReading {
  double factor = 0;
  double lost_contact = 0;
};

// A shaft's or bearing's quantity of a train's sweep (train_run.hpp's TrainPartQuantity): the
// part's name and what it is ("torque_nm", "force_x_n", "force_y_n", "axial_force_n",
// "moment_x_nm", "moment_y_nm"). sweep.csv's columns <part>_<what>_peak and
// <part>_<what>_factor; the Python result's part_peak and part_factor arrays.
struct SweepPart {
  std::string part, what;
  std::string label() const { return part + "_" + what; }
  std::string peak_column() const { return label() + "_peak"; }
  std::string factor_column() const { return label() + "_factor"; }
};

// That quantity over a point's measurement: its largest magnitude (N or N m, the engine's exact
// extremes) and its dynamic factor, that over the static value (part_dynamic_factor; NaN where
// the static value is absent or negligible, and for a failed point).
struct PartReading {
  double peak = 0, factor = 0;
};

struct SweepPoint {
  SweepDirection direction = SweepDirection::kUp;  // kUp or kDown
  double value = 0;
  double value2 = 0;  // 0 for a 1-D sweep
  // Empty, or why the point failed numerically (its statistics are then NaN, and the next
  // point of its sequence starts from the case's initial condition).
  std::string failure;
  bool settled = false;
  int settle_periods = 0;  // periods run before the measurement
  // The response's period in system periods T0 when settled (1: period-1, 2: period-doubled,
  // ...), 0 when not settled.
  int period_multiple = 0;
  // The predicted distance to the periodic response when measured (b, b w_n; see
  // SweepOptions::steady_tolerance); infinite when no decay was seen.
  double steady_error = 0;
  double mean_delta_bar = 0, rms_delta_bar = 0, pp_delta_bar = 0, min_delta_bar = 0;
  double mean_force_bar = 0, rms_force_bar = 0, pp_force_bar = 0, max_force_bar = 0;
  std::optional<double> dynamic_factor;
  double separated_fraction = 0;
  double impacts_per_period = 0;
  Regime regime = Regime::kNone;  // over the measurement: separated in its last period or not
  bool double_sided = false;
  // Once per system period over the measurement.
  std::vector<double> strobe_delta_bar, strobe_velocity_m_s, strobe_force_bar;
  // A train's (or a coupled pair's) meshes over the measurement, in SweepResult::meshes' order
  // (NaN for a failed point); empty for the one-degree forms.
  std::vector<MeshReading> meshes;
  // A train's load-sharing groups, in SweepResult::load_sharing's order (NaN for a failed point).
  std::vector<LoadSharingReading> load_sharing;
  // A train's joints (its bearing clearance directions, then its elements' springs: a clutch
  // damper's), in SweepResult::clearances' order, over the measurement: impacts (leaving the rest
  // stage) per system period, and the fraction of the time inside the rest stage (NaN for a
  // failed point).
  std::vector<std::array<double, 2>> clearances;
  // A train's shaft and bearing quantities, in SweepResult::parts' order.
  std::vector<PartReading> parts;
};

// Where the up and the down sweep part: the parameter interval over which their responses
// differ (hysteresis), and the jumps that bound it.
// In a map, each row (a value of the second key, value2) is read on its own.
// A point that did not settle is measured as it is: its readings are a stretch of a motion
// that is chaotic, quasi-periodic or slower to settle than max_settle_periods, and a rounding
// change may read another stretch of it. A hysteresis interval or a jump that reads such a
// point says so (`unsettled`), and the sweep lists where they lie (UnsettledRange).
struct Hysteresis {
  double from_value = 0, to_value = 0;
  double value2 = 0;       // the map's row (0 for a 1-D sweep)
  bool unsettled = false;  // an up or down point in it did not settle
};
struct Jump {
  SweepDirection direction = SweepDirection::kUp;
  double from_value = 0, to_value = 0;  // the two consecutive points between which it jumps
  double before = 0, after = 0;         // pp_delta_bar on either side
  double value2 = 0;                    // the map's row (0 for a 1-D sweep)
  bool unsettled = false;               // one of the two did not settle
};
// Consecutive points of one sequence (a direction, a map's row) that did not settle, failed
// points apart.
struct UnsettledRange {
  SweepDirection direction = SweepDirection::kUp;
  double from_value = 0, to_value = 0;  // its first and last point, in run order
  double value2 = 0;                    // the map's row (0 for a 1-D sweep)
  std::size_t points = 0;
};

// Where a sequence (a direction, a map's row) first reads impacts: its first point, in run
// order, at which the mesh read or (a train) any mesh has impacts in the measurement, and the
// meshes that do there.
struct ImpactOnset {
  SweepDirection direction = SweepDirection::kUp;
  double value = 0;
  double value2 = 0;  // the map's row (0 for a 1-D sweep)
  std::vector<std::string> meshes;
};

struct SweepResult {
  SweepOptions options;
  double period_s = 0;                    // the system period at the first point (tau: non-dim.)
  ModelForm form = ModelForm::kGearPair;  // the units of the files (output.hpp's form_key)
  // A train's meshes, and the one the points' own statistics read (SweepOptions::mesh).
  std::vector<std::string> meshes;
  std::string mesh;
  // A train's load-sharing groups (a sun's planets, a ring's): sweep.csv's
  // <label>_load_sharing_factor and <label>_lost_contact.
  std::vector<LoadSharingGroup> load_sharing;
  // A train's joints (train::Assembled::joints()): its bearing clearance directions,
  // "<bearing>_x" and "<bearing>_y", then its elements' ("<damper>"): sweep.csv's
  // <name>_impacts_per_period and <name>_inside_fraction.
  std::vector<std::string> clearances;
  // A train's shaft and bearing quantities (part_quantities' order): sweep.csv's two columns
  // each.
  std::vector<SweepPart> parts;
  // How a point is judged steady (a phrase: "predicted distance to the periodic response under
  // 1e-06 b", or its statistics' agreement window by window).
  std::string steadiness;
  // Why the points were not judged steady, when a train has no common period (quasi-periodic:
  // each point runs max_settle_periods periods of its reference body's turn before it is
  // measured, flagged not settled).
  std::string period_note;
  std::vector<SweepPoint> points;  // in sweep order: up (each row), then down
  std::vector<Hysteresis> hysteresis;
  std::vector<Jump> jumps;
  // Each sequence's first point with impacts, in sequence order (none: no impacts there).
  std::vector<ImpactOnset> impact_onsets;
  std::vector<UnsettledRange> unsettled_ranges;  // each row's up sequence, then its down one
  std::size_t unsettled = 0;
  std::size_t failed = 0;  // points whose integration failed (SweepPoint::failure)
  bool cancelled = false;
  double wall_time_s = 0;
  unsigned threads = 0;
  // The base case's settings that the model does not use (case_keys.hpp's unused_settings).
  std::vector<std::string> unused_settings;
};

// Thresholds of the jump reading, on the peak-to-peak delta_bar (it changes most at a jump): up
// and down differ where theirs differ by more than kHysteresisFraction of the larger; a sweep
// jumps where consecutive points differ by more than kJumpFraction of the larger and by more
// than kJumpContrast times the change on either side: a discontinuity, not a steep but smooth
// resonance flank sampled coarsely.
constexpr double kHysteresisFraction = 0.05;
constexpr double kJumpFraction = 0.3;
constexpr double kJumpContrast = 3.0;

// What a sweep will do, told before it starts: its points, the period (or statistics window)
// its points settle and measure in, how a point is judged steady, and the wall time of its first
// point's first period on this machine, from which its cost is bracketed.
struct SweepPlan {
  std::size_t points = 0;  // points in all directions and rows
  unsigned threads = 0;    // threads its sequences run on
  double period_s = 0;     // of the first point: its settling period or statistics window
  std::string steadiness;  // as SweepResult::steadiness
  // The periods a point runs: at least --settle-periods (and the two a verdict needs) with
  // --measure-periods, at most --max-settle-periods + --measure-periods.
  int least_periods = 0, most_periods = 0;
  // The wall time of the first point's first period, its start included (NaN when it failed).
  double first_period_wall_s = 0;
  // The sweep's wall time if every period cost as much, with the points settling as soon as
  // they may (least) or never (most), shared among the threads.
  double least_wall_s() const;
  double most_wall_s() const;
};
// Checks the options as sweep() does (throwing InputError) and times one period.
SweepPlan plan_sweep(const Case& base, const SweepOptions& o);

// Runs the sweep. Throws InputError for a bad key, value or option (naming it); a point that
// fails numerically is kept with its reason (SweepPoint::failure) and the others go on.
SweepResult sweep(const Case& base, const SweepOptions& o);

}  // namespace geardyn
