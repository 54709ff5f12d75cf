// Periodic orbits of gear trains (train_orbit.hpp): the orbit closes, and its monodromy matrix
// (the exact Jacobian with saltation at every impact) is the period map's central differences.
#include "geardyn/train_orbit.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include "geardyn/case.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/train_case.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

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
  // rattles (its largest multiplier above 10), found by Newton from the settled rattle on four
  // segments.
  const Case c = loose_gear(290);
  const TrainOrbit orbit = orbit_of(c);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  ASSERT_EQ(orbit.coordinates, (std::vector<std::string>{"loose_rad", "loose_rad_s"}));
  EXPECT_NEAR(orbit.period_s, 1.0 / 25, 1e-15);  // the firing order: 2 x 12.5 Hz
  ASSERT_EQ(orbit.impacts_per_period.size(), 1U);
  EXPECT_GE(orbit.impacts_per_period[0], 2);
  EXPECT_FALSE(orbit.stable);
  EXPECT_GT(orbit.max_multiplier(), 10);

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
  // With less mesh damping (0.005) at 255 rad/s^2 the rattle settles on a stable orbit of six
  // impacts per period (multipliers inside the unit circle, the largest about 0.94): started a
  // little off it, the flow comes back to it, by about that factor each period.
  Case c = loose_gear(255);
  set_case_value(c, {"train.mesh[0].damping_ratio", "0.005"});
  const TrainOrbit orbit = orbit_of(c);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  EXPECT_TRUE(orbit.stable);
  EXPECT_EQ(orbit.impacts_per_period[0], 6);
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
  for (int k = 0; k < 100; ++k) x = period_map(a, engine, orbit.period_s, x);
  EXPECT_LT(distance(x), 0.1 * start);
  EXPECT_GT(distance(x), 1e-6 * start);  // not at once: the largest multiplier is near 1
}

TEST(TrainOrbit, WhatHasNoOrbitSaysWhy) {
  // A train that turns freely (no prescribed speed): its orbits form a family.
  const Case reducer =
      load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "two_stage_reducer.toml");
  try {
    (void)find_train_orbit(reducer, OrbitOptions{});
    ADD_FAILURE() << "an orbit of a freely turning train was sought";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no body of this train has a prescribed speed"),
              std::string::npos)
        << e.what();
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

}  // namespace
}  // namespace geardyn
