// Continuation (continuation.hpp) on the Kahraman-Singh oscillator (zeta 0.05, F_m 0.1, F_a
// 0.02): the branch with its two folds and two grazings (these against their closed form);
// the folds where simulations jump; the stable points' amplitudes against long simulations;
// the unstable part between the folds; outputs, bad input and cancelling.
#include "geardyn/continuation.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include "geardyn/continuation_output.hpp"
#include "geardyn/one_degree_orbit.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/run.hpp"
#include "geardyn/sweep.hpp"
#include "geardyn/train_orbit.hpp"
#include "geardyn/validation.hpp"
#include "test_support.hpp"

namespace {

using geardyn::BifurcationType;
using geardyn::Case;
using geardyn::ContinuationOptions;
using geardyn::ContinuationResult;

Case ks_case(double omega = 0.5) { return geardyn::kahraman_singh_case(omega); }

ContinuationOptions ks_options() {
  ContinuationOptions o;
  o.key = "model.omega";
  o.from = 0.5;
  o.to = 1.5;
  return o;
}

const ContinuationResult& ks_branch() {
  static const ContinuationResult r = geardyn::continuation(ks_case(), ks_options());
  return r;
}

// A one-degree branch orbit's state on the section t = 0.
geardyn::ode::State section_state(const geardyn::BranchOrbit& o) {
  return {0.0, o.state[0], o.state[1], 0.0, 0};
}

// (max - min) / 2 of delta_bar over the last period of a long exact simulation at omega from
// `start` (periods of the excitation), and whether it separated in that period.
struct Settled {
  double amplitude;
  std::int64_t impacts;
};
Settled simulate(double omega, geardyn::ode::State start, int periods) {
  const Case c = ks_case(omega);
  const geardyn::GearPairModel model = geardyn::build_model(c);
  geardyn::SolverData sd = c.solver;
  sd.tolerance = 1e-12;
  const geardyn::Solver solver(model, sd);
  const double T = 2 * std::numbers::pi / omega;
  start.t = 0;
  start.region = model.classify(model.drive(0), start.q, start.v);
  const auto settled = solver.advance(start, (periods - 1) * T);
  EXPECT_TRUE(settled.ok()) << settled.message;
  geardyn::RunReader reader(model, (periods - 1) * T, periods * T, 1.0, true, false);
  const auto r = solver.run(settled.end_state, periods * T, geardyn::ode::OutputGrid{}, reader);
  EXPECT_TRUE(r.ok()) << r.message;
  const auto x = reader.reading();
  return {0.5 * (x.max_delta_bar - x.min_delta_bar), x.impacts};
}

TEST(Continuation, KahramanSinghBranchHasTwoFoldsAndTwoGrazings) {
  const ContinuationResult& r = ks_branch();
  ASSERT_TRUE(r.completed) << r.message;
  ASSERT_EQ(r.bifurcations.size(), 4U);
  // Along the branch: the contact orbit grazes, the impacting branch folds back, the unstable
  // branch folds forward, the rattle leaves the backlash at a grazing.
  const BifurcationType expected[] = {BifurcationType::kGrazing, BifurcationType::kFold,
                                      BifurcationType::kFold, BifurcationType::kGrazing};
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_EQ(r.bifurcations[i].type, expected[i]) << "bifurcation " << i;
  const double graze_in = r.bifurcations[0].param, fold_up = r.bifurcations[1].param;
  const double fold_down = r.bifurcations[2].param, graze_out = r.bifurcations[3].param;
  EXPECT_LT(graze_in, fold_up);
  EXPECT_LT(fold_down, graze_in);
  EXPECT_GT(graze_out, fold_up);
  // Both grazings are of the orbit in contact, which is linear: its amplitude |H| =
  // F_a / |1 - Omega^2 + 2 i zeta Omega| reaches F_m (delta_bar touches 1) where
  // (1 - u)^2 + 4 zeta^2 u = (F_a / F_m)^2, u = Omega^2.
  const double zeta = 0.05, ratio = 0.02 / 0.1;
  const double bq = -(2 - 4 * zeta * zeta), cq = 1 - ratio * ratio;
  const double disc = std::sqrt(bq * bq - 4 * cq);
  EXPECT_NEAR(graze_in, std::sqrt((-bq - disc) / 2), 1e-9);
  EXPECT_NEAR(graze_out, std::sqrt((-bq + disc) / 2), 1e-9);
  EXPECT_NEAR(r.bifurcations[0].orbit.reading.min_delta_bar, 1.0, 1e-9);
  EXPECT_NEAR(r.bifurcations[3].orbit.reading.min_delta_bar, 1.0, 1e-9);
  // Unstable exactly between the folds, in the order the branch runs.
  bool between = false;
  int unstable = 0;
  for (const auto& p : r.points) {
    if (!p.orbit.stable) {
      ++unstable;
      EXPECT_GE(p.param, fold_down - 1e-9);
      EXPECT_LE(p.param, fold_up + 1e-9);
    }
    between |= !p.orbit.stable;
  }
  EXPECT_GE(unstable, 5);
  EXPECT_TRUE(between);
}

TEST(Continuation, FoldsAreWhereTheSimulationsJump) {
  // The upper fold ends the low branch: just below it a simulation started at the fold's
  // orbit stays low (x_a about 0.107), just above it jumps to the rattle (x_a about 0.18). The
  // lower fold ends the rattle branch: just above it the rattle stays, just below it falls to
  // the low branch in contact.
  const ContinuationResult& r = ks_branch();
  ASSERT_EQ(r.bifurcations.size(), 4U);
  const double fold_up = r.bifurcations[1].param, fold_down = r.bifurcations[2].param;
  const double d = 2e-4;
  const geardyn::ode::State low_end = section_state(r.bifurcations[1].orbit);
  EXPECT_LT(simulate(fold_up - d, low_end, 3000).amplitude, 0.12);
  EXPECT_GT(simulate(fold_up + d, low_end, 3000).amplitude, 0.15);
  const geardyn::ode::State top_end = section_state(r.bifurcations[2].orbit);
  const Settled above = simulate(fold_down + d, top_end, 3000);
  EXPECT_EQ(above.impacts, 1);
  EXPECT_GT(above.amplitude, 0.2);
  const Settled below = simulate(fold_down - d, top_end, 3000);
  EXPECT_EQ(below.impacts, 0);
  EXPECT_LT(below.amplitude, 0.1);
}

TEST(Continuation, StablePointsMatchLongSimulations) {
  // Every 8th stable point not near a fold (multipliers below 0.9, so that 400 periods
  // settle): a simulation from 1e-3 off the orbit settles to its amplitude.
  const ContinuationResult& r = ks_branch();
  int checked = 0;
  for (std::size_t i = 0; i < r.points.size(); i += 8) {
    const auto& p = r.points[i];
    if (!p.orbit.stable || p.orbit.max_multiplier() > 0.9) continue;
    geardyn::ode::State s = section_state(p.orbit);
    s.q += 1e-3;
    const Settled x = simulate(p.param, s, 400);
    EXPECT_NEAR(x.amplitude, p.amplitude(), 1e-9) << "omega = " << p.param;
    EXPECT_EQ(x.impacts, p.orbit.reading.impacts) << "omega = " << p.param;
    ++checked;
  }
  EXPECT_GE(checked, 6);
}

TEST(Continuation, LargerForcingFoldIsTheSweepsJumpAndBothBranchesMatchTheSweep) {
  // F_a 0.05: the branch from static contact grazes, then folds where the up sweep jumps; the
  // sweep's points (settled to a predicted distance to the periodic response under 1e-7: the
  // amplitude read over a period can be off by a few times the section's distance) lie on
  // the orbits to 1e-6 in amplitude, the low branch's below the jump, the rattle branch's on
  // the way down.
  Case c = ks_case();
  c.model.force_alternating = 0.05;
  c.solver.initial = geardyn::InitialCondition::kStatic;
  geardyn::SweepOptions so;
  so.axis = {"model.omega", 0.5, 1.5, 51};
  so.steady_tolerance = 1e-7;
  const geardyn::SweepResult sweep = geardyn::sweep(c, so);
  EXPECT_EQ(sweep.unsettled, 0U);
  const geardyn::Jump* up = nullptr;
  for (const auto& j : sweep.jumps)
    if (j.direction == geardyn::SweepDirection::kUp) up = &j;
  ASSERT_NE(up, nullptr);
  const ContinuationResult r = geardyn::continuation(c, ks_options());
  const geardyn::Bifurcation* fold = nullptr;
  for (const auto& b : r.bifurcations)
    if (b.type == BifurcationType::kFold) fold = &b;
  ASSERT_NE(fold, nullptr) << r.message;
  EXPECT_GT(fold->param, up->from_value);
  EXPECT_LT(fold->param, up->to_value);
  int low = 0, high = 0;
  for (const auto& p : sweep.points) {
    const bool on_low = p.direction == geardyn::SweepDirection::kUp && p.value < up->from_value;
    const bool on_high = p.direction == geardyn::SweepDirection::kDown;
    if (!on_low && !on_high) continue;
    Case cp = c;
    cp.model.omega = p.value;
    // Newton from the sweep's last stroboscopic state (b = 1 in this form): the orbit the
    // sweep settled on.
    ASSERT_FALSE(p.strobe_delta_bar.empty());
    const geardyn::ode::State start{0.0, p.strobe_delta_bar.back(), p.strobe_velocity_m_s.back(),
                                    0.0, 0};
    const geardyn::Orbit o = geardyn::find_orbit(cp, geardyn::OrbitOptions{}, start);
    ASSERT_TRUE(o.converged) << o.message;
    EXPECT_NEAR(0.5 * (o.reading.max_delta_bar - o.reading.min_delta_bar), 0.5 * p.pp_delta_bar,
                1e-6)
        << (on_low ? "low" : "high") << " branch, Omega = " << p.value;
    (on_low ? low : high) += 1;
  }
  EXPECT_GE(low, 10);
  EXPECT_GE(high, 40);
}

TEST(Continuation, PeriodDoublingIsLocatedAndItsBranchFollowed) {
  // F_a 0.2 from static contact: the period-1 branch doubles its period near Omega 1.61. The
  // located orbit has a multiplier -1; the switched branch holds orbits of period 2 T0 that
  // an independent integrator (dopri5 at 1e-12) confirms: back after two periods, not after
  // one.
  Case c = ks_case();
  c.model.force_alternating = 0.2;
  c.solver.initial = geardyn::InitialCondition::kStatic;
  ContinuationOptions o = ks_options();
  o.from = 1.3;
  o.to = 2.5;
  o.follow_period_doubling = true;
  o.max_points = 300;
  const ContinuationResult r = geardyn::continuation(c, o);
  const geardyn::Bifurcation* pd = nullptr;
  for (const auto& b : r.bifurcations)
    if (b.branch == 0 && b.type == BifurcationType::kPeriodDoubling) pd = &b;
  ASSERT_NE(pd, nullptr) << r.message;
  EXPECT_NEAR(pd->param, 1.6077, 1e-3);
  double nearest = 1e9;
  for (const auto& m : pd->orbit.multipliers) nearest = std::min(nearest, std::abs(m + 1.0));
  EXPECT_LT(nearest, 1e-6);
  std::vector<const geardyn::BranchPoint*> doubled;
  for (const auto& p : r.points)
    if (p.branch == 1) doubled.push_back(&p);
  ASSERT_GE(doubled.size(), 10U) << r.message;
  const geardyn::BranchPoint& q = *doubled[doubled.size() / 2];
  EXPECT_EQ(q.periods, 2);
  Case cq = c;
  cq.model.omega = q.param;
  const geardyn::GearPairModel model = geardyn::build_model(cq);
  geardyn::SolverData sd = cq.solver;
  sd.method = geardyn::Method::kDopri5;
  sd.tolerance = 1e-12;
  const geardyn::Solver solver(model, sd);
  geardyn::ode::State s = section_state(q.orbit);
  s.region = model.classify(model.drive(0), s.q, s.v);
  const double T0 = 2 * std::numbers::pi / q.param;
  const auto one = solver.advance(s, T0);
  const auto two = solver.advance(s, 2 * T0);
  ASSERT_TRUE(one.ok() && two.ok());
  EXPECT_NEAR(two.end_state.q, s.q, 1e-8);
  EXPECT_NEAR(two.end_state.v, s.v, 1e-8);
  EXPECT_GT(std::abs(one.end_state.q - s.q) + std::abs(one.end_state.v - s.v), 1e-4);
  // The figure's key names each branch by its period, once per stability found on it.
  const auto dir = std::filesystem::temp_directory_path() / "geardyn_continuation_doubled";
  std::filesystem::remove_all(dir);
  geardyn::write_continuation(dir, r, "model.omega", true);
  std::stringstream body;
  body << std::ifstream(dir / "branch_body.gp").rdbuf();
  for (int branch = 0; branch < 2; ++branch)
    for (const bool stable : {true, false}) {
      const bool found = std::any_of(r.points.begin(), r.points.end(), [&](const auto& p) {
        return p.branch == branch && p.orbit.stable == stable;
      });
      const std::string title =
          fmt::format("title 'period {}, {}'", branch + 1, stable ? "stable" : "unstable");
      EXPECT_EQ(body.str().find(title) != std::string::npos, found) << title;
    }
  EXPECT_EQ(body.str().find("title 'stable'"), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(Continuation, WritesTheBranchAndItsBifurcations) {
  const ContinuationResult& r = ks_branch();
  const auto dir = std::filesystem::temp_directory_path() / "geardyn_continuation_test";
  std::filesystem::remove_all(dir);
  geardyn::write_continuation(dir, r, "model.omega", false);
  std::ifstream csv(dir / "branch.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(
      header.rfind("param,stable,x_a,min_delta_bar,max_delta_bar,max_force_bar,impacts_per_period,"
                   "max_multiplier",
                   0),
      0U);
  std::size_t rows = 0;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, r.points.size());
  std::stringstream json;
  json << std::ifstream(dir / "bifurcations.json").rdbuf();
  EXPECT_NE(json.str().find("\"type\": \"fold\""), std::string::npos);
  EXPECT_NE(json.str().find("\"type\": \"grazing\""), std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(Continuation, ARangeEndingOnTheKeysBoundEndsOnIt) {
  // zeta from 0.05 down to 0, where the key's range ends: the last step lands on 0 and the
  // derivative in the key there is one-sided; no point lies past the bound.
  ContinuationOptions o;
  o.key = "model.zeta";
  o.from = 0.05;
  o.to = 0.0;
  const ContinuationResult r = geardyn::continuation(ks_case(0.95), o);
  ASSERT_TRUE(r.completed) << r.message;
  ASSERT_GE(r.points.size(), 10U);
  EXPECT_EQ(r.points.back().param, 0.0);
  for (const auto& p : r.points) EXPECT_GE(p.param, 0.0);
  // Undamped, the piecewise-linear orbit is conservative: its multipliers lie on the circle.
  EXPECT_NEAR(r.points.back().orbit.max_multiplier(), 1.0, 1e-6);
  EXPECT_LT(r.points[r.points.size() - 2].orbit.max_multiplier(), 1.0);
}

TEST(Continuation, BadInputIsRejectedWithItsReason) {
  ContinuationOptions o = ks_options();
  o.to = o.from;
  EXPECT_THROW((void)geardyn::continuation(ks_case(), o), geardyn::InputError);
  o = ks_options();
  o.key = "solver.method";  // not numeric
  try {
    (void)geardyn::continuation(ks_case(), o);
    ADD_FAILURE() << "a string key was accepted";
  } catch (const geardyn::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--param solver.method"), std::string::npos) << e.what();
  }
  // An end the key does not allow is named before any work.
  o = ks_options();
  o.key = "model.zeta";
  o.from = 0.05;
  o.to = -0.1;
  const std::string why =
      geardyn::testing::error_of([&] { (void)geardyn::continuation(ks_case(), o); });
  EXPECT_NE(why.find("--to -0.1"), std::string::npos) << why;
  EXPECT_NE(why.find("model.zeta"), std::string::npos) << why;
  EXPECT_NE(why.find("[0, 1)"), std::string::npos) << why;
}

TEST(Continuation, ProgressCanStopItWithThePointsKept) {
  ContinuationOptions o = ks_options();
  o.progress = [](double, std::size_t points) { return points < 10; };
  const ContinuationResult r = geardyn::continuation(ks_case(), o);
  EXPECT_TRUE(r.cancelled);
  EXPECT_FALSE(r.completed);
  EXPECT_EQ(r.points.size(), 10U);
}

}  // namespace
