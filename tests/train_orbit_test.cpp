// Periodic orbits of gear trains (train_orbit.hpp): the orbit closes, and its monodromy matrix
// (the exact Jacobian with saltation at every impact) is the period map's central differences.
#include "geardyn/train_orbit.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>

#include "geardyn/case.hpp"
#include "geardyn/coupled_orbit.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/one_degree_orbit.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/validation.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;

Case loose_gear(double acceleration_rad_s2) {
  Case c =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "loose_gear_rattle.toml");
  set_case_value(c, {"train.speed[0].acceleration_harmonics",
                     fmt::format("[[{}, 2, 0]]", acceleration_rad_s2)});
  return c;
}

// The loose gear's state after one period from (theta, theta') at t = 0, the input as
// prescribed.
Eigen::Vector2d period_map(const train::Assembled& a, const ode::ExactEngine& engine, double period,
                           const Eigen::Vector2d& z) {
  return testing::free_period_map(a, engine, period, z);
}

// The orbit of c by Newton on four segments from 200 settled periods.
TrainOrbit orbit_of(const Case& c) {
  OrbitOptions o;
  o.segments = 4;
  o.settle_periods = 200;
  return find_train_orbit(c, o);
}

TEST(TrainOrbit, ALooseGearsRattlingOrbitClosesAndItsMultipliersAreItsPeriodMaps) {
  // The shipped loose gear at 290 rad/s^2 (a fifth above its onset): an unstable orbit that
  // rattles, found by Newton from the settled rattle on four segments. The rattle is chaotic:
  // which of its unstable orbits Newton finds depends on the settled states it starts from
  // (OrbitOptions::starts).
  const Case c = loose_gear(290);
  const TrainOrbit orbit = orbit_of(c);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  ASSERT_EQ(orbit.coordinates, (std::vector<std::string>{"loose_rad", "loose_rad_s"}));
  EXPECT_NEAR(orbit.period_s, 1.0 / 25, 1e-15);  // the firing order: 2 x 12.5 Hz
  ASSERT_EQ(orbit.impacts_per_period.size(), 1U);
  EXPECT_GE(orbit.impacts_per_period[0], 2);
  EXPECT_FALSE(orbit.stable);
  EXPECT_GT(orbit.max_multiplier(), 2);

  const train::Assembled a = assembled_train(c);
  ode::EngineOptions eo;
  eo.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), eo);
  const Eigen::Vector2d z(orbit.state(1), orbit.state(3));
  const Eigen::Vector2d once = period_map(a, engine, orbit.period_s, z);
  // The orbit closes: to the Newton tolerance on the scaled state (b / R, times w_n for a rate).
  const double angle = 50e-6 / std::abs(a.mesh_vector(0)(1));
  EXPECT_LT(std::abs(once(0) - z(0)) / angle, 1e-8);
  // Central differences of the period map, column by column, against the monodromy.
  double w = 0;
  for (const train::TrainMode& m : train::modes(a))
    w = std::max(w, 2 * std::numbers::pi * m.frequency_hz);
  const Eigen::Vector2d scale(angle, angle * w);
  const Eigen::Matrix2d fd = testing::central_differences(
      [&](const Eigen::VectorXd& x) { return period_map(a, engine, orbit.period_s, x); }, z,
      1e-6 * scale);
  // Compared in the scaled unknowns, where each entry is of order one.
  const Eigen::Matrix2d s = scale.asDiagonal();
  testing::expect_matrix_near(s.inverse() * fd * s, s.inverse() * orbit.monodromy * s, 1e-6, 1e-9);
  // A mutant that leaves out the saltation at the impacts would miss by order one.
}

TEST(TrainOrbit, NewtonStartsAgainFromTheSettledStatesThatFollow) {
  // Settled 200 periods, the loose gear's chaotic rattle at 290 rad/s^2 is where Newton on four
  // segments does not converge; with more starts it starts again one period later each time,
  // and the orbit it finds from start k is the one a single start finds settled k - 1 periods
  // longer. A mutant that restarts from the same state, or from a state a period off, fails
  // one of the two.
  // The engine at the finder's tolerance (the Newton tolerance's 1e-4), so that a flow by hand
  // is the finder's own.
  Case c = loose_gear(290);
  OrbitOptions o;
  c.solver.tolerance = o.tolerance * 1e-4;
  o.segments = 4;
  o.settle_periods = 200;
  o.starts = 1;
  const TrainOrbit once = find_train_orbit(c, o);
  ASSERT_FALSE(once.converged);
  EXPECT_EQ(once.message.find("settled states"), std::string::npos) << once.message;
  o.starts = 16;
  const TrainOrbit again = find_train_orbit(c, o);
  ASSERT_TRUE(again.converged) << again.message;
  const std::size_t at = again.message.find("(start ");
  ASSERT_NE(at, std::string::npos) << again.message;
  int k = 0;
  ASSERT_EQ(std::sscanf(again.message.c_str() + at, "(start %d", &k), 1) << again.message;
  EXPECT_GT(k, 1);
  EXPECT_GE(again.iterations, k);  // every start's iterations count
  // Start k by hand: the settled state, then k - 1 flows of one period, Newton from there. Each
  // flow starts, as the finder's, from the state as the orbits read it (train_orbit_state of
  // its unknowns: the input at its prescription): the rattle is chaotic, and a difference in
  // the last bit grows to order one in 200 periods.
  const TrainSolver solver(c);
  const auto lift = [&](const ode::Vector& y) {
    return train_orbit_state(c, train_orbit_unknowns(c, y));
  };
  ode::Vector y =
      solver.advance(0, lift(solver.initial_state(c.solver.initial)), 200 * again.period_s).state;
  for (int i = 1; i < k; ++i) y = solver.advance(0, lift(y), again.period_s).state;
  o.settle_periods = 0;
  o.starts = 1;
  const TrainOrbit direct = find_train_orbit(c, o, train_orbit_unknowns(c, y));
  ASSERT_TRUE(direct.converged) << direct.message;
  EXPECT_LT(direct.iterations, again.iterations);
  ASSERT_EQ(direct.unknowns.size(), again.unknowns.size());
  for (Eigen::Index i = 0; i < direct.unknowns.size(); ++i)
    EXPECT_NEAR(direct.unknowns(i), again.unknowns(i), 1e-9 * std::abs(direct.unknowns(i)) + 1e-15);
  EXPECT_EQ(direct.impacts_per_period, again.impacts_per_period);
  // Without settling the start is the one start: nothing is said of others.
  o.settle_periods = 0;
  o.starts = 16;
  const TrainOrbit unsettled = find_train_orbit(c, o);
  EXPECT_EQ(unsettled.message.find("settled state"), std::string::npos) << unsettled.message;
}

TEST(TrainOrbit, APlanarLooseGearsMultipliersAreItsPeriodMapsThroughTheImpacts) {
  // The loose gear planar on a bearing (its centre's x and y join the unknowns): the orbit of
  // its rattle at 245 rad/s^2 closes, and its monodromy, with the saltation of every impact
  // through the centre's entries of V, is the period map's central differences on all six
  // unknowns. A mutant that leaves the centre out of the guards' rows or of the saltation
  // misses by order one in those columns.
  Case c = loose_gear(245);
  set_case_value(c, {"train.body[1].dof", "\"planar\""});
  set_case_value(c, {"train.mesh[0].position_angle_deg", "75"});
  set_case_value(c, {"train.bearing", "[{body = \"loose\", stiffness_n_per_m = 1e8}]"});
  const TrainOrbit orbit = orbit_of(c);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  ASSERT_EQ(orbit.coordinates,
            (std::vector<std::string>{"loose_rad", "loose_x_m", "loose_y_m", "loose_rad_s",
                                      "loose_x_m_s", "loose_y_m_s"}));
  EXPECT_GE(orbit.impacts_per_period[0], 2);
  const train::Assembled a = assembled_train(c);
  ode::EngineOptions eo;
  eo.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), eo);
  const Eigen::VectorXd z = orbit.unknowns;
  const auto map = [&](const Eigen::VectorXd& x) {
    return testing::free_period_map(a, engine, orbit.period_s, x);
  };
  double w = 0;
  for (const train::TrainMode& m : train::modes(a))
    w = std::max(w, 2 * std::numbers::pi * m.frequency_hz);
  const double b = 50e-6, angle = b / std::abs(a.mesh_vector(0)(1));
  Eigen::VectorXd scale(6);
  scale << angle, b, b, angle * w, b * w, b * w;
  EXPECT_LT((map(z) - z).cwiseQuotient(scale).norm(), 1e-7);  // it closes
  const Eigen::MatrixXd fd = testing::central_differences(map, z, 1e-6 * scale);
  const Eigen::MatrixXd s = scale.asDiagonal();
  testing::expect_matrix_near(s.inverse() * fd * s, s.inverse() * orbit.monodromy * s, 1e-5, 1e-8);
}

TEST(TrainOrbit, AStableOrbitIsWhereTheRattleSettles) {
  // With more mesh damping (0.02) at 250 rad/s^2 the rattle settles (its flow repeats to 1e-10
  // a period from about the 55th: 0.70 a period) on a stable orbit that chatters, 43 impacts a
  // period (multipliers inside the unit circle, the largest about 0.70): Newton's first start
  // converges, and started a little off the orbit, the flow comes back to it by about that
  // factor each period. (At 0.005 and 255 rad/s^2 a stable orbit of six impacts coexists with
  // the chaotic rattle, which has not settled after 3000 periods: which one Newton finds
  // depends on the last bits of the settled state.)
  Case c = loose_gear(250);
  set_case_value(c, {"train.mesh[0].damping_ratio", "0.02"});
  const TrainOrbit orbit = orbit_of(c);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  EXPECT_EQ(orbit.message.find("(start "), std::string::npos) << orbit.message;
  EXPECT_TRUE(orbit.stable);
  EXPECT_EQ(orbit.impacts_per_period[0], 43);
  EXPECT_NEAR(orbit.max_multiplier(), 0.70, 0.01);
  const train::Assembled a = assembled_train(c);
  ode::EngineOptions eo;
  eo.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), eo);
  const Eigen::Vector2d z(orbit.state(1), orbit.state(3));
  // Distances in the scaled state (b / R, and times w_n for the rate).
  const double angle = 50e-6 / std::abs(a.mesh_vector(0)(1));
  double w = 0;
  for (const train::TrainMode& m : train::modes(a))
    w = std::max(w, 2 * std::numbers::pi * m.frequency_hz);
  const Eigen::Vector2d scale(angle, angle * w);
  const auto distance = [&](const Eigen::Vector2d& x) {
    return (x - z).cwiseQuotient(scale).norm();
  };
  Eigen::Vector2d x = z + Eigen::Vector2d(1e-3 * angle, 0);
  const double start = distance(x);
  for (int k = 0; k < 10; ++k) x = period_map(a, engine, orbit.period_s, x);
  EXPECT_LT(distance(x), 0.1 * start);   // 0.70^10 = 0.028
  EXPECT_GT(distance(x), 1e-3 * start);  // not at once
}

TEST(TrainOrbit, AFreelyTurningPairsRattlingOrbitIsTheOneDegreeModels) {
  // The paper's pair as a train turning freely (a torque on each gear), at a light load whose
  // torque falls to zero once a turn: one impact a period. Taken modulo its rigid rotation, its
  // orbit is the one-degree model's: the same d and d' on the section to 1e-8 b (and b w), and
  // the same two multipliers to 1e-6 (its unknowns, the wheel's angle and rate with the
  // pinion's angle at 0 and the momentum fixed, leave out the rigid rotation's two neutral
  // ones). The whole state returns after a period, angles included: the train turns at its
  // nominal speed on average (the phase condition). A mutant that keeps the momentum of the
  // settled start, or forgets the rigid turn in the wheel's angle, fails.
  const auto [pair, train] = testing::light_pair();
  OrbitOptions o;
  o.settle_periods = 200;
  const Orbit one = find_one_degree_orbit(pair, o);
  const TrainOrbit two = find_train_orbit(train, o);
  ASSERT_TRUE(one.converged) << one.message;
  ASSERT_TRUE(two.converged) << two.message;
  EXPECT_TRUE(two.modulo_rotation);
  EXPECT_EQ(two.coordinates, (std::vector<std::string>{"wheel_rad", "wheel_rad_s"}));
  EXPECT_EQ(two.impacts_per_period[0], 1);
  const train::Assembled a = assembled_train(train);
  const Eigen::RowVectorXd v = a.mesh_vector(0);
  const double b = a.train().meshes[0].backlash_m;
  double w = 0;
  for (const train::TrainMode& m : train::modes(a)) w = std::max(w, 2 * kPi * m.frequency_hz);
  EXPECT_NEAR(v.dot(two.state.head(2)) / b, one.state.q / b, 1e-8);
  EXPECT_NEAR(v.dot(two.state.tail(2)) / (b * w), one.state.v / (b * w), 1e-8);
  ASSERT_EQ(two.multipliers.size(), 2U);
  ASSERT_EQ(one.multipliers.size(), 2U);
  for (std::size_t k = 0; k < 2; ++k)
    EXPECT_LT(std::abs(two.multipliers[k] - one.multipliers[k]), 1e-6) << k;
  // Its contact sequence over the period is the one-degree orbit's: each change's kind, its
  // time from the section and its velocity delta' = d' - e'.
  ASSERT_EQ(two.sequence.size(), one.sequence.size());
  ASSERT_GE(one.sequence.size(), 2U);
  for (std::size_t k = 0; k < one.sequence.size(); ++k) {
    EXPECT_EQ(two.sequence[k].part, 0);
    EXPECT_EQ(two.sequence[k].kind, one.sequence[k].kind) << k;
    EXPECT_NEAR(two.sequence[k].t_s / two.period_s, one.sequence[k].t_s / one.period_s, 1e-8);
    EXPECT_NEAR(two.sequence[k].velocity_m_s / one.sequence[k].velocity_m_s, 1.0, 1e-6) << k;
  }
  EXPECT_EQ(
      two.readings[0].max_impact_velocity_m_s,
      std::abs(two.sequence[0].kind == EventKind::kSeparation ? two.sequence[1].velocity_m_s
                                                              : two.sequence[0].velocity_m_s));
  // A period later the whole state is back: no drift of the rigid rotation.
  ode::EngineOptions eo;
  eo.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), eo);
  ode::FlowObserver nothing;
  const ode::FlowResult r = engine.flow(0.0, two.state, a.classify(0.0, two.state), two.period_s,
                                        ode::OutputGrid{}, nothing);
  ASSERT_TRUE(r.ok()) << r.message;
  const double angle = b / std::abs(v(0));
  EXPECT_LT((r.state.head(2) - two.state.head(2)).lpNorm<Eigen::Infinity>() / angle, 1e-7);
  EXPECT_LT((r.state.tail(2) - two.state.tail(2)).lpNorm<Eigen::Infinity>() / (angle * w), 1e-7);
  EXPECT_EQ(two.state(0), 0.0);  // the pinion's angle is the reference's 0
}

TEST(TrainOrbit, AFreelyTurningTrainsMeanRigidSpeedIsItsNominalOne) {
  // The shipped idler with a fluctuating drive torque alone (the load steady): the torques
  // accelerate the whole train, p' = T_1(t) - mean, so its rigid momentum p = r^T J theta'
  // swings; the orbit holds it at zero on average over the period (trapezoids on 4000 samples,
  // to 1e-6 of its swing), and its monodromy is the period map's central differences. A mutant
  // that drops the torques' part of the momentum, or forgets the rigid turn, fails.
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "idler_train.toml");
  set_case_value(c, {"train.torque[0].harmonics", "[[10, 1, 30]]"});
  OrbitOptions o;
  o.settle_periods = 30;
  const TrainOrbit orbit = find_train_orbit(c, o);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  const train::Assembled a = assembled_train(c);
  const Eigen::VectorXd r = a.rigid_rotation();
  const Eigen::RowVectorXd momentum = r.transpose() * a.mass();
  ode::EngineOptions eo;
  eo.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), eo);
  struct Momentum : ode::FlowObserver {
    Eigen::RowVectorXd row;
    std::vector<double> p;
    void on_sample(double, const ode::Vector& y, int) override {
      p.push_back(row.dot(y.tail(row.size())));
    }
  } seen;
  seen.row = momentum;
  const int samples = 4000;
  (void)engine.flow(0.0, orbit.state, a.classify(0.0, orbit.state), orbit.period_s,
                    ode::make_output_grid(0.0, orbit.period_s, orbit.period_s / samples), seen);
  ASSERT_EQ(seen.p.size(), static_cast<std::size_t>(samples + 1));
  double mean = 0;
  for (std::size_t k = 0; k + 1 < seen.p.size(); ++k) mean += 0.5 * (seen.p[k] + seen.p[k + 1]);
  mean /= samples;
  const auto [lo, hi] = std::minmax_element(seen.p.begin(), seen.p.end());
  EXPECT_GT(*hi - *lo, 0);
  EXPECT_LT(std::abs(mean), 1e-6 * (*hi - *lo));
  // The multipliers against central differences of the period map of the unknowns (the idler's
  // and the driven gear's angles and rates, each counted from the rigid turn that goes with the
  // driver's: with the driver's angle at 0, its rate from the momentum the orbit holds at the
  // section), built here from the state.
  const double p0 = momentum.dot(orbit.state.tail(3));
  const Eigen::Vector3d share = r / r(0);  // each body's turn per turn of the driver
  const auto lift = [&](const Eigen::VectorXd& z) {
    ode::Vector y = ode::Vector::Zero(6);
    const double driver = (p0 - momentum(1) * z(2) - momentum(2) * z(3)) / momentum.dot(share);
    y << 0, z(0), z(1), driver, z(2) + share(1) * driver, z(3) + share(2) * driver;
    return y;
  };
  const auto map = [&](const Eigen::VectorXd& z) {
    ode::FlowObserver nothing;
    const ode::Vector y = lift(z);
    const ode::Vector e =
        engine.flow(0.0, y, a.classify(0.0, y), orbit.period_s, ode::OutputGrid{}, nothing).state;
    return Eigen::Vector4d(e(1) - share(1) * e(0), e(2) - share(2) * e(0), e(4) - share(1) * e(3),
                           e(5) - share(2) * e(3));
  };
  EXPECT_LT((lift(orbit.unknowns) - orbit.state).norm(), 1e-12 * orbit.state.norm());
  double w = 0;
  for (const train::TrainMode& m : train::modes(a)) w = std::max(w, 2 * kPi * m.frequency_hz);
  const double angle = 40e-6 / std::abs(a.mesh_vector(1)(1));
  const Eigen::Vector4d scale(angle, angle, angle * w, angle * w);
  // In contact all period long the map is affine: a step of 1e-3 of the scale keeps it so. The
  // monodromy's entries are some 1e-7 (the response decays by that much over the 30 mesh cycles
  // of a period), and the shooting's engine (at its own tolerance) has them to some 1e-11 of
  // the scaled unit: compared to 1e-9 of it, or 1e-3 of each.
  const Eigen::MatrixXd fd = testing::central_differences(map, orbit.unknowns, 1e-3 * scale);
  const Eigen::MatrixXd d = Eigen::VectorXd(scale).asDiagonal();
  testing::expect_matrix_near(d.inverse() * fd * d, d.inverse() * orbit.monodromy * d, 1e-3, 0,
                              1e-9);
  EXPECT_GT((d.inverse() * orbit.monodromy * d).norm(), 1e-8);  // not nothing
}

TEST(TrainOrbit, AViscousDragKeepsTheRigidRateAnUnknownThatTheOtherRatesFollow) {
  // The light pair as a train with an oil drag on the wheel's speed fluctuation: the drag damps
  // the rigid rate, so the reference's (the pinion's) rate is an unknown beside the wheel's
  // angle and rate, each counted from the rigid turn and rate that go with the pinion's. Its
  // three multipliers are inside the unit circle. The whole state at the section is the unknowns
  // lifted (the wheel's rate its own unknown plus its share of the pinion's), and taking the
  // unknowns of that state gives it back. A mutant whose lift leaves out the wheel's share of the
  // pinion's rate fails both.
  Case train = testing::light_pair().second;
  set_case_value(train, {"train.drag",
                         "[{name = \"oil\", body = \"wheel\", "
                         "viscous_n_m_s_per_rad = 0.01}]"});
  OrbitOptions o;
  o.settle_periods = 200;
  const TrainOrbit orbit = find_train_orbit(train, o);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  EXPECT_TRUE(orbit.modulo_rotation);
  ASSERT_EQ(orbit.coordinates,
            (std::vector<std::string>{"wheel_rad", "pinion_rad_s", "wheel_rad_s"}));
  ASSERT_EQ(orbit.multipliers.size(), 3U);
  EXPECT_LT(orbit.max_multiplier(), 1);
  const train::Assembled a = assembled_train(train);
  const Eigen::VectorXd r = a.rigid_motions().col(0);
  const int pinion = a.index("pinion"), wheel = a.index("wheel"), n = a.size();
  const double share = r(wheel) / r(pinion);
  EXPECT_EQ(orbit.state(pinion), 0);
  EXPECT_NEAR(orbit.state(wheel), orbit.unknowns(0), 1e-15);
  EXPECT_NEAR(orbit.state(n + pinion), orbit.unknowns(1), 1e-15);
  EXPECT_NEAR(orbit.state(n + wheel), orbit.unknowns(2) + share * orbit.unknowns(1),
              1e-12 * std::abs(orbit.state(n + wheel)) + 1e-15);
  EXPECT_GT(std::abs(orbit.unknowns(1)), 1e-6 * std::abs(orbit.unknowns(2)));  // not nothing
  const ode::Vector back = train_orbit_state(train, train_orbit_unknowns(train, orbit.state));
  EXPECT_LT((back - orbit.state).norm(), 1e-12 * orbit.state.norm());
}

TEST(TrainOrbit, NewtonStartsWhereItIsToldAndFindsTheSameOrbit) {
  // The loose gear's unstable rattle (above): from its own unknowns Newton has nothing to do;
  // from a start 1e-4 of the section's scale away (no settling: an unstable orbit that the run
  // leaves) it converges back onto the same orbit. A start of another size is refused by name.
  const Case c = loose_gear(290);
  const TrainOrbit orbit = orbit_of(c);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  ASSERT_EQ(orbit.unknowns.size(), 2);
  OrbitOptions o;
  o.segments = 4;
  o.settle_periods = 0;
  const TrainOrbit same = find_train_orbit(c, o, orbit.unknowns);
  ASSERT_TRUE(same.converged) << same.message;
  EXPECT_LE(same.iterations, 1);
  const train::Assembled a = assembled_train(c);
  const double angle = 50e-6 / std::abs(a.mesh_vector(0)(1));
  ode::Vector near = orbit.unknowns;
  near(0) += 1e-4 * angle;
  const TrainOrbit back = find_train_orbit(c, o, near);
  ASSERT_TRUE(back.converged) << back.message;
  EXPECT_GE(back.iterations, 1);
  EXPECT_NEAR(back.unknowns(0), orbit.unknowns(0), 1e-7 * angle);
  EXPECT_EQ(back.impacts_per_period, orbit.impacts_per_period);
  try {
    (void)find_train_orbit(c, o, ode::Vector::Zero(3));
    ADD_FAILURE() << "a start of three values was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--state: 3 values given; this train takes 2"),
              std::string::npos)
        << e.what();
  }
}

TEST(TrainOrbit, WhatHasNoOrbitSaysWhy) {
  // A train that turns freely with mean torques that do not balance speeds up: no orbit.
  Case reducer =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "two_stage_reducer.toml");
  set_case_value(reducer, {"train.torque[1].balances", "false"});
  set_case_value(reducer, {"train.torque[1].mean_nm", "-1000"});
  try {
    (void)find_train_orbit(reducer, OrbitOptions{});
    ADD_FAILURE() << "an orbit of a train that speeds up was sought";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("turns freely and has no periodic orbit"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("do not balance"), std::string::npos) << e.what();
  }
  // Quasi-periodic: an order of sqrt(2) has no common period with the firing order.
  Case quasi = loose_gear(300);
  set_case_value(quasi, {"train.speed[0].acceleration_harmonics",
                         "[[300, 2, 0], [50, 1.4142135623730951, 0]]"});
  try {
    (void)find_train_orbit(quasi, OrbitOptions{});
    ADD_FAILURE() << "an orbit of a quasi-periodic train was sought";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no periodic orbit"), std::string::npos) << e.what();
  }
}

TEST(TrainOrbit, TheCoupledPairsOrbitAsItsTrainIsTheCoupledModels) {
  // The coupled pair at dof 3 with clearance bearings that open and close within the period
  // (CoupledOrbit.TheMonodromyThroughBearingClearancesIsTheFlowMapsDerivative): as its train
  // (the gears held to the line of action, the rigid rotation a coordinate) the orbit is the
  // coupled model's, an independent assembly: the same impacts of the mesh and of each
  // clearance per period, and (d - e)/b's exact extremes and the multipliers to 1e-6.
  const Case c = testing::coupled_with_clearances();
  OrbitOptions o;
  o.settle_periods = 300;
  const CoupledOrbit one = find_coupled_orbit(c, o);
  ASSERT_TRUE(one.converged) << one.message;
  const TrainOrbit x = find_train_orbit(c, o);
  ASSERT_TRUE(x.converged) << x.message;
  EXPECT_EQ(x.impacts_per_period[0], one.reading.mesh.impacts);
  EXPECT_EQ(x.clearances, (std::vector<std::string>{"pinion_bearing_y", "wheel_bearing_y"}));
  ASSERT_EQ(x.clearance_readings.size(), 2U);
  for (std::size_t k = 0; k < 2; ++k)
    EXPECT_EQ(x.clearance_readings[k].impacts, one.reading.bearing[k].impacts) << k;
  const double b = one.reading.parameters.backlash_m;
  EXPECT_NEAR(x.readings[0].min_deflection_m / b, one.reading.min_deflection_m / b, 1e-6);
  EXPECT_NEAR(x.readings[0].max_deflection_m / b, one.reading.max_deflection_m / b, 1e-6);
  // Modulo the rigid rotation at its mean speed (the phase condition) the unknowns are as many
  // as the coupled model's coordinates and rates, and so are the multipliers.
  ASSERT_EQ(x.multipliers.size(), one.multipliers.size());
  for (std::size_t k = 0; k < x.multipliers.size(); ++k)
    EXPECT_LT(std::abs(x.multipliers[k] - one.multipliers[k]), 1e-6) << k;
  // The JSON's readings are these.
  const nlohmann::json j = nlohmann::json::parse(train_orbit_json(x));
  EXPECT_EQ(j["clearances"][1]["impacts_per_period"], one.reading.bearing[1].impacts);
  EXPECT_EQ(j["meshes"][0]["max_deflection_bar"].get<double>(), x.readings[0].max_deflection_m / b);
  // Each part's sequence holds its impacts and separations of the period, in time order within
  // the period.
  const auto expect_sequence = [&](const nlohmann::json& part, std::int64_t impacts,
                                   std::int64_t separations) {
    std::int64_t hits = 0, leaves = 0;
    double last = 0;
    for (const nlohmann::json& e : part["sequence"]) {
      (e["event"] == "separation" ? leaves : hits) += 1;
      EXPECT_GE(e["t_s"].get<double>(), last);
      last = e["t_s"].get<double>();
    }
    EXPECT_LE(last, x.period_s);
    EXPECT_EQ(hits, impacts) << part["name"];
    EXPECT_EQ(leaves, separations) << part["name"];
  };
  expect_sequence(j["meshes"][0], x.impacts_per_period[0], x.readings[0].separations);
  for (std::size_t k = 0; k < 2; ++k)
    expect_sequence(j["clearances"][k], x.clearance_readings[k].impacts,
                    x.clearance_readings[k].separations);
  EXPECT_GT(j["clearances"][0]["sequence"].size(), 0U);
}

}  // namespace
}  // namespace geardyn
