// Floquet stability in permanent contact (stability.hpp): the damped Mathieu equation
// x'' + 2 zeta x' + (1 + eps cos(Omega t)) x = 0 (the non-dimensional form with one stiffness
// harmonic, kappa_1 = eps). Its first (principal) tongue's boundaries against an independent
// Hill determinant; the monodromy of constant stiffness against exp(A T); bad input.
#include "geardyn/stability.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <boost/math/tools/toms748_solve.hpp>
#include <cmath>
#include <complex>
#include <map>
#include <numbers>
#include <unsupported/Eigen/MatrixFunctions>

#include "geardyn/coupled_model.hpp"
#include "geardyn/run.hpp"

namespace {

using geardyn::BifurcationType;
using geardyn::Case;
using geardyn::StabilityOptions;

Case mathieu(double zeta, double eps) {
  Case c;
  c.model.form = geardyn::ModelForm::kNondimensional;
  c.model.zeta = zeta;
  c.model.force_mean = 1.0;
  c.model.force_alternating = 0.0;
  c.model.omega = 2.0;
  if (eps > 0) c.model.stiffness_harmonics = {{eps, 0.0}};
  return c;
}

// Hill's determinant of the solutions of period 2T (multiplier -1): x = sum over odd k of
// a_k cos(k theta) + b_k sin(k theta), theta = Omega t / 2, truncated at kHarmonics odd
// harmonics. Independent of geardyn: the harmonic balance of the equation, in real form.
constexpr int kHarmonics = 40;
double hill_determinant(double zeta, double eps, double omega) {
  const int n = kHarmonics;
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  const double w = omega / 2;
  for (int i = 0; i < n; ++i) {
    const int k = 2 * i + 1;
    const double diag = 1 - k * k * w * w;
    h(2 * i, 2 * i) = diag;                  // cos row, a_k
    h(2 * i, 2 * i + 1) = 2 * zeta * k * w;  // cos row, b_k (from 2 zeta x')
    h(2 * i + 1, 2 * i + 1) = diag;          // sin row, b_k
    h(2 * i + 1, 2 * i) = -2 * zeta * k * w;
    // eps cos(2 theta) couples k with k +- 2; k = 1 also with itself (cos(-theta) = cos theta,
    // sin(-theta) = -sin theta).
    if (i > 0) {
      h(2 * i, 2 * (i - 1)) += eps / 2;
      h(2 * i + 1, 2 * (i - 1) + 1) += eps / 2;
    }
    if (i + 1 < n) {
      h(2 * i, 2 * (i + 1)) += eps / 2;
      h(2 * i + 1, 2 * (i + 1) + 1) += eps / 2;
    }
    if (i == 0) {
      h(0, 0) += eps / 2;
      h(1, 1) -= eps / 2;
    }
  }
  return h.determinant();
}

// The Hill determinant's root in [a, b].
double hill_root(double zeta, double eps, double a, double b) {
  std::uintmax_t it = 200;
  const auto f = [&](double w) { return hill_determinant(zeta, eps, w); };
  const auto r = boost::math::tools::toms748_solve(
      f, a, b, [](double x, double y) { return std::abs(x - y) < 1e-14; }, it);
  return 0.5 * (r.first + r.second);
}

TEST(Stability, MathieuPrincipalTongueMatchesTheHillDeterminant) {
  for (const auto& [zeta, eps] :
       {std::pair{0.0, 0.2}, std::pair{0.01, 0.2}, std::pair{0.02, 0.5}, std::pair{0.05, 0.4}}) {
    StabilityOptions o;
    o.axis = {"model.omega", 1.5, 2.5, 41};
    const auto r = geardyn::stability(mathieu(zeta, eps), o);
    std::vector<double> pd;
    for (const auto& b : r.boundaries)
      if (b.type == BifurcationType::kPeriodDoubling) pd.push_back(b.param);
    ASSERT_EQ(pd.size(), 2U) << "zeta " << zeta << ", eps " << eps;
    // Hill: the two roots around Omega = 2 (the tongue's edges, bracketed by the samples).
    const double left = hill_root(zeta, eps, pd[0] - 0.02, pd[0] + 0.02);
    const double right = hill_root(zeta, eps, pd[1] - 0.02, pd[1] + 0.02);
    EXPECT_NEAR(pd[0], left, 1e-8) << "zeta " << zeta << ", eps " << eps;
    EXPECT_NEAR(pd[1], right, 1e-8) << "zeta " << zeta << ", eps " << eps;
    // Inside the tongue unstable, outside stable.
    for (const auto& s : r.samples)
      EXPECT_EQ(s.stable, s.param < pd[0] || s.param > pd[1]) << "Omega " << s.param;
  }
}

TEST(Stability, DampingNarrowsTheTongueAndClosesIt) {
  // With zeta large enough against eps the principal tongue vanishes: no boundary at all.
  StabilityOptions o;
  o.axis = {"model.omega", 1.5, 2.5, 41};
  const auto r = geardyn::stability(mathieu(0.1, 0.2), o);
  EXPECT_TRUE(r.boundaries.empty());
  for (const auto& s : r.samples) EXPECT_TRUE(s.stable);
}

TEST(Stability, ChartOverTheHarmonicAmplitudeOpensThePrincipalTongue) {
  // zeta 0.02: at eps 0.06 the principal tongue is closed (it opens near eps = 4 zeta), at
  // eps 0.12 and 0.2 open and wider with eps. The second key addresses the harmonic's amplitude
  // inside its array.
  StabilityOptions o;
  o.axis = {"model.omega", 1.5, 2.5, 41};
  o.axis2 = geardyn::SweepAxis{"model.stiffness_harmonics[0][0]", 0.06, 0.2, 0};
  o.axis2->explicit_values = {0.06, 0.12, 0.2};
  o.axis2->points = 3;
  const auto r = geardyn::stability(mathieu(0.02, 0.1), o);
  ASSERT_EQ(r.samples.size(), 3U * 41U);
  std::map<double, std::vector<double>> rows;
  for (const auto& b : r.boundaries) rows[b.param2].push_back(b.param);
  EXPECT_EQ(rows.count(0.06), 0U);
  ASSERT_EQ(rows[0.12].size(), 2U);
  ASSERT_EQ(rows[0.2].size(), 2U);
  EXPECT_LT(rows[0.2][0], rows[0.12][0]);
  EXPECT_GT(rows[0.2][1], rows[0.12][1]);
  // The row at eps 0.2 is the 1-D result at eps 0.2.
  StabilityOptions one;
  one.axis = o.axis;
  const auto r1 = geardyn::stability(mathieu(0.02, 0.2), one);
  ASSERT_EQ(r1.boundaries.size(), 2U);
  EXPECT_EQ(r1.boundaries[0].param, rows[0.2][0]);
  EXPECT_EQ(r1.boundaries[1].param, rows[0.2][1]);
}

TEST(Stability, ConstantStiffnessMonodromyIsTheMatrixExponential) {
  // Without stiffness harmonics: Phi(T) = exp(A T), A = [[0, 1], [-1, -2 zeta]], T = 2 pi / Omega
  // (the period of the torque, F_a > 0).
  Case c = mathieu(0.05, 0.0);
  c.model.force_alternating = 0.1;
  c.model.omega = 1.3;
  const geardyn::ode::Matrix m = geardyn::contact_monodromy(c);
  const double T = 2 * std::numbers::pi / 1.3;
  Eigen::Matrix2d a;
  a << 0, 1, -1, -0.1;
  const Eigen::Matrix2d e = (a * T).exp();
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) EXPECT_NEAR(m(i, j), e(i, j), 1e-13);
}

// The coupled model's contact monodromy by a classical RK4 of y' = A(t) y over the mesh
// period, A(t) from the system's own definition of the drive-contact region (ode::derivative
// of the homogeneous part), 4000 steps: independent of the exact engine's cells.
geardyn::ode::Matrix rk4_contact_monodromy(const Case& c) {
  const geardyn::CoupledModel model(geardyn::coupled_parameters(c));
  const geardyn::ode::LinearSwitchedSystem sys = model.linear_system();
  const int region = geardyn::coupled_region({geardyn::kDriveContact, {0, 0}});
  const Eigen::Index n = sys.dimension;
  const double T = sys.coefficient_period_s;
  const int steps = 4000;
  const double h = T / steps;
  const auto f = [&](double t, const geardyn::ode::Vector& y) -> geardyn::ode::Vector {
    return geardyn::ode::derivative(sys, region, t, y) -
           geardyn::ode::derivative(sys, region, t, geardyn::ode::Vector::Zero(n));
  };
  geardyn::ode::Matrix phi(n, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    geardyn::ode::Vector y = geardyn::ode::Vector::Unit(n, j);

    for (int k = 0; k < steps; ++k) {
      const double t = k * h;
      const geardyn::ode::Vector k1 = f(t, y), k2 = f(t + h / 2, y + h / 2 * k1),
                                 k3 = f(t + h / 2, y + h / 2 * k2), k4 = f(t + h, y + h * k3);
      y += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    phi.col(j) = y;
  }
  return phi;
}

TEST(Stability, TheCoupledModelsPrincipalTongueIsThatOfAnIndependentMonodromy) {
  // The Table 1 pair on its bearings, dof 3, one stiffness harmonic of 0.1, light damping
  // (0.005): the mesh-critical mode at 3357 Hz opens its principal tongue where the mesh
  // frequency is near twice it (56 f_1 = 2 x 3357 Hz, f_1 = 119.9 Hz). The contact monodromy
  // equals an RK4 integration's to 1e-8 at samples, and at each located boundary the RK4
  // monodromy's det(Phi + I) changes sign within 1e-6 of it.
  Case c = geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010_coupled.toml");
  c.model.dof = 3;
  c.mesh.stiffness_source = geardyn::StiffnessSource::kHarmonics;
  c.mesh.stiffness_harmonics = {{0.1, 0.0}};
  c.mesh.damping_ratio = 0.005;
  c.bearings.damping_ratio = 0.005;
  for (const double f1 : {110.0, 120.0}) {
    Case at = c;
    at.speed.shaft_frequency_hz = f1;
    const geardyn::ode::Matrix exact = geardyn::contact_monodromy(at);
    const geardyn::ode::Matrix rk4 = rk4_contact_monodromy(at);
    EXPECT_LT((exact - rk4).cwiseAbs().maxCoeff(), 1e-8 * rk4.cwiseAbs().maxCoeff()) << f1;
  }
  StabilityOptions o;
  o.axis = {"speed.shaft_frequency_hz", 100, 140, 41, false};
  const geardyn::StabilityResult r = geardyn::stability(c, o);
  ASSERT_EQ(r.boundaries.size(), 2U);
  EXPECT_NEAR(r.boundaries[0].param, 117.18, 0.01);  // docs/orbits.md
  EXPECT_NEAR(r.boundaries[1].param, 122.56, 0.01);
  for (const auto& b : r.boundaries) {
    EXPECT_EQ(b.type, BifurcationType::kPeriodDoubling);
    double det[2];
    for (int side = 0; side < 2; ++side) {
      Case at = c;
      at.speed.shaft_frequency_hz = b.param * (side == 0 ? 1 - 1e-6 : 1 + 1e-6);
      const geardyn::ode::Matrix phi = rk4_contact_monodromy(at);
      det[side] = (phi + geardyn::ode::Matrix::Identity(phi.rows(), phi.cols())).determinant();
    }
    EXPECT_LT(det[0] * det[1], 0) << b.param;
  }
  // Between them the motion is unstable, outside it is stable.
  for (const auto& s : r.samples) EXPECT_EQ(s.stable, s.param < 117.18 || s.param > 122.56);
}

TEST(Stability, EachSampleIsItsCasesOwnWhetherTheStiffnessIsSharedOrNot) {
  // A study computes the energy method's curve once when its keys leave it alone
  // (shared_stiffness). Along f_1 (shared) and along the face width (each value its own), every
  // sample's multipliers are those of the case at that value computed alone, bit for bit: a
  // curve shared along the face width would keep the first width's.
  const Case c = geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010.toml");
  EXPECT_TRUE(geardyn::shared_stiffness(c, {"speed.shaft_frequency_hz"}));
  EXPECT_FALSE(geardyn::shared_stiffness(c, {"speed.shaft_frequency_hz", "gear.face_width_mm"}));
  EXPECT_FALSE(geardyn::shared_stiffness(mathieu(0.02, 0.1), {"model.omega"}));
  for (const geardyn::SweepAxis& axis :
       {geardyn::SweepAxis{"speed.shaft_frequency_hz", 600, 3000, 4, false},
        geardyn::SweepAxis{"gear.face_width_mm", 15, 25, 4, false}}) {
    StabilityOptions o;
    o.axis = axis;
    const geardyn::StabilityResult r = geardyn::stability(c, o);
    ASSERT_EQ(r.samples.size(), 4U);
    std::vector<double> moduli;
    for (const geardyn::StabilitySample& s : r.samples) {
      Case at = c;
      geardyn::set_case_value(at, {axis.key, fmt::format("{:.17g}", s.param)});
      const Eigen::EigenSolver<geardyn::ode::Matrix> eig(geardyn::contact_monodromy(at), false);
      EXPECT_EQ(s.max_multiplier, eig.eigenvalues().cwiseAbs().maxCoeff()) << axis.key << s.param;
      moduli.push_back(s.max_multiplier);
    }
    EXPECT_NE(moduli.front(), moduli.back()) << axis.key;  // the key moves the multipliers
  }
}

TEST(Stability, BadInputIsRejectedWithItsReason) {
  StabilityOptions o;
  o.axis = {"model.omega", 1.5, 2.5, 1};
  try {
    (void)geardyn::stability(mathieu(0.0, 0.2), o);
    ADD_FAILURE() << "one point accepted";
  } catch (const geardyn::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--points = 1"), std::string::npos) << e.what();
  }
}

}  // namespace
