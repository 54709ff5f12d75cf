// Gear trains from a case file (train_case.hpp) and their runs (train_run.hpp): the reader
// against the gear pair it must equal, the static state against its closed form, a prescribed
// speed against its own formula, and the reader's messages.
#include "geardyn/train_case.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include "geardyn/adaptive.hpp"
#include "geardyn/case.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/coupled_model.hpp"
#include "geardyn/coupled_run.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/model.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/plausibility.hpp"
#include "geardyn/reproduce.hpp"
#include "geardyn/run.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_statics.hpp"
#include "geardyn/validation.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(TrainCase, ATwoGearTrainFromAFileIsTheHelicalGearPair) {
  // Through every impact of a rattling start (from the middle of the backlash), the file's
  // train reads as the one-degree model of the same helical pair: the base radii and base
  // helix from the gear data, the inertias from the blanks, the damping from its ratio, the
  // torques from their harmonics. A mutant that drops cos(beta_b) from the mesh, or takes the
  // transverse pressure angle for the normal one, moves delta by far more than the bound.
  // The pair and its train file: validation.hpp (the shipped check train_pair is this test's
  // core).
  const Case pair = park2010_pair_case();
  const RunResult one = run(pair);
  ASSERT_TRUE(one.integration.ok()) << one.integration.message;
  ASSERT_GT(one.reading.impacts, 3);
  const TrainRunResult train = run_train(park2010_pair_as_train());
  ASSERT_TRUE(train.ok()) << train.message;
  ASSERT_EQ(train.samples.t_s.size(), one.samples.size());
  double worst = 0;
  for (std::size_t i = 0; i < one.samples.size(); ++i)
    worst =
        std::max(worst, std::abs(train.samples.deflection_bar[i][0] - one.samples.delta_bar[i]));
  EXPECT_LT(worst, 1e-11);  // 4e-13 measured
  const TrainMeshReading& m = train.meshes.at(0);
  EXPECT_EQ(m.impacts, one.reading.impacts);
  EXPECT_EQ(m.backside_impacts, one.reading.backside_impacts);
  EXPECT_EQ(m.regime, one.reading.regime);
  const GearPairParameters p = build_model(pair).parameters();
  const double force_scale = p.backlash_m * p.mean_stiffness_n_per_m();
  EXPECT_NEAR(m.max_force_n / force_scale, one.reading.max_force_bar, 1e-8);
  EXPECT_NEAR(m.min_force_n / force_scale, one.reading.min_force_bar, 1e-8);
  // The static mesh force of the train is the pair's F_m / cos^2(beta_b).
  ASSERT_TRUE(m.static_force_n);
  EXPECT_NEAR(*m.static_force_n / p.static_mesh_force_n(), 1.0, 1e-12);
  EXPECT_NEAR(m.mesh_frequency_hz, 56 * 100.0, 1e-9);
}

TEST(TrainCase, ATwoGearTrainsSteadyPartIsThePairs) {
  // The steady part is sought as the one-degree run seeks it (integrate_watching): the pair's
  // train settles at the same section time, its steady reading the pair's, and its dynamic
  // factor is the steady part's largest force over the static one.
  Case pair = park2010_pair_case();
  Case as_train = park2010_pair_as_train();
  for (Case* c : {&pair, &as_train}) set_case_value(*c, {"solver.duration_s", "0.1"});
  const RunResult one = run(pair);
  ASSERT_TRUE(one.integration.ok()) << one.integration.message;
  ASSERT_EQ(one.steady.basis, SteadyBasis::kSettled);
  const TrainRunResult train = run_train(as_train);
  ASSERT_TRUE(train.ok()) << train.message;
  EXPECT_EQ(train.steady.basis, SteadyBasis::kSettled);
  EXPECT_EQ(train.steady.period_multiple, one.steady.period_multiple);
  EXPECT_DOUBLE_EQ(train.steady.from_s, one.steady.from_s);
  const TrainMeshReading& m = train.meshes.at(0);
  const RunReading& y = one.steady.reading;
  EXPECT_EQ(m.steady.impacts, y.impacts);
  EXPECT_EQ(m.steady.regime, y.regime);
  EXPECT_GT(m.impacts, m.steady.impacts);  // the start-up rattled
  const GearPairParameters p = build_model(pair).parameters();
  const double force_scale = p.backlash_m * p.mean_stiffness_n_per_m();
  EXPECT_NEAR(m.steady.max_force_n / force_scale, y.max_force_bar, 1e-8);
  EXPECT_NEAR(m.steady.min_force_n / force_scale, y.min_force_bar, 1e-8);
  EXPECT_NEAR(m.steady.max_deflection_m / p.backlash_m, y.max_delta_bar, 1e-8);
  ASSERT_TRUE(m.dynamic_factor && m.static_force_n);
  EXPECT_DOUBLE_EQ(*m.dynamic_factor, m.steady.max_force_n / *m.static_force_n);
  EXPECT_LT(*m.dynamic_factor, *m.dynamic_factor_with_startup);
  EXPECT_NEAR(*m.dynamic_factor / *y.dynamic_factor, 1.0, 1e-7);  // forces to 1e-8 b k_m
}

TEST(TrainCase, ARattlingLooseGearReadsItsFinalHalf) {
  // The loose gear rattles without settling: the final half is read, and said so; its impacts
  // are those of the final half, the regime sustained.
  const Case c =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "loose_gear_rattle.toml");
  const TrainRunResult r = run_train(c);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.steady.basis, SteadyBasis::kNotSettled);
  EXPECT_DOUBLE_EQ(r.steady.from_s, 0.5 * c.solver.duration_s);
  const TrainMeshReading& m = r.meshes.at(0);
  EXPECT_EQ(m.steady.regime, Regime::kSustained);
  EXPECT_GT(m.steady.impacts, 10);
  EXPECT_LT(m.steady.impacts, m.impacts);
  EXPECT_LE(m.steady.max_force_n, m.max_force_n);
  EXPECT_GE(m.steady.min_force_n, m.min_force_n);
  // The part's impacts are the whole's after from_s, counted from the samples' contact.
  std::int64_t entries = 0;
  for (std::size_t i = 1; i < r.samples.t_s.size(); ++i)
    if (r.samples.t_s[i - 1] >= r.steady.from_s && r.samples.contact[i - 1][0] == 0 &&
        r.samples.contact[i][0] != 0)
      ++entries;
  EXPECT_LE(entries, m.steady.impacts);  // an impact and its rebound may fall between samples
  EXPECT_GE(entries, m.steady.impacts / 2);
}

TEST(TrainCase, TheIdlersSteadyPartIsTheSameThroughEitherIntegrator) {
  // The exact engine and dopri5 (adaptive.hpp) find the idler train's steady part at the same
  // section time, and read its forces alike: dopri5's extremes are those of its step ends,
  // samples and each step's midpoint, within 5e-5 of the force's swing of the exact ones (2.2e-5
  // here; 1.3e-4 at the step ends and samples alone).
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "idler_train.toml");
  const TrainRunResult exact = run_train(c);
  set_case_value(c, {"solver.method", "dopri5"});
  set_case_value(c, {"solver.tolerance", "1e-10"});
  const TrainRunResult adaptive = run_train(c);
  ASSERT_TRUE(exact.ok() && adaptive.ok()) << exact.message << adaptive.message;
  ASSERT_EQ(exact.steady.basis, SteadyBasis::kSettled);
  EXPECT_EQ(adaptive.steady.basis, SteadyBasis::kSettled);
  ASSERT_TRUE(exact.system_period_s);
  EXPECT_NEAR(adaptive.steady.from_s, exact.steady.from_s, 1.01 * *exact.system_period_s);
  for (std::size_t m = 0; m < exact.meshes.size(); ++m) {
    const TrainMeshPart &a = exact.meshes[m].steady, &b = adaptive.meshes[m].steady;
    const double swing = a.max_force_n - a.min_force_n;
    EXPECT_NEAR(b.max_force_n, a.max_force_n, 5e-5 * swing) << m;
    EXPECT_NEAR(b.min_force_n, a.min_force_n, 5e-5 * swing) << m;
    EXPECT_LE(b.max_force_n, a.max_force_n + 1e-6 * swing) << m;  // step points lie inside
    // The steady part's range lies within the whole window's, which holds the start-up.
    EXPECT_LT(a.max_force_n, exact.meshes[m].max_force_n) << m;
  }
}

TEST(TrainCase, TheReducersStaticMeshForcesAreItsTorquesOverTheBaseRadii) {
  // In a tree of meshes each mesh carries the torque that reaches it: stage 1 the motor's over
  // pinion 1's base radius, stage 2 that times z_w1 / z_p1 over pinion 2's, each along the
  // normal line of action (over cos(beta_b)).
  const Case c =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "two_stage_reducer.toml");
  const train::Assembled a = assembled_train(c);
  std::string why;
  const auto q = static_state(a, &why);
  ASSERT_TRUE(q) << why;
  const std::vector<double> f = static_mesh_forces_n(a, *q);
  const auto base = [](int z, double mn_mm, double beta_deg) {
    const double beta = beta_deg * kPi / 180,
                 at = std::atan(std::tan(20 * kPi / 180) / std::cos(beta));
    return std::pair{0.5 * z * mn_mm * 1e-3 / std::cos(beta) * std::cos(at),
                     std::cos(std::atan(std::tan(beta) * std::cos(at)))};
  };
  const auto [r1, cb1] = base(23, 1.75, 25);
  const auto [r2, cb2] = base(19, 2.5, 22);
  EXPECT_NEAR(f[0] / (150 / (r1 * cb1)), 1.0, 1e-9);
  EXPECT_NEAR(f[1] / (150.0 * 61 / 23 / (r2 * cb2)), 1.0, 1e-9);
  // Unbalanced torques have no static state, and say so.
  Case unbalanced = c;
  set_case_value(unbalanced, {"train.torque[1].balances", "false"});
  set_case_value(unbalanced, {"train.torque[1].mean_nm", "-1000"});
  EXPECT_FALSE(static_state(assembled_train(unbalanced), &why));
  EXPECT_NE(why.find("do not balance"), std::string::npos) << why;
}

// A torque written with `balances = true` is the reaction to the others: the reducer's road
// load at -150 x (61 / 23) x (65 / 19) N m, as its case file writes it; with every torque given
// and off, the imbalance's message names the balancing value, to twelve digits. Two reactions,
// or one on a body at rest, are refused.
TEST(TrainCase, AReactionBalancesTheOtherTorquesAtTheTrainsSpeeds) {
  const std::filesystem::path file =
      std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "two_stage_reducer.toml";
  std::string text;
  {
    std::ifstream in(file);
    std::stringstream all;
    all << in.rdbuf();
    text = all.str();
  }
  const std::string given = "balances = true";
  ASSERT_NE(text.find(given), std::string::npos);
  const std::string& reaction = text;
  const Case c = parse_case(reaction, file.string());
  const train::Train t = train_of(c);
  EXPECT_NEAR(t.torques[1].mean_nm / (-150.0 * 61 / 23 * 65 / 19), 1.0, 1e-15);
  std::string why;
  EXPECT_TRUE(static_state(assembled_train(c), &why)) << why;
  // A load that does not balance names the one that does.
  std::string off = text;
  off.replace(off.find(given), given.size(), "mean_nm = -1361");
  EXPECT_FALSE(static_state(assembled_train(parse_case(off, file.string())), &why));
  EXPECT_NE(why.find("torque 'road_load' balances them at mean_nm = -1360.98398169"),
            std::string::npos)
      << why;
  // Refused: two reactions, a reaction on a body at rest.
  std::string twice = reaction;
  twice.replace(twice.find("mean_nm = 150"), 13, "balances = true");
  EXPECT_NE(geardyn::testing::error_of([&] {
              (void)train_of(parse_case(twice, "t.toml"));
            }).find("torque 'road_load': balances = true, as torque 'motor_torque' has"),
            std::string::npos);
  const std::filesystem::path set =
      std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "planetary_set.toml";
  std::ifstream in(set);
  std::stringstream all;
  all << in.rdbuf();
  const std::string held = all.str() +
                           "[[train.torque]]\nname = \"held\"\nbody = \"ring\"\n"
                           "balances = true\n";
  EXPECT_NE(geardyn::testing::error_of([&] {
              (void)train_of(parse_case(held, "t.toml"));
            }).find("torque 'held': balances = true on body 'ring', which is at rest"),
            std::string::npos);
}

// Said before any work: a mesh whose driving and driven gears are written the wrong way round
// is loaded on its back flank at rest; a planet's pin off the centre distance its teeth give.
// The shipped trains draw neither.
TEST(TrainCase, ABackFlankAtRestAndAPinOffItsGearsAreWarnedOf) {
  const std::filesystem::path dir = std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases";
  for (const char* name :
       {"two_stage_reducer.toml", "idler_train.toml", "loose_gear_rattle.toml",
        "planetary_set.toml", "lin_parker_1999.toml", "wind_turbine_grc750.toml"}) {
    const std::vector<std::string> w = train_plausibility(load_case(dir / name));
    EXPECT_TRUE(w.empty()) << name << ": " << fmt::format("{}", fmt::join(w, "\n"));
  }
  Case swapped = load_case(dir / "two_stage_reducer.toml");
  set_case_value(swapped, {"train.mesh[1].driving", "\"wheel2\""});
  set_case_value(swapped, {"train.mesh[1].driven", "\"pinion2\""});
  const std::vector<std::string> back = train_plausibility(swapped);
  ASSERT_EQ(back.size(), 1U) << fmt::format("{}", fmt::join(back, "\n"));
  EXPECT_NE(back[0].find("mesh 'stage2'"), std::string::npos) << back[0];
  EXPECT_NE(back[0].find("loaded on its back flank at rest (static force -"), std::string::npos)
      << back[0];
  Case pin = load_case(dir / "planetary_set.toml");
  set_case_value(pin, {"train.bearing[3].pin_radius_mm", "52"});
  const std::vector<std::string> off = train_plausibility(pin);
  ASSERT_FALSE(off.empty());
  EXPECT_NE(off[0].find("train.bearing[3].pin_radius_mm = 52"), std::string::npos) << off[0];
  EXPECT_NE(off[0].find("1.96 % off the centre distance its gears' teeth, module and profile "
                        "shifts give, 51 mm"),
            std::string::npos)
      << off[0];
  set_case_value(pin, {"train.bearing[3].pin_radius_mm", "51.04"});  // within 0.1 %
  EXPECT_TRUE(train_plausibility(pin).empty());
}

// A value written in another unit than its key's, said before any work with the unit the key
// takes: a backlash in millimetres, a module in metres, a speed in rpm, a torque in N mm. Each
// warning names the key as written and its value; at the shipped values there is none (above).
TEST(TrainCase, AValueInTheWrongUnitIsWarnedOf) {
  const std::filesystem::path dir = std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases";
  const auto warned = [](const Case& c, const std::string& what) {
    const std::vector<std::string> w = train_plausibility(c);
    const std::string all = fmt::format("{}", fmt::join(w, "\n"));
    EXPECT_NE(all.find(what), std::string::npos) << all;
    return all;
  };
  Case backlash = load_case(dir / "two_stage_reducer.toml");
  set_case_value(backlash, {"train.mesh[1].backlash_um", "0.04", "--set"});
  const std::string b = warned(backlash, "train.mesh[1].backlash_um = 0.04");
  EXPECT_NE(b.find("was it written in millimetres?"), std::string::npos) << b;
  set_case_value(backlash, {"train.mesh[1].backlash_um", "20", "--set"});  // a tight mesh's
  EXPECT_TRUE(train_plausibility(backlash).empty());
  Case module = load_case(dir / "wind_turbine_grc750.toml");
  set_case_value(module, {"train.body[4].normal_module_mm", "0.01", "--set"});
  const std::string m = warned(module, "train.body[4].normal_module_mm = 0.01");
  EXPECT_NE(m.find("was it written in metres?"), std::string::npos) << m;
  Case rpm = load_case(dir / "wind_turbine_grc750.toml");
  set_case_value(rpm, {"train.reference_speed_hz", "1800", "--set"});
  const std::string v = warned(rpm, "mesh 'high_speed'");
  EXPECT_NE(v.find("its pitch line runs at 641"), std::string::npos) << v;
  EXPECT_NE(v.find("is train.reference_speed_hz = 1800 (--set) a speed in rpm?"), std::string::npos)
      << v;
  Case torque = load_case(dir / "wind_turbine_grc750.toml");
  set_case_value(torque, {"train.torque[1].mean_nm", "-3979000", "--set"});
  const std::string q = warned(torque, "mesh 'high_speed'");
  EXPECT_NE(q.find("is a torque in N mm written as N m?"), std::string::npos) << q;
}

TEST(TrainCase, ShaftTorquesAndBearingForcesAreReadExactlyWithTheirStaticValues) {
  // The shipped reducer: at rest each shaft carries the torque that reaches it (the motor's,
  // times z_w1 / z_p1 on the intermediate shaft, times z_w2 / z_p2 again on the half shafts);
  // running with the exact engine, their extremes are its exact ones, the same whatever the
  // output grid
  // (to 1e-9) and beyond every sample. A mutant that reads a shaft's twist the other way, or
  // takes the extremes from the samples, fails.
  Case c =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "two_stage_reducer.toml");
  set_case_value(c, {"solver.duration_s", "0.004"});
  set_case_value(c, {"solver.method", "\"exact\""});  // the case's own is dopri5's
  const TrainRunResult coarse = run_train(c);
  set_case_value(c, {"solver.output_interval_s", "2e-6"});
  const TrainRunResult fine = run_train(c);
  ASSERT_TRUE(coarse.ok() && fine.ok()) << coarse.message << fine.message;
  ASSERT_EQ(fine.shafts.size(), 3U);
  const std::vector<double> statics = {150, 150.0 * 61 / 23, 150.0 * 61 / 23 * 65 / 19};
  for (std::size_t k = 0; k < 3; ++k) {
    SCOPED_TRACE(fine.shafts[k].name);
    ASSERT_TRUE(fine.shafts[k].static_torque_nm);
    EXPECT_NEAR(*fine.shafts[k].static_torque_nm / statics[k], 1.0, 1e-9);
    const TrainExtremes &a = coarse.shafts[k].torque_nm, &b = fine.shafts[k].torque_nm;
    EXPECT_NEAR(a.max / b.max, 1.0, 1e-9);
    EXPECT_NEAR(a.min / b.min, 1.0, 1e-9);
    double lo = kInf, hi = -kInf;
    for (const auto x : fine.samples.parts) {
      lo = std::min(lo, x[k]);
      hi = std::max(hi, x[k]);
    }
    EXPECT_GE(b.max, hi);
    EXPECT_LE(b.min, lo);
    EXPECT_LT(b.max - hi, 1e-3 * (b.max - b.min));  // a fine grid comes close
    EXPECT_GT(b.max - b.min, 1.0);                  // the torque does fluctuate
  }
}

TEST(TrainCase, APlanarIdlersBearingCarriesBothMeshForcesAtRest) {
  // The shipped idler planar on a bearing, its second mesh at theta: at rest the bearing takes
  // F (n_in - n_out), the force of the first mesh on the idler and the reaction of the second
  // (train.hpp's n; F = T / R_driver in both, spur gears): along y alone, 2 F cos(alpha), when
  // the three gears are in line.
  for (const double theta_deg : {0.0, 40.0}) {
    SCOPED_TRACE(theta_deg);
    Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "idler_train.toml");
    set_case_value(c, {"train.body[1].dof", "\"planar\""});
    set_case_value(c, {"train.mesh[1].position_angle_deg", fmt::format("{}", theta_deg)});
    set_case_value(c, {"train.bearing", "[{body = \"idler\", stiffness_n_per_m = 2e8}]"});
    set_case_value(c, {"solver.duration_s", "0.002"});
    const TrainRunResult r = run_train(c);
    ASSERT_TRUE(r.ok()) << r.message;
    ASSERT_EQ(r.bearings.size(), 1U);
    const double alpha = 20 * kPi / 180, theta = theta_deg * kPi / 180;
    const double force = 20 / (0.5 * 30 * 2e-3 * std::cos(alpha));
    const Eigen::Vector2d n_in(std::sin(alpha), std::cos(alpha));  // driver ccw, idler at +x
    const Eigen::Vector2d t(-std::sin(theta), std::cos(theta)), e(std::cos(theta), std::sin(theta));
    const Eigen::Vector2d n_out = -std::cos(alpha) * t + std::sin(alpha) * e;  // idler cw
    const Eigen::Vector2d expected = force * (n_in - n_out);
    const TrainBearingReading& b = r.bearings[0];
    ASSERT_TRUE(b.static_force_x_n && b.static_force_y_n);
    EXPECT_NEAR(*b.static_force_x_n, expected.x(), 1e-9 * force);
    EXPECT_NEAR(*b.static_force_y_n, expected.y(), 1e-9 * force);
    if (theta_deg == 0.0) EXPECT_NEAR(expected.y(), 2 * force * std::cos(alpha), 1e-9 * force);
    // The run's extremes hold the static value between them (it starts from rest).
    EXPECT_LE(b.force_y_n.min, *b.static_force_y_n + 1e-9 * force);
    EXPECT_GE(b.force_y_n.max, *b.static_force_y_n - 1e-9 * force);
  }
}

TEST(TrainCase, APrescribedSpeedFollowsItsAccelerationHarmonics) {
  // The input gear of the loose-gear case turns as prescribed: its rotation is
  // -a / (n Omega)^2 cos(n Omega t + phase), so that its acceleration is a cos(n Omega t +
  // phase), whatever the loose gear does.
  Case c =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "loose_gear_rattle.toml");
  set_case_value(c, {"train.speed[0].acceleration_harmonics", "[[500, 2, 30]]"});
  set_case_value(c, {"solver.duration_s", "0.1"});
  const TrainRunResult r = run_train(c);
  ASSERT_TRUE(r.ok()) << r.message;
  const double w = 2 * 2 * kPi * 12.5;
  double worst = 0;
  for (std::size_t i = 0; i < r.samples.t_s.size(); ++i) {
    const double t = r.samples.t_s[i];
    const double expected = -500 / (w * w) * std::cos(w * t + 30 * kPi / 180);
    worst = std::max(worst, std::abs(r.samples.state[i](0) - expected));
  }
  EXPECT_LT(worst, 1e-12 * 500 / (w * w) + 1e-15);
  EXPECT_GT(r.meshes[0].impacts, 0);  // above the onset of rattle
}

TEST(TrainCase, RattleStartsWhereTheDragCanNoLongerHoldTheLooseGear) {
  // The loose gear stays on its drive flank while J (R_in / R_loose) a <= T_drag (the onset of
  // the case file's comment); within the mesh compliance's effect (the library's own test
  // bounds it at 0.05 %), 2 % below the onset there is no separation and 2 % above it rattles.
  Case c =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "loose_gear_rattle.toml");
  const train::Assembled a = assembled_train(c);
  const double j_loose = a.mass()(1, 1);
  const double onset = 0.2 / (j_loose * 30.0 / 40.0);
  EXPECT_NEAR(onset, 240.0, 1.0);  // as the case's comment says
  for (const double f : {0.98, 1.02}) {
    set_case_value(
        c, {"train.speed[0].acceleration_harmonics", fmt::format("[[{}, 2, 0]]", f * onset)});
    const TrainRunResult r = run_train(c);
    ASSERT_TRUE(r.ok()) << r.message;
    if (f < 1) {
      EXPECT_EQ(r.meshes[0].separations, 0) << f;
    } else {
      EXPECT_GT(r.meshes[0].separations, 0) << f;
    }
  }
}

// The largest difference of (d - e) / b over every mesh and sample of two runs of one case.
// A shipped case with keys set as a study sets them.
Case shipped_case(const std::string& file, const std::vector<Override>& keys) {
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / file);
  for (const Override& k : keys) set_case_value(c, k);
  return c;
}

double largest_difference(const TrainRunResult& a, const TrainRunResult& b) {
  EXPECT_EQ(a.samples.t_s.size(), b.samples.t_s.size());
  double worst = 0;
  for (std::size_t i = 0; i < std::min(a.samples.t_s.size(), b.samples.t_s.size()); ++i)
    for (std::size_t m = 0; m < a.meshes.size(); ++m)
      worst = std::max(worst,
                       std::abs(a.samples.deflection_bar[i][m] - b.samples.deflection_bar[i][m]));
  return worst;
}

// The wind-turbine gearbox with the default method (dopri5 chosen: its meshes' common period
// of 437 s is too long for the exact engine's cells) against dopri5 a thousand times tighter:
// every mesh's (d - e) / b at every sample within 1e-5, through the static start and the
// rotor's 3P.
TEST(TrainCase, TheDefaultMethodOnAWindTurbineGearboxIsAccurate) {
  const Case c = shipped_case("wind_turbine_grc750.toml", {{"solver.duration_s", "0.05"}});
  const TrainRunResult by_default = run_train(c);
  ASSERT_TRUE(by_default.ok()) << by_default.message;
  EXPECT_EQ(by_default.method, Method::kDopri5);
  EXPECT_NE(by_default.method_note.find("chosen by the default"), std::string::npos);
  Case tight = c;
  set_case_value(tight, {"solver.method", "dopri5"});
  set_case_value(tight, {"solver.tolerance", "1e-11"});
  const TrainRunResult reference = run_train(tight);
  ASSERT_TRUE(reference.ok()) << reference.message;
  EXPECT_TRUE(reference.method_note.empty());  // asked for: nothing chosen
  EXPECT_LT(largest_difference(by_default, reference), 1e-5);
}

// The wind-turbine gearbox's ring meshes take ISO 6336-1's stiffness as its planet-sun meshes
// do, the ring as the standard takes an internal gear: by hand, c'_th = 1 / (C1 + C2 / z_n1)
// of the planet's virtual teeth alone (z_n2 infinite, no shifts), c' = 0.8 C_B cos(beta) c'_th
// (solid blanks, steel, line load above 100 N/mm), c_gamma_alpha = c' (0.75 eps_alpha + 0.25)
// with the internal pair's contact ratio, over the 227.5 mm face width.
TEST(TrainCase, ARingsMeshTakesItsStiffnessFromIso6336) {
  const Case c = shipped_case("wind_turbine_grc750.toml", {});
  const train::Assembled a = assembled_train(c);
  std::map<std::string, double> k;
  for (const train::Mesh& m : a.train().meshes) k[m.name] = m.mean_stiffness_n_per_m;
  const double beta = 7.5 * kPi / 180, alpha = 20 * kPi / 180;
  const double beta_b = std::asin(std::sin(beta) * std::cos(alpha));
  const double zn1 = 39 / (std::cos(beta_b) * std::cos(beta_b) * std::cos(beta));
  const double c_th = 1 / (0.04723 + 0.15551 / zn1);
  const double c_b = 1 + 0.5 * (1.2 - 1.25);
  const double c_prime = 0.8 * c_b * std::cos(beta) * c_th;
  // The internal pair's transverse contact ratio (ISO 21771), unshifted, standard tips.
  const double mt = 10e-3 / std::cos(beta), alpha_t = std::atan(std::tan(alpha) / std::cos(beta));
  const double r1 = 39 * mt / 2, r2 = 99 * mt / 2, ra1 = r1 + 10e-3, ra2 = r2 - 10e-3;
  const double rb1 = r1 * std::cos(alpha_t), rb2 = r2 * std::cos(alpha_t);
  const double eps = (std::sqrt(ra1 * ra1 - rb1 * rb1) - std::sqrt(ra2 * ra2 - rb2 * rb2) +
                      (r2 - r1) * std::sin(alpha_t)) /
                     (kPi * mt * std::cos(alpha_t));
  EXPECT_GT(eps, 1.5);
  const double expected = c_prime * (0.75 * eps + 0.25) * 227.5 * 1e6;
  for (const char* ring : {"ring_planet1", "ring_planet2", "ring_planet3"}) {
    EXPECT_NEAR(k[ring] / expected, 1.0, 1e-12) << ring;
    EXPECT_GT(k[ring], k["planet_sun1"]) << ring;  // no sun's 21 teeth, a longer contact
  }
  // The energy method takes the ring's concave flanks: within ISO's scatter of its c_gamma
  // (the external pairs' +-30 %, EnergyMethod.MeanAgreesWithIsoWithinThePublishedScatter), with
  // the harmonics of its own curve.
  Case energy = c;
  set_case_value(energy, {"train.mesh[1].stiffness_source", "\"energy\"", "--set"});
  set_case_value(energy, {"train.mesh[1].stiffness_harmonics", "[]", "--set"});
  for (const train::Mesh& m : assembled_train(energy).train().meshes)
    if (m.name.rfind("ring_planet", 0) == 0) {
      EXPECT_GT(m.mean_stiffness_n_per_m, 0.7 * expected) << m.name;
      EXPECT_LT(m.mean_stiffness_n_per_m, 1.3 * expected) << m.name;
      EXPECT_FALSE(m.stiffness.empty()) << m.name;
    }
  // Shifted gears are taken (ISO's terms in x): a planet shifted by 0.2 and its ring by -0.4
  // mesh at one centre distance (99 - 39 = 21 + 39 teeth), where the pins sit.
  Case shifted = c;
  set_case_value(shifted, {"train.body[2].profile_shift", "0.2", "--set"});
  set_case_value(shifted, {"train.body[4].profile_shift", "-0.4", "--set"});
  EXPECT_TRUE(train_plausibility(shifted).empty());
  const train::Assembled moved = assembled_train(shifted);
  for (const train::Mesh& m : moved.train().meshes)
    if (m.name.rfind("ring_planet", 0) == 0) EXPECT_NE(m.mean_stiffness_n_per_m, k[m.name]);
  for (const train::Bearing& b : moved.train().bearings)
    if (!b.on.empty()) EXPECT_GT(b.pin_radius_m, 0.3026 + 1e-3) << b.name;  // 302.6 mm unshifted
  // The planet's tip, not given, is the one its sun mesh shortens (ISO 21771's k), in its ring
  // mesh too: as if written so.
  const double a_sun =
      shifted_center_distance(false, 39, 21, 0.2, 0, 10, alpha, beta).center_distance;
  const double tip_k = 0.2 - (a_sun - 0.5 * 60 * 10 / std::cos(beta)) / 10;
  ASSERT_GT(tip_k, 1e-3);
  Case tipped = shifted;
  set_case_value(
      tipped, {"train.body[2].outside_diameter_mm",
               fmt::format("{:.17g}", 39 * 10 / std::cos(beta) + 2 * 10 * (1.2 - tip_k)), "--set"});
  const train::Assembled written_tip = assembled_train(tipped);
  for (std::size_t i = 0; i < moved.train().meshes.size(); ++i)
    EXPECT_NEAR(moved.train().meshes[i].mean_stiffness_n_per_m /
                    written_tip.train().meshes[i].mean_stiffness_n_per_m,
                1.0, 1e-12)
        << moved.train().meshes[i].name;
  // The planet alone shifted: its sun's and its ring's meshes put it at two centre distances,
  // said before any work.
  set_case_value(shifted, {"train.body[4].profile_shift", "0", "--set"});
  const std::vector<std::string> w = train_plausibility(shifted);
  ASSERT_EQ(w.size(), 1U) << fmt::format("{}", fmt::join(w, "\n"));
  EXPECT_NE(w[0].find("put planet 'planet'"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("one pin cannot hold it at both"), std::string::npos) << w[0];
}

// A shifted planetary set: its pins sit at the centre distance its shifts give (ISO 21771), the
// same for the sun's and the ring's meshes when the ring's shift is x_r = (inv(alpha) -
// inv(alpha_w')) (z_r - z_p) / (2 tan(alpha)) - x_p at that distance, and each mesh's line of
// action lies at its own working pressure angle, cos(alpha_w) = (r_b,a +- r_b,b) / a; with the
// ring's shift of the other sign the meshes disagree, said before any work.
TEST(TrainCase, AShiftedPlanetarySetsPinsSitWhereItsTeethMesh) {
  const double alpha = 20 * kPi / 180, m = 2e-3;  // planetary_set.toml: 24, 27, 78 teeth
  const double x_sun = 0.3, x_planet = 0.2;
  const double inv_w = std::tan(alpha) - alpha + 2 * std::tan(alpha) * (x_sun + x_planet) / 51;
  double w = alpha;  // Newton on inv(w) = inv_w
  for (int i = 0; i < 50; ++i) w -= (std::tan(w) - w - inv_w) / std::pow(std::tan(w), 2);
  const double a = 0.5 * m * 51 * std::cos(alpha) / std::cos(w);
  const double w_ring = std::acos(0.5 * m * 51 * std::cos(alpha) / a);
  const double x_ring =
      (std::tan(alpha) - alpha - (std::tan(w_ring) - w_ring)) * 51 / (2 * std::tan(alpha)) -
      x_planet;
  Case c = shipped_case("planetary_set.toml", {});
  set_case_value(c, {"train.body[0].profile_shift", fmt::format("{}", x_sun), "--set"});
  set_case_value(c, {"train.body[1].profile_shift", fmt::format("{}", x_planet), "--set"});
  set_case_value(c, {"train.body[2].profile_shift", fmt::format("{:.17g}", x_ring), "--set"});
  set_case_value(c, {"train.bearing[3].pin_radius_mm", "0", "--set"});
  EXPECT_TRUE(train_plausibility(c).empty())
      << fmt::format("{}", fmt::join(train_plausibility(c), "\n"));
  const train::Assembled set = assembled_train(c);
  for (const train::Bearing& b : set.train().bearings)
    if (!b.on.empty()) EXPECT_NEAR(b.pin_radius_m, a, 1e-12) << b.name;
  for (const train::Mesh& x : set.train().meshes)
    EXPECT_NEAR(std::cos(x.transverse_pressure_angle_rad),
                (x.base_radius_driving_m + (x.internal ? -1 : 1) * x.base_radius_driven_m) /
                    (x.internal ? -a : a),
                1e-9)
        << x.name;
  // The ring's shift as a drawing rounds it (-0.697: its mesh a few um off the pins' radius,
  // within their tolerance): nothing said, and the set's torques still balance at rest (each
  // planet's lines of action at its pin's radius).
  set_case_value(c,
                 {"train.body[2].profile_shift", fmt::format("{:.3f}", x_ring + 0.003), "--set"});
  EXPECT_TRUE(train_plausibility(c).empty());
  std::string why;
  EXPECT_TRUE(static_state(assembled_train(c), &why).has_value()) << why;
  set_case_value(c, {"train.body[2].profile_shift", fmt::format("{:.17g}", -x_ring), "--set"});
  const std::vector<std::string> said = train_plausibility(c);
  ASSERT_EQ(said.size(), 1U) << fmt::format("{}", fmt::join(said, "\n"));
  EXPECT_NE(said[0].find("mesh 'planet_ring'"), std::string::npos) << said[0];
}

// A load given as what a user knows, the generator's power: its torque is P / (2 pi n) at the
// generator's 30 Hz, the rotor's reaction balances it, and summary values follow; a power beside
// a mean or a reaction, or on a body at rest, is refused naming the torque.
TEST(TrainCase, ATorqueGivenAsAPowerIsItsTorqueAtItsBodysSpeed) {
  Case c = shipped_case("wind_turbine_grc750.toml", {});
  const train::Assembled given = assembled_train(c);
  const std::string text =
      std::regex_replace(to_toml(c), std::regex("mean_nm = -3979\n"), "power_kw = -750\n");
  ASSERT_NE(text.find("power_kw = -750"), std::string::npos);
  const Case powered = parse_case(text, "powered.toml");
  const train::Assembled a = assembled_train(powered);
  std::map<std::string, double> mean, was;
  for (const train::Torque& q : a.train().torques) mean[q.name] = q.mean_nm;
  for (const train::Torque& q : given.train().torques) was[q.name] = q.mean_nm;
  EXPECT_NEAR(mean["generator"], -750e3 / (2 * kPi * 30), 1e-9);
  EXPECT_NEAR(mean["rotor"] / was["rotor"], mean["generator"] / was["generator"], 1e-12);
  EXPECT_NEAR(a.mean_power_nm(), 0, 1e-9 * std::abs(mean["rotor"]));
  const std::string both = testing::error_of([&] {
    (void)assembled_train(parse_case(std::regex_replace(text, std::regex("power_kw = -750\n"),
                                                        "power_kw = -750\nmean_nm = -3979\n"),
                                     "both.toml"));
  });
  EXPECT_NE(both.find("torque 'generator': give one of mean_nm, power_kw and balances = true"),
            std::string::npos)
      << both;
  const std::string rest = testing::error_of([&] {
    (void)assembled_train(
        parse_case(std::regex_replace(text, std::regex("body = \"generator\"\npower_kw"),
                                      "body = \"ring\"\npower_kw"),
                   "rest.toml"));
  });
  EXPECT_NE(rest.find("power_kw = -750 on body 'ring', which is at rest"), std::string::npos)
      << rest;
}

// A key set on a loaded train (a sweep's point, a study's sample: set_case_value) gives the case
// that reading the file with that key would: the same case written back, the same origin for
// every element and key (the set key's the override's, every other one its place in the file),
// whether the number is set in place (set_train_number_in_place) or the case read again (a
// name); and an out-of-bounds number the reader's message.
TEST(TrainCase, AKeySetOnALoadedTrainIsTheFileReadWithIt) {
  const std::filesystem::path reducer =
      std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "two_stage_reducer.toml";
  const std::vector<Override> overrides = {
      {"train.reference_speed_hz", "77.5", "--param train.reference_speed_hz at 77.5"},
      {"train.mesh[1].backlash_um", "55", "--param train.mesh[1].backlash_um at 55"},
      {"train.body[0].inertia_kg_m2", "0.0123", "--to 0.0123"},
      {"train.body[2].inertia_kg_m2", "0.0123", "--to 0.0123"},  // absent in the file
      {"train.torque[1].mean_nm", "-12.5", "--from -12.5"},
      {"train.shaft[2].stiffness_n_m_per_rad", "2.5e4", "--param"},
      {"train.mesh[0].stiffness_source", "\"harmonics\"", "--set name"},  // read again
      // A harmonic's entries: amplitude, phase.
      {"train.mesh[1].stiffness_harmonics[1][0]", "0.02", "--from 0.02"},
      {"train.mesh[0].stiffness_harmonics[0][1]", "-35", "--to -35"},
  };
  for (const Override& o : overrides) {
    Case set = load_case(reducer);
    set_case_value(set, o);
    const Case read = load_case(reducer, {o});
    EXPECT_EQ(to_toml(set), to_toml(read)) << o.key;
    ASSERT_TRUE(set.train && read.train);
    EXPECT_EQ(set.train->origins, read.train->origins) << o.key;
  }
  // A planetary set's mesh, its planets written once and copied (train.planet).
  const std::filesystem::path planetary =
      std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "planetary_set.toml";
  for (const Override& o :
       std::vector<Override>{{"train.mesh[1].stiffness_harmonics[0][0]", "0.1", "--from 0.1"},
                             {"train.mesh[0].stiffness_harmonics[1][1]", "45", "--to 45"}}) {
    Case set = load_case(planetary);
    set_case_value(set, o);
    const Case read = load_case(planetary, {o});
    EXPECT_EQ(to_toml(set), to_toml(read)) << o.key;
    EXPECT_EQ(set.train->origins, read.train->origins) << o.key;
  }
  // The same for the loose gear's prescribed speed: [amplitude, order, phase_deg].
  const std::filesystem::path loose =
      std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "loose_gear_rattle.toml";
  for (const Override& o : std::vector<Override>{
           {"train.speed[0].acceleration_harmonics[0][0]", "250", "--param at 250"},
           {"train.speed[0].acceleration_harmonics[0][1]", "1.5", "--to 1.5"},
           {"train.speed[0].acceleration_harmonics[0][2]", "30", "--from 30"}}) {
    Case set = load_case(loose);
    set_case_value(set, o);
    const Case read = load_case(loose, {o});
    EXPECT_EQ(to_toml(set), to_toml(read)) << o.key;
    EXPECT_NE(to_toml(set), to_toml(load_case(loose))) << o.key;
    EXPECT_EQ(set.train->origins, read.train->origins) << o.key;
  }
  // What the reader refuses, the same words either way: a negative amplitude, an order of 0,
  // an entry past the harmonics given.
  for (const Override& o :
       std::vector<Override>{{"train.speed[0].acceleration_harmonics[0][0]", "-1", "--from -1"},
                             {"train.speed[0].acceleration_harmonics[0][1]", "0", "--from 0"},
                             {"train.speed[0].acceleration_harmonics[1][0]", "10", "--from 10"},
                             {"train.mesh[0].stiffness_harmonics[0][0]", "1", "--to 1"}}) {
    const std::filesystem::path file = o.key.find("speed") != std::string::npos ? loose : reducer;
    Case set = load_case(file);
    const std::string in_place = testing::error_of([&] { set_case_value(set, o); });
    const std::string read = testing::error_of([&] { (void)load_case(file, {o}); });
    EXPECT_FALSE(in_place.empty()) << o.key << " = " << o.value;
    EXPECT_EQ(in_place, read) << o.key;
    // Where the value came from, not the array's line in the file.
    EXPECT_EQ(in_place.rfind(o.label() + ": " + o.key.substr(0, o.key.find("][") - 2), 0), 0U)
        << in_place;
  }
  Case c = load_case(reducer);
  try {
    set_case_value(c, {"train.mesh[1].backlash_um", "-1", "--from -1"});
    ADD_FAILURE() << "a negative backlash was taken";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--from -1: train.mesh[1].backlash_um = -1: must ", 0),
              0U)
        << e.what();
  }
}

// The adaptive integrator's right-hand side (RegionDerivative: copies, one dense product, the
// varying part through its shared row space or as entries) is derivative()'s, the system's own
// sum, to rounding: every shipped train, in permanent contact and in two other regions, and the
// one-degree pair in each of its regions, at random times and states.
TEST(TrainCase, TheAdaptiveDerivativeIsTheSystemsOwnSum) {
  const auto check = [](const ode::LinearSwitchedSystem& s, int region, const std::string& what) {
    const ode::RegionDerivative f(s, region);
    const ode::LinearRegion& r = s.region(region);
    std::mt19937 engine(7);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    const auto random = [&] { return unit(engine); };
    double worst = 0;  // the largest difference over its rounding scale
    for (int k = 0; k < 20; ++k) {
      const double t = 0.01 * random() + 0.02;
      ode::Vector y(s.dimension);
      for (Eigen::Index i = 0; i < y.size(); ++i) y(i) = random();
      const ode::Vector want = ode::derivative(s, region, t, y);
      ode::Vector got(s.dimension);
      f(y.data(), got.data(), t);
      // Each entry's rounding scale: the sum of the magnitudes it adds up.
      ode::Vector scale = r.a.constant.cwiseAbs() * y.cwiseAbs() + r.u.constant.cwiseAbs();
      for (std::size_t j = 0; j < r.a.cos.size(); ++j)
        scale += (r.a.cos[j].cwiseAbs() + r.a.sin[j].cwiseAbs()) * y.cwiseAbs();
      for (std::size_t j = 0; j < r.u.cos.size(); ++j)
        scale += r.u.cos[j].cwiseAbs() + r.u.sin[j].cwiseAbs();
      for (Eigen::Index i = 0; i < y.size(); ++i)
        worst = std::max(worst, std::abs(got(i) - want(i)) / (scale(i) + 1e-300));
    }
    EXPECT_LE(worst, 1e-13) << what << ", region " << region;
    return f.low_rank() ? f.rank() : Eigen::Index{-1};
  };
  const std::filesystem::path cases = std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases";
  for (const char* name : {"planetary_set.toml", "two_stage_reducer.toml", "idler_train.toml",
                           "loose_gear_rattle.toml", "park2010_coupled.toml"}) {
    const train::Assembled a = assembled_train(load_case(cases / name));
    const ode::LinearSwitchedSystem s = a.linear_system();
    const int contact = a.region(std::vector<int>(a.train().meshes.size(), 1),
                                 std::vector<int>(a.clearances().size(), 0));
    const Eigen::Index rank = check(s, contact, name);
    check(s, 0, name);
    check(s, s.region_count() - 1, name);
    // Through the row space where that is cheaper: the stage's six meshes and the idler's two
    // (of 12 states); the reducer's two torsional meshes are a few entries, cheaper than its rank
    // form's products.
    if (std::string(name) == "planetary_set.toml") EXPECT_EQ(rank, 6);
    if (std::string(name) == "idler_train.toml") EXPECT_EQ(rank, 2);
    if (std::string(name) == "two_stage_reducer.toml") EXPECT_EQ(rank, -1);
  }
  const ode::LinearSwitchedSystem pair =
      build_model(load_case(cases / "park2010.toml")).linear_system();
  for (int r = 0; r < pair.region_count(); ++r) check(pair, r, "park2010.toml");
}

TEST(TrainCase, TheAdaptiveIntegratorAgreesWithTheExactEngineThroughTheImpacts) {
  // Two independent integrators of one train (adaptive.hpp against engine.hpp): the loose gear
  // through its first impacts, and the reducer in permanent contact with both stages' stiffness
  // and transmission error varying. The rattle is sensitive to its state (a difference grows
  // four to ten times in each 20 ms), so the window is the first 60 ms.
  Case loose = shipped_case("loose_gear_rattle.toml", {{"solver.duration_s", "0.06"},
                                                       {"solver.output_interval_s", "1e-4"},
                                                       {"solver.tolerance", "1e-11"}});
  const TrainRunResult exact = run_train(loose);
  set_case_value(loose, {"solver.method", "dopri5"});
  const TrainRunResult adaptive = run_train(loose);
  ASSERT_TRUE(exact.ok() && adaptive.ok()) << exact.message << adaptive.message;
  ASSERT_GE(exact.meshes[0].impacts, 10);
  EXPECT_EQ(adaptive.meshes[0].impacts, exact.meshes[0].impacts);
  EXPECT_EQ(adaptive.meshes[0].backside_impacts, exact.meshes[0].backside_impacts);
  EXPECT_LT(largest_difference(exact, adaptive), 1e-6);
  // The extremes of the adaptive run are read at its step ends, events, samples and each step's
  // midpoint: below the exact ones, and close (3.3e-5 here).
  EXPECT_LE(adaptive.meshes[0].max_force_n, exact.meshes[0].max_force_n * (1 + 1e-9));
  EXPECT_GT(adaptive.meshes[0].max_force_n, (1 - 1e-4) * exact.meshes[0].max_force_n);
  // Each located contact change, with the mesh's d' - e' there, is the exact engine's (31 of
  // them; 2e-10 s and 4e-6 of the velocity measured, the rattle's sensitivity).
  ASSERT_EQ(adaptive.contact_events.size(), exact.contact_events.size());
  for (std::size_t k = 0; k < exact.contact_events.size(); ++k) {
    const TrainContactEvent &e = exact.contact_events[k], &f = adaptive.contact_events[k];
    EXPECT_EQ(f.kind, e.kind) << k;
    EXPECT_NEAR(f.t_s, e.t_s, 1e-8) << k;
    EXPECT_NEAR(f.velocity_m_s, e.velocity_m_s, 1e-4 * std::abs(e.velocity_m_s)) << k;
  }
  EXPECT_NEAR(adaptive.meshes[0].max_impact_velocity_m_s, exact.meshes[0].max_impact_velocity_m_s,
              1e-4 * exact.meshes[0].max_impact_velocity_m_s);

  Case reducer = shipped_case("two_stage_reducer.toml", {{"solver.duration_s", "0.02"},
                                                         {"solver.output_interval_s", "1e-5"},
                                                         {"solver.tolerance", "1e-10"},
                                                         {"solver.method", "exact"}});
  const TrainRunResult contact_exact = run_train(reducer);
  set_case_value(reducer, {"solver.method", "dopri5"});
  const TrainRunResult contact_adaptive = run_train(reducer);
  ASSERT_TRUE(contact_exact.ok() && contact_adaptive.ok());
  EXPECT_LT(largest_difference(contact_exact, contact_adaptive), 1e-8);
}

// The paper's Newmark-beta on a train (newmark_flow.hpp): the reducer in permanent contact, both
// stages' stiffness and transmission error varying, against the exact engine at 1e-12. Its
// error falls four times when the step is halved (second order), its automatic step divides
// the system period, and a step that cannot resolve the train's fastest time scale is refused
// naming the key and where it came from.
TEST(TrainCase, NewmarkStepsATrainAtSecondOrder) {
  Case reducer = shipped_case("two_stage_reducer.toml", {{"solver.duration_s", "0.02"},
                                                         {"solver.output_interval_s", "1e-5"},
                                                         {"solver.tolerance", "1e-12"}});
  const TrainRunResult exact = run_train(reducer);
  ASSERT_TRUE(exact.ok()) << exact.message;
  set_case_value(reducer, {"solver.method", "newmark"});
  const TrainSolver automatic(reducer);
  const double period = automatic.assembled().system_period_s().value_or(0);
  ASSERT_GT(automatic.newmark_step_s(), 0);
  const double per_period = period / automatic.newmark_step_s();
  EXPECT_NEAR(per_period, std::round(per_period), 1e-6 * per_period);
  EXPECT_LE(automatic.newmark_step_s(), automatic.fastest_period_s() / kStepsPerFastestPeriod);
  std::vector<double> errors;
  for (const double step : {2e-6, 1e-6, 5e-7}) {
    set_case_value(reducer, {"solver.time_step_s", fmt::format("{}", step)});
    const TrainRunResult newmark = run_train(reducer);
    ASSERT_TRUE(newmark.ok()) << newmark.message;
    EXPECT_EQ(newmark.meshes[0].impacts, exact.meshes[0].impacts);
    errors.push_back(largest_difference(exact, newmark));
  }
  for (std::size_t i = 1; i < errors.size(); ++i) {
    EXPECT_GT(errors[i - 1] / errors[i], 3.9) << i;  // 3.99 and 4.00 measured
    EXPECT_LT(errors[i - 1] / errors[i], 4.1) << i;
  }
  EXPECT_LT(errors.back(), 2e-5);  // 1.0e-5 b at 0.5 us
  EXPECT_GT(errors.back(), 1e-9);  // a Newmark run, not the exact engine's
  set_case_value(reducer, {"solver.time_step_s", "1e-3", "--set solver.time_step_s=1e-3"});
  try {
    (void)run_train(reducer);
    ADD_FAILURE() << "a step of 1 ms was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("solver.time_step_s = 0.001"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("--set"), std::string::npos) << e.what();
  }
}

TEST(TrainCase, AnAdaptiveRunCanBeCancelledAndKeepsWhatItDid) {
  Case c =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "loose_gear_rattle.toml");
  set_case_value(c, {"solver.method", "dopri5"});
  TrainRunOptions o;
  o.progress = [](double fraction) { return fraction < 0.3; };
  const TrainRunResult r = run_train(c, o);
  EXPECT_EQ(r.termination, ode::Termination::kCancelled);
  ASSERT_FALSE(r.samples.t_s.empty());
  // Cancelled where the progress first reached 0.3 (a period's end: the run goes a period at a
  // time while it watches for the steady part), the samples kept up to there.
  EXPECT_GT(r.samples.t_s.back(), 0.29 * c.solver.duration_s);
  EXPECT_LT(r.samples.t_s.back(), 0.6 * c.solver.duration_s);
}

// A train of two gears "a" and "b", without its mesh, in two pieces: [model], [train] and
// body a (lines 1 to 9), then body b (five lines).
constexpr const char* kBodyA = R"([model]
form = "train"
[train]
reference_speed_hz = 50
[[train.body]]
name = "a"
teeth = 20
normal_module_mm = 2
face_width_mm = 10
)";
constexpr const char* kBodyB = R"([[train.body]]
name = "b"
teeth = 40
normal_module_mm = 2
face_width_mm = 10
)";
// A mesh of the two bodies above.
constexpr const char* kMeshAB = R"([[train.mesh]]
name = "m"
driving = "a"
driven = "b"
mean_stiffness_n_per_m = 2e8
)";

// A shaft damped as a ratio of its mode: a heavy rotor on a soft shaft to a gear pair and a light
// load, the drivetrain's first mode mostly in the shaft. mode_damping_ratio = 0.05 gives that
// mode's damped eigenvalue a ratio of 0.05 (to 2 %: the first-order estimate of a damping that
// is not proportional); the same 0.05 as damping_ratio, against the shaft's two bodies' reduced
// inertia (the rotor's and the small gear's), gives it under 0.005; the coefficient given is
// the coefficient taken; two of them given are refused.
TEST(TrainCase, AShaftDampsItsModeAsWritten) {
  // The test file's two gears a and b and their mesh (its own damping off), a rotor on a's
  // shaft, a load on b's.
  const auto with = [](const std::string& damping) {
    return parse_case(
        std::string(kBodyA) + kBodyB + kMeshAB + "damping_ratio = 0\n" + R"([[train.body]]
name = "rotor"
inertia_kg_m2 = 1e4
[[train.body]]
name = "load"
inertia_kg_m2 = 0.5
[[train.shaft]]
name = "out"
from = "b"
to = "load"
stiffness_n_m_per_rad = 1e6
damping_n_m_s_per_rad = 0
[[train.shaft]]
name = "main"
from = "rotor"
to = "a"
stiffness_n_m_per_rad = 1e3
)" + damping,
        "t.toml");
  };
  // The damped ratio of the mode the main shaft holds most of.
  const auto first_mode_ratio = [](const Case& c) {
    const train::Assembled a = assembled_train(c);
    const std::vector<train::TrainMode> modes = train::modes(a);
    const train::TrainMode* best = nullptr;
    for (const train::TrainMode& m : modes)
      if (m.frequency_hz > 0 && (!best || m.shaft_energy[1] > best->shaft_energy[1])) best = &m;
    EXPECT_TRUE(best && best->shaft_energy[1] > 0.9);
    double ratio = -1, miss = std::numeric_limits<double>::infinity();
    for (const std::array<double, 2>& e : train::damped_eigenvalues(a))
      if (std::abs(e[0] - best->frequency_hz) < miss) {
        miss = std::abs(e[0] - best->frequency_hz);
        ratio = e[1];
      }
    return ratio;
  };
  EXPECT_NEAR(first_mode_ratio(with("mode_damping_ratio = 0.05\n")) / 0.05, 1.0, 0.02);
  EXPECT_LT(first_mode_ratio(with("damping_ratio = 0.05\n")), 0.005);
  EXPECT_EQ(train_of(with("damping_n_m_s_per_rad = 123\n")).shafts[1].damping_n_m_s_per_rad, 123.0);
  EXPECT_NE(geardyn::testing::error_of(
                [&] { (void)train_of(with("damping_ratio = 0.05\nmode_damping_ratio = 0.05\n")); })
                .find("shaft 'main': give one of damping_ratio, mode_damping_ratio and "
                      "damping_n_m_s_per_rad"),
            std::string::npos);
}

// The message of reading `text`, or "" when it reads.
std::string error_of(const std::string& text) {
  try {
    (void)assembled_train(parse_case(text, "t.toml"));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The paper's pair as a train (validation.hpp) with both gears planar (dof 3) or spatial (dof
// 12) on bearings, against the coupled model with that dof of the same pair on the same
// bearings (whose y is along the line of action), each bearing with the radial clearance given
// (um; the train's acts in x and y, the coupled model's along its y: the same when the line of
// action is the train's y, with `position_angle_deg` the transverse pressure angle, and the
// centres' motion across it, which no force drives, stays 0): through every impact of a
// rattling start, the same d - e, impacts and forces, and the pinion's centre along the line of
// action is the coupled y1; with dof 12 its z is the coupled z1 and its tilt about the line of
// action the coupled ty1. The gears' masses and tilt inertias come from their blanks, the
// bearings' damping from its ratio, in both.
struct PairCases {
  Case coupled, train;
};
PairCases the_pair_both_ways(std::array<double, 2> clearance_um, bool along_y, int dof) {
  Case coupled = park2010_pair_case();
  coupled.model.form = ModelForm::kCoupled;
  coupled.model.dof = dof;
  coupled.bearings.radial_stiffness_n_per_m = {1.1e8, 2.3e8};
  coupled.bearings.axial_stiffness_n_per_m = {1.6e7, 0.9e7};
  coupled.bearings.tilt_stiffness_n_m_per_rad = {2.8e5, 4.1e5};
  coupled.bearings.damping_ratio = 0.03;
  coupled.bearings.radial_clearance_um = clearance_um;
  Case train = park2010_pair_as_train();
  const char* body_dof = dof == 12 ? "\"spatial\"" : dof == 6 ? "\"axial\"" : "\"planar\"";
  for (const char* body : {"0", "1"})
    set_case_value(train, {fmt::format("train.body[{}].dof", body), body_dof});
  const std::array<std::string, 2> out_of_plane = {
      dof == 12  ? ", axial_stiffness_n_per_m = 1.6e7, tilt_stiffness_n_m_per_rad = 2.8e5"
      : dof == 6 ? ", axial_stiffness_n_per_m = 1.6e7"
                 : "",
      dof == 12  ? ", axial_stiffness_n_per_m = 0.9e7, tilt_stiffness_n_m_per_rad = 4.1e5"
      : dof == 6 ? ", axial_stiffness_n_per_m = 0.9e7"
                 : ""};
  set_case_value(train,
                 {"train.bearing",
                  fmt::format("[{{body = \"pinion\", stiffness_n_per_m = 1.1e8, damping_ratio = "
                              "0.03, clearance_um = {}{}}}, {{body = \"wheel\", stiffness_n_per_m "
                              "= 2.3e8, damping_ratio = 0.03, clearance_um = {}{}}}]",
                              clearance_um[0], out_of_plane[0], clearance_um[1], out_of_plane[1])});
  const double alpha_t_deg =
      assembled_train(train).train().meshes[0].transverse_pressure_angle_rad * 180 /
      std::numbers::pi;
  set_case_value(train, {"train.mesh[0].position_angle_deg",
                         along_y ? fmt::format("{}", alpha_t_deg) : std::string("40")});
  return {coupled, train};
}

void expect_the_coupled_pair(std::array<double, 2> clearance_um, bool along_y, int dof = 3) {
  const auto [coupled, train] = the_pair_both_ways(clearance_um, along_y, dof);
  const bool spatial = dof >= 6, tilts = dof == 12;
  const CoupledRunResult one = run_coupled(coupled);
  ASSERT_TRUE(one.ok()) << one.message;
  ASSERT_GT(one.mesh.impacts, 3);
  const TrainRunResult x = run_train(train);
  ASSERT_TRUE(x.ok()) << x.message;
  EXPECT_EQ(
      x.coordinates,
      tilts     ? (std::vector<std::string>{"pinion_rad", "wheel_rad", "pinion_x_m", "pinion_y_m",
                                            "pinion_z_m", "pinion_tx_rad", "pinion_ty_rad", "wheel_x_m",
                                            "wheel_y_m", "wheel_z_m", "wheel_tx_rad", "wheel_ty_rad"})
      : spatial ? (std::vector<std::string>{"pinion_rad", "wheel_rad", "pinion_x_m", "pinion_y_m",
                                            "pinion_z_m", "wheel_x_m", "wheel_y_m", "wheel_z_m"})
                : (std::vector<std::string>{"pinion_rad", "wheel_rad", "pinion_x_m", "pinion_y_m",
                                            "wheel_x_m", "wheel_y_m"}));
  ASSERT_EQ(x.samples.t_s.size(), one.samples.t_s.size());
  const train::Assembled a = assembled_train(train);
  const Eigen::RowVectorXd v = a.mesh_vector(0);
  const double cb = std::cos(a.train().meshes[0].base_helix_angle_rad);
  const Eigen::Vector2d n(v(2) / cb, v(3) / cb);
  EXPECT_NEAR(n.norm(), 1.0, 1e-15);
  if (along_y) EXPECT_NEAR(n.y(), 1.0, 1e-15);
  const CoupledParameters p = coupled_parameters(coupled);
  double worst = 0, worst_centre = 0, scale_centre = 0;
  // With dof 12, each gear's z and its tilt about the line of action against the coupled ones.
  std::array<double, 2> worst_axial{}, scale_axial{}, worst_tilt{}, scale_tilt{};
  for (std::size_t i = 0; i < x.samples.t_s.size(); ++i) {
    worst =
        std::max(worst, std::abs(x.samples.deflection_bar[i][0] - one.samples.deflection_bar[i]));
    const double y1 = one.samples.state[i](p.line[0]);
    worst_centre = std::max(worst_centre, std::abs(n.dot(x.samples.state[i].segment(2, 2)) - y1));
    scale_centre = std::max(scale_centre, std::abs(y1));
    if (!spatial) continue;
    for (int g = 0; g < 2; ++g) {
      const int z = a.axial(g);
      const double z_coupled =
          one.samples.state[i](p.index(g == 0 ? Coordinate::kAxial1 : Coordinate::kAxial2));
      worst_axial[g] = std::max(worst_axial[g], std::abs(x.samples.state[i](z) - z_coupled));
      scale_axial[g] = std::max(scale_axial[g], std::abs(z_coupled));
      if (!tilts) continue;
      const double ty_coupled =
          one.samples.state[i](p.index(g == 0 ? Coordinate::kTilt1 : Coordinate::kTilt2));
      worst_tilt[g] = std::max(worst_tilt[g],
                               std::abs(n.dot(x.samples.state[i].segment(z + 1, 2)) - ty_coupled));
      scale_tilt[g] = std::max(scale_tilt[g], std::abs(ty_coupled));
    }
  }
  EXPECT_LT(worst, 1e-8);
  EXPECT_GT(scale_centre, 1e-7);  // the centre moves by a fraction of the backlash
  EXPECT_LT(worst_centre, 1e-7 * scale_centre);
  // Each spatial bearing's axial force, sample by sample and at its largest, is the coupled
  // bearing's, and its moment about the line of action k_t ty.
  for (int g = 0; spatial && g < 2; ++g) {
    const TrainBearingReading& b = x.bearings[static_cast<std::size_t>(g)];
    ASSERT_TRUE(b.spatial);
    EXPECT_EQ(b.tilts, tilts);
    EXPECT_EQ(b.part_count(), tilts ? 5 : 3);
    // The parts start where shaft 0 would (there is none), the axial force after x and y.
    const int part = a.bearing_observable(g) - a.shaft_observable(0) + 2;
    double worst_force = 0;
    for (std::size_t i = 0; i < x.samples.t_s.size(); ++i)
      worst_force = std::max(worst_force,
                             std::abs(x.samples.parts[i][part] - one.samples.axial_force_n[i][g]));
    EXPECT_LT(worst_force, 1e-6 * one.max_axial_force_n[g]) << g;
    EXPECT_NEAR(std::max(b.axial_force_n.max, -b.axial_force_n.min) / one.max_axial_force_n[g], 1.0,
                1e-6)
        << g;
    EXPECT_GT(one.max_axial_force_n[g], 10.0) << g;
  }
  for (int g = 0; spatial && g < 2; ++g) {
    EXPECT_GT(scale_axial[g], 1e-7) << g;  // the helix's thrust moves each gear along its axis
    EXPECT_LT(worst_axial[g], 1e-7 * scale_axial[g]) << g;
    if (!tilts) continue;
    EXPECT_GT(scale_tilt[g], 1e-7) << g;  // and its moment tilts it
    EXPECT_LT(worst_tilt[g], 1e-7 * scale_tilt[g]) << g;
  }
  const TrainMeshReading& m = x.meshes.at(0);
  EXPECT_EQ(m.impacts, one.mesh.impacts);
  EXPECT_EQ(m.backside_impacts, one.mesh.backside_impacts);
  EXPECT_NEAR(m.max_force_n / one.max_force_n, 1.0, 1e-8);
  // Each clearance's impacts, the line of action's (y) as the coupled bearing's; none across.
  for (std::size_t g = 0; g < 2; ++g) {
    if (clearance_um[g] == 0) continue;
    EXPECT_EQ(x.bearings[g].clearance_y.impacts, one.bearing[g].impacts) << g;
    EXPECT_EQ(x.bearings[g].clearance_x.impacts, 0) << g;
    EXPECT_NEAR(x.bearings[g].clearance_y.separated_fraction, one.bearing[g].separated_fraction,
                1e-6)
        << g;
  }
  if (clearance_um[0] > 0) EXPECT_GT(one.bearing[0].impacts, 2);
}

TEST(TrainCase, PlanarGearsOnBearingsRunAsTheCoupledPairWithThreeDegrees) {
  // A mutant that drops cos(beta_b) from the centres' entries of V, or damps a bearing against
  // the inertia, moves d - e by far more than the bound.
  expect_the_coupled_pair({0, 0}, false);
}

TEST(TrainCase, BearingClearancesAreTheCoupledPairsDeadZones) {
  expect_the_coupled_pair({0.3, 0.2}, true);
}

TEST(TrainCase, SpatialGearsOnBearingsRunAsTheCoupledPairWithTwelveDegrees) {
  // A mutant that flips the tilts' lever arm, drops sin(beta_b) from the axial entries of V, or
  // damps a tilt against the mass, moves z, the tilt or d - e by far more than the bounds.
  expect_the_coupled_pair({0, 0}, true, 12);
  expect_the_coupled_pair({0, 0}, false, 12);
  expect_the_coupled_pair({0.3, 0.2}, true, 12);
}

TEST(TrainCase, AxialGearsOnBearingsRunAsTheCoupledPairWithSixDegrees) {
  // dof = "axial": each gear keeps z beside x and y, its tilts held (the coupled pair's dof 6):
  // the same d - e, centres, z and axial bearing forces through every impact. A mutant that
  // drops the helix's axial entry sin(beta_b) of a body that does not tilt fails it.
  expect_the_coupled_pair({0, 0}, false, 6);
  expect_the_coupled_pair({0.3, 0.2}, true, 6);
}

// A train's modes x after its rigid rotation against the coupled model's: each frequency and
// damping ratio to 1e-9, the strain energy in the mesh and in both bearings to 1e-6.
void expect_the_coupled_modes(const ModeSet& one, const std::vector<train::TrainMode>& x) {
  ASSERT_EQ(x.size(), one.modes.size() + 1);
  for (std::size_t k = 0; k < one.modes.size(); ++k) {
    const Mode& m = one.modes[k];
    EXPECT_NEAR(x[k + 1].frequency_hz / m.frequency_hz, 1.0, 1e-9) << k;
    // The modal damping ratio of the same shape with the same contact damping.
    EXPECT_NEAR(x[k + 1].damping_ratio, m.damping_ratio, 1e-9) << k;
    const double bearings = m.line_energy[0] + m.line_energy[1] + m.axial_energy[0] +
                            m.axial_energy[1] + m.tilt_energy[0] + m.tilt_energy[1] +
                            m.cross_energy[0] + m.cross_energy[1];
    // Degenerate pairs (x and the rock about it, which no mesh touches) may mix their shares
    // within a pair; the sum over both bearings is a mode's own.
    EXPECT_NEAR(x[k + 1].bearing_energy[0] + x[k + 1].bearing_energy[1], bearings, 1e-6) << k;
    EXPECT_NEAR(x[k + 1].mesh_energy[0], m.mesh_energy, 1e-6) << k;
  }
}

TEST(TrainCase, SpatialGearsModesAreTheCoupledPairsWithTwelveDegrees) {
  // The train keeps the pair's rigid rotation (frequency 0) beside the coupled model's 11
  // coordinates: the other 11 frequencies are the coupled ones, and the axial and tilt bearings
  // hold strain energy in the modes that move them.
  for (const bool along_y : {true, false}) {
    const auto [coupled, train] = the_pair_both_ways({0, 0}, along_y, 12);
    const ModeSet one = modes(CoupledModel(coupled_parameters(coupled)));
    const std::vector<train::TrainMode> x = train::modes(assembled_train(train));
    ASSERT_EQ(one.modes.size(), 11U);
    ASSERT_EQ(x.size(), 12U);
    EXPECT_EQ(x[0].frequency_hz, 0.0);
    // The rigid rotation strains and damps nothing.
    EXPECT_EQ(x[0].mesh_energy[0], 0.0);
    EXPECT_EQ(x[0].bearing_energy[0] + x[0].bearing_energy[1], 0.0);
    EXPECT_EQ(x[0].damping_ratio, 0.0);
    expect_the_coupled_modes(one, x);
  }
}

TEST(TrainCase, TheCoupledFormsTrainHasTheCoupledPairsModesAndCoordinates) {
  // train_form_of writes the coupled pair's gears with dof 3 and 6 held to the line of action
  // ("line", "line_axial"), as the coupled model holds them, and with dof 12 spatial: its train
  // has the coupled model's coordinates and the rigid rotation (which the coupled u leaves
  // out), and its modes are the coupled ones to 1e-9 beside that rotation, the mesh's and the
  // bearings' strain energies to 1e-6. With "planar" bodies dof 3 would have two more modes
  // (each centre across the line on its bearing alone).
  for (const int dof : {3, 6, 12}) {
    SCOPED_TRACE(dof);
    const auto [coupled, unused] = the_pair_both_ways({0, 0}, true, dof);
    const CoupledParameters p = coupled_parameters(coupled);
    const train::Assembled a = assembled_train(train_form_of(coupled));
    EXPECT_EQ(a.size(), static_cast<int>(p.coordinates.size()) + 1);
    if (dof < 12) EXPECT_EQ(a.coordinate_names()[2], "pinion_line_m");
    const ModeSet one = modes(CoupledModel(p));
    const std::vector<train::TrainMode> x = train::modes(a);
    ASSERT_EQ(x.size(), one.modes.size() + 1);
    EXPECT_EQ(x[0].frequency_hz, 0.0);
    expect_the_coupled_modes(one, x);
    // The damped eigenvalues, the rigid rotation's left out: the coupled model's.
    const std::vector<std::array<double, 2>> damped = train::damped_eigenvalues(a);
    ASSERT_EQ(damped.size(), one.damped.size());
    for (std::size_t k = 0; k < damped.size(); ++k) {
      EXPECT_NEAR(damped[k][0] / one.damped[k][0], 1.0, 1e-9) << k;
      EXPECT_NEAR(damped[k][1], one.damped[k][1], 1e-9) << k;
    }
  }
}

TEST(TrainCase, TheOneDegreeFormsTrainsHaveTheContactModeAndTheRigidRotation) {
  // The paper's pair (the shipped case: energy-method stiffness, helical) and the
  // non-dimensional oscillator, as their trains (`geardyn modes` of a one-degree case): the
  // rigid rotation at 0 and one mode in contact at the one-degree model's natural frequency
  // sqrt(cos^2 beta_b k_m / m_eq) (1 rad per tau in the non-dimensional form, whose train turns
  // a second into a tau), its damping ratio the mesh's, all its strain energy in the mesh.
  Case nd;
  nd.model.form = ModelForm::kNondimensional;
  nd.model.zeta = 0.07;
  nd.model.stiffness_harmonics = {{0.2, 10.0}};
  const Case paper =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "park2010.toml");
  for (const Case& c : {paper, nd}) {
    SCOPED_TRACE(to_string(c.model.form));
    const GearPairModel one = build_model(c);
    const std::vector<train::TrainMode> m = train::modes(assembled_train(c));
    ASSERT_EQ(m.size(), 2U);
    EXPECT_EQ(m[0].frequency_hz, 0.0);
    EXPECT_EQ(m[0].mesh_energy.at(0), 0.0);
    const double w = one.parameters().natural_angular_frequency_rad_s();
    EXPECT_NEAR(m[1].frequency_hz / (w / (2 * std::numbers::pi)), 1.0, 1e-12);
    EXPECT_NEAR(m[1].damping_ratio,
                c.model.form == ModelForm::kNondimensional ? nd.model.zeta : c.mesh.damping_ratio,
                1e-12);
    EXPECT_NEAR(m[1].mesh_energy.at(0), 1.0, 1e-12);
  }
  EXPECT_NEAR(build_model(nd).parameters().natural_angular_frequency_rad_s(), 1.0, 1e-15);
}

TEST(TrainCase, AMeshTakesItsStiffnessFromItsGearsByTheEnergyMethod) {
  // The shipped paper's pair (energy method, helical, shifted, its centre distance given, its
  // curve scaled to k_m) written as a train whose mesh has stiffness_source = "energy": the
  // mesh's k_m and harmonics are the one-degree model's curve to 1e-12, so the train runs as
  // the pair's train form; without k_m, the curve's own mean, as the pair's with k_m = 0.
  // Without center_distance_mm the mesh takes the one its shifts imply (the geometry's
  // shift_center_distance_m), and without outside_diameter_mm d + 2 m_n (1 + x).
  Case pair = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "park2010.toml");
  const GearData& g = pair.gear;
  // The train's text: each gear's lines (and `extra`), then the mesh's lines.
  const auto text = [&](const std::array<std::string, 2>& extra, const std::string& mesh) {
    std::string out = "[model]\nform = \"train\"\n[train]\nreference_speed_hz = 1000\n";
    for (std::size_t i = 0; i < 2; ++i)
      out += fmt::format(
          "[[train.body]]\nname = \"{}\"\nteeth = {}\nnormal_module_mm = {}\n"
          "normal_pressure_angle_deg = {}\nhelix_angle_deg = {}\nface_width_mm = {}\n{}",
          i == 0 ? "pinion" : "wheel", g.teeth[i], g.normal_module_mm, g.normal_pressure_angle_deg,
          g.helix_angle_deg, g.face_width_mm, extra[i]);
    return out +
           "[[train.mesh]]\ndriving = \"pinion\"\ndriven = \"wheel\"\n"
           "stiffness_source = \"energy\"\n" +
           mesh;
  };
  const std::string shipped_gear = fmt::format("profile_shift = {}\noutside_diameter_mm = {}\n",
                                               g.profile_shift[0], g.outside_diameter_mm[0]);
  const std::array<std::string, 2> shipped{shipped_gear, shipped_gear};
  const auto curve = [](const train::Assembled& a) {
    const train::Mesh& m = a.train().meshes.at(0);
    std::vector<double> v{m.mean_stiffness_n_per_m};
    for (const train::MeshHarmonic& h : m.stiffness) {
      v.push_back(h.value * std::cos(h.phase_rad));
      v.push_back(h.value * std::sin(h.phase_rad));
    }
    return v;
  };
  const auto expect_same = [](const std::vector<double>& x, const std::vector<double>& y) {
    ASSERT_EQ(x.size(), y.size());
    EXPECT_NEAR(x[0] / y[0], 1.0, 1e-12);
    for (std::size_t i = 1; i < x.size(); ++i) EXPECT_NEAR(x[i], y[i], 1e-12) << i;
  };
  const std::vector<double> pair_curve = curve(assembled_train(pair));
  ASSERT_EQ(pair_curve.size(), 1 + 2 * 2U);  // k_m and two harmonics
  EXPECT_GT(pair_curve[1] * pair_curve[1] + pair_curve[2] * pair_curve[2], 1e-4);
  const std::string at_150 = fmt::format("center_distance_mm = {}\n", g.center_distance_mm);
  expect_same(curve(assembled_train(
                  parse_case(text(shipped, at_150 + fmt::format("mean_stiffness_n_per_m = {}\n",
                                                                pair.mesh.mean_stiffness_n_per_m)),
                             "t.toml"))),
              pair_curve);
  Case own = pair;
  own.mesh.mean_stiffness_n_per_m = 0;
  const std::vector<double> own_curve = curve(assembled_train(own));
  EXPECT_GT(std::abs(own_curve[0] / pair_curve[0] - 1), 0.1);  // the shipped case scales it
  expect_same(curve(assembled_train(parse_case(text(shipped, at_150), "t.toml"))), own_curve);
  // Other shifts, the tips from them and the centre distance they imply.
  Case shifted = own;
  shifted.gear.profile_shift = {0.5, 0.1};
  const double beta = g.helix_angle_deg * kPi / 180;
  for (std::size_t i = 0; i < 2; ++i)
    shifted.gear.outside_diameter_mm[i] =
        g.teeth[i] * g.normal_module_mm / std::cos(beta) +
        2 * g.normal_module_mm * (1 + shifted.gear.profile_shift[i]);
  shifted.gear.center_distance_mm = compute_geometry(shifted.gear).shift_center_distance_m * 1e3;
  EXPECT_GT(std::abs(shifted.gear.center_distance_mm - 150), 0.4);
  // Tips not given: the standard basic rack's with the tip shortening that centre distance
  // leaves (ISO 21771).
  const Geometry standard = compute_geometry(shifted.gear);
  for (std::size_t i = 0; i < 2; ++i)
    shifted.gear.outside_diameter_mm[i] = standard.expected_outside_diameter_m[i] * 1e3;
  EXPECT_LT(shifted.gear.outside_diameter_mm[0],
            g.teeth[0] * g.normal_module_mm / std::cos(beta) + 2 * g.normal_module_mm * 1.5 - 0.01);
  expect_same(curve(assembled_train(parse_case(
                  text({"profile_shift = 0.5\n", "profile_shift = 0.1\n"}, ""), "t.toml"))),
              curve(assembled_train(shifted)));
  // What it cannot take is said, naming the mesh, where it was written and the train's keys.
  const std::string internal = error_of(text({"", "inertia_kg_m2 = 1\n"}, "kind = \"internal\"\n"));
  EXPECT_NE(internal.find("t.toml:"), std::string::npos) << internal;
  EXPECT_NE(internal.find("mesh 'mesh1': stiffness_source = \"energy\": the gears' teeth = [56, "
                          "56]: an internal pair needs a ring of more teeth than its pinion"),
            std::string::npos)
      << internal;
  const std::string near = error_of(text(shipped, "center_distance_mm = 100\n"));
  EXPECT_NE(near.find("mesh 'mesh1': stiffness_source = \"energy\": center_distance_mm = 100: "
                      "must exceed the sum of the base radii"),
            std::string::npos)
      << near;
  // Flanks no energy mesh reads, and a mesh's keys its source does not read, are reported.
  const std::vector<std::string> unused =
      unused_settings(parse_case(std::string(kBodyA) + "profile_shift = 0.3\n" + kBodyB + kMeshAB +
                                     "harmonics_kept = 4\ncenter_distance_mm = 61\n",
                                 "t.toml"));
  ASSERT_EQ(unused.size(), 3U) << fmt::format("{}", fmt::join(unused, "\n"));
  EXPECT_EQ(unused[0].find("train.body[0].profile_shift = 0.3 (t.toml:10:17): not used: no mesh of "
                           "body 'a' takes its stiffness from the gears"),
            0U)
      << unused[0];
  EXPECT_EQ(unused[1].find("train.mesh[0].harmonics_kept = 4"), 0U) << unused[1];
  EXPECT_EQ(unused[2].find("train.mesh[0].center_distance_mm = 61"), 0U) << unused[2];
  EXPECT_TRUE(unused_settings(parse_case(text(shipped, at_150), "t.toml")).empty());
  // What the pair's geometry says and goes on from is said, in the train's keys.
  const std::vector<std::string> apart =
      unused_settings(parse_case(text(shipped, "center_distance_mm = 151\n"), "t.toml"));
  // (The shipped tips are those of the tip shortening at 150 mm.)
  ASSERT_EQ(apart.size(), 3U);
  EXPECT_EQ(apart[0].find("train.mesh[0] ('mesh1', t.toml:"), 0U) << apart[0];
  EXPECT_NE(apart[0].find("center_distance_mm = 151 disagrees with the 149.9998 mm that the "
                          "profile shifts x1 + x2 = 0.415 imply"),
            std::string::npos)
      << apart[0];
  EXPECT_NE(apart[0].find("the backlash is backlash_um as given"), std::string::npos) << apart[0];
  EXPECT_NE(apart[1].find("the outside_diameter_mm of 'pinion' = 154.98 disagrees"),
            std::string::npos)
      << apart[1];
  EXPECT_NE(apart[2].find("the outside_diameter_mm of 'wheel' = 154.98 disagrees"),
            std::string::npos)
      << apart[2];
  const std::vector<std::string> harmonics =
      unused_settings(parse_case(text(shipped, "stiffness_harmonics = [[0.1, 0]]\n"), "t.toml"));
  ASSERT_EQ(harmonics.size(), 1U);
  EXPECT_NE(harmonics[0].find("train.mesh[0].stiffness_harmonics"), std::string::npos);
  // Each key is said where it was written: a --set of the source moves not the harmonics'.
  const std::vector<std::string> moved = unused_settings(
      parse_case(std::string(kBodyA) + kBodyB + kMeshAB + "stiffness_harmonics = [[0.1, 0]]\n",
                 "t.toml", {parse_override("train.mesh[0].stiffness_source = \"energy\"")}));
  ASSERT_EQ(moved.size(), 1U) << fmt::format("{}", fmt::join(moved, "\n"));
  EXPECT_EQ(moved[0].find("train.mesh[0].stiffness_harmonics (t.toml:"), 0U) << moved[0];
  const std::string given =
      error_of(std::string(kBodyA) + kBodyB + "[[train.mesh]]\ndriving = \"a\"\ndriven = \"b\"\n");
  EXPECT_NE(given.find("mesh 'mesh1': train.mesh[0] has no mean_stiffness_n_per_m: it must be "
                       "given with stiffness_source = \"harmonics\""),
            std::string::npos)
      << given;
}

TEST(TrainCase, AMeshTakesIso6336sStiffnessAtItsStaticLoad) {
  // The shipped paper's pair written as a train, its pinion driven by the case's torque and its
  // wheel loaded to balance it: the mesh's static force puts the pair's torque back on the
  // pinion, so its k_m is the gear pair's own "iso6336" k_m; under this light load (below ISO's
  // 100 N/mm) doubling the torque raises it by 2^0.25. Its harmonics are the ones given.
  Case pair = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "park2010.toml");
  const GearData& g = pair.gear;
  const auto text = [&](double torque_nm, const std::string& mesh) {
    std::string out = "[model]\nform = \"train\"\n[train]\nreference_speed_hz = 1000\n";
    for (std::size_t i = 0; i < 2; ++i)
      out += fmt::format(
          "[[train.body]]\nname = \"{}\"\nteeth = {}\nnormal_module_mm = {}\n"
          "normal_pressure_angle_deg = {}\nhelix_angle_deg = {}\nface_width_mm = {}\n"
          "profile_shift = {}\noutside_diameter_mm = {}\n",
          i == 0 ? "pinion" : "wheel", g.teeth[i], g.normal_module_mm, g.normal_pressure_angle_deg,
          g.helix_angle_deg, g.face_width_mm, g.profile_shift[i], g.outside_diameter_mm[i]);
    return out +
           fmt::format(
               "[[train.torque]]\nbody = \"pinion\"\nmean_nm = {}\n[[train.torque]]\nbody = "
               "\"wheel\"\nmean_nm = {}\n",
               torque_nm, -torque_nm * g.teeth[1] / g.teeth[0]) +
           fmt::format(
               "[[train.mesh]]\nname = \"m\"\ndriving = \"pinion\"\ndriven = \"wheel\"\n"
               "stiffness_source = \"iso6336\"\ncenter_distance_mm = {}\n",
               g.center_distance_mm) +
           mesh;
  };
  pair.mesh.stiffness_source = StiffnessSource::kIso6336;
  pair.mesh.stiffness_harmonics = {{0.2, 40.0}};
  const double k_pair = mesh_stiffness(pair, case_geometry(pair)).fourier.mean_n_per_m;
  const Case train_case =
      parse_case(text(pair.load.torque_nm, "stiffness_harmonics = [[0.2, 40]]\n"), "t.toml");
  const train::Train t = train_of(train_case);
  EXPECT_NEAR(t.meshes[0].mean_stiffness_n_per_m / k_pair, 1.0, 1e-10);
  ASSERT_EQ(t.meshes[0].stiffness.size(), 1U);
  EXPECT_EQ(t.meshes[0].stiffness[0].value, 0.2);
  const double k_double = train_of(parse_case(text(2 * pair.load.torque_nm, ""), "t.toml"))
                              .meshes[0]
                              .mean_stiffness_n_per_m;
  EXPECT_NEAR(k_double / t.meshes[0].mean_stiffness_n_per_m, std::pow(2.0, 0.25), 1e-10);
  // The damping keeps its ratio at the stiffness found: c = 2 zeta sqrt(m_n k_m).
  const train::Train harmonics = train_of(parse_case(
      text(pair.load.torque_nm, "")
              .replace(text(pair.load.torque_nm, "").find("iso6336"), 7, "harmonics") +
          fmt::format("mean_stiffness_n_per_m = {:.17g}\n", t.meshes[0].mean_stiffness_n_per_m),
      "t.toml"));
  EXPECT_NEAR(t.meshes[0].damping_n_s_per_m / harmonics.meshes[0].damping_n_s_per_m, 1.0, 1e-12);
  // No load on the mesh, no ISO stiffness; a k_m given is not read.
  const std::string unloaded = error_of(text(0, ""));
  EXPECT_NE(unloaded.find("mesh 'm': stiffness_source = \"iso6336\": the mesh carries 0 N at the "
                          "train's static state"),
            std::string::npos)
      << unloaded;
  const std::vector<std::string> unused = unused_settings(
      parse_case(text(pair.load.torque_nm, "mean_stiffness_n_per_m = 3e8\n"), "t.toml"));
  ASSERT_EQ(unused.size(), 1U) << fmt::format("{}", fmt::join(unused, "\n"));
  EXPECT_EQ(unused[0].find("train.mesh[0].mean_stiffness_n_per_m = 300000000 (t.toml:"), 0U)
      << unused[0];
}

TEST(TrainCase, IsoMeshesSettleWhereTheirLoadsDependOnTheirStiffnesses) {
  // A split drive: a pinion meshes with two wheels that join the output through shafts of
  // unequal stiffness, so the two meshes share the pinion's torque by their compliances, and
  // ISO's k_m of each (under 100 N/mm, its load factor) by its share. At the train found, each
  // mesh's k_m is ISO's at the load the train's static state puts on it, to 1e-10: a fixed
  // point, which one pass from the full-load stiffnesses does not reach.
  std::string text =
      "[model]\nform = \"train\"\n[train]\nreference_speed_hz = 20\n"
      "[[train.body]]\nname = \"input\"\nteeth = 20\nnormal_module_mm = 2\nface_width_mm = 20\n";
  for (const char* w : {"w1", "w2"})
    text += fmt::format(
        "[[train.body]]\nname = \"{}\"\nteeth = 40\nnormal_module_mm = 2\nface_width_mm = 20\n"
        "[[train.mesh]]\ndriving = \"input\"\ndriven = \"{}\"\nstiffness_source = \"iso6336\"\n",
        w, w);
  text +=
      "[[train.body]]\nname = \"output\"\ninertia_kg_m2 = 0.1\n"
      "[[train.shaft]]\nfrom = \"w1\"\nto = \"output\"\nstiffness_n_m_per_rad = 2e4\n"
      "[[train.shaft]]\nfrom = \"w2\"\nto = \"output\"\nstiffness_n_m_per_rad = 8e4\n"
      "[[train.torque]]\nbody = \"input\"\nmean_nm = 50\n"
      "[[train.torque]]\nbody = \"output\"\nmean_nm = -100\n";
  const Case c = parse_case(text, "t.toml");
  const train::Assembled a = assembled_train(c);
  const std::optional<Eigen::VectorXd> y = static_state(a);
  ASSERT_TRUE(y);
  const std::vector<double> force = static_mesh_forces_n(a, *y);
  const TrainCase& t = *c.train;
  double full_load = 0;
  for (std::size_t i = 0; i < 2; ++i) {
    const train::Mesh& x = a.train().meshes[i];
    const double torque = force[i] * std::cos(x.base_helix_angle_rad) * x.base_radius_driving_m;
    const PairMeshStiffness iso =
        iso_mesh_stiffness(t.meshes[i], t.bodies[0], t.bodies[i + 1], torque);
    EXPECT_NEAR(x.mean_stiffness_n_per_m / iso.mean_n_per_m, 1.0, 1e-10) << i;
    full_load = iso_mesh_stiffness(t.meshes[i], t.bodies[0], t.bodies[i + 1]).mean_n_per_m;
  }
  // The stiffer path carries more, and its mesh is the stiffer; both below full load.
  EXPECT_GT(force[1], 1.1 * force[0]);
  EXPECT_GT(a.train().meshes[1].mean_stiffness_n_per_m, a.train().meshes[0].mean_stiffness_n_per_m);
  EXPECT_LT(a.train().meshes[1].mean_stiffness_n_per_m, full_load);
  // The torques balance through the two meshes: F cos(beta_b) r_b sums to the pinion's.
  double carried = 0;
  for (std::size_t i = 0; i < 2; ++i) {
    const train::Mesh& x = a.train().meshes[i];
    carried += force[i] * std::cos(x.base_helix_angle_rad) * x.base_radius_driving_m;
  }
  EXPECT_NEAR(carried, 50, 1e-9);
}

TEST(TrainCase, AMeshReadsItsStiffnessAndItsTransmissionErrorFromTables) {
  // Tables of eight rows over a mesh cycle, resampled linearly to 256 positions (32 per row):
  // the samples' mean is the rows' mean exactly, and the first harmonic of a sampled cosine
  // keeps its phase (the linear kernel is even) with its amplitude times
  // (sin(pi / 8) / (32 sin(pi / 256)))^2, the kernel's transfer at that harmonic.
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / fmt::format("geardyn_tables_{}", ::getpid());
  std::filesystem::create_directories(dir);
  const std::array<double, 8> k = {3.0e8, 3.1e8, 2.9e8, 2.2e8, 2.0e8, 2.1e8, 2.3e8, 2.8e8};
  {
    std::ofstream ks(dir / "k.csv");
    ks << "position,stiffness_n_per_m\n";
    for (std::size_t j = 0; j < k.size(); ++j) ks << fmt::format("{},{}\n", j / 8.0, k[j]);
    std::ofstream es(dir / "e.csv");
    es << "position,transmission_error_um\n";
    for (int j = 0; j < 8; ++j)
      es << fmt::format("{},{:.17g}\n", j / 8.0, 2.0 + 1.5 * std::cos(kPi * j / 4 + 0.3));
    std::ofstream bad(dir / "bad.csv");
    bad << "position,stiffness_n_per_m\n0,1e8\n0.5,-1\n";
  }
  const auto write = [&](const std::string& mesh) {
    std::ofstream(dir / "t.toml") << std::string(kBodyA) + kBodyB + R"([[train.mesh]]
name = "m"
driving = "a"
driven = "b"
)" + mesh;
    return load_case(dir / "t.toml");
  };
  const Case tables = write(
      "stiffness_source = \"table\"\nstiffness_table = \"k.csv\"\n"
      "transmission_error_table = \"e.csv\"\ntransmission_error_kept = 3\n");
  const train::Assembled a = assembled_train(tables);
  const train::Mesh& m = a.train().meshes.at(0);
  double mean = 0;
  for (double v : k) mean += v / 8;
  EXPECT_NEAR(m.mean_stiffness_n_per_m / mean, 1.0, 1e-12);
  ASSERT_EQ(m.stiffness.size(), 2U);  // harmonics_kept's default
  EXPECT_NEAR(m.transmission_error_mean_m, 2e-6, 1e-17);
  ASSERT_EQ(m.transmission_error.size(), 3U);
  const double gain = std::pow(std::sin(kPi / 8) / (32 * std::sin(kPi / 256)), 2);
  EXPECT_NEAR(m.transmission_error[0].value, 1.5e-6 * gain, 1e-17);
  EXPECT_NEAR(m.transmission_error[0].phase_rad, 0.3, 1e-12);
  EXPECT_LT(m.transmission_error[1].value, 1e-17);  // a sampled cosine has no second harmonic
  // The constant part moves where the teeth touch: the contact state at rest reads it.
  EXPECT_NEAR(a.error_series(0).offset, 2e-6, 1e-17);
  // The gear pair's reading of the same tables: the train's to 1e-12, and the pair's train form
  // keeps the transmission error's mean.
  Case pair = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "park2010.toml");
  pair.mesh.stiffness_source = StiffnessSource::kTable;
  pair.mesh.stiffness_table = (dir / "k.csv").string();
  pair.mesh.mean_stiffness_n_per_m = 0;
  pair.mesh.transmission_error_um.clear();
  pair.mesh.transmission_error_table = (dir / "e.csv").string();
  pair.mesh.transmission_error_kept = 3;
  const MeshStiffness pk = mesh_stiffness(pair, case_geometry(pair));
  EXPECT_NEAR(pk.fourier.mean_n_per_m / m.mean_stiffness_n_per_m, 1.0, 1e-12);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_NEAR(pk.fourier.harmonics[i].ratio, m.stiffness[i].value, 1e-12);
    EXPECT_NEAR(pk.fourier.harmonics[i].phase_deg * kPi / 180, m.stiffness[i].phase_rad, 1e-12);
  }
  const train::Assembled pair_train = assembled_train(pair);
  EXPECT_NEAR(pair_train.error_series(0).offset, 2e-6, 1e-17);
  EXPECT_NEAR(pair_train.train().meshes[0].transmission_error[0].value, 1.5e-6 * gain, 1e-17);
  // k_m given scales the table's curve.
  const Case scaled = write(
      "stiffness_source = \"table\"\nstiffness_table = \"k.csv\"\nmean_stiffness_n_per_m = 1e8\n");
  EXPECT_NEAR(train_of(scaled).meshes[0].mean_stiffness_n_per_m, 1e8, 1e-4);
  EXPECT_NEAR(train_of(scaled).meshes[0].stiffness[0].value, m.stiffness[0].value, 1e-12);
  // What cannot be read is said, with the key's own line.
  const auto refusal = [&](const std::string& mesh) -> std::string {
    try {
      (void)assembled_train(write(mesh));
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  const std::string missing = refusal("stiffness_source = \"table\"\n");
  EXPECT_NE(missing.find("mesh 'm': train.mesh[0] has no stiffness_table: it must be given with "
                         "stiffness_source = \"table\""),
            std::string::npos)
      << missing;
  const std::string negative =
      refusal("stiffness_source = \"table\"\nstiffness_table = \"bad.csv\"\n");
  EXPECT_NE(negative.find("t.toml:20:19: train: mesh 'm': stiffness_table = \"bad.csv\": "),
            std::string::npos)
      << negative;
  EXPECT_NE(negative.find("bad.csv:3: '0.5,-1': must be"), std::string::npos) << negative;
  const std::string number = refusal("stiffness_source = \"table\"\nstiffness_table = 5\n");
  EXPECT_NE(number.find("train.mesh[0].stiffness_table = 5: must be a file's path in quotes"),
            std::string::npos)
      << number;
  const std::string both = refusal(
      "mean_stiffness_n_per_m = 2e8\ntransmission_error_um = [[1, 0]]\n"
      "transmission_error_table = \"e.csv\"\n");
  EXPECT_NE(both.find("mesh 'm': transmission_error_table = \"e.csv\": the transmission error is "
                      "a table or harmonics"),
            std::string::npos)
      << both;
  // What the mesh's sources do not read is reported.
  const std::vector<std::string> unused =
      unused_settings(write("mean_stiffness_n_per_m = 2e8\nstiffness_table = \"k.csv\"\n"
                            "transmission_error_kept = 2\n"));
  ASSERT_EQ(unused.size(), 2U) << fmt::format("{}", fmt::join(unused, "\n"));
  EXPECT_EQ(unused[0].find("train.mesh[0].stiffness_table = \"k.csv\" ("), 0U) << unused[0];
  EXPECT_NE(unused[0].find("t.toml:20:"), std::string::npos) << unused[0];
  EXPECT_EQ(unused[1].find("train.mesh[0].transmission_error_kept = 2"), 0U) << unused[1];
  // The constant part is in the mean static state: with the wheel loaded by the balancing
  // torque, the same force (the torques set it) at a deflection moved by it.
  const auto held = [&](const std::string& mean) {
    return assembled_train(write("mean_stiffness_n_per_m = 2e8\n" + mean + R"([[train.torque]]
body = "a"
mean_nm = 50
[[train.torque]]
body = "b"
mean_nm = -100
)"));
  };
  const train::Assembled plain = held(""), offset = held("transmission_error_mean_um = 2\n");
  const std::optional<Eigen::VectorXd> y0 = static_state(plain), y1 = static_state(offset);
  ASSERT_TRUE(y0 && y1);
  const double f0 = static_mesh_forces_n(plain, *y0).at(0);
  EXPECT_GT(f0, 1000);
  EXPECT_NEAR(static_mesh_forces_n(offset, *y1).at(0) / f0, 1.0, 1e-12);
  EXPECT_NEAR(offset.mesh_vector(0).dot(y1->head(offset.size())) -
                  plain.mesh_vector(0).dot(y0->head(plain.size())),
              2e-6, 1e-15);
  std::filesystem::remove_all(dir);
}

// kBodyB and a mesh "m" in which a drives b, with one more line of the mesh's: line 15 of a
// file that kBodyA and one line of body a's head.
std::string body_b_and_mesh(const std::string& mesh_line) {
  return std::string(kBodyB) + R"([[train.mesh]]
name = "m"
driving = "a"
driven = "b"
mean_stiffness_n_per_m = 2e8
)" + mesh_line +
         "\n";
}

TEST(TrainCase, APlanarBodysKeysAreCheckedAndALayoutNothingReadsIsReported) {
  const std::string head = kBodyA;
  const std::string tail = body_b_and_mesh("position_angle_deg = 30");
  // A word the key does not take, named with its place and the words it does.
  const std::string wrong = error_of(head + "dof = \"rigid\"\n" + tail);
  EXPECT_NE(wrong.find("t.toml:10:"), std::string::npos) << wrong;
  EXPECT_NE(wrong.find("train.body[0].dof = \"rigid\": must be \"torsion\", \"planar\", "
                       "\"axial\", \"spatial\", \"line\" or \"line_axial\""),
            std::string::npos)
      << wrong;
  // A mass on a body that keeps torsion only is read by nothing: refused.
  const std::string mass = error_of(head + "mass_kg = 2\n" + tail);
  EXPECT_NE(mass.find("body 'a': mass_kg = 2 is read only for a planar body"), std::string::npos)
      << mass;
  // A layout read by nothing (neither gear planar) is reported where it was written.
  const Case torsional = parse_case(head + tail, "t.toml");
  const std::vector<std::string> unused = unused_settings(torsional);
  ASSERT_EQ(unused.size(), 1U);
  EXPECT_NE(unused[0].find("train.mesh[0].position_angle_deg = 30 (t.toml:20:"), std::string::npos)
      << unused[0];
  EXPECT_NE(unused[0].find("neither gear of mesh 'm' is planar or eccentric"), std::string::npos);
  // Read for the mesh phase from the layout.
  Case phased = torsional;
  set_case_value(phased, {"train.mesh_phase", "\"layout\""});
  EXPECT_TRUE(unused_settings(phased).empty());
  // Planar, it is read; without a bearing the body is refused, with one it assembles, its mass
  // from the blank (rho pi w d^2 / 4).
  const std::string planar = head + "dof = \"planar\"\n" + tail;
  EXPECT_TRUE(unused_settings(parse_case(planar, "t.toml")).empty());
  EXPECT_NE(error_of(planar).find("body 'a': is planar (dof = \"planar\") but no bearing"),
            std::string::npos)
      << error_of(planar);
  const std::string bearing = "[[train.bearing]]\nbody = \"a\"\nstiffness_n_per_m = 1e8\n";
  ASSERT_EQ(error_of(planar + bearing), "");
  const train::Assembled a = assembled_train(parse_case(planar + bearing, "t.toml"));
  EXPECT_NEAR(a.train().bodies[0].mass_kg / (7850 * kPi * 0.01 * 0.04 * 0.04 / 4), 1.0, 1e-12);
  EXPECT_NE(
      error_of(head + tail + bearing).find("bearing 'bearing1': body = \"a\" keeps torsion only"),
      std::string::npos);
}

TEST(TrainCase, ASpatialBodysKeysAreCheckedAndAThrustNothingReadsIsReported) {
  const std::string head = kBodyA;
  const std::string tail = body_b_and_mesh("thrust = \"-z\"");
  const std::string bearing = "[[train.bearing]]\nbody = \"a\"\nstiffness_n_per_m = 1e8\n";
  const std::string held =
      bearing + "axial_stiffness_n_per_m = 2e7\ntilt_stiffness_n_m_per_rad = 3e5\n";
  // A tilt inertia on a planar body and an axial stiffness under one are read by nothing:
  // refused, naming the key as written.
  const std::string planar = head + "dof = \"planar\"\n" + tail;
  const std::string tilt =
      error_of(head + "dof = \"planar\"\ntilt_inertia_kg_m2 = 0.1\n" + tail + bearing);
  EXPECT_NE(tilt.find("body 'a': tilt_inertia_kg_m2 = 0.1 is read only for a spatial body"),
            std::string::npos)
      << tilt;
  const std::string axial = error_of(planar + held);
  EXPECT_NE(axial.find("bearing 'bearing1': axial_stiffness_n_per_m = 20000000 is read only for a "
                       "body that moves along its axis (dof = \"axial\" or \"spatial\"); body "
                       "'a' is planar"),
            std::string::npos)
      << axial;
  // A body that moves along its axis without tilting takes an axial stiffness, not a tilt one.
  const std::string slides = head + "dof = \"axial\"\n" + tail;
  ASSERT_EQ(error_of(slides + bearing + "axial_stiffness_n_per_m = 2e7\n"), "");
  const std::string no_tilt = error_of(slides + held);
  EXPECT_NE(no_tilt.find("bearing 'bearing1': tilt_stiffness_n_m_per_rad = 300000 is read only "
                         "for a body that tilts (dof = \"spatial\"); body 'a' is axial"),
            std::string::npos)
      << no_tilt;
  EXPECT_NE(error_of(slides + bearing)
                .find("body 'a': is axial (dof = \"axial\") but its "
                      "bearings' axial stiffness is 0"),
            std::string::npos)
      << error_of(slides + bearing);
  // A spatial body whose bearings do not hold it along its axis is refused.
  const std::string spatial = head + "dof = \"spatial\"\n" + tail;
  const std::string free = error_of(spatial + bearing);
  EXPECT_NE(free.find("body 'a': is spatial (dof = \"spatial\") but its bearings' axial stiffness "
                      "is 0"),
            std::string::npos)
      << free;
  // Held, it assembles: its z and tilts after x and y, its tilt inertia the blank's
  // m (3 r^2 + w^2) / 12 (a solid cylinder of the reference diameter).
  ASSERT_EQ(error_of(spatial + held), "");
  const Case c = parse_case(spatial + held, "t.toml");
  const train::Assembled a = assembled_train(c);
  EXPECT_EQ(a.coordinate_names(), (std::vector<std::string>{"a_rad", "b_rad", "a_x_m", "a_y_m",
                                                            "a_z_m", "a_tx_rad", "a_ty_rad"}));
  EXPECT_EQ(a.axial(0), 4);
  EXPECT_EQ(a.axial(1), -1);
  const double m = a.train().bodies[0].mass_kg, r = 0.02, w = 0.01;
  EXPECT_NEAR(a.train().bodies[0].tilt_inertia_kg_m2 / (m * (3 * r * r + w * w) / 12), 1.0, 1e-12);
  EXPECT_EQ(a.mass()(5, 5), a.train().bodies[0].tilt_inertia_kg_m2);
  // The spur mesh's thrust moves nothing (sin(beta_b) = 0): reported where it was written.
  const std::vector<std::string> unused = unused_settings(c);
  ASSERT_EQ(unused.size(), 1U);
  EXPECT_NE(unused[0].find("train.mesh[0].thrust = \"-z\" (t.toml:"), std::string::npos)
      << unused[0];
  EXPECT_NE(unused[0].find("no gear of mesh 'm' is both spatial and helical"), std::string::npos);
  EXPECT_EQ(a.mesh_vector(0).segment(4, 3).norm(), 0.0);
  // Helical, the thrust moves the spatial gear along its axis, with the sense asked for.
  Case helical = c;
  for (const char* body : {"0", "1"})
    set_case_value(helical, {fmt::format("train.body[{}].helix_angle_deg", body), "20"});
  EXPECT_TRUE(unused_settings(helical).empty());
  const train::Assembled h = assembled_train(helical);
  const double sb = std::sin(h.train().meshes[0].base_helix_angle_rad);
  EXPECT_NEAR(h.mesh_vector(0)(4), -sb, 1e-15);  // h = -1 on the driving gear's z
  set_case_value(helical, {"train.mesh[0].thrust", "\"+z\""});
  EXPECT_NEAR(assembled_train(helical).mesh_vector(0)(4), sb, 1e-15);
  // Pins and the frame's terms are refused with a spatial body.
  Case framed = helical;
  set_case_value(framed, {"train.frame_terms", "true"});
  set_case_value(framed,
                 {"train.shaft", "[{from = \"b\", to = \"ground\", stiffness_n_m_per_rad = 1e5}]"});
  try {
    (void)assembled_train(framed);
    ADD_FAILURE() << "a spatial body with frame_terms assembled";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("body 'a': is spatial with frame_terms = true"),
              std::string::npos)
        << e.what();
  }
}

// A run of `c`'s train form against `c`'s own samples of (d - e) / b: the worst difference in b
// over the samples, and the train's mesh reading.
template <class Samples>
double worst_against(const Samples& delta_bar, const TrainRunResult& x) {
  EXPECT_TRUE(x.ok()) << x.message;
  EXPECT_EQ(x.samples.t_s.size(), delta_bar.size());
  double worst = 0;
  for (std::size_t i = 0; i < std::min(delta_bar.size(), x.samples.t_s.size()); ++i)
    worst = std::max(worst, std::abs(x.samples.deflection_bar[i][0] - delta_bar[i]));
  return worst;
}

// Two readings of one run in the pair's terms agree, each number to `tolerance` of its own
// size (or of 1 below it).
void expect_same_reading(const RunReading& a, const RunReading& b, double tolerance) {
  const auto near = [&](double x, double y, const char* what) {
    EXPECT_NEAR(x, y, tolerance * std::max(1.0, std::abs(y))) << what;
  };
  EXPECT_EQ(a.regime, b.regime);
  EXPECT_EQ(a.double_sided, b.double_sided);
  EXPECT_EQ(a.impacts, b.impacts);
  EXPECT_EQ(a.backside_impacts, b.backside_impacts);
  EXPECT_EQ(a.separations, b.separations);
  ASSERT_EQ(a.last_separation_s.has_value(), b.last_separation_s.has_value());
  if (a.last_separation_s) near(*a.last_separation_s, *b.last_separation_s, "last separation");
  near(a.separated_fraction, b.separated_fraction, "separated fraction");
  near(a.max_impact_velocity_m_s, b.max_impact_velocity_m_s, "max impact velocity");
  near(a.max_force_bar, b.max_force_bar, "max F_bar");
  near(a.min_force_bar, b.min_force_bar, "min F_bar");
  near(a.mean_force_bar, b.mean_force_bar, "mean F_bar");
  near(a.rms_force_bar, b.rms_force_bar, "rms F_bar");
  near(a.max_delta_bar, b.max_delta_bar, "max delta_bar");
  near(a.min_delta_bar, b.min_delta_bar, "min delta_bar");
  near(a.mean_delta_bar, b.mean_delta_bar, "mean delta_bar");
  near(a.rms_delta_bar, b.rms_delta_bar, "rms delta_bar");
  ASSERT_EQ(a.dynamic_factor.has_value(), b.dynamic_factor.has_value());
  if (a.dynamic_factor) near(*a.dynamic_factor, *b.dynamic_factor, "dynamic factor");
}

TEST(TrainCase, APairFormsRunIsItsTrainsReadInThePairsTerms) {
  // run() of the one-degree forms runs the case as its train (run_train) and reads its mesh back
  // as the one-degree model reads delta: the shipped pair (its stiffness from the energy method,
  // 50 impacts in 50 ms) and the Kahraman-Singh oscillator (non-dimensional, 61 impacts) read
  // as run_one_degree_model reads them, every reading over the window and the steady part, the
  // derived quantities, every event and sample, to 1e-10 (measured: 1e-12 for the pair, 1e-13
  // for the oscillator). A reading divided by the wrong scale (F by b, a mean by its RMS), the
  // dynamic factors swapped between the window and its steady part, or the back-side impacts
  // read as impacts fails it.
  const std::filesystem::path cases = std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases";
  for (const char* file : {"park2010.toml", "kahraman_singh.toml"}) {
    SCOPED_TRACE(file);
    const Case c = load_case(cases / file);
    const RunResult r = run(c), one = run_one_degree_model(c);
    ASSERT_TRUE(r.integration.ok()) << r.integration.message;
    ASSERT_TRUE(one.integration.ok()) << one.integration.message;
    ASSERT_GE(one.reading.impacts, 50);
    constexpr double kTolerance = 1e-10;
    expect_same_reading(r.reading, one.reading, kTolerance);
    expect_same_reading(r.steady.reading, one.steady.reading, kTolerance);
    EXPECT_EQ(r.steady.basis, one.steady.basis);
    EXPECT_EQ(r.steady.from_s, one.steady.from_s);
    EXPECT_EQ(r.steady_start_s, one.steady_start_s);
    EXPECT_EQ(r.derived.output_interval_s, one.derived.output_interval_s);
    EXPECT_EQ(r.derived.natural_frequency_hz, one.derived.natural_frequency_hz);
    EXPECT_EQ(r.derived.time_step_s, one.derived.time_step_s);
    const double largest = std::max(std::abs(one.reading.max_impact_velocity_m_s), 1.0);
    ASSERT_EQ(r.events.size(), one.events.size());
    for (std::size_t k = 0; k < one.events.size(); ++k) {
      EXPECT_EQ(r.events[k].kind, one.events[k].kind) << k;
      EXPECT_NEAR(r.events[k].t_s, one.events[k].t_s, kTolerance * one.events.back().t_s) << k;
      EXPECT_NEAR(r.events[k].velocity_m_s, one.events[k].velocity_m_s, kTolerance * largest) << k;
    }
    ASSERT_EQ(r.samples.size(), one.samples.size());
    for (std::size_t i = 0; i < one.samples.size(); ++i) {
      ASSERT_NEAR(r.samples.t_s[i], one.samples.t_s[i], 1e-15 * one.samples.t_s.back()) << i;
      EXPECT_NEAR(r.samples.delta_bar[i], one.samples.delta_bar[i], kTolerance) << i;
      EXPECT_NEAR(r.samples.force_bar[i], one.samples.force_bar[i], kTolerance) << i;
      EXPECT_NEAR(r.samples.velocity_m_s[i], one.samples.velocity_m_s[i], kTolerance * largest)
          << i;
      EXPECT_EQ(r.samples.contact[i], one.samples.contact[i]) << i;
    }
    ASSERT_EQ(r.force_peaks.size(), one.force_peaks.size());
    for (std::size_t k = 0; k < one.force_peaks.size(); ++k) {
      EXPECT_NEAR(r.force_peaks[k].frequency_hz, one.force_peaks[k].frequency_hz,
                  kTolerance * one.force_peaks[k].frequency_hz);
      EXPECT_NEAR(r.force_peaks[k].amplitude, one.force_peaks[k].amplitude, kTolerance);
    }
  }
}

TEST(TrainCase, ARunThatReadsItsOwnSpectraLeavesTheMeshesPeaksUnread) {
  // The one-degree forms' run reads its spectra in the pair's units (compute_spectra), so its
  // train's run skips its own (TrainRunOptions::read_peaks): the same samples, no peaks.
  const Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "park2010.toml");
  TrainRunOptions o;
  o.keep_states = false;
  const TrainRunResult with = run_train(c, o);
  o.read_peaks = false;
  const TrainRunResult without = run_train(c, o);
  ASSERT_TRUE(with.ok() && without.ok());
  ASSERT_EQ(with.meshes.size(), 1U);
  EXPECT_FALSE(with.meshes[0].force_peaks.empty());
  EXPECT_FALSE(with.meshes[0].deflection_peaks.empty());
  EXPECT_TRUE(without.meshes[0].force_peaks.empty());
  EXPECT_TRUE(without.meshes[0].deflection_peaks.empty());
  EXPECT_EQ(without.samples.t_s, with.samples.t_s);
  EXPECT_EQ(without.meshes[0].max_force_n, with.meshes[0].max_force_n);
  // The pair's run reads the same peaks from the same samples, in its own units.
  const RunResult r = run(c);
  ASSERT_FALSE(r.force_peaks.empty());
  const double force_scale = with.meshes[0].backlash_m * with.meshes[0].mean_stiffness_n_per_m;
  EXPECT_NEAR(r.force_peaks[0].frequency_hz, with.meshes[0].force_peaks[0].frequency_hz, 1e-9);
  EXPECT_NEAR(r.force_peaks[0].amplitude * force_scale, with.meshes[0].force_peaks[0].amplitude,
              1e-9 * with.meshes[0].force_peaks[0].amplitude);
}

TEST(TrainCase, APairsDopri5RunReadsItsDynamicFactorAsTheExactEngineDoes) {
  // The pair's run with dopri5 (run() on its train, adaptive.hpp) at 1e-10 reads the steady
  // dynamic factor of the shipped pair within 1e-5 of the exact engine's (measured 1e-7): its
  // extremes are read at each step's midpoint too, which step ends alone miss by 3e-4 here. The
  // one-degree model's own dopri5 (run_one_degree_model, its step ends) read it to 4e-5 before the
  // pair ran on its train: no closer than this run.
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "park2010.toml");
  const RunResult exact = run(c);
  set_case_value(c, {"solver.method", "dopri5"});
  set_case_value(c, {"solver.tolerance", "1e-10"});
  const RunResult adaptive = run(c), one = run_one_degree_model(c);
  ASSERT_TRUE(exact.integration.ok() && adaptive.integration.ok() && one.integration.ok());
  const double df = exact.steady.reading.dynamic_factor.value();
  const double error = std::abs(adaptive.steady.reading.dynamic_factor.value() - df);
  EXPECT_LT(error, 1e-5 * df);
  EXPECT_LE(error, std::abs(one.steady.reading.dynamic_factor.value() - df));
  // The start-up's largest crest falls away from its step's midpoint: 5e-5 of itself.
  EXPECT_NEAR(adaptive.reading.dynamic_factor.value(), exact.reading.dynamic_factor.value(),
              1e-4 * df);
}

TEST(TrainCase, ThePapersElevenCasesRunAsTheirTrainsToRounding) {
  // Each of the paper's 11 cases (park2010_study, over the study's window, the exact engine) as
  // its train form: every sample's (d - e) / b is the one-degree run's delta / b and every
  // sample's d' its delta' to rounding, the same contact changes at the same times with the
  // same velocities, the same steady start and the same extremes of F over the window and its
  // steady part, though the train steps other coordinates (the pair's angles less their common
  // rotation) on other cells: the one-degree forms' run may move onto the train without
  // moving its outputs (issue 28; docs/performance.md says what it would cost). Measured (fig4d
  // the farthest): samples to 1.2e-11 b and 4.6e-11 of the largest velocity, events to 2.3e-14
  // s and 1.3e-11 of the largest velocity, F's extremes to 8e-14 of its swing. A train engine
  // summing its cells to solver.tolerance (1e-10) rather than 1e-4 of it fails it.
  const Study study = park2010_study();
  for (const StudyCase& spec : study.cases) {
    SCOPED_TRACE(spec.id);
    Case c = spec.input;
    set_case_value(c, {"solver.duration_s", fmt::format("{}", study.window_s)});
    const RunResult one = run_one_degree_model(c);
    ASSERT_TRUE(one.integration.ok()) << one.integration.message;
    const TrainRunResult x = run_train(train_form_of(c));
    ASSERT_TRUE(x.ok()) << x.message;
    EXPECT_LT(worst_against(one.samples.delta_bar, x), 5e-11);
    double rate = 0, largest = 0;
    for (std::size_t i = 0; i < one.samples.size(); ++i) {
      largest = std::max(largest, std::abs(one.samples.velocity_m_s[i]));
      rate = std::max(rate,
                      std::abs(x.samples.deflection_rate_m_s[i][0] - one.samples.velocity_m_s[i]));
    }
    EXPECT_LT(rate, 2e-10 * largest);
    ASSERT_EQ(x.contact_events.size(), one.events.size());
    for (std::size_t k = 0; k < one.events.size(); ++k) {
      EXPECT_EQ(x.contact_events[k].kind, one.events[k].kind) << k;
      EXPECT_NEAR(x.contact_events[k].t_s, one.events[k].t_s, 1e-13) << k;
      EXPECT_NEAR(x.contact_events[k].velocity_m_s, one.events[k].velocity_m_s, 1e-10 * largest)
          << k;
    }
    EXPECT_EQ(x.steady.from_s, one.steady.from_s);
    const TrainMeshReading& m = x.meshes.at(0);
    const double force_scale = m.backlash_m * m.mean_stiffness_n_per_m;
    const double swing = one.reading.max_force_bar - one.reading.min_force_bar;
    EXPECT_NEAR(m.max_force_n / force_scale, one.reading.max_force_bar, 1e-11 * swing);
    EXPECT_NEAR(m.min_force_n / force_scale, one.reading.min_force_bar, 1e-11 * swing);
    EXPECT_NEAR(m.steady.max_force_n / force_scale, one.steady.reading.max_force_bar,
                1e-11 * swing);
    EXPECT_EQ(m.impacts, one.reading.impacts);
    EXPECT_EQ(m.steady.impacts, one.steady.reading.impacts);
  }
}

TEST(TrainCase, TheGearPairsFormsAreTrainsOfElements) {
  // The shipped pair (its stiffness from the energy method), with a matched and with an
  // independent fluctuating load, and on bearings (dof 3 and 12, with and without the coupled
  // pair's shafts): each case's train form (train_form_of) runs as the case through every
  // impact, (d - e) / b within 1e-8 at every sample, the same impacts. With a transmission
  // error both start at rest relative to it, from the middle of the backlash and from the
  // static state (rest_state, static_state at t0): a train that started at rest in d instead
  // misses by 0.15 b from the middle and 0.02 b from the static state.
  const std::filesystem::path cases = std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases";
  Case pair = load_case(cases / "park2010.toml");
  set_case_value(pair, {"solver.duration_s", "0.02"});
  for (const char* load : {"matched", "independent", "error", "error, static"}) {
    Case c = pair;
    if (std::string(load) == "independent") {
      set_case_value(c, {"load.load_torque_nm", "45"});
      set_case_value(c, {"load.load_fluctuation_nm", "6"});
      set_case_value(c, {"load.load_fluctuation_order", "2.5"});
    }
    if (std::string(load).starts_with("error"))
      set_case_value(c, {"mesh.transmission_error_um", "[[0.5, 30], [0.2, -60]]"});
    if (std::string(load) == "error, static") set_case_value(c, {"solver.initial", "\"static\""});
    SCOPED_TRACE(load);
    const RunResult one = run_one_degree_model(c);
    const Case t = train_form_of(c);
    ASSERT_TRUE(t.train);
    EXPECT_EQ(t.train->meshes.at(0).stiffness_harmonics.size(), 2U);  // the energy method's two
    const TrainRunResult x = run_train(t);
    EXPECT_LT(worst_against(one.samples.delta_bar, x), 1e-8);
    EXPECT_EQ(x.meshes.at(0).impacts, one.reading.impacts);
    if (std::string(load) != "error, static") EXPECT_GT(one.reading.impacts, 3);
  }
  Case on_bearings = load_case(cases / "park2010_coupled.toml");
  set_case_value(on_bearings, {"solver.duration_s", "0.02"});
  for (const char* dof : {"3", "6", "12"})
    for (const bool shafts : {false, true}) {
      Case c = on_bearings;
      set_case_value(c, {"model.dof", dof});
      if (shafts) set_case_value(c, {"shafts.end_inertia_kg_m2", "[0.004, 0.009]"});
      SCOPED_TRACE(fmt::format("dof {}{}", dof, shafts ? " with shafts" : ""));
      const CoupledRunResult one = run_coupled(c);
      ASSERT_TRUE(one.ok()) << one.message;
      const TrainRunResult x = run_train(train_form_of(c));
      EXPECT_LT(worst_against(one.samples.deflection_bar, x), 1e-8);
      EXPECT_EQ(x.meshes.at(0).impacts, one.mesh.impacts);
      EXPECT_EQ(x.shafts.size(), shafts ? 2U : 0U);
    }
  // The coupled pair with a transmission error starts at rest relative to it too.
  for (const char* initial : {"\"center\"", "\"static\""}) {
    SCOPED_TRACE(fmt::format("coupled, error, {}", initial));
    Case c = on_bearings;
    set_case_value(c, {"model.dof", "3"});
    set_case_value(c, {"shafts.end_inertia_kg_m2", "[0.004, 0.009]"});
    set_case_value(c, {"mesh.transmission_error_um", "[[0.5, 30], [0.2, -60]]"});
    set_case_value(c, {"solver.initial", initial});
    const CoupledRunResult one = run_coupled(c);
    ASSERT_TRUE(one.ok()) << one.message;
    const TrainRunResult x = run_train(train_form_of(c));
    EXPECT_LT(worst_against(one.samples.deflection_bar, x), 1e-8);
    EXPECT_EQ(x.meshes.at(0).impacts, one.mesh.impacts);
  }
  // The non-dimensional oscillator, in units where the train is it (its seconds are tau):
  // the shipped Kahraman-Singh case and one with varying stiffness and a transmission error,
  // from rest in the middle of the backlash, x/b against (d - e)/b.
  for (const bool varying : {false, true}) {
    SCOPED_TRACE(varying ? "nondimensional, varying" : "nondimensional");
    Case c = load_case(cases / "kahraman_singh.toml");
    set_case_value(c, {"solver.duration_s", "60"});
    set_case_value(c, {"solver.initial", "\"center\""});
    if (varying) {
      set_case_value(c, {"model.stiffness_harmonics", "[[0.2, 10], [0.05, 0]]"});
      set_case_value(c, {"model.transmission_error", "[[0.1, 45]]"});
      set_case_value(c, {"model.omega", "1.3"});
    }
    const RunResult one = run_one_degree_model(c);
    const TrainRunResult x = run_train(train_form_of(c));
    ASSERT_TRUE(x.ok()) << x.message;
    ASSERT_EQ(x.samples.t_s.size(), one.samples.delta_bar.size());
    EXPECT_LT(worst_against(one.samples.delta_bar, x), 1e-8);
    EXPECT_EQ(x.meshes.at(0).impacts, one.reading.impacts);
    EXPECT_GT(one.reading.impacts, 3);
  }
}

// The shipped pair over `duration_s` with the transmission error `error_um`
// (mesh.transmission_error_um): its one-degree run and its train form's, whose contact changes
// are checked to be the one-degree run's: each one's kind, its time to time_tolerance_s, and
// delta' = d' - e' there to velocity_tolerance of itself.
struct PairRuns {
  Case c;
  RunResult one;
  TrainRunResult x;
};
PairRuns pair_runs_with_error(const std::string& duration_s, const std::string& error_um,
                              double time_tolerance_s, double velocity_tolerance) {
  PairRuns r;
  r.c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases/park2010.toml");
  set_case_value(r.c, {"solver.duration_s", duration_s});
  set_case_value(r.c, {"mesh.transmission_error_um", error_um});
  r.one = run_one_degree_model(r.c);
  EXPECT_TRUE(r.one.integration.ok()) << r.one.integration.message;
  r.x = run_train(train_form_of(r.c));
  EXPECT_TRUE(r.x.ok()) << r.x.message;
  EXPECT_EQ(r.x.contact_parts, std::vector<std::string>{"mesh"});
  EXPECT_EQ(r.x.contact_events.size(), r.one.events.size());
  double worst_t = 0, worst_v = 0;
  for (std::size_t k = 0; k < std::min(r.one.events.size(), r.x.contact_events.size()); ++k) {
    const ContactEvent& e = r.one.events[k];
    const TrainContactEvent& f = r.x.contact_events[k];
    EXPECT_EQ(f.part, 0);
    EXPECT_EQ(f.kind, e.kind) << k;
    worst_t = std::max(worst_t, std::abs(f.t_s - e.t_s));
    worst_v =
        std::max(worst_v, std::abs(f.velocity_m_s - e.velocity_m_s) / std::abs(e.velocity_m_s));
  }
  EXPECT_LT(worst_t, time_tolerance_s);
  EXPECT_LT(worst_v, velocity_tolerance);
  return r;
}

TEST(TrainCase, ATransmissionErrorThatRattlesTheMeshEveryCycleIsRunWithoutChattering) {
  // The shipped pair with a transmission error of 5 and 2 um, as its train form: the teeth
  // part and strike once a mesh cycle (3846 contact changes in 0.05 s). On the train the error
  // is in the guard's offset, whose series the engine truncates at the cell's start: a state
  // handed over at an impact may look across the contact's guard by more than the slack, and
  // the engine then left the contact at once and came back at once, at one time, until it gave
  // up ("a chattering contact", at 0.025 s). Judged by the guard's exact value and the
  // motion's direction there, the run completes, and every contact change is the one-degree
  // run's (which has the error in its forcing, not in its guard): times to 1.4e-12 s measured,
  // velocities to 3.2e-5 of themselves (2e-6 m/s at a slow one, 0.06 m/s: the time's 1e-12 s
  // times the error's accelerations of some 6e5 m/s^2).
  const PairRuns r = pair_runs_with_error("0.05", "[[5, 30], [2, 0]]", 1e-10, 1e-4);
  EXPECT_GT(r.one.events.size(), 3000U);
  EXPECT_EQ(r.x.meshes.at(0).backside_impacts, r.one.reading.backside_impacts);
}

TEST(TrainCase, AMeshsEventsAndSampleMeansAreTheOneDegreeRuns) {
  // The shipped pair with a transmission error, as its train form: every contact change the
  // one-degree run locates is the train's (its time, its kind and delta' = d' - e' there), and
  // the mesh's largest impact velocity, its means and RMS of F and of d - e over the output
  // samples and its spectra's peaks are the one-degree reading's, over the window and over the
  // steady part. A mutant
  // that leaves e' out of the rate, or reads it from the state before the event's, fails the
  // velocities; one that counts the start-up's samples in the part fails its means.
  // Times 1e-14 s measured; velocities 6e-9 of themselves, at a grazing impact.
  const PairRuns r = pair_runs_with_error("0.1", "[[0.5, 30], [0.2, -60]]", 1e-12, 1e-7);
  const Case& c = r.c;
  const RunResult& one = r.one;
  const TrainRunResult& x = r.x;
  ASSERT_TRUE(one.integration.ok() && x.ok());
  ASSERT_GT(one.events.size(), 10U);
  const GearPairParameters p = build_model(c).parameters();
  const double b = p.backlash_m, force_scale = b * p.mean_stiffness_n_per_m();
  const auto expect_reading = [&](const TrainMeshPart& m, const RunReading& r) {
    EXPECT_NEAR(m.max_impact_velocity_m_s / r.max_impact_velocity_m_s, 1.0, 1e-8);
    EXPECT_NEAR(m.mean_force_n / force_scale, r.mean_force_bar, 1e-8);
    EXPECT_NEAR(m.rms_force_n / force_scale, r.rms_force_bar, 1e-8);
    EXPECT_NEAR(m.mean_deflection_m / b, r.mean_delta_bar, 1e-8);
    EXPECT_NEAR(m.rms_deflection_m / b, r.rms_delta_bar, 1e-8);
  };
  expect_reading(x.meshes[0], one.reading);
  ASSERT_TRUE(x.steady.marked);
  EXPECT_EQ(x.steady.from_s, one.steady.from_s);
  expect_reading(x.meshes[0].steady, one.steady.reading);
  // The spectra's peaks over the steady part are the one-degree run's: F's in b k_m, and d's.
  const auto expect_peaks = [](const std::vector<SpectralPeak>& train,
                               const std::vector<SpectralPeak>& pair, double scale) {
    ASSERT_EQ(train.size(), pair.size());
    ASSERT_EQ(pair.size(), kReportedPeaks);
    for (std::size_t k = 0; k < pair.size(); ++k) {
      EXPECT_NEAR(train[k].frequency_hz / pair[k].frequency_hz, 1.0, 1e-9) << k;
      EXPECT_NEAR(train[k].amplitude / scale, pair[k].amplitude, 1e-8) << k;
    }
  };
  expect_peaks(x.meshes[0].force_peaks, one.force_peaks, force_scale);
  expect_peaks(x.meshes[0].deflection_peaks, one.delta_peaks, 1.0);
  EXPECT_EQ(x.output_interval_s, one.derived.output_interval_s);
  // Every sample's d' - e' is the one-degree sample's rate (timeseries.csv's velocity_m_s).
  ASSERT_EQ(x.samples.deflection_rate_m_s.size(), one.samples.size());
  double worst_rate = 0, largest_rate = 0;
  for (std::size_t i = 0; i < one.samples.size(); ++i) {
    largest_rate = std::max(largest_rate, std::abs(one.samples.velocity_m_s[i]));
    worst_rate = std::max(
        worst_rate, std::abs(x.samples.deflection_rate_m_s[i][0] - one.samples.velocity_m_s[i]));
  }
  EXPECT_LT(worst_rate, 1e-8 * largest_rate);
}

TEST(TrainCase, EachMeshsRateIsTheDerivativeOfItsDeflection) {
  // The shipped reducer, both meshes with transmission errors (1 um at 2300 Hz on the first,
  // 1.5 um at 716 Hz on the second, with their second orders): each sample's d' - e' is the
  // time derivative of its (d - e), by the fourth-order central difference of the samples 1 us
  // apart (its error (w h)^4 / 30, below 1e-6 for the third mesh order). A rate that leaves e'
  // out is wrong by up to 2 pi 2300 Hz 1 um, about half of the rate.
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases/two_stage_reducer.toml");
  set_case_value(c, {"solver.method", "\"exact\""});
  set_case_value(c, {"solver.duration_s", "0.002"});
  set_case_value(c, {"solver.output_interval_s", "1e-6"});
  const TrainRunResult r = run_train(c);
  ASSERT_TRUE(r.ok()) << r.message;
  const TrainSamples& s = r.samples;
  ASSERT_EQ(s.deflection_rate_m_s.size(), s.t_s.size());
  ASSERT_GT(s.t_s.size(), 1000U);
  for (std::size_t m = 0; m < r.meshes.size(); ++m) {
    const double b = r.meshes[m].backlash_m;
    double worst = 0, largest = 0;
    for (std::size_t i = 2; i + 2 < s.t_s.size(); ++i) {
      const double h = s.t_s[i + 1] - s.t_s[i];
      const double difference = b *
                                (-s.deflection_bar[i + 2][m] + 8 * s.deflection_bar[i + 1][m] -
                                 8 * s.deflection_bar[i - 1][m] + s.deflection_bar[i - 2][m]) /
                                (12 * h);
      largest = std::max(largest, std::abs(s.deflection_rate_m_s[i][m]));
      worst = std::max(worst, std::abs(difference - s.deflection_rate_m_s[i][m]));
    }
    EXPECT_GT(largest, 0.01) << m;  // m/s: the mesh moves
    EXPECT_LT(worst, 1e-5 * largest) << r.meshes[m].name;
  }
}

TEST(TrainCase, ABearingClearancesEventsCarryTheCentresVelocity) {
  // The coupled pair with 5 um radial clearances at 600 Hz as its train: each clearance
  // direction's events are its impacts and separations, in time order, and each one's rate is
  // the centre's velocity along the direction, against a central difference of the centre's
  // displacement flowed to just before and just after it. An impact against +c moves outwards
  // (w' > 0), against -c inwards, and a separation leaves the side the last impact struck. A
  // mutant that takes the other direction's row, or the mesh's, fails the differences.
  const Case c = testing::coupled_with_clearances();
  const TrainRunResult x = run_train(c);
  ASSERT_TRUE(x.ok()) << x.message;
  const TrainSolver solver(c);
  const train::Assembled& a = solver.assembled();
  ASSERT_EQ(x.contact_parts.size(), 1 + a.clearances().size());
  ASSERT_GE(a.clearances().size(), 2U);
  const ode::Vector y0 = solver.initial_state(c.solver.initial);
  int checked = 0;
  for (std::size_t j = 0; j < a.clearances().size(); ++j) {
    const auto [bearing, axis] = a.clearances()[j];
    const int part = static_cast<int>(1 + j);
    EXPECT_EQ(x.contact_parts[static_cast<std::size_t>(part)], a.joints()[j].name);
    const TrainBearingReading& r = x.bearings[static_cast<std::size_t>(bearing)];
    const ContactReading& gap = axis == 0 ? r.clearance_x : r.clearance_y;
    std::int64_t count = 0;
    double last_t = 0;
    EventKind last_impact = EventKind::kSeparation;
    for (const TrainContactEvent& e : x.contact_events) {
      if (e.part != part) continue;
      ++count;
      EXPECT_GE(e.t_s, last_t);
      last_t = e.t_s;
      const double sign = e.kind == EventKind::kImpact           ? 1.0
                          : e.kind == EventKind::kBacksideImpact ? -1.0
                          : last_impact == EventKind::kImpact    ? -1.0
                                                                 : 1.0;
      EXPECT_GT(sign * e.velocity_m_s, 0) << e.t_s;
      if (e.kind != EventKind::kSeparation) last_impact = e.kind;
      if (checked >= 6 || e.kind == EventKind::kSeparation) continue;
      // w' from w at t -+ h, each flowed from the start.
      constexpr double kH = 1e-8;
      const auto w = [&](double t) {
        const ode::FlowResult f = solver.advance(0, y0, t);
        return a.bearing_matrix(bearing).row(axis).dot(f.state.head(a.size()));
      };
      EXPECT_NEAR(e.velocity_m_s, (w(e.t_s + kH) - w(e.t_s - kH)) / (2 * kH),
                  1e-5 * std::abs(e.velocity_m_s))
          << a.joints()[j].name << " at " << e.t_s;
      ++checked;
    }
    EXPECT_EQ(count, gap.impacts + gap.separations);
  }
  EXPECT_GE(checked, 2);
}

TEST(TrainCase, ACoupledCaseRunsAsItsTrainWithTheCoupledModelsReadings) {
  // run_train takes a coupled case as it is (TrainSolver builds its train form): the run keeps
  // the case as given, and its readings are the coupled model's (CoupledModel, an independent
  // assembly of the same equations): the mesh's impacts, force extremes and dynamic factors,
  // each bearing's dynamic factor along the line of action (the train's y) and along the axis,
  // and each shaft's, over the same steady part (the final half of a window that does not
  // settle). A direction the static load leaves unloaded (x) has no factor.
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases/park2010_coupled.toml");
  set_case_value(c, {"solver.duration_s", "0.02"});
  set_case_value(c, {"shafts.end_inertia_kg_m2", "[0.004, 0.009]"});
  for (const char* dof : {"3", "12"}) {
    SCOPED_TRACE(fmt::format("dof {}", dof));
    set_case_value(c, {"model.dof", dof});
    const CoupledRunResult one = run_coupled(c);
    ASSERT_TRUE(one.ok()) << one.message;
    const TrainRunResult x = run_train(c);
    ASSERT_TRUE(x.ok()) << x.message;
    EXPECT_EQ(x.input.model.form, ModelForm::kCoupled);
    ASSERT_EQ(one.steady.basis, SteadyBasis::kNotSettled);
    ASSERT_EQ(x.steady.basis, SteadyBasis::kNotSettled);
    ASSERT_EQ(x.steady.from_s, one.steady.from_s);
    // On the coupled model's cells (kTrainCellRateProduct): as many, the same events.
    EXPECT_EQ(x.cells, one.cells);
    EXPECT_EQ(x.events, one.events);
    const TrainMeshReading& m = x.meshes.at(0);
    EXPECT_EQ(m.impacts, one.mesh.impacts);
    EXPECT_GT(m.impacts, 3);
    EXPECT_NEAR(m.max_force_n / one.max_force_n, 1, 1e-9);
    EXPECT_NEAR(*m.dynamic_factor / one.dynamic_mesh_factor, 1, 1e-9);
    EXPECT_NEAR(*m.dynamic_factor_with_startup / one.dynamic_mesh_factor_with_startup, 1, 1e-9);
    ASSERT_EQ(x.bearings.size(), 2U);
    ASSERT_EQ(x.shafts.size(), 2U);
    for (std::size_t i = 0; i < 2; ++i) {
      const TrainBearingReading& b = x.bearings[i];
      EXPECT_FALSE(part_dynamic_factor(x, b.steady_force_x_n, b.static_force_x_n));
      EXPECT_NEAR(
          *part_dynamic_factor(x, b.steady_force_y_n, b.static_force_y_n) / one.bearing_factor[i],
          1, 1e-9)
          << i;
      if (std::string(dof) == "12")
        EXPECT_NEAR(*part_dynamic_factor(x, b.steady_axial_force_n, b.static_axial_force_n) /
                        one.axial_factor[i],
                    1, 1e-9)
            << i;
      const TrainShaftReading& s = x.shafts[i];
      EXPECT_NEAR(
          *part_dynamic_factor(x, s.steady_torque_nm, s.static_torque_nm) / one.shaft_factor[i], 1,
          1e-9)
          << i;
    }
  }
}

TEST(TrainCase, ATrainThatTurnsFreelyStepsAsItsReducedPairDoes) {
  // The pair on bearings (dof 3) with a constant mesh stiffness and a transmission error: the
  // coupled model reads it in the mesh's relative coordinates, its train on the complement of
  // its free rotation (rigid_split.hpp), each with A0 invertible. The engine takes the static
  // state and the constant coefficients though the error gives the system a period
  // (drop_zero_terms): the train steps the coupled model's cells, jumping the same steady
  // blocks, and reads the same run. A mutant that keeps the zero terms steps it as periodic.
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.mesh.mean_stiffness_n_per_m = 2.34e8;
  c.mesh.damping_ratio = 0.05;
  c.mesh.transmission_error_um = {{2.0, 0.0}};
  c.load.torque_nm = 150;
  c.load.fluctuation_ratio = 0;
  c.model.form = ModelForm::kCoupled;
  c.model.dof = 3;
  c.bearings.radial_stiffness_n_per_m = {2.34e8, 2.34e8};
  c.solver.initial = InitialCondition::kStatic;
  c.solver.duration_s = 0.02;
  for (const double f_hz : {45.0, 57.2}) {  // permanent contact; the rattle past its grazing
    SCOPED_TRACE(fmt::format("f1 {} Hz", f_hz));
    c.speed.shaft_frequency_hz = f_hz;
    const CoupledRunResult one = run_coupled(c);
    ASSERT_TRUE(one.ok()) << one.message;
    const TrainRunResult x = run_train(c);
    ASSERT_TRUE(x.ok()) << x.message;
    EXPECT_EQ(x.cells, one.cells);
    EXPECT_EQ(x.events, one.events);
    EXPECT_EQ(x.meshes.at(0).impacts, one.mesh.impacts);
    EXPECT_EQ(one.mesh.impacts > 0, f_hz > 50);
    EXPECT_NEAR(x.meshes.at(0).max_force_n / one.max_force_n, 1, 1e-9);
    EXPECT_NEAR(x.meshes.at(0).min_force_n / one.min_force_n, 1, 1e-9);
  }
}

TEST(TrainCase, AFreelyTurningTrainIsSteppedWithoutItsRotation) {
  // rigid_split.hpp: a train that turns freely is stepped on the complement of its rotation,
  // two states fewer, by the exact engine and Newmark; one whose rotation something holds,
  // drives or drags is stepped whole, as is every train by dopri5 (whose steps the whole
  // train's sparse matrices make cheaper).
  const auto states = [](const Case& c) { return TrainSolver(c).stepped_states(); };
  EXPECT_EQ(states(park2010_pair_as_train()), 2);
  EXPECT_EQ(states(shipped_case("two_stage_reducer.toml", {{"solver.method", "exact"}})),
            2 * 6 - 2);
  EXPECT_EQ(states(shipped_case("park2010_coupled.toml", {})), 24 - 2);  // dof 12
  EXPECT_EQ(states(shipped_case("loose_gear_rattle.toml", {})), 2 * 2);  // a prescribed speed
  // The same pair with a viscous drag on its wheel (which damps the rotation too); a planetary
  // set whose ring a torsional shaft holds to the ground
  const std::string pair = std::string(kBodyA) + kBodyB + kMeshAB +
                           "[[train.torque]]\nname = \"in\"\nbody = \"a\"\nmean_nm = 10\n"
                           "[[train.torque]]\nname = \"out\"\nbody = \"b\"\nmean_nm = -20\n";
  EXPECT_EQ(states(parse_case(pair, "t.toml")), 2);
  EXPECT_EQ(states(parse_case(pair + "[[train.drag]]\nname = \"oil\"\nbody = \"b\"\n"
                                     "viscous_n_m_s_per_rad = 0.01\n",
                              "t.toml")),
            4);
  // still turns freely about it (split: two states fewer).
  EXPECT_EQ(states(shipped_case("planetary_set.toml", {{"solver.method", "exact"}})), 2 * 18 - 2);
  for (const char* method : {"dopri5", "newmark"}) {
    Case other = park2010_pair_as_train();
    set_case_value(other, {"solver.method", method});
    EXPECT_EQ(states(other), std::string(method) == "dopri5" ? 4 : 2) << method;
    set_case_value(other, {"train.drag",
                           "[{name = \"oil\", body = \"wheel\", viscous_n_m_s_per_rad = 0.01}]"});
    EXPECT_EQ(states(other), 4) << method;
  }
}

TEST(TrainCase, NewmarkOnAPairAsItsTrainIsTheOneDegreeNewmark) {
  // Newmark steps the pair's train on the complement of its rotation, one coordinate as the
  // one-degree model steps delta, on the same grid (the same step rule): the same run, (d - e)
  // / b within 1e-8 at every sample through the impacts (the shipped pair's two timeseries.csv
  // agree to their ten digits), the same impacts and steps.
  Case pair = park2010_pair_case();
  Case train = park2010_pair_as_train();
  for (Case* c : {&pair, &train}) {
    set_case_value(*c, {"solver.duration_s", "0.02"});
    set_case_value(*c, {"solver.method", "newmark"});
  }
  const RunResult one = run(pair);
  ASSERT_TRUE(one.integration.ok()) << one.integration.message;
  ASSERT_GT(one.reading.impacts, 2);
  const TrainRunResult x = run_train(train);
  EXPECT_LT(worst_against(one.samples.delta_bar, x), 1e-8);
  EXPECT_EQ(x.meshes.at(0).impacts, one.reading.impacts);
  EXPECT_EQ(x.cells, one.integration.steps);
}

TEST(TrainCase, AMeshDampedAtAllTimesOrClippingItsTensionIsThePairs) {
  // The one-degree model's damping forms and tension rules as a train mesh's damping and
  // tension: the pair with its damper at all times, and with its tension clipped, on rigid
  // and on elastic bearings, runs as its train form to 1e-8 b at every sample, with the same
  // impacts; each option changes the run, and the clipped states are visited.
  const std::filesystem::path cases = std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases";
  Case pair = load_case(cases / "park2010.toml");
  set_case_value(pair, {"solver.duration_s", "0.02"});
  set_case_value(pair, {"mesh.damping_ratio", "0.15"});  // enough to pull as the teeth part
  Case on_bearings = load_case(cases / "park2010_coupled.toml");
  set_case_value(on_bearings, {"solver.duration_s", "0.02"});
  set_case_value(on_bearings, {"mesh.damping_ratio", "0.15"});
  set_case_value(on_bearings, {"model.dof", "3"});
  const RunResult plain = run(pair);
  for (const auto& [key, value] :
       {std::pair{"mesh.damping", "\"always\""}, std::pair{"mesh.tension", "\"clip\""}}) {
    SCOPED_TRACE(fmt::format("{} = {}", key, value));
    Case c = pair;
    set_case_value(c, {key, value});
    const RunResult one = run_one_degree_model(c);
    const Case t = train_form_of(c);
    const TrainRunResult x = run_train(t);
    EXPECT_LT(worst_against(one.samples.delta_bar, x), 1e-8);
    EXPECT_GT(worst_against(plain.samples.delta_bar, x), 1e-4);  // the option moves the run
    EXPECT_EQ(x.meshes.at(0).impacts, one.reading.impacts);
    const bool clip = std::string(key) == "mesh.tension";
    const auto clipped = std::count_if(x.samples.contact.begin(), x.samples.contact.end(),
                                       [](const auto s) { return std::abs(s[0]) == 2; });
    if (clip)
      EXPECT_GT(clipped, 0);
    else
      EXPECT_EQ(clipped, 0);
    // Clipped, the force never pulls; damped at all times, it does in the backlash.
    double least = 0;
    for (const auto& f : x.samples.force_n) least = std::min(least, f[0]);
    if (clip)
      EXPECT_GE(least, 0.0);
    else
      EXPECT_LT(least, 0.0);

    Case b = on_bearings;
    set_case_value(b, {key, value});
    const CoupledRunResult coupled = run_coupled(b);
    ASSERT_TRUE(coupled.ok()) << coupled.message;
    const TrainRunResult y = run_train(train_form_of(b));
    EXPECT_LT(worst_against(coupled.samples.deflection_bar, y), 1e-8);
    EXPECT_EQ(y.meshes.at(0).impacts, coupled.mesh.impacts);
  }
  // Clipping a mesh damped at all times moves nothing: reported unused, naming the mesh.
  Case both = train_form_of(pair);
  set_case_value(both, {"train.mesh[0].damping", "\"always\""});
  EXPECT_TRUE(unused_settings(both).empty());
  set_case_value(both, {"train.mesh[0].tension", "\"clip\""});
  const std::vector<std::string> unused = unused_settings(both);
  ASSERT_EQ(unused.size(), 1U);
  EXPECT_NE(unused[0].find("train.mesh[0].tension = \"clip\" (--set"), std::string::npos)
      << unused[0];
  EXPECT_NE(unused[0].find("mesh 'mesh' is damped at all times"), std::string::npos);
}

TEST(TrainCase, ATrainWrittenBackReadsAsTheSame) {
  // case.toml of a run (and the case a Dask worker gets) holds the train as given: read again,
  // it writes the same text and assembles to the same train. The wind-turbine gearbox's main
  // shaft, damped by its mode's ratio, was written back with the default damping_ratio beside
  // it, which the reader refuses, and with solver.method = "exact", which its default had
  // replaced by dopri5.
  for (const char* file :
       {"two_stage_reducer.toml", "idler_train.toml", "loose_gear_rattle.toml",
        "lin_parker_1999.toml", "planetary_set.toml", "wind_turbine_grc750.toml"}) {
    const Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / file);
    ASSERT_TRUE(c.train) << file;
    const std::string text = to_toml(c);
    const Case again = parse_case(text, "again.toml");
    ASSERT_TRUE(again.train) << file;
    EXPECT_EQ(to_toml(again), text) << file;
    EXPECT_EQ(again.train->meshes.size(), c.train->meshes.size());
    // A method left to the default stays so (written, it would read as asked for).
    EXPECT_EQ(again.origins.count("solver.method"), c.origins.count("solver.method")) << file;
    const train::Train a = assembled_train(c).train(), b = assembled_train(again).train();
    ASSERT_EQ(a.shafts.size(), b.shafts.size()) << file;
    for (std::size_t k = 0; k < a.shafts.size(); ++k)
      EXPECT_EQ(a.shafts[k].damping_n_m_s_per_rad, b.shafts[k].damping_n_m_s_per_rad) << file;
  }
}

// Lin and Parker's set as its elements were written by hand before the preset (bodies, meshes,
// the ring's support, bearings and pin): cases/lin_parker_1999.toml's [[train.planetary]]
// assembles to the same train, bit for bit.
constexpr const char* kLinParkerByHand = R"(
[model]
form = "train"
[train]
reference = "sun"
reference_speed_hz = 10
planet = "planet"
planets = 3
[[train.body]]
name = "sun"
dof = "planar"
teeth = 85
normal_module_mm = 1
normal_pressure_angle_deg = 24.6
inertia_kg_m2 = 0.000582366
mass_kg = 0.4
[[train.body]]
name = "ring"
dof = "planar"
teeth = 305
normal_module_mm = 1
normal_pressure_angle_deg = 24.6
inertia_kg_m2 = 0.0576785
mass_kg = 2.35
[[train.body]]
name = "carrier"
dof = "planar"
inertia_kg_m2 = 0.0597943
mass_kg = 5.43
[[train.body]]
name = "planet"
dof = "planar"
teeth = 110
normal_module_mm = 1
normal_pressure_angle_deg = 24.6
inertia_kg_m2 = 0.00152549
mass_kg = 0.66
[[train.mesh]]
name = "sun_planet"
driving = "sun"
driven = "planet"
mean_stiffness_n_per_m = 5e8
position_angle_deg = 0
[[train.mesh]]
name = "planet_ring"
driving = "planet"
driven = "ring"
kind = "internal"
mean_stiffness_n_per_m = 5e8
position_angle_deg = 180
[[train.shaft]]
name = "ring_support"
from = "ring"
to = "ground"
stiffness_n_m_per_rad = 1.92262e7
[[train.bearing]]
name = "sun_bearing"
body = "sun"
stiffness_n_per_m = 1e8
[[train.bearing]]
name = "ring_bearing"
body = "ring"
stiffness_n_per_m = 1e8
[[train.bearing]]
name = "carrier_bearing"
body = "carrier"
stiffness_n_per_m = 1e8
[[train.bearing]]
name = "pin"
body = "planet"
on = "carrier"
pin_angle_deg = 0
stiffness_n_per_m = 1e8
)";

TEST(TrainCase, APlanetaryPresetIsTheElementsItWrites) {
  const Case preset =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "lin_parker_1999.toml");
  const Case by_hand = parse_case(kLinParkerByHand, "by_hand.toml");
  for (int planets : {3, 4}) {
    Case a = preset, b = by_hand;
    set_case_value(a, {"train.planets", fmt::format("{}", planets)});
    set_case_value(b, {"train.planets", fmt::format("{}", planets)});
    const train::Assembled x = assembled_train(a), y = assembled_train(b);
    EXPECT_EQ(x.mass(), y.mass()) << planets;
    EXPECT_EQ(x.contact_stiffness(), y.contact_stiffness()) << planets;
    EXPECT_EQ(x.contact_damping(), y.contact_damping()) << planets;
    EXPECT_EQ(x.train().meshes.size(), y.train().meshes.size());
  }
  // Written back as the preset alone, and read again the same; its keys set like any other.
  const std::string text = to_toml(preset);
  EXPECT_NE(text.find("[[train.planetary]]"), std::string::npos) << text;
  EXPECT_EQ(text.find("[[train.body]]"), std::string::npos) << text;
  EXPECT_EQ(to_toml(parse_case(text, "again.toml")), text);
  Case stiffer = preset;
  set_case_value(stiffer, {"train.planetary[0].mesh_stiffness_n_per_m", "6e8"});
  for (const train::Mesh& m : assembled_train(stiffer).train().meshes)
    EXPECT_EQ(m.mean_stiffness_n_per_m, 6e8) << m.name;
  EXPECT_TRUE(train_key_not_sweepable("train.planetary[0].mesh_stiffness_n_per_m").empty());
  // An element it wrote is set through its keys: by its index, it is no element of the file.
  const std::string by_index = testing::error_of([&] {
    set_case_value(stiffer, {"train.mesh[0].backlash_um", "20", "--set"});
  });
  EXPECT_NE(by_index.find("the case writes no [[train.mesh]] table (the elements its "
                          "[[train.planetary]] writes are set through the preset's keys"),
            std::string::npos)
      << by_index;
}

// A set driven through its carrier (a wind turbine's): the planet pushes the sun and the ring
// pushes the planet, so at rest every mesh is loaded on its drive flank; the preset's line
// where an element beside it takes one of its names, a second set, a held member without its
// support.
TEST(TrainCase, APlanetaryPresetDrivenThroughItsCarrier) {
  const std::string head = R"(
[model]
form = "train"
[train]
reference = "carrier"
reference_speed_hz = 0.4
planets = 3
[[train.body]]
name = "rotor"
inertia_kg_m2 = 1e5
[[train.shaft]]
name = "main_shaft"
from = "rotor"
to = "carrier"
stiffness_n_m_per_rad = 1e8
[[train.torque]]
name = "wind"
body = "rotor"
balances = true
[[train.torque]]
name = "load"
body = "sun"
mean_nm = -2000
)";
  const std::string set = R"(
[[train.planetary]]
name = "stage1"
sun_teeth = 21
planet_teeth = 39
normal_module_mm = 10
helix_angle_deg = 7.5
face_width_mm = 227.5
input = "carrier"
ring_inertia_kg_m2 = 130
ring_mass_kg = 460
carrier_inertia_kg_m2 = 60
carrier_mass_kg = 800
bearing_stiffness_n_per_m = 5e9
pin_stiffness_n_per_m = 1.5e9
support_n_m_per_rad = 5e8
)";
  const Case c = parse_case(head + set, "t.toml");
  EXPECT_TRUE(train_plausibility(c).empty())
      << fmt::format("{}", fmt::join(train_plausibility(c), "\n"));
  const train::Assembled a = assembled_train(c);
  std::vector<std::string> meshes;
  for (const train::Mesh& m : a.train().meshes) meshes.push_back(m.name);
  EXPECT_EQ(meshes, (std::vector<std::string>{"planet_sun1", "planet_sun2", "planet_sun3",
                                              "ring_planet1", "ring_planet2", "ring_planet3"}));
  // ISO 6336-1's k_m at the static load, the ring's teeth 21 + 2 x 39, the sun's speed by Willis.
  for (const train::Mesh& m : a.train().meshes) EXPECT_GT(m.mean_stiffness_n_per_m, 1e9) << m.name;
  EXPECT_NEAR(std::abs(a.body_speed_hz(a.index("sun"))), 0.4 * (1 + 99.0 / 21), 1e-12);
  const auto refused = [&](const std::string& text, const std::string& what) {
    const std::string e = testing::error_of([&] { (void)parse_case(text, "t.toml"); });
    EXPECT_NE(e.find("t.toml:"), std::string::npos) << e;
    EXPECT_NE(e.find("planetary 'stage1'"), std::string::npos) << e;
    EXPECT_NE(e.find(what), std::string::npos) << e;
  };
  refused(head + "[[train.body]]\nname = \"sun\"\ninertia_kg_m2 = 1\n" + set,
          "writes body 'sun', and a [[train.body]] of that name is written too");
  refused(head + set + set, "a train has one planetary set written as a preset");
  refused(std::regex_replace(head + set, std::regex("support_n_m_per_rad = 5e8\n"), ""),
          "held = \"ring\": give support_n_m_per_rad");
}

TEST(TrainCase, PlanetsWrittenOnceAreCopiedTurnedAboutTheSetsAxis) {
  // cases/lin_parker_1999.toml names its planet once: train.planets copies it and every element
  // that names it, in their places, each turned by its angle (equally spaced, or given).
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "lin_parker_1999.toml");
  const train::Train t = train_of(c);
  std::vector<std::string> bodies, meshes;
  for (const train::Body& b : t.bodies) bodies.push_back(b.name);
  for (const train::Mesh& m : t.meshes) meshes.push_back(m.name);
  EXPECT_EQ(bodies,
            (std::vector<std::string>{"sun", "ring", "carrier", "planet1", "planet2", "planet3"}));
  EXPECT_EQ(meshes, (std::vector<std::string>{"sun_planet1", "sun_planet2", "sun_planet3",
                                              "planet_ring1", "planet_ring2", "planet_ring3"}));
  constexpr double kDeg = kPi / 180;
  for (int n = 0; n < 3; ++n) {
    EXPECT_EQ(t.meshes[static_cast<std::size_t>(n)].driven, fmt::format("planet{}", n + 1));
    EXPECT_NEAR(t.meshes[static_cast<std::size_t>(n)].position_angle_rad, 120 * n * kDeg, 1e-15);
    EXPECT_EQ(t.meshes[static_cast<std::size_t>(3 + n)].driving, fmt::format("planet{}", n + 1));
    EXPECT_NEAR(t.meshes[static_cast<std::size_t>(3 + n)].position_angle_rad,
                (180 + 120 * n) * kDeg, 1e-15);
    const train::Bearing& pin = t.bearings[static_cast<std::size_t>(3 + n)];
    EXPECT_EQ(pin.name, fmt::format("pin{}", n + 1));
    EXPECT_EQ(pin.body, fmt::format("planet{}", n + 1));
    EXPECT_EQ(pin.on, "carrier");
    EXPECT_NEAR(pin.pin_radius_m, 0.0975, 1e-15);  // written without: the gears' (85 + 110) / 2
    EXPECT_NEAR(pin.pin_angle_rad, 120 * n * kDeg, 1e-15);
  }
  EXPECT_EQ(t.shafts.size(), 1U);  // the ring's support names no planet: kept once
  // Angles given, one per planet.
  set_case_value(c, {"train.planet_angles_deg", "[0, 100, 250]"});
  EXPECT_NEAR(train_of(c).bearings[4].pin_angle_rad, 100 * kDeg, 1e-15);
  // A copy's error names the copy and where its template was written (here the --set that
  // changed it; cli_test shows a file's line), in the set written element by element.
  Case by_hand = parse_case(kLinParkerByHand, "by_hand.toml");
  set_case_value(by_hand, {"train.bearing[3].on", "\"sun\""});
  try {
    assembled_train(by_hand);
    ADD_FAILURE() << "a pin on the sun assembled";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--set train.bearing[3].on"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("bearing 'pin1'"), std::string::npos) << e.what();
  }
  // A count without its planet, a planet that is no body.
  const std::string head = std::string(kBodyA) + kBodyB;
  const std::string mesh = kMeshAB;
  const auto with = [&](const std::string& keys) {
    std::string text = head + mesh;
    return text.replace(text.find("[[train.body]]"), 0, keys);
  };
  EXPECT_NE(error_of(with("planets = 3\n")).find("train.planet, the body written once"),
            std::string::npos);
  EXPECT_NE(
      error_of(with("planet = \"p\"\nplanets = 3\n")).find("planet = \"p\": no body of that name"),
      std::string::npos);
  EXPECT_NE(error_of(with("planets = 0\n")).find("train.planets = 0: must be a whole number"),
            std::string::npos);
  // A pin's place on a bearing on the ground is read by nothing: reported.
  const std::vector<std::string> unused = unused_settings(parse_case(
      with("") + "[[train.bearing]]\nbody = \"a\"\nstiffness_n_per_m = 1e8\npin_radius_mm = 5\n",
      "t.toml"));
  ASSERT_EQ(unused.size(), 1U);
  EXPECT_NE(unused[0].find("train.bearing[0].pin_radius_mm = 5 (t.toml:"), std::string::npos)
      << unused[0];
}

TEST(TrainCase, BadArrangementsAreNamedWithTheirElementKeyAndPlace) {
  const std::string head = std::string(kBodyA) + kBodyB;
  const std::string mesh = kMeshAB;
  EXPECT_EQ(error_of(head + mesh), "");
  // An empty array of elements is none of them: no torque is a train without torques.
  EXPECT_EQ(error_of(std::string(kBodyA).replace(std::string(kBodyA).find("[[train.body]]"), 0,
                                                 "torque = []\n") +
                     kBodyB + mesh),
            "");
  // The ring of an internal mesh with its inertia given: the pair turns the same way.
  const Case internal =
      parse_case(head + "inertia_kg_m2 = 0.02\n" + mesh + "kind = \"internal\"\n", "t.toml");
  EXPECT_EQ(assembled_train(internal).sense(1), 1);
  struct Row {
    std::string text;
    std::vector<std::string> pieces;
  };
  const std::vector<Row> rows = {
      {head + R"([[train.mesh]]
name = "m"
driving = "a"
driven = "c"
mean_stiffness_n_per_m = 2e8
)",
       {"t.toml:18:", "mesh 'm'", "driven = \"c\"", "no body of that name"}},
      {head + mesh + R"([[train.body]]
name = "a"
inertia_kg_m2 = 1
)",
       {"t.toml:20:", "body 'a'", "named twice"}},
      {head, {"has no mesh"}},
      // An empty array is no element, not a wrong type: no mesh is refused as no mesh.
      {std::string(kBodyA).replace(std::string(kBodyA).find("[[train.body]]"), 0, "mesh = []\n") +
           kBodyB,
       {"has no mesh"}},
      {head + mesh + R"([[train.shaft]]
from = "a"
to = "b"
stiffness_n_m_per_rad = 1e4
)",
       {"shaft 'shaft1'", "loop", "t.toml:20:"}},
      {head + R"([[train.mesh]]
driving = "a"
driven = "b"
mean_stiffness_n_per_m = 2e8
backlash_um = -5
)",
       {"t.toml:19:", "train.mesh[0].backlash_um = -5", "> 0.001 um"}},
      {head + R"([[train.mesh]]
driving = "a"
driven = "b"
)",
       {"t.toml:15:", "train.mesh[0] has no mean_stiffness_n_per_m"}},
      {head + mesh + R"([[train.drag]]
body = "b"
oil = 0.1
)",
       {"t.toml:22:", "unknown key 'train.drag[0].oil'", "constant_nm"}},
      {"[train]\nreference_speed_hz = 5\n", {"[train] is read with model.form = \"train\""}},
      {"[model]\nform = \"train\"\n", {"t.toml:2:", "needs a [train] section"}},
      // A misspelt [train] is named as the unknown key it is, not as a missing [train].
      {"[model]\nform = \"train\"\n[trian]\nreference_speed_hz = 5\n",
       {"t.toml:3:", "unknown key 'trian' (did you mean 'train'?); allowed at the top level:"}},
      {head + mesh + "kind = \"internal\"\n",
       {"t.toml:10:", "body 'b': is the ring gear of internal mesh 'm': give its inertia_kg_m2"}},
      {std::string(kBodyA).replace(std::string(kBodyA).find("[[train.body]]"), 0,
                                   "mesh_phase = \"auto\"\n") +
           kBodyB + mesh,
       {"t.toml:5:", "train.mesh_phase = \"auto\": must be \"given\" or \"layout\""}},
      {head + mesh + "kind = \"inner\"\n",
       {"t.toml:20:", "train.mesh[0].kind = \"inner\": must be \"external\" or \"internal\""}},
  };
  for (const Row& row : rows) {
    std::string message;
    try {
      (void)assembled_train(parse_case(row.text, "t.toml"));
    } catch (const InputError& e) {
      message = e.what();
    }
    for (const std::string& piece : row.pieces)
      EXPECT_NE(message.find(piece), std::string::npos) << piece << " in: " << message;
  }
  // A reference to no body is named where it was given.
  try {
    (void)assembled_train(parse_case(head + mesh, "t.toml", {{"train.reference", "\"nobody\""}}));
    ADD_FAILURE() << "a reference to no body was taken";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--set train.reference=\"nobody\": the train: "
                                          "reference = \"nobody\": no body of that name",
                                          0),
              0U)
        << e.what();
  }
  // A --set of an element's key is named as given.
  try {
    (void)parse_case(head + mesh, "t.toml", {{"train.mesh[0].backlash_um", "-1"}});
    ADD_FAILURE() << "a negative backlash was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--set train.mesh[0].backlash_um=-1"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace geardyn

namespace geardyn {
namespace {

// The default method does not fail where dopri5 does not: the reducer with a shaft damped so
// hard (1e4 N m s/rad on the motor's 9e-5 kg m^2 pinion: a rate of 1e8 1/s) that a contact
// region the exact engine enters on the way needs more cells than it can hold. With the
// method left out the run is run again with dopri5 and says why; it reads what dopri5 asked
// for reads, sample for sample. Asked for by name, the exact engine fails as asked.
TEST(TrainRun, TheDefaultMethodHandsARunTheExactEngineFailsToDopri5) {
  Case c = shipped_case(
      "two_stage_reducer.toml",
      {{"solver.duration_s", "0.001"}, {"train.shaft[0].damping_n_m_s_per_rad", "1e4"}});
  Case exact = c;
  set_case_value(exact, {"solver.method", "exact"});
  const TrainRunResult failed = run_train(exact);
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.message.find("the cell series do not converge"), std::string::npos)
      << failed.message;
  Case chosen = c;
  chosen.solver.method = Method::kExact;
  chosen.origins.erase("solver.method");
  const TrainRunResult r = run_train(chosen);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.method, Method::kDopri5);
  EXPECT_NE(r.method_note.find("chosen by the default: the exact engine failed on the way "
                               "(diverged: linear system: region"),
            std::string::npos)
      << r.method_note;
  EXPECT_NE(r.method_note.find("dopri5 ran the train from the start"), std::string::npos);
  EXPECT_EQ(r.input.origins.count("solver.method"), 0u);
  const TrainRunResult asked = run_train(c);  // the case's own dopri5
  ASSERT_TRUE(asked.ok()) << asked.message;
  EXPECT_EQ(largest_difference(r, asked), 0.0);
  EXPECT_EQ(r.meshes[0].max_force_n, asked.meshes[0].max_force_n);
}

}  // namespace
}  // namespace geardyn
