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

TEST(TrainOrbit, ALooseGearsRattlingOrbitClosesAndItsMultipliersAreItsPeriodMaps) {
  // The shipped loose gear at 290 rad/s^2 (a fifth above its onset): an unstable orbit that
  // rattles (its largest multiplier above 10), found by Newton from the settled rattle on four
  // segments.
  const Case c = loose_gear(290);
  OrbitOptions o;
  o.segments = 4;
  o.settle_periods = 200;
  const TrainOrbit orbit = find_train_orbit(c, o);
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
  const Eigen::Vector2d step(1e-6 * angle, 1e-6 * angle * w);
  Eigen::Matrix2d fd;
  for (int j = 0; j < 2; ++j) {
    Eigen::Vector2d e = Eigen::Vector2d::Zero();
    e(j) = step(j);
    fd.col(j) = (period_map(a, engine, orbit.period_s, z + e) -
                 period_map(a, engine, orbit.period_s, z - e)) /
                (2 * step(j));
  }
  // Compared in the scaled unknowns, where each entry is of order one.
  const Eigen::Matrix2d s = Eigen::Vector2d(angle, angle * w).asDiagonal();
  const Eigen::Matrix2d exact = s.inverse() * orbit.monodromy * s, central = s.inverse() * fd * s;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      EXPECT_NEAR(central(i, j), exact(i, j), 1e-6 * std::abs(exact(i, j)) + 1e-9 * exact.norm())
          << i << ", " << j << "\nexact\n"
          << exact << "\ncentral\n"
          << central;
  // A mutant that leaves out the saltation at the impacts would miss by order one.
}

TEST(TrainOrbit, AStableOrbitIsWhereTheRattleSettles) {
  // With less mesh damping (0.005) at 255 rad/s^2 the rattle settles on a stable orbit of six
  // impacts per period (multipliers inside the unit circle, the largest about 0.94): started a
  // little off it, the flow comes back to it, by about that factor each period.
  Case c = loose_gear(255);
  set_case_value(c, {"train.mesh[0].damping_ratio", "0.005"});
  OrbitOptions o;
  o.segments = 4;
  o.settle_periods = 200;
  const TrainOrbit orbit = find_train_orbit(c, o);
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
