#include "geardyn/sweep.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "geardyn/case_keys.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/steady.hpp"
#include "geardyn/sweep_output.hpp"
#include "geardyn/train_orbit.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

namespace fs = std::filesystem;

// x'' + 2 zeta x' + k f(x) = F_m + F_a cos(Omega tau), b = 1 (Kahraman and Singh 1990).
Case nondimensional(double zeta, double fm, double fa) {
  Case c;
  c.model.form = ModelForm::kNondimensional;
  c.model.zeta = zeta;
  c.model.force_mean = fm;
  c.model.force_alternating = fa;
  c.solver.initial = InitialCondition::kStatic;
  return c;
}

SweepOptions omega_sweep(double from, double to, int points, SweepDirection d) {
  SweepOptions o;
  o.axis = {"model.omega", from, to, points, false};
  o.direction = d;
  return o;
}

// integrate_watching's contract, on a scripted response: the run goes a period at a time while
// it judges, marks where the verdict says steady and runs the rest in one piece; without a
// verdict it marks the final half; a failed piece ends it unmarked before the half.
struct Watched {
  std::vector<double> stops, judged, marks;
  SteadyStart start;
};
Watched watch(double period, int settle_at, double fail_at = 1e9) {
  Watched w;
  double now = 0;
  w.start = integrate_watching(
      0, 10, period,
      [&] {
        w.judged.push_back(now);
        const bool steady = static_cast<int>(w.judged.size()) > settle_at;
        return SteadyVerdict{steady ? 2 : 0, steady ? 1e-9 : 0.5};
      },
      [&](double stop) {
        if (stop > fail_at) return false;
        w.stops.push_back(stop);
        now = stop;
        return true;
      },
      [&](double t) { w.marks.push_back(t); });
  return w;
}

TEST(IntegrateWatching, GoesAPeriodAtATimeUntilSteadyThenMarksAndRunsToTheEnd) {
  const Watched w = watch(1.0, 3);  // steady at the 4th verdict: t = 3
  EXPECT_EQ(w.stops, (std::vector<double>{1, 2, 3, 10}));
  EXPECT_EQ(w.judged, (std::vector<double>{0, 1, 2, 3}));
  EXPECT_EQ(w.marks, (std::vector<double>{3}));
  EXPECT_EQ(w.start.basis, SteadyBasis::kSettled);
  EXPECT_EQ(w.start.period_multiple, 2);
  EXPECT_DOUBLE_EQ(w.start.from_s, 3);
  EXPECT_TRUE(w.start.marked);
}

TEST(IntegrateWatching, WithoutAVerdictTheFinalHalfIsMarked) {
  const Watched w = watch(1.0, 100);
  // Judged while at least two periods are left (t + 2 T <= t1), then on to the end; the half
  // is marked where the run stands at t = 5.
  EXPECT_EQ(w.judged.back(), 9);
  EXPECT_EQ(w.marks, (std::vector<double>{5}));
  EXPECT_EQ(w.start.basis, SteadyBasis::kNotSettled);
  EXPECT_DOUBLE_EQ(w.start.error, 0.5);
  EXPECT_EQ(w.stops.back(), 10);
  // No period: the half is one stop, the rest another, nothing judged.
  const Watched a = watch(0.0, 0);
  EXPECT_EQ(a.stops, (std::vector<double>{5, 10}));
  EXPECT_TRUE(a.judged.empty());
  EXPECT_EQ(a.start.basis, SteadyBasis::kAperiodic);
  // A period that does not divide the half: the half is a stop of its own.
  const Watched b = watch(1.5, 100);
  EXPECT_EQ(b.marks, (std::vector<double>{5}));
  EXPECT_NE(std::find(b.stops.begin(), b.stops.end(), 5.0), b.stops.end());
  // A failure before the half: unmarked, from_s the half.
  const Watched f = watch(1.0, 100, 2.5);
  EXPECT_TRUE(f.marks.empty());
  EXPECT_FALSE(f.start.marked);
  EXPECT_DOUBLE_EQ(f.start.from_s, 5);
}

TEST(Sweep, LinearCaseFollowsTheClosedFormFrequencyResponse) {
  // F_m = 1 keeps the teeth in contact (x >= 1.5 > b): x - 2 is a linear oscillator whose
  // amplitude is F_a / sqrt((1 - Omega^2)^2 + (2 zeta Omega)^2).
  const double zeta = 0.1, fa = 0.1;
  const SweepResult r =
      sweep(nondimensional(zeta, 1.0, fa), omega_sweep(0.5, 1.5, 11, SweepDirection::kUp));
  ASSERT_EQ(r.points.size(), 11u);
  for (const SweepPoint& p : r.points) {
    const double w = p.value;
    const double amplitude = fa / std::hypot(1 - w * w, 2 * zeta * w);
    EXPECT_TRUE(p.settled) << w;
    EXPECT_EQ(p.regime, Regime::kNone) << w;
    // Error budget: Newmark's (omega dt)^2 ~ 1e-4 and the sampled peak (64 per period) ~ 1e-3.
    EXPECT_NEAR(p.pp_delta_bar, 2 * amplitude, 3e-3 * 2 * amplitude) << "Omega " << w;
    EXPECT_NEAR(p.mean_delta_bar, 2.0, 1e-6) << w;
    ASSERT_EQ(p.strobe_delta_bar.size(), 10u);  // one per measured period
  }
  EXPECT_TRUE(r.jumps.empty());
}

TEST(Sweep, BacklashGivesAJumpAndHysteresis) {
  const SweepResult r =
      sweep(nondimensional(0.05, 0.1, 0.1), omega_sweep(0.3, 1.5, 61, SweepDirection::kBoth));
  ASSERT_EQ(r.points.size(), 122u);
  ASSERT_FALSE(r.hysteresis.empty());
  const Jump* up = nullptr;
  const Jump* down = nullptr;
  // The primary resonance's jumps: the largest rise up and the largest fall down (smaller
  // superharmonic jumps may lie below it).
  for (const Jump& j : r.jumps) {
    if (j.direction == SweepDirection::kUp && j.after > j.before &&
        (!up || j.after - j.before > up->after - up->before))
      up = &j;
    if (j.direction == SweepDirection::kDown && j.after < j.before &&
        (!down || j.before - j.after > down->before - down->after))
      down = &j;
  }
  ASSERT_NE(up, nullptr);
  ASSERT_NE(down, nullptr);
  // Softening: the up sweep jumps onto the large response later than the down sweep leaves it,
  // and the hysteresis interval spans the two.
  EXPECT_GT(up->from_value, down->to_value);
  bool spanned = false;
  for (const Hysteresis& h : r.hysteresis)
    spanned |= h.from_value <= down->from_value && h.to_value >= up->from_value;
  EXPECT_TRUE(spanned);
}

TEST(Sweep, ResultsDoNotDependOnTheThreadCount) {
  SweepOptions o = omega_sweep(0.3, 1.5, 25, SweepDirection::kBoth);
  o.threads = 1;
  const std::string one = sweep_csv(sweep(nondimensional(0.05, 0.1, 0.1), o));
  o.threads = 2;
  const std::string two = sweep_csv(sweep(nondimensional(0.05, 0.1, 0.1), o));
  o.threads = 8;
  const std::string eight = sweep_csv(sweep(nondimensional(0.05, 0.1, 0.1), o));
  EXPECT_EQ(one, two);
  EXPECT_EQ(one, eight);
}

TEST(Sweep, CsvNumbersReadBackExactly) {
  // Every number of sweep.csv is written with the shortest digits that read back to the same
  // double: a linear response can be checked to rounding from the file.
  const SweepResult r =
      sweep(nondimensional(0.05, 0.1, 0.02), omega_sweep(0.3, 1.5, 7, SweepDirection::kUp));
  std::istringstream csv(sweep_csv(r));
  std::string line;
  std::getline(csv, line);
  for (const SweepPoint& p : r.points) {
    ASSERT_TRUE(std::getline(csv, line));
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_GE(cells.size(), 15U);
    EXPECT_EQ(std::stod(cells[2]), p.value);
    EXPECT_EQ(std::stod(cells[9]), p.pp_delta_bar);
    EXPECT_EQ(std::stod(cells[12]), p.rms_force_bar);
    EXPECT_EQ(std::stod(cells[14]), p.max_force_bar);
  }
}

TEST(Sweep, AFailingPointIsKeptWithItsReasonAndTheOthersGoOn) {
  // Down from an absurd torque, which diverges: the points after it are computed as without
  // it, the first of them from the initial condition.
  Case c;
  c.solver.initial = InitialCondition::kStatic;
  SweepOptions o;
  o.axis.key = "load.torque_nm";
  o.axis.explicit_values = {40.0, 60.0, 1e307};
  o.axis.points = 3;
  o.direction = SweepDirection::kDown;
  const SweepResult r = sweep(c, o);
  ASSERT_EQ(r.points.size(), 3U);
  EXPECT_EQ(r.failed, 1U);
  EXPECT_EQ(r.points[0].value, 1e307);
  EXPECT_NE(r.points[0].failure.find("numerical failure"), std::string::npos);
  EXPECT_TRUE(std::isnan(r.points[0].pp_delta_bar));
  EXPECT_TRUE(r.points[1].failure.empty());
  EXPECT_TRUE(r.points[2].failure.empty());
  o.axis.explicit_values = {40.0, 60.0};
  o.axis.points = 2;
  const SweepResult without = sweep(c, o);
  EXPECT_EQ(r.points[1].pp_delta_bar, without.points[0].pp_delta_bar);
  EXPECT_EQ(r.points[2].pp_delta_bar, without.points[1].pp_delta_bar);
  const std::string csv = sweep_csv(r);
  EXPECT_NE(csv.find(",failed,0,0,0,numerical failure"), std::string::npos) << csv;
}

TEST(Sweep, SteadinessIsThePredictedDistanceToThePeriodicResponse) {
  // Permanent contact (F_m 1) with little damping (zeta 0.001) at Omega 0.5: the start-up
  // transient decays by only exp(-zeta 4 pi) = 0.9875 per period, so two similar blocks are
  // no evidence of a steady state. Within the default 200 periods the point is flagged; given
  // time, it settles and its amplitude meets the closed form to the tolerance.
  const double zeta = 0.001, fa = 0.1, w = 0.5;
  SweepOptions o = omega_sweep(w, w, 1, SweepDirection::kUp);
  const SweepResult flagged = sweep(nondimensional(zeta, 1.0, fa), o);
  ASSERT_EQ(flagged.points.size(), 1U);
  EXPECT_FALSE(flagged.points[0].settled);
  EXPECT_EQ(flagged.unsettled, 1U);
  EXPECT_GT(flagged.points[0].steady_error, o.steady_tolerance);
  o.max_settle_periods = 5000;
  const SweepResult r = sweep(nondimensional(zeta, 1.0, fa), o);
  const SweepPoint& p = r.points[0];
  const double amplitude = fa / std::hypot(1 - w * w, 2 * zeta * w);
  EXPECT_TRUE(p.settled);
  EXPECT_EQ(p.period_multiple, 1);
  EXPECT_LE(p.steady_error, o.steady_tolerance);
  // The transient left is exp(-zeta t) small: about ln(0.1 / 1e-6) / (zeta 4 pi) = 900
  // periods, not the ~150 at which consecutive periods first agree to 1e-3.
  EXPECT_GT(p.settle_periods, 700);
  EXPECT_NEAR(0.5 * p.pp_delta_bar, amplitude, 2 * o.steady_tolerance);
}

TEST(Sweep, ThePredictedDistanceBoundsTheTrueOne) {
  // Kahraman-Singh (zeta 0.05, F_m 0.1, F_a 0.05) up and down through its jump, period-1
  // responses in contact and in rattle: the section state each point is measured from lies
  // within its predicted distance (and the tolerance) of the periodic orbit Newton finds
  // from it.
  SweepOptions o = omega_sweep(0.5, 1.5, 21, SweepDirection::kBoth);
  const Case c = nondimensional(0.05, 0.1, 0.05);
  const SweepResult r = sweep(c, o);
  EXPECT_EQ(r.unsettled, 0U);
  int checked = 0;
  for (const SweepPoint& p : r.points) {
    Case cp = c;
    cp.model.omega = p.value;
    const ode::State start{0.0, p.strobe_delta_bar[0], p.strobe_velocity_m_s[0], 0.0, 0};
    const Orbit orbit = find_orbit(cp, OrbitOptions{}, start);
    ASSERT_TRUE(orbit.converged) << orbit.message;
    const double distance = std::max(std::abs(orbit.state.q - start.q),
                                     std::abs(orbit.state.v - start.v));  // b = w_n = 1
    EXPECT_LE(distance, std::max(2 * p.steady_error, 1e-9)) << "Omega " << p.value;
    EXPECT_LE(distance, o.steady_tolerance) << "Omega " << p.value;
    ++checked;
  }
  EXPECT_EQ(checked, 42);
}

TEST(Sweep, APeriodDoubledResponseSettlesAsPeriodTwo) {
  // F_a 0.2: the period-1 orbit loses stability by period doubling near Omega 1.608
  // (Continuation.PeriodDoublingIsLocatedAndItsBranchFollowed); below it the sweep settles on
  // the period-2 orbit, above it on the period-1 orbit.
  SweepOptions o = omega_sweep(1.575, 1.65, 2, SweepDirection::kUp);
  const SweepResult r = sweep(nondimensional(0.05, 0.1, 0.2), o);
  ASSERT_EQ(r.points.size(), 2U);
  const SweepPoint& two = r.points[0];
  const SweepPoint& one = r.points[1];
  EXPECT_TRUE(two.settled && one.settled);
  EXPECT_EQ(two.period_multiple, 2);
  EXPECT_EQ(one.period_multiple, 1);
  ASSERT_GE(two.strobe_delta_bar.size(), 3U);
  EXPECT_GT(std::abs(two.strobe_delta_bar[1] - two.strobe_delta_bar[0]), 1e-3);
  EXPECT_NEAR(two.strobe_delta_bar[2], two.strobe_delta_bar[0], 1e-5);
  EXPECT_EQ(two.strobe_delta_bar.size() % 2, 0U);  // whole period-2 orbits measured
  EXPECT_NEAR(one.strobe_delta_bar[1], one.strobe_delta_bar[0], 1e-5);
}

TEST(Sweep, StrobeIsTakenAtTheCommonPeriod) {
  // Torque order 3 on the 56-tooth pinion: the torque period 1/(3 f1) does not hold a whole
  // number of mesh periods; the common period is 1/f1, and only there does a steady response
  // repeat on the strobe.
  Case c;
  c.load.fluctuation_order = 3;
  SweepOptions o;
  o.axis = {"speed.shaft_frequency_hz", 100, 100, 1, false};
  o.direction = SweepDirection::kUp;
  const SweepResult r = sweep(c, o);
  EXPECT_DOUBLE_EQ(r.period_s, 1.0 / 100);
  const SweepPoint& p = r.points.at(0);
  ASSERT_TRUE(p.settled);
  EXPECT_EQ(p.period_multiple, 1);
  ASSERT_GE(p.strobe_force_bar.size(), 2U);
  for (std::size_t k = 1; k < p.strobe_force_bar.size(); ++k)
    EXPECT_NEAR(p.strobe_delta_bar[k], p.strobe_delta_bar[0], 2 * o.steady_tolerance);
}

TEST(Sweep, FlagsPointsThatNeverSettle) {
  SweepOptions o = omega_sweep(0.8, 1.2, 3, SweepDirection::kUp);
  o.steady_tolerance = 1e-12;  // below the integration's floor (its tolerance, 1e-10)
  o.settle_periods = 0;
  o.max_settle_periods = 30;
  const SweepResult r = sweep(nondimensional(0.05, 1.0, 0.1), o);
  EXPECT_EQ(r.unsettled, 3u);
  for (const SweepPoint& p : r.points) {
    EXPECT_FALSE(p.settled);
    EXPECT_GE(p.settle_periods, 30);
  }
}

TEST(Sweep, StopsWhenTheProgressCallbackSaysSo) {
  SweepOptions o = omega_sweep(0.3, 1.5, 40, SweepDirection::kUp);
  o.progress = [](double done, std::size_t) { return done < 3; };
  const SweepResult r = sweep(nondimensional(0.05, 0.1, 0.1), o);
  EXPECT_TRUE(r.cancelled);
  EXPECT_EQ(r.points.size(), 3u);
}

// A point that takes long shows it moves: the progress hears each settling period's share of
// the point, in increasing order; a stop inside a point drops that point, keeping those done.
TEST(Sweep, ProgressMovesWithinAPointAndAStopThereDropsIt) {
  SweepOptions o = omega_sweep(0.8, 1.2, 3, SweepDirection::kUp);
  o.steady_tolerance = 1e-12;  // never settles: each point runs all its periods
  o.max_settle_periods = 30;
  o.threads = 1;
  std::vector<double> heard;
  o.progress = [&](double done, std::size_t total) {
    EXPECT_EQ(total, 3u);
    heard.push_back(done);
    return done < 1.5;
  };
  const SweepResult r = sweep(nondimensional(0.05, 1.0, 0.1), o);
  EXPECT_TRUE(r.cancelled);
  ASSERT_EQ(r.points.size(), 1u);  // the second point stopped half-way is not kept
  EXPECT_TRUE(std::is_sorted(heard.begin(), heard.end()));
  // Within the first point: its periods' shares, each 1/40 of the point (30 + 10 periods).
  const auto within =
      std::count_if(heard.begin(), heard.end(), [](double d) { return d > 0 && d < 1; });
  EXPECT_GE(within, 25);
  EXPECT_NEAR(heard.front(), 1.0 / 40, 1e-12);
  EXPECT_GE(heard.back(), 1.5);
  EXPECT_LT(heard.back(), 2.0);
}

TEST(Sweep, BadOptionsAndKeysAreInputErrors) {
  SweepOptions o = omega_sweep(-1, 1, 5, SweepDirection::kUp);
  o.axis.log = true;
  EXPECT_NE(testing::error_of([&] { sweep(Case{}, o); }).find("--log"), std::string::npos);
  o = omega_sweep(1, 2, 100000, SweepDirection::kUp);
  o.axis2 = SweepAxis{"model.force_alternating", 0.1, 0.2, 100000, false};
  const std::string map = testing::error_of([&] { sweep(Case{}, o); });
  EXPECT_NE(map.find("1e+10 points in the map; at most 1e+06"), std::string::npos) << map;
  o = omega_sweep(1, 2, 100000, SweepDirection::kBoth);
  o.max_settle_periods = 1000000;
  const std::string periods = testing::error_of([&] { sweep(Case{}, o); });
  EXPECT_NE(periods.find("system periods; at most 1e+09"), std::string::npos) << periods;
  o = omega_sweep(1, 2, 2, SweepDirection::kUp);
  o.axis.key = "speed.rpm";
  const std::string msg = testing::error_of([&] { sweep(Case{}, o); });
  EXPECT_NE(msg.find("--param speed.rpm"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown key"), std::string::npos) << msg;
}

// A swept key the case does not read would give every point the same response: refused before
// any work, naming the option, the key, the value's origin and why (case_keys.hpp,
// unread_study_key), wherever the form, the method or another key leaves it unread.
TEST(Sweep, AKeyTheCaseDoesNotReadIsRefusedBeforeAnyWork) {
  const auto refusal = [](const Case& c, const SweepOptions& o) {
    return testing::error_of([&] { sweep(c, o); });
  };
  // The gear pair reads [gear], [mesh], [load] and [speed], not model.omega.
  SweepOptions o = omega_sweep(1, 2, 3, SweepDirection::kUp);
  std::string msg = refusal(Case{}, o);
  for (const char* part : {"--param model.omega:", "model.omega = 1.0 (--from 1)", "not used",
                           "only \"nondimensional\" reads model.omega"})
    EXPECT_NE(msg.find(part), std::string::npos) << part << "\n" << msg;
  // The non-dimensional form has no backlash in um: the second key of a map, with its option.
  o.axis2 = SweepAxis{"mesh.backlash_um", 50, 150, 2, false};
  msg = refusal(nondimensional(0.05, 0.1, 0.1), o);
  EXPECT_NE(msg.find("--param2 mesh.backlash_um: "), std::string::npos) << msg;
  EXPECT_NE(msg.find("(--from2 50)"), std::string::npos) << msg;
  // A train turns at train.reference_speed_hz; [speed] is not its.
  const Case train = load_case(fs::path(GEARDYN_SOURCE_DIR) / "cases" / "two_stage_reducer.toml");
  SweepOptions speed;
  speed.axis = {"speed.shaft_frequency_hz", 100, 200, 3, false};
  msg = refusal(train, speed);
  EXPECT_NE(msg.find("reads [train] and [solver]"), std::string::npos) << msg;
  // A train's key that its element's source does not read: k_m of an ISO 6336 mesh.
  Case iso = train;
  set_case_value(iso, {"train.mesh[0].stiffness_source", "\"iso6336\""});
  speed.axis = {"train.mesh[0].mean_stiffness_n_per_m", 5e8, 7e8, 3, false};
  msg = refusal(iso, speed);
  EXPECT_NE(msg.find("train.mesh[0].mean_stiffness_n_per_m = 500000000 (--from 500000000): not "
                     "used: mesh 'stage1' takes k_m from ISO 6336-1"),
            std::string::npos)
      << msg;
  // A key read at some corner of a map is varied: the fluctuation's order, with its ratio swept
  // from 0; with the ratio held at 0 the order alone is refused, at its default value too.
  Case still;
  set_case_value(still, {"load.fluctuation_ratio", "0"});
  const Override order_low{"load.fluctuation_order", "1", "--from 1"};
  const Override order_high{"load.fluctuation_order", "3", "--to 3"};
  EXPECT_EQ(unread_study_key(still, {{order_low, {"load.fluctuation_ratio", "0", "--from2 0"}},
                                     {order_high, {"load.fluctuation_ratio", "0", "--from2 0"}},
                                     {order_low, {"load.fluctuation_ratio", "0.2", "--to2 0.2"}},
                                     {order_high, {"load.fluctuation_ratio", "0.2", "--to2 0.2"}}}),
            "");
  msg = unread_study_key(still, {{order_low}, {order_high}});
  EXPECT_NE(msg.find("load.fluctuation_order = 1.0 (--from 1): not used: load.fluctuation_ratio "
                     "= 0"),
            std::string::npos)
      << msg;
}

TEST(Sweep, AMapReadsJumpsAndHysteresisRowByRow) {
  // Each row of a map (both directions by default) is read as the 1-D sweep at that value of
  // the second key would be: the same jumps and hysteresis, labelled with the row.
  SweepOptions o = omega_sweep(0.3, 1.5, 25, SweepDirection::kBoth);
  o.axis2 = SweepAxis{"model.force_alternating", 0.02, 0.06, 2, false};
  const SweepResult map = sweep(nondimensional(0.05, 0.1, 0.1), o);
  ASSERT_EQ(map.points.size(), 2U * 2U * 25U);
  for (double fa : {0.02, 0.06}) {
    SweepOptions row = omega_sweep(0.3, 1.5, 25, SweepDirection::kBoth);
    const SweepResult line = sweep(nondimensional(0.05, 0.1, fa), row);
    ASSERT_FALSE(line.jumps.empty()) << fa;
    ASSERT_FALSE(line.hysteresis.empty()) << fa;
    std::vector<const Jump*> in_row;
    for (const Jump& j : map.jumps)
      if (j.value2 == fa) in_row.push_back(&j);
    ASSERT_EQ(in_row.size(), line.jumps.size()) << fa;
    for (std::size_t i = 0; i < in_row.size(); ++i) {
      EXPECT_EQ(in_row[i]->direction, line.jumps[i].direction);
      EXPECT_EQ(in_row[i]->from_value, line.jumps[i].from_value);
      EXPECT_EQ(in_row[i]->to_value, line.jumps[i].to_value);
    }
    std::size_t hysteresis = 0;
    for (const Hysteresis& h : map.hysteresis)
      if (h.value2 == fa) {
        ASSERT_LT(hysteresis, line.hysteresis.size());
        EXPECT_EQ(h.from_value, line.hysteresis[hysteresis].from_value);
        EXPECT_EQ(h.to_value, line.hysteresis[hysteresis].to_value);
        ++hysteresis;
      }
    EXPECT_EQ(hysteresis, line.hysteresis.size()) << fa;
  }
}

// Each sequence's first point with impacts, in its own run order (the down sweep's from its
// top): no point before it has any, it has; summary.json lists them.
TEST(Sweep, ImpactOnsetsAreEachSequencesFirstPointWithImpacts) {
  const SweepResult r =
      sweep(nondimensional(0.05, 0.1, 0.1), omega_sweep(0.3, 1.5, 25, SweepDirection::kBoth));
  ASSERT_EQ(r.impact_onsets.size(), 2u);
  for (const ImpactOnset& onset : r.impact_onsets) {
    SCOPED_TRACE(to_string(onset.direction));
    bool reached = false;
    for (const SweepPoint& p : r.points) {
      if (p.direction != onset.direction) continue;
      if (p.value == onset.value) {
        EXPECT_GT(p.impacts_per_period, 0);
        reached = true;
        break;
      }
      EXPECT_EQ(p.impacts_per_period, 0) << p.value;
    }
    EXPECT_TRUE(reached);
  }
  EXPECT_EQ(r.impact_onsets[0].direction, SweepDirection::kUp);
  EXPECT_EQ(r.impact_onsets[1].direction, SweepDirection::kDown);
  const auto d =
      std::filesystem::temp_directory_path() / ("geardyn_onset_" + std::to_string(getpid()));
  std::filesystem::remove_all(d);
  write_sweep(d, r, /*figures=*/false);
  std::ifstream in(d / "summary.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["impact_onsets"].size(), 2u);
  EXPECT_EQ(j["impact_onsets"][0]["value"], r.impact_onsets[0].value);
  std::filesystem::remove_all(d);
}

// A swept key's axis names its unit, read off the key's name.
TEST(Sweep, AnAxisNamesItsKeysUnit) {
  SweepOptions o;
  o.axis = {"speed.shaft_frequency_hz", 1500, 1600, 2, false};
  o.direction = SweepDirection::kUp;
  const SweepResult r = sweep(Case{}, o);
  const auto d =
      std::filesystem::temp_directory_path() / ("geardyn_axis_" + std::to_string(getpid()));
  std::filesystem::remove_all(d);
  write_sweep(d, r);
  std::ifstream in(d / "frequency_response_body.gp");
  const std::string body(std::istreambuf_iterator<char>(in), {});
  EXPECT_NE(body.find("set xlabel 'speed.shaft_frequency_hz (Hz)'"), std::string::npos) << body;
  std::filesystem::remove_all(d);
}

TEST(Sweep, MapWritesItsFilesAndFigures) {
  SweepOptions o = omega_sweep(0.6, 1.4, 4, SweepDirection::kUp);
  o.axis2 = SweepAxis{"model.force_alternating", 0.05, 0.15, 3, false};
  const SweepResult r = sweep(nondimensional(0.05, 0.1, 0.1), o);
  ASSERT_EQ(r.points.size(), 12u);
  const auto d =
      std::filesystem::temp_directory_path() / ("geardyn_sweep_" + std::to_string(getpid()));
  std::filesystem::remove_all(d);
  write_sweep(d, r);
  for (const char* f : {"sweep.csv", "strobe.csv", "summary.json", "frequency_response.png",
                        "bifurcation.png", "regime_map.png", "regime_map.svg"})
    EXPECT_GT(std::filesystem::file_size(d / f), 100u) << f;
  std::ifstream in(d / "summary.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["param2"], "model.force_alternating");
  EXPECT_EQ(j["points_computed"], 12);
  // Up sweeps only: one panel, no coexistence to mark, only the regimes that occurred named.
  const auto body = [](const fs::path& dir) {
    std::ifstream b(dir / "regime_map_body.gp");
    return std::string(std::istreambuf_iterator<char>(b), {});
  };
  const std::string up = body(d);
  EXPECT_EQ(up.find("branches coexist"), std::string::npos);
  EXPECT_EQ(up.find("title 'failed'"), std::string::npos);
  EXPECT_EQ(up.find("down sweeps"), std::string::npos);
  // Both directions through the hysteresis of F_a 0.1: two panels and the coexisting branches
  // circled at the points where up and down differ.
  o.direction = SweepDirection::kBoth;
  o.axis = {"model.omega", 0.3, 0.7, 9, false};
  const SweepResult both = sweep(nondimensional(0.05, 0.1, 0.1), o);
  ASSERT_FALSE(both.hysteresis.empty());
  write_sweep(d, both);
  const std::string two = body(d);
  EXPECT_NE(two.find("branches coexist"), std::string::npos);
  EXPECT_NE(two.find("down sweeps"), std::string::npos);
}

TEST(Sweep, GearCaseKeepsTheStiffnessAcrossFrequencyPoints) {
  // A frequency sweep of the Table 1 case computes the mesh stiffness once (the speed does not
  // change it); a map whose second key changes the stiffness (here at its default value)
  // computes it at every point. Both give the same numbers to the last digit.
  Case c;
  SweepOptions o;
  o.axis = {"speed.shaft_frequency_hz", 1500, 1600, 2, false};
  o.direction = SweepDirection::kUp;
  const SweepResult kept = sweep(c, o);
  o.axis2 = SweepAxis{"mesh.application_factor", c.mesh.application_factor,
                      c.mesh.application_factor, 1, false};
  const SweepResult each = sweep(c, o);
  ASSERT_EQ(kept.points.size(), 2u);
  ASSERT_EQ(each.points.size(), 2u);
  EXPECT_NEAR(kept.period_s, 1.0 / 1500, 1e-15);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(kept.points[i].rms_force_bar, each.points[i].rms_force_bar);
    EXPECT_EQ(kept.points[i].pp_delta_bar, each.points[i].pp_delta_bar);
    EXPECT_EQ(kept.points[i].strobe_delta_bar, each.points[i].strobe_delta_bar);
  }
  // And they are not a constant stiffness's: without harmonics the response differs.
  Case flat = c;
  flat.mesh.harmonics_kept = 0;
  o.axis2.reset();
  EXPECT_NE(sweep(flat, o).points[0].pp_delta_bar, kept.points[0].pp_delta_bar);
}

TEST(Sweep, SeveralProjectionsAreJudgedTogether) {
  // judge_together: steady when every projection is, with the least common multiple of their
  // periods; the largest distance; not steady when one is not or the common period passes
  // kMaxSettledMultiple.
  const auto series = [](int period, double decay, double amplitude) {
    SectionSeries s(1.0, 1.0, 1e-13);
    for (int j = 0; j < 40; ++j) {
      const double cycle = period == 1 ? 0.0 : std::cos(2 * std::numbers::pi * j / period);
      const double lag = period == 1 ? 0.0 : std::cos(2 * std::numbers::pi * j / period + 1);
      s.add(ode::State{static_cast<double>(j), 0.3 * cycle + amplitude * std::pow(decay, j),
                       0.2 * lag - amplitude * std::pow(decay, j), 0.0, 0});
    }
    return s;
  };
  const double tol = 1e-6;
  const SectionSeries one = series(1, 0.5, 1e-3), two = series(2, 0.5, 1e-3),
                      three = series(3, 0.5, 1e-3), four = series(4, 0.5, 1e-3),
                      slow = series(1, 0.99, 1e-3);
  ASSERT_EQ(one.judge(tol).period_multiple, 1);
  ASSERT_EQ(two.judge(tol).period_multiple, 2);
  ASSERT_EQ(three.judge(tol).period_multiple, 3);
  ASSERT_EQ(four.judge(tol).period_multiple, 4);
  ASSERT_FALSE(slow.judge(tol).settled());
  EXPECT_EQ(judge_together({one}, tol).period_multiple, 1);
  EXPECT_EQ(judge_together({one, two}, tol).period_multiple, 2);
  EXPECT_EQ(judge_together({two, three}, tol).period_multiple, 6);
  EXPECT_FALSE(judge_together({three, four}, tol).settled());  // 12 > kMaxSettledMultiple
  const SteadyVerdict with_slow = judge_together({one, slow, two}, tol);
  EXPECT_FALSE(with_slow.settled());
  EXPECT_EQ(with_slow.error, slow.judge(tol).error);
  EXPECT_EQ(judge_together({one, two}, tol).error,
            std::max(one.judge(tol).error, two.judge(tol).error));
}

TEST(Sweep, AnAffineMapsResponseIsItsFixedPointWithABoundOnItsError) {
  // affine_response: P(y) = M y + c with a non-normal M (multipliers 0.9, 0.5, -0.3, 0.2) and
  // components 1e4 apart in scale, as a monodromy's positions and rates are. From one state and
  // its image it gives the point the map's iterates converge to; an error e in the image moves
  // it by at most amplification x e, and by that much for the worst e.
  const auto vec = [](double a, double b, double c, double d) {
    return ode::Vector((ode::Vector(4) << a, b, c, d).finished());
  };
  ode::Matrix t(4, 4);
  t << 1, 0.7, 0, 0.2, 0, 1, 0.5, 0, 0.3, 0, 1, 0.6, 0, 0.4, 0, 1;
  const ode::Vector scale = vec(1, 1e4, 1, 1e4);
  // S T diag(multipliers) T^-1 S^-1.
  const auto monodromy = [&](const ode::Vector& multipliers) {
    return ode::Matrix(scale.asDiagonal() * t * multipliers.asDiagonal() * t.inverse() *
                       scale.cwiseInverse().asDiagonal());
  };
  const ode::Matrix m = monodromy(vec(0.9, 0.5, -0.3, 0.2));
  const ode::Vector c = vec(0.3, -2e3, 0.1, 5e3);
  const auto map = [&](const ode::Vector& y) { return ode::Vector(m * y + c); };
  const ode::Vector y = vec(2, 1e4, -1, 3e3);
  const std::optional<AffineResponse> r = affine_response(m, y, map(y), scale);
  ASSERT_TRUE(r);
  ode::Vector x = y;
  for (int k = 0; k < 600; ++k) x = map(x);  // 0.9^600 ~ 3e-28
  EXPECT_LT(scaled_norm(r->state - x, scale), 1e-12);
  EXPECT_LT(scaled_norm(map(r->state) - r->state, scale), 1e-12);
  // The worst error of the image for the bound's row: e_j = eps s_j sign(A^-1_ij).
  const ode::Matrix a_inv =
      (scale.cwiseInverse().asDiagonal() * (ode::Matrix::Identity(4, 4) - m) * scale.asDiagonal())
          .inverse();
  Eigen::Index row = 0;
  a_inv.cwiseAbs().rowwise().sum().maxCoeff(&row);
  const double eps = 1e-8;
  const ode::Vector worst = eps * scale.cwiseProduct(a_inv.row(row).transpose().unaryExpr(
                                      [](double v) { return v >= 0 ? 1.0 : -1.0; }));
  const std::optional<AffineResponse> moved = affine_response(m, y, map(y) + worst, scale);
  ASSERT_TRUE(moved);
  EXPECT_NEAR(scaled_norm(moved->state - r->state, scale), r->amplification * eps,
              1e-6 * r->amplification * eps);
  for (int j = 0; j < 4; ++j) {  // other errors of that size move it less
    const ode::Vector e = eps * scale.cwiseProduct(ode::Vector::Unit(4, j));
    const std::optional<AffineResponse> other = affine_response(m, y, map(y) + e, scale);
    ASSERT_TRUE(other);
    EXPECT_LE(scaled_norm(other->state - r->state, scale), r->amplification * eps * (1 + 1e-9));
  }
  // A multiplier at 1: no unique fixed point.
  const ode::Matrix neutral = monodromy(vec(1.0, 0.5, -0.3, 0.2));
  EXPECT_FALSE(affine_response(neutral, y, neutral * y + c, scale));
}

}  // namespace
}  // namespace geardyn
