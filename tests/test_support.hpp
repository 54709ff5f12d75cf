// Helpers shared by the tests.
#pragma once

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/train.hpp"
#include "geardyn/validation.hpp"

namespace geardyn::testing {

// A spur stage as [[train.body]] and [[train.mesh]] tables: gear "input" (30 teeth, 4e-3 kg m^2)
// driving gear "output" (45 teeth, 0.02 kg m^2), module 2.5 mm, mesh "gears" of 3e8 N/m with a
// backlash of 50 um and the damping ratio given: the gearbox the element tests put an element
// before or after.
inline std::string spur_stage_toml(double mesh_damping_ratio) {
  return R"(
[[train.body]]
name = "input"
teeth = 30
normal_module_mm = 2.5
inertia_kg_m2 = 0.004
[[train.body]]
name = "output"
teeth = 45
normal_module_mm = 2.5
inertia_kg_m2 = 0.02
[[train.mesh]]
name = "gears"
driving = "input"
driven = "output"
backlash_um = 50
mean_stiffness_n_per_m = 3e8
damping_ratio = )" +
         fmt::format("{}", mesh_damping_ratio) + "\n";
}

// The message of the InputError that `f` throws, or "" if it throws none.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The default case (Park 2010's Table 1 pair) as the coupled model with `dof` kept.
inline Case coupled(int dof) {
  Case c;
  c.model.form = ModelForm::kCoupled;
  c.model.dof = dof;
  return c;
}

// The coupled model with dof 3 at f_1 = 600 Hz, its bearings with radial clearances of 5 um that
// open and close within a period of its orbit (two impacts each).
inline Case coupled_with_clearances() {
  Case c = coupled(3);
  c.bearings.radial_clearance_um = {5, 5};
  c.speed.shaft_frequency_hz = 600;
  return c;
}

// The paper's pair at a light load whose torque falls to zero once a turn (5 N m, fluctuating
// fully: one impact a period), as the one-degree model (first) and as a train turning freely
// with a torque on each gear (second).
inline std::pair<Case, Case> light_pair() {
  Case pair = park2010_pair_case();
  Case train = park2010_pair_as_train();
  set_case_value(pair, {"load.torque_nm", "5"});
  set_case_value(pair, {"load.fluctuation_ratio", "1"});
  set_case_value(train, {"train.torque",
                         "[{body = \"pinion\", mean_nm = 5, harmonics = [[5, 1, 0]]}, "
                         "{body = \"wheel\", mean_nm = -5, harmonics = [[5, 1, 180]]}]"});
  return {pair, train};
}

// Central differences of `map` at z, column j by the step steps(j).
template <class Map>
Eigen::MatrixXd central_differences(const Map& map, const Eigen::VectorXd& z,
                                    const Eigen::VectorXd& steps) {
  Eigen::MatrixXd fd(z.size(), z.size());
  for (Eigen::Index j = 0; j < z.size(); ++j) {
    Eigen::VectorXd e = Eigen::VectorXd::Zero(z.size());
    e(j) = steps(j);
    fd.col(j) = (map(z + e) - map(z - e)) / (2 * steps(j));
  }
  return fd;
}

// Expects every entry of `approximate` within relative |exact(i, j)| + absolute ||exact|| +
// floor of exact's (in units where the state's entries are of order one; floor for a matrix
// whose entries are all far below one), printing both matrices if not.
inline void expect_matrix_near(const Eigen::MatrixXd& approximate, const Eigen::MatrixXd& exact,
                               double relative, double absolute, double floor = 0) {
  for (Eigen::Index i = 0; i < exact.rows(); ++i)
    for (Eigen::Index j = 0; j < exact.cols(); ++j)
      EXPECT_NEAR(approximate(i, j), exact(i, j),
                  relative * std::abs(exact(i, j)) + absolute * exact.norm() + floor)
          << i << ", " << j << "\nexact\n"
          << exact << "\napproximate\n"
          << approximate;
}

// A train's period map on its free bodies (those without a prescribed speed): their angles
// then their rates, z, at t = 0, the prescribed bodies as prescribed, flown over `period` by
// `engine` (the test's own); the free bodies' state at its end.
inline Eigen::VectorXd free_period_map(const train::Assembled& a, const ode::ExactEngine& engine,
                                       double period, const Eigen::VectorXd& z) {
  const int n = a.size();
  std::vector<int> free;
  for (int i = 0; i < n; ++i)
    if (!a.prescribed(i)) free.push_back(i);
  const auto f = static_cast<Eigen::Index>(free.size());
  ode::Vector y = ode::Vector::Zero(2 * n);
  for (Eigen::Index k = 0; k < f; ++k) {
    y(free[static_cast<std::size_t>(k)]) = z(k);
    y(n + free[static_cast<std::size_t>(k)]) = z(f + k);
  }
  a.prescribe(0.0, y);
  ode::FlowObserver nothing;
  const ode::FlowResult r =
      engine.flow(0.0, y, a.classify(0.0, y), period, ode::OutputGrid{}, nothing);
  EXPECT_TRUE(r.ok()) << r.message;
  Eigen::VectorXd out(2 * f);
  for (Eigen::Index k = 0; k < f; ++k) {
    out(k) = r.state(free[static_cast<std::size_t>(k)]);
    out(f + k) = r.state(n + free[static_cast<std::size_t>(k)]);
  }
  return out;
}

// A mesh of constant stiffness and no damping between `driving` and `driven`.
inline train::Mesh mesh(const std::string& name, const std::string& driving,
                        const std::string& driven, std::array<int, 2> teeth,
                        std::array<double, 2> base_radius_m, double backlash_m,
                        double stiffness_n_per_m) {
  train::Mesh m;
  m.name = name;
  m.driving = driving;
  m.driven = driven;
  m.teeth_driving = teeth[0];
  m.teeth_driven = teeth[1];
  m.base_radius_driving_m = base_radius_m[0];
  m.base_radius_driven_m = base_radius_m[1];
  m.backlash_m = backlash_m;
  m.mean_stiffness_n_per_m = stiffness_n_per_m;
  return m;
}

}  // namespace geardyn::testing
