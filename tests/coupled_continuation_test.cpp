// Continuation of the coupled pair (continuation.hpp, on its train: train_form_of) on the Table
// 1 pair with a steady torque, a constant mesh stiffness and a transmission error of 2 um (a
// dimensional Kahraman-Singh oscillator), continued in the shaft frequency across the mesh mode's
// primary resonance:
// - on bearings 1e6 and 1e5 times stiffer than the mesh, its folds and grazings are the
//   one-degree model's, the gap shrinking tenfold per decade;
// - on bearings as stiff as the mesh (the resonance moves up), the stable points are where long
//   simulations of its train settle, the unstable ones return after a period, and the
//   folds are where the simulations jump;
// - with a radial clearance, the grazing where the bearings stop separating lies between a
//   simulation whose bearings separate and one whose do not;
// - on the shipped case at dof 3, a period doubling of the rattle is switched to its doubled
//   branch, whose orbits return after two periods and not after one, and which ends where it
//   meets a period-1 orbit of another family.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "geardyn/continuation.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_orbit.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {
namespace {

constexpr double kMeshStiffness = 2.34e8;  // N/m, the default mean

// The pair, one-degree (bearing_ratio 0) or coupled (dof 3) on bearings bearing_ratio times
// as stiff as the mesh with a radial clearance.
Case te_pair(double bearing_ratio = 0, double clearance_um = 0) {
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.mesh.mean_stiffness_n_per_m = kMeshStiffness;
  c.mesh.damping_ratio = 0.05;
  c.mesh.transmission_error_um = {{2.0, 0.0}};
  c.load.torque_nm = 150;
  c.load.fluctuation_ratio = 0;
  if (bearing_ratio > 0) {
    c.model.form = ModelForm::kCoupled;
    c.model.dof = 3;
    c.bearings.radial_stiffness_n_per_m = {bearing_ratio * kMeshStiffness,
                                           bearing_ratio * kMeshStiffness};
    c.bearings.radial_clearance_um = {clearance_um, clearance_um};
    c.solver.initial = InitialCondition::kStatic;
  }
  return c;
}

ContinuationResult branch(const Case& c, double from, double to) {
  ContinuationOptions o;
  o.key = "speed.shaft_frequency_hz";
  o.from = from;
  o.to = to;
  return continuation(c, o);
}

// The coupled case is continued on its train (train_form_of): a branch's state is the train's
// unknowns (modulo the rigid rotation: the wheel's angle, each gear's centre along the line of
// action, then their rates). Each check below flows the train's whole state without Jacobians.

// The last period of a simulation of the coupled case at f_1 = f_hz from the unknowns z0,
// `periods` mesh periods long.
TrainRunResult settle(Case c, double f_hz, const ode::Vector& z0, int periods) {
  c.speed.shaft_frequency_hz = f_hz;
  c.solver.tolerance = 1e-12;
  const TrainSolver solver(c);
  const double mesh_period_s = 1.0 / (f_hz * c.gear.teeth[0]);
  const double last_s = (periods - 1) * mesh_period_s, end_s = periods * mesh_period_s;
  const ode::FlowResult settled = solver.advance(0.0, train_orbit_state(c, z0), last_s);
  EXPECT_TRUE(settled.ok()) << settled.message;
  return solver.read(last_s, settled.state, end_s, ode::OutputGrid{}, end_s, std::nullopt);
}

double amplitude(const TrainRunResult& r) {
  const TrainMeshReading& m = r.meshes.at(0);
  return 0.5 * (m.max_deflection_m - m.min_deflection_m) / m.backlash_m;
}

// The largest difference of two states' coordinates (unknowns), in metres along the line of
// action: the wheel's angle times its lever in the mesh (first), the centres as they are.
double coordinate_gap_m(const Case& c, const ode::Vector& a, const ode::Vector& b) {
  const train::Assembled t = assembled_train(c);
  const auto& names = t.coordinate_names();
  const auto wheel = std::find(names.begin(), names.end(), "wheel_rad") - names.begin();
  const double lever_m = std::abs(t.mesh_vector(0)(wheel));
  const Eigen::Index n = a.size() / 2;
  ode::Vector d = (a - b).head(n).cwiseAbs();
  d(0) *= lever_m;
  return d.maxCoeff();
}

TEST(CoupledContinuation, RigidBearingsGiveTheOneDegreeBranch) {
  const ContinuationResult one = branch(te_pair(), 36, 54);
  ASSERT_TRUE(one.completed) << one.message;
  // Grazing into rattle, the fold up, the fold down, grazing out of rattle.
  ASSERT_EQ(one.bifurcations.size(), 4U);
  std::vector<double> gap[2];
  for (const double ratio : {1e5, 1e6}) {
    const ContinuationResult r = branch(te_pair(ratio), 36, 54);
    ASSERT_TRUE(r.completed) << r.message;
    ASSERT_EQ(r.bifurcations.size(), one.bifurcations.size()) << "bearings " << ratio;
    for (std::size_t i = 0; i < r.bifurcations.size(); ++i) {
      EXPECT_EQ(r.bifurcations[i].type, one.bifurcations[i].type);
      gap[ratio > 5e5].push_back(std::abs(r.bifurcations[i].param - one.bifurcations[i].param) /
                                 one.bifurcations[i].param);
    }
  }
  for (std::size_t i = 0; i < gap[1].size(); ++i) {
    EXPECT_LT(gap[1][i], 3e-6) << "bifurcation " << i;
    EXPECT_GT(gap[1][i], 1e-8) << "bifurcation " << i;  // the bearings are there
    EXPECT_NEAR(gap[0][i] / gap[1][i], 10.0, 0.5) << "bifurcation " << i;
  }
}

TEST(CoupledContinuation, StablePointsAndFoldsAreThoseOfSimulations) {
  const Case c = te_pair(1.0);
  const ContinuationResult r = branch(c, 45, 60);
  ASSERT_TRUE(r.completed) << r.message;
  ASSERT_EQ(r.state_names.size(), 6U);
  EXPECT_EQ(r.state_names[0], "wheel_rad");
  EXPECT_EQ(r.state_names[1], "pinion_line_m");
  EXPECT_EQ(r.state_names[3], "wheel_rad_s");
  // Grazing into rattle at the mesh, the fold up, the fold down; the bearings never separate.
  ASSERT_EQ(r.bifurcations.size(), 3U);
  EXPECT_EQ(r.bifurcations[0].type, BifurcationType::kGrazing);
  EXPECT_EQ(r.bifurcations[0].detail, "mesh mesh impacts 0 -> 1, separations 0 -> 1 per period");
  EXPECT_EQ(r.bifurcations[1].type, BifurcationType::kFold);
  EXPECT_EQ(r.bifurcations[2].type, BifurcationType::kFold);
  // Where docs/orbits.md says they are.
  EXPECT_NEAR(r.bifurcations[0].param, 57.157, 1e-3);
  EXPECT_NEAR(r.bifurcations[1].param, 57.315, 1e-3);
  EXPECT_NEAR(r.bifurcations[2].param, 56.509, 1e-3);
  // Every 6th stable point away from the folds (its multipliers below 0.98; the bearing mode's
  // are near 0.95): a simulation from 1e-3 b off the orbit (in the wheel's angle) settles to
  // its amplitude and impacts.
  int checked = 0;
  const train::Assembled t = assembled_train(c);
  const double wheel_lever_m = std::abs(t.mesh_vector(0)(1));
  ASSERT_EQ(t.coordinate_names()[1], "wheel_rad");
  for (std::size_t i = 0; i < r.points.size(); i += 6) {
    const BranchPoint& p = r.points[i];
    if (!p.orbit.stable || p.orbit.max_multiplier() > 0.98) continue;
    ode::Vector z = p.orbit.state;
    z[0] += 1e-3 * 100e-6 / wheel_lever_m;
    const TrainRunResult x = settle(c, p.param, z, 2000);
    ASSERT_TRUE(x.ok()) << x.message;
    EXPECT_NEAR(amplitude(x), p.amplitude(), 1e-8) << "f_1 = " << p.param;
    EXPECT_EQ(x.meshes.at(0).impacts, p.orbit.reading.impacts) << "f_1 = " << p.param;
    ++checked;
  }
  EXPECT_GE(checked, 6);
  // The unstable points between the folds are orbits too: a flow of one mesh period without
  // Jacobians (the engine at 1e-12) returns to each, to 1e-7 b.
  int unstable = 0;
  for (const BranchPoint& p : r.points) {
    if (p.orbit.stable) continue;
    ++unstable;
    Case cp = c;
    cp.speed.shaft_frequency_hz = p.param;
    cp.solver.tolerance = 1e-12;
    const TrainSolver solver(cp);
    const ode::FlowResult back = solver.advance(0.0, train_orbit_state(cp, p.orbit.state),
                                                1.0 / (p.param * c.gear.teeth[0]));
    ASSERT_TRUE(back.ok()) << back.message;
    EXPECT_LT(coordinate_gap_m(cp, train_orbit_unknowns(cp, back.state), p.orbit.state),
              1e-7 * 100e-6)
        << "f_1 = " << p.param;
    EXPECT_GT(p.orbit.max_multiplier(), 1.0);
  }
  EXPECT_GE(unstable, 3);
  // Each fold ends a branch: just beyond it the simulation from its orbit leaves for the other.
  const double d = 0.01;  // Hz
  const Bifurcation &up = r.bifurcations[1], &down = r.bifurcations[2];
  EXPECT_LT(amplitude(settle(c, up.param - d, up.orbit.state, 3000)), 0.11);
  EXPECT_GT(amplitude(settle(c, up.param + d, up.orbit.state, 3000)), 0.13);
  const TrainRunResult above = settle(c, down.param + d, down.orbit.state, 3000);
  EXPECT_EQ(above.meshes.at(0).impacts, 1);
  EXPECT_GT(amplitude(above), 0.13);
  const TrainRunResult below = settle(c, down.param - d, down.orbit.state, 3000);
  EXPECT_EQ(below.meshes.at(0).impacts, 0);
  EXPECT_LT(amplitude(below), 0.11);
}

TEST(CoupledContinuation, ABearingClearanceGrazingIsWhereTheBearingsStopSeparating) {
  // A clearance of 5 um, half the static bearing deflection: near the bearing mode's
  // superharmonic resonance the bearings leave contact once a mesh period.
  const Case c = te_pair(1.0, 5.0);
  const ContinuationResult r = branch(c, 20, 24);
  ASSERT_TRUE(r.completed) << r.message;
  ASSERT_EQ(r.bifurcations.size(), 1U);
  const Bifurcation& g = r.bifurcations[0];
  EXPECT_EQ(g.type, BifurcationType::kGrazing);
  EXPECT_EQ(g.detail,
            "clearance pinion_bearing_y impacts 1 -> 0, separations 1 -> 0; clearance "
            "wheel_bearing_y impacts 1 -> 0, separations 1 -> 0 per period");
  EXPECT_FALSE(g.orbit_json.empty());
  EXPECT_NEAR(g.param, 20.419, 1e-3);
  const double d = 1e-3;  // Hz
  const TrainRunResult before = settle(c, g.param - d, g.orbit.state, 1000);
  const TrainRunResult after = settle(c, g.param + d, g.orbit.state, 1000);
  ASSERT_TRUE(before.ok() && after.ok());
  ASSERT_EQ(before.bearings.size(), 2U);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(before.bearings[i].clearance_y.separations, 1) << "bearing " << i + 1;
    EXPECT_EQ(after.bearings[i].clearance_y.separations, 0) << "bearing " << i + 1;
  }
}

// The Table 1 pair on its bearings at dof 3 (cases/park2010_coupled.toml).
Case shipped_pair_at_dof_3() {
  return load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases/park2010_coupled.toml",
                   {{"model.dof", "3"}});
}

// Its branch along f_1 from 652 to 700 Hz with the period-doubled branch followed, at most
// `max_points` points on each.
ContinuationResult shipped_pair_doubled_branch(int max_points) {
  ContinuationOptions o;
  o.key = "speed.shaft_frequency_hz";
  o.from = 652;
  o.to = 700;
  o.max_points = max_points;
  o.follow_period_doubling = true;
  return continuation(shipped_pair_at_dof_3(), o);
}

TEST(CoupledContinuation, APeriodDoublingIsSwitchedToItsDoubledBranch) {
  // The shipped pair at dof 3: its period-1 rattle along f_1 doubles its period near 657.7 Hz.
  // The switched branch's orbits return after two system periods and not after one (a flow of
  // the coupled model without Jacobians).
  const Case c = shipped_pair_at_dof_3();
  const ContinuationResult r = shipped_pair_doubled_branch(9);
  ASSERT_FALSE(r.bifurcations.empty()) << r.message;
  const Bifurcation& pd = r.bifurcations[0];
  ASSERT_EQ(pd.type, BifurcationType::kPeriodDoubling) << r.message;
  EXPECT_NEAR(pd.param, 657.7267, 1e-3);
  // There a multiplier is -1.
  double nearest = 1;
  for (const auto& mu : pd.orbit.multipliers) nearest = std::min(nearest, std::abs(mu + 1.0));
  EXPECT_LT(nearest, 1e-5);
  int doubled = 0;
  for (const BranchPoint& p : r.points) {
    if (p.branch != 1) continue;
    ++doubled;
    EXPECT_EQ(p.periods, 2);
    Case cp = c;
    cp.speed.shaft_frequency_hz = p.param;
    cp.solver.tolerance = 1e-12;
    const TrainSolver solver(cp);
    const double t0 = 1.0 / p.param;  // the system period: the torque's
    const ode::Vector y = train_orbit_state(cp, p.orbit.state);
    const ode::FlowResult one = solver.advance(0.0, y, t0);
    const ode::FlowResult two = solver.advance(0.0, y, 2 * t0);
    ASSERT_TRUE(one.ok() && two.ok());
    const double b = 100e-6;
    const auto gap = [&](const ode::Vector& end) {
      return coordinate_gap_m(cp, train_orbit_unknowns(cp, end), p.orbit.state) / b;
    };
    EXPECT_LT(gap(two.state), 1e-7) << "f_1 = " << p.param;
    EXPECT_GT(gap(one.state), 1e-3) << "f_1 = " << p.param;
  }
  EXPECT_GE(doubled, 4);
}

TEST(CoupledContinuation, ThePeriodDoubledBranchEndsWhereItMeetsAnotherPeriodOneOrbit) {
  // The same pair: the doubled branch from 657.7267 Hz winds through folds between 657.35 and
  // 657.83 Hz, then runs unstable up to 681.21 Hz, where it meets a period-1 orbit of
  // another (unstable) family: there that family doubles its period. Beyond, the branch is its
  // own orbits shifted by one period, which it would retrace back to 657.7267 Hz and out again
  // without end; it ends on the meeting instead. Checked without the continuation: shooting a
  // period-1 orbit from the last point's state converges there, with a multiplier at -1 that
  // moves through -1 across it. No fold is found twice (no part of the branch retraced).
  const Case c = shipped_pair_at_dof_3();
  // At most 400 points a branch: the meeting is some 160 points along the doubled one.
  const ContinuationResult r = shipped_pair_doubled_branch(400);
  EXPECT_NE(r.message.find("the period-doubled branch met a period-1 orbit"), std::string::npos)
      << r.message;
  const BranchPoint& last = r.points.back();
  ASSERT_EQ(last.branch, 1) << r.message;
  EXPECT_NEAR(last.param, 681.21, 0.01);
  std::vector<double> folds;
  for (const Bifurcation& b : r.bifurcations)
    if (b.branch == 1 && b.type == BifurcationType::kFold) folds.push_back(b.param);
  // 11, two of them 4e-3 Hz apart: one step held both (det(M - I) changes sign twice) until a
  // step across which the key moves against both ends' tangents was halved.
  EXPECT_EQ(folds.size(), 11U);
  EXPECT_EQ(
      std::count_if(folds.begin(), folds.end(), [](double f) { return f > 657.82 && f < 657.84; }),
      2);
  for (std::size_t i = 0; i < folds.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      EXPECT_GT(std::abs(folds[i] - folds[j]), 1e-6) << folds[i] << " found twice";
  // The period-1 orbit there: its multiplier nearest -1 is above -1 below the meeting, at -1
  // on it (to the meeting's half-period gap) and below -1 above it.
  const auto nearest_to_minus_one = [&](double f1, const ode::Vector& start) {
    Case at = c;
    at.speed.shaft_frequency_hz = f1;
    const TrainOrbit orbit = find_train_orbit(at, OrbitOptions{}, start);
    EXPECT_TRUE(orbit.converged) << f1 << ": " << orbit.message;
    std::complex<double> best = 0;
    for (const auto& mu : orbit.multipliers)
      if (std::abs(mu + 1.0) < std::abs(best + 1.0)) best = mu;
    EXPECT_EQ(best.imag(), 0.0);
    return best.real();
  };
  EXPECT_GT(nearest_to_minus_one(last.param - 0.2, last.orbit.state), -1.0);
  EXPECT_NEAR(nearest_to_minus_one(last.param, last.orbit.state), -1.0, 1e-4);
  EXPECT_LT(nearest_to_minus_one(last.param + 0.2, last.orbit.state), -1.0);
  // The meeting located: a period doubling of that period-1 orbit on the doubled branch, its
  // multiplier at -1 to the engine's accuracy, and through -1 within 1e-5 Hz either side
  // (the last point, a bisection in arclength stopped where the corrector fails, is 1e-3 Hz
  // off).
  const Bifurcation* meeting = nullptr;
  for (const Bifurcation& b : r.bifurcations)
    if (b.branch == 1 && b.type == BifurcationType::kPeriodDoubling) meeting = &b;
  ASSERT_NE(meeting, nullptr) << r.message;
  EXPECT_NEAR(meeting->param, 681.214, 0.01);
  EXPECT_NE(r.message.find("where that orbit's multiplier passes through -1"), std::string::npos)
      << r.message;
  double nearest = 1;
  for (const auto& mu : meeting->orbit.multipliers) nearest = std::min(nearest, std::abs(mu + 1.0));
  EXPECT_LT(nearest, 1e-10);
  EXPECT_GT(nearest_to_minus_one(meeting->param - 1e-5, meeting->orbit.state), -1.0);
  EXPECT_LT(nearest_to_minus_one(meeting->param + 1e-5, meeting->orbit.state), -1.0);
}

}  // namespace
}  // namespace geardyn
