// Floquet stability in permanent contact (stability.hpp): the damped Mathieu equation
// x'' + 2 zeta x' + (1 + eps cos(Omega t)) x = 0 (the non-dimensional form with one stiffness
// harmonic, kappa_1 = eps). Its first (principal) tongue's boundaries against an independent
// Hill determinant; the monodromy of constant stiffness against exp(A T); bad input.
#include "geardyn/stability.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <boost/math/tools/toms748_solve.hpp>
#include <cmath>
#include <complex>
#include <map>
#include <numbers>
#include <optional>
#include <unsupported/Eigen/MatrixFunctions>

#include "geardyn/coupled_model.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/validation.hpp"
#include "test_support.hpp"

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

// The multipliers of a monodromy, by modulus then argument.
std::vector<std::complex<double>> sorted_multipliers(const geardyn::ode::Matrix& m) {
  std::vector<std::complex<double>> mu = geardyn::floquet_multipliers(m);
  std::sort(mu.begin(), mu.end(), [](std::complex<double> a, std::complex<double> b) {
    return std::abs(a) != std::abs(b) ? std::abs(a) < std::abs(b) : std::arg(a) < std::arg(b);
  });
  return mu;
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

// The shipped pair on its bearings at dof 3 in contact, one stiffness harmonic of 0.1, the
// mesh's and the bearings' damping ratios `damping`.
Case shipped_pair_one_harmonic(double damping) {
  Case c = geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010_coupled.toml");
  c.model.dof = 3;
  c.mesh.stiffness_source = geardyn::StiffnessSource::kHarmonics;
  c.mesh.stiffness_harmonics = {{0.1, 0.0}};
  c.mesh.damping_ratio = damping;
  c.bearings.damping_ratio = damping;
  return c;
}

TEST(Stability, TheCoupledModelsPrincipalTongueIsThatOfAnIndependentMonodromy) {
  // The Table 1 pair on its bearings, dof 3, one stiffness harmonic of 0.1, light damping
  // (0.005): the mesh-critical mode at 3357 Hz opens its principal tongue where the mesh
  // frequency is near twice it (56 f_1 = 2 x 3357 Hz, f_1 = 119.9 Hz). The study reads the
  // pair as its train (train_form_of: the gears held to the line of action, the rigid rotation
  // a coordinate), whose elastic contact monodromy has the multipliers of an RK4 integration of
  // the coupled model's (u, y1, y2), an independent assembly and integrator, to 1e-8 of the
  // largest at samples; and at each located boundary the RK4 monodromy's det(Phi + I) changes
  // sign within 1e-6 of it.
  const Case c = shipped_pair_one_harmonic(0.005);
  for (const double f1 : {110.0, 120.0}) {
    Case at = c;
    at.speed.shaft_frequency_hz = f1;
    const std::vector<std::complex<double>> exact =
        sorted_multipliers(geardyn::elastic_contact_monodromy(at));
    const std::vector<std::complex<double>> rk4 = sorted_multipliers(rk4_contact_monodromy(at));
    ASSERT_EQ(exact.size(), rk4.size());
    for (std::size_t i = 0; i < rk4.size(); ++i)
      EXPECT_LT(std::abs(exact[i] - rk4[i]), 1e-8 * std::abs(rk4.back())) << f1 << " " << i;
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

TEST(Stability, AnUndampedCombinationTongueIsThatOfAnIndependentMonodromy) {
  // The same pair undamped: where the mesh frequency is near the sum of the first and the
  // mesh-critical mode's (56 f_1 = 971 + 3357 Hz at 77.3 Hz) a complex pair leaves the unit
  // circle (a quadruple mu, 1/mu and their conjugates: no sign change of |mu| - 1, which the
  // boundary test's margin turns into one). Outside the tongue every multiplier lies on the
  // circle: to 1e-12 on the balanced monodromy (unbalanced, the eigenvalues' errors of ~1e-9
  // made noise look like boundaries). Each located boundary is checked on the RK4 monodromy:
  // stable 1e-3 Hz outside, unstable 1e-3 Hz inside.
  const Case c = shipped_pair_one_harmonic(0.0);
  StabilityOptions o;
  o.axis = {"speed.shaft_frequency_hz", 70, 85, 31, false};
  const geardyn::StabilityResult r = geardyn::stability(c, o);
  ASSERT_EQ(r.boundaries.size(), 2U);
  const double lo = r.boundaries[0].param, hi = r.boundaries[1].param;
  EXPECT_NEAR(lo, 76.84, 0.01);  // docs/orbits.md
  EXPECT_NEAR(hi, 77.61, 0.01);
  for (const auto& b : r.boundaries) EXPECT_EQ(b.type, BifurcationType::kNeimarkSacker);
  for (const auto& s : r.samples) {
    EXPECT_EQ(s.stable, s.param < lo || s.param > hi) << s.param;
    if (s.stable)
      for (const auto& mu : s.multipliers) EXPECT_NEAR(std::abs(mu), 1.0, 1e-12) << s.param;
  }
  const auto largest = [&](double f1) {
    Case at = c;
    at.speed.shaft_frequency_hz = f1;
    return std::abs(geardyn::floquet_multipliers(rk4_contact_monodromy(at)).front());
  };
  for (const auto& [boundary, outward] : {std::pair{lo, -1.0}, std::pair{hi, 1.0}}) {
    EXPECT_LT(largest(boundary + outward * 1e-3), 1 + 1e-7) << boundary;
    EXPECT_GT(largest(boundary - outward * 1e-3), 1 + 1e-5) << boundary;
  }
  // Vanishing damping does not give the undamped tongue back: two modes' first-order averaged
  // equations give the damped tongue's half-width (mu_1 + mu_3) / sqrt(mu_1 mu_3) x
  // sqrt(Lambda - mu_1 mu_3) (mu_i = zeta_i w_i, the modes' decay rates) against the undamped
  // 2 sqrt(Lambda): as damping vanishes with its proportions kept, the width ratio tends to
  // (mu_1 + mu_3) / (2 sqrt(mu_1 mu_3)), 1.458 here (the modes' damping ratios differ).
  const Case damped = shipped_pair_one_harmonic(1e-5);
  const geardyn::StabilityResult d = geardyn::stability(damped, o);
  ASSERT_EQ(d.boundaries.size(), 2U);
  EXPECT_NEAR(d.boundaries[0].param, 76.665, 1e-3);  // docs/orbits.md
  EXPECT_NEAR(d.boundaries[1].param, 77.788, 1e-3);
  const geardyn::ModeSet m =
      geardyn::modes(geardyn::CoupledModel(geardyn::coupled_parameters(damped)));
  ASSERT_EQ(m.modes.size(), 3U);
  const auto rate = [&](int i) {
    const geardyn::Mode& mode = m.modes[static_cast<std::size_t>(i)];
    return mode.damping_ratio * 2 * std::numbers::pi * mode.frequency_hz;
  };
  const double ratio = (rate(0) + rate(2)) / (2 * std::sqrt(rate(0) * rate(2)));
  EXPECT_NEAR(ratio, 1.458, 1e-3);
  EXPECT_NEAR((d.boundaries[1].param - d.boundaries[0].param) / (hi - lo), ratio, 1e-3 * ratio);
  // At the damping of the principal tongue's test (0.005) the tongue is narrower than both.
  const geardyn::StabilityResult light = geardyn::stability(shipped_pair_one_harmonic(0.005), o);
  ASSERT_EQ(light.boundaries.size(), 2U);
  EXPECT_NEAR(light.boundaries[0].param, 76.93, 0.01);
  EXPECT_NEAR(light.boundaries[1].param, 77.52, 0.01);
  // Both tongues centred where the mesh frequency is the two modes' sum, to first order.
  const double centre = (m.modes[0].frequency_hz + m.modes[2].frequency_hz) / 56;
  EXPECT_NEAR(0.5 * (lo + hi), centre, 1e-3 * centre);
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
      const auto mu = geardyn::floquet_multipliers(geardyn::elastic_contact_monodromy(at));
      EXPECT_EQ(s.max_multiplier, std::abs(mu.front())) << axis.key << s.param;
      // The study reads every form through its train; the one-degree model's own monodromy
      // has the same multipliers to rounding.
      const auto own = geardyn::floquet_multipliers(geardyn::contact_monodromy(at));
      EXPECT_NEAR(std::abs(own.front()), s.max_multiplier, 1e-12) << axis.key << s.param;
      moduli.push_back(s.max_multiplier);
    }
    EXPECT_NE(moduli.front(), moduli.back()) << axis.key;  // the key moves the multipliers
  }
  // ISO 6336-1's k_m follows the torque (c' below 100 N/mm of line load): never shared, so that
  // a chart along the torque reads each torque's own stiffness (it once kept the first's).
  Case iso = c;
  geardyn::set_case_value(iso, {"mesh.stiffness_source", "\"iso6336\""});
  EXPECT_FALSE(geardyn::shared_stiffness(iso, {"load.torque_nm"}));
  StabilityOptions o;
  o.axis = geardyn::SweepAxis{"load.torque_nm", 5, 40, 3, false};
  const geardyn::StabilityResult r = geardyn::stability(iso, o);
  ASSERT_EQ(r.samples.size(), 3U);
  for (const geardyn::StabilitySample& s : r.samples) {
    Case at = iso;
    geardyn::set_case_value(at, {"load.torque_nm", fmt::format("{:.17g}", s.param)});
    const auto mu = geardyn::floquet_multipliers(geardyn::elastic_contact_monodromy(at));
    EXPECT_EQ(s.max_multiplier, std::abs(mu.front())) << s.param;
  }
  EXPECT_NE(r.samples.front().max_multiplier, r.samples.back().max_multiplier);
}

// A key the contact flow does not read (a backlash, a torque on the energy method's stiffness,
// a loose gear's imposed acceleration: they force the motion, not its linearised flow) would
// chart one verdict everywhere: refused, naming the key and the two ends; a key of the flow is
// charted, on the one-degree form and on a train.
TEST(Stability, AKeyTheContactFlowDoesNotReadIsRefused) {
  const Case c = geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010.toml");
  const auto refusal = [](const Case& x, const geardyn::SweepAxis& axis,
                          std::optional<geardyn::SweepAxis> axis2 = std::nullopt) {
    StabilityOptions o;
    o.axis = axis;
    o.axis2 = axis2;
    return geardyn::testing::error_of([&] { (void)geardyn::stability(x, o); });
  };
  std::string msg = refusal(c, {"mesh.backlash_um", 50, 150, 3, false});
  for (const char* part : {"--param mesh.backlash_um: the stability in permanent contact does "
                           "not depend on it",
                           "the same at --from 50 and at --to 150"})
    EXPECT_NE(msg.find(part), std::string::npos) << part << "\n" << msg;
  EXPECT_NE(refusal(c, {"load.torque_nm", 20, 150, 3, false}).find("--param load.torque_nm"),
            std::string::npos);
  // The second key of a map, with its own option.
  msg = refusal(c, {"speed.shaft_frequency_hz", 500, 1500, 3, false},
                geardyn::SweepAxis{"mesh.backlash_um", 50, 150, 2, false});
  EXPECT_NE(msg.find("--param2 mesh.backlash_um"), std::string::npos) << msg;
  EXPECT_NE(msg.find("--from2 50"), std::string::npos) << msg;
  const Case loose =
      geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/loose_gear_rattle.toml");
  msg = refusal(loose, {"train.speed[0].acceleration_harmonics[0][0]", 100, 300, 3, false});
  EXPECT_NE(msg.find("does not depend on it"), std::string::npos) << msg;
  // Keys of the flow: the speed, the mesh's damping ratio, the loose gear's drive speed.
  EXPECT_EQ(refusal(c, {"mesh.damping_ratio", 0.01, 0.05, 3, false}), "");
  EXPECT_EQ(refusal(loose, {"train.reference_speed_hz", 10, 20, 3, false}), "");
}

TEST(Stability, AFreelyTurningTrainHasItsMeshsMultipliersAndANeutralRate) {
  // The paper's pair written as a train of two gears under torques: read modulo the rigid
  // rotation, its monodromy holds the one-degree pair's two multipliers and a third of 1, the
  // rate of the rotation, which nothing damps. Read in the full state it would hold a Jordan
  // block at 1 that rounding splits by about 1e-8, above the neutral margin.
  const geardyn::ode::Matrix pair = geardyn::contact_monodromy(geardyn::park2010_pair_case());
  const geardyn::ode::Matrix train = geardyn::contact_monodromy(geardyn::park2010_pair_as_train());
  ASSERT_EQ(pair.rows(), 2);
  ASSERT_EQ(train.rows(), 3);
  const auto mp = sorted_multipliers(pair);
  std::vector<std::complex<double>> mt = sorted_multipliers(train);
  const auto one = std::min_element(
      mt.begin(), mt.end(), [](auto a, auto b) { return std::abs(a - 1.0) < std::abs(b - 1.0); });
  EXPECT_LT(std::abs(*one - 1.0), 1e-10) << *one;
  mt.erase(one);
  for (std::size_t i = 0; i < 2; ++i)
    EXPECT_LT(std::abs(mt[i] - mp[i]), 1e-8 * std::abs(mp[i])) << mt[i] << " against " << mp[i];
  // The study's monodromy reads the flow on the complement of the rotation (elastic_quotient):
  // two states, as the one-degree model's, and its two multipliers, with no 1 to deflate.
  const geardyn::ode::Matrix elastic =
      geardyn::elastic_contact_monodromy(geardyn::park2010_pair_as_train());
  ASSERT_EQ(elastic.rows(), 2);
  const auto me = sorted_multipliers(elastic);
  for (std::size_t i = 0; i < 2; ++i)
    EXPECT_LT(std::abs(me[i] - mp[i]), 1e-10 * std::abs(mp[i])) << me[i] << " against " << mp[i];

  // The shipped idler train (30, 47 and 60 teeth: the rotation is not 1, 1, 1): its reduced
  // multipliers, the 1 of the rate aside, are the full state's, the two at the rotation's 1
  // aside.
  const Case idler =
      geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/idler_train.toml");
  const geardyn::train::Assembled a = geardyn::assembled_train(idler);
  geardyn::ode::LinearSwitchedSystem sys =
      a.linear_system(geardyn::train::Assembled::RegionBuild::kEager);  // its regions to edit
  const int contact = a.region(std::vector<int>(a.train().meshes.size(), 1));
  sys.regions[contact].guards.clear();
  geardyn::ode::EngineOptions eo;
  eo.tolerance = 1e-12;
  const geardyn::ode::ExactEngine engine(sys, eo);
  geardyn::ode::FlowObserver nothing;
  const geardyn::ode::FlowResult full =
      engine.flow(0.0, geardyn::ode::Vector::Zero(sys.dimension), contact, sys.coefficient_period_s,
                  geardyn::ode::OutputGrid{}, nothing, true);
  ASSERT_TRUE(full.ok() && full.jacobian) << full.message;
  const auto drop_nearest_one = [](std::vector<std::complex<double>> mu, int count) {
    for (int i = 0; i < count; ++i)
      mu.erase(std::min_element(mu.begin(), mu.end(), [](auto x, auto y) {
        return std::abs(x - 1.0) < std::abs(y - 1.0);
      }));
    return mu;
  };
  const auto mf = drop_nearest_one(sorted_multipliers(*full.jacobian), 2);
  const geardyn::ode::Matrix reduced = geardyn::contact_monodromy(idler);
  ASSERT_EQ(reduced.rows(), 5);
  const auto mr = sorted_multipliers(reduced);
  const auto rate = std::min_element(
      mr.begin(), mr.end(), [](auto x, auto y) { return std::abs(x - 1.0) < std::abs(y - 1.0); });
  EXPECT_LT(std::abs(*rate - 1.0), 1e-10) << *rate;
  const auto rest = drop_nearest_one(mr, 1);
  ASSERT_EQ(rest.size(), mf.size());
  for (std::size_t i = 0; i < rest.size(); ++i)
    EXPECT_LT(std::abs(rest[i] - mf[i]), 1e-8 * std::max(1e-3, std::abs(mf[i])))
        << rest[i] << " against " << mf[i];
}

TEST(Stability, TheStudyReadsAFreeTrainWithoutItsNeutralRate) {
  // The idler train turns freely: elastic_contact_monodromy is contact_monodromy with its rate's
  // multiplier of 1 deflated, the others the same to rounding. Lin and Parker's set, its meshes
  // in phase and varying by 20 %, is unstable where the mesh frequency is near twice its
  // rotational sun mode's (11775 Hz, mu = -1: period doubling); along
  // the speed the study finds that region's two ends and no other boundary (with the neutral 1
  // kept, det(M - I) takes rounding's sign at every sample and boundaries appear everywhere).
  const Case idler =
      geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/idler_train.toml");
  const geardyn::ode::Matrix full = geardyn::contact_monodromy(idler),
                             elastic = geardyn::elastic_contact_monodromy(idler);
  ASSERT_EQ(elastic.rows(), full.rows() - 1);
  std::vector<std::complex<double>> kept = sorted_multipliers(full);
  kept.erase(std::min_element(kept.begin(), kept.end(), [](auto x, auto y) {
    return std::abs(x - 1.0) < std::abs(y - 1.0);
  }));
  const std::vector<std::complex<double>> deflated = sorted_multipliers(elastic);
  ASSERT_EQ(deflated.size(), kept.size());
  // Each to 1e-9 of itself, and the smallest (some 3e-7, the fast contact modes decayed over a
  // period) to 1e-7 of the largest: a small eigenvalue of this far from normal matrix moves by
  // that much under rounding of its entries.
  for (std::size_t i = 0; i < kept.size(); ++i)
    EXPECT_LT(std::abs(deflated[i] - kept[i]),
              1e-9 * std::abs(kept[i]) + 1e-7 * std::abs(kept.back()))
        << deflated[i] << " against " << kept[i];
  // A train with a prescribed speed has no rate to deflate.
  const Case loose =
      geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/loose_gear_rattle.toml");
  EXPECT_EQ(geardyn::elastic_contact_monodromy(loose), geardyn::contact_monodromy(loose));

  Case set = geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/lin_parker_1999.toml");
  geardyn::set_case_value(set, {"train.planetary[0].mesh_stiffness_harmonics", "[[0.2, 0]]"});
  // The sun's own speed; the meshes engage at 85 times its speed relative to the carrier, 305 /
  // 390 of it with the ring held: 250 to 300 Hz there.
  constexpr double kOwn = 390.0 / 305;
  StabilityOptions o;
  o.axis = {"train.reference_speed_hz", 250 * kOwn, 300 * kOwn, 11};
  const geardyn::StabilityResult r = geardyn::stability(set, o);
  ASSERT_EQ(r.boundaries.size(), 2U);
  const double centre_hz = 2 * 11775.3 / 85 * kOwn;
  EXPECT_EQ(r.boundaries[0].type, geardyn::BifurcationType::kPeriodDoubling);
  EXPECT_EQ(r.boundaries[1].type, geardyn::BifurcationType::kPeriodDoubling);
  EXPECT_LT(r.boundaries[0].param, centre_hz);
  EXPECT_GT(r.boundaries[1].param, centre_hz);
  for (const geardyn::StabilitySample& x : r.samples) {
    const bool inside = x.param > r.boundaries[0].param && x.param < r.boundaries[1].param;
    EXPECT_EQ(x.stable, !inside) << x.param;
    if (!inside) EXPECT_LT(x.max_multiplier, 1.0) << x.param;  // damped: no neutral 1 left
  }
}

TEST(Stability, APrescribedTrainIsReadInItsFreeBodysCoordinates) {
  // The shipped loose gear, its input's speed prescribed: the monodromy is the loose gear's
  // (theta, theta') alone. In permanent contact at constant stiffness it is exp(A T) of
  // J theta'' + C theta' + K theta = 0 with the loose gear's entries of the assembled matrices:
  // over its own period (the firing period, in which the contact oscillation decays to 1e-13)
  // and over 3 / w (w^2 = K / J), where it has decayed little; compared with the rates scaled
  // by w.
  const Case c =
      geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/loose_gear_rattle.toml");
  const geardyn::train::Assembled a = geardyn::assembled_train(c);
  const int loose = a.index("loose");
  const double j = a.mass()(loose, loose), k = a.contact_stiffness()(loose, loose),
               d = a.contact_damping()(loose, loose);
  ASSERT_GT(d, 0);
  const double w = std::sqrt(k / j);
  EXPECT_NEAR(*a.system_period_s(), 1.0 / 25, 1e-15);
  // The system with the rate scaled by w, whose exponential is well conditioned.
  Eigen::Matrix2d s, scale;
  s << 0, w, -w, -d / j;
  scale << 1, 0, 0, w;
  for (const double T : {*a.system_period_s(), 3 / w}) {
    const geardyn::ode::Matrix m = geardyn::contact_monodromy(c, 1e-12, T == 3 / w ? T : 0.0);
    ASSERT_EQ(m.rows(), 2);
    const Eigen::Matrix2d es = (s * T).exp();
    const Eigen::Matrix2d ms = scale.inverse() * m * scale;
    for (int r = 0; r < 2; ++r)
      for (int q = 0; q < 2; ++q) EXPECT_NEAR(ms(r, q), es(r, q), 1e-12) << T << ": " << r << q;
  }
}

TEST(Stability, ATrainsChartVariesItsElementsKeys) {
  // A chart over a mesh's damping ratio of the loose gear: each sample its own case's (the
  // largest multiplier exp(-zeta w T) falls as the damping rises); a key of no element kind, or
  // a name, is refused before any work.
  const Case c =
      geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/loose_gear_rattle.toml");
  StabilityOptions o;
  o.axis = {"train.mesh[0].damping_ratio", 0.01, 0.1, 4};
  const geardyn::StabilityResult r = geardyn::stability(c, o);
  ASSERT_EQ(r.samples.size(), 4U);
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    EXPECT_TRUE(r.samples[i].stable);
    Case at = c;
    geardyn::set_case_value(
        at, {"train.mesh[0].damping_ratio", fmt::format("{:.17g}", r.samples[i].param)});
    EXPECT_NEAR(r.samples[i].max_multiplier,
                std::abs(sorted_multipliers(geardyn::contact_monodromy(at)).back()), 1e-14);
    if (i > 0) EXPECT_LT(r.samples[i].max_multiplier, r.samples[i - 1].max_multiplier);
  }
  // Only the meshes' stiffness enters the monodromy: the idler train with a torque harmonic at
  // an order that shares no period with its meshes is charted as without it; a train in which
  // nothing varies has no period to chart over, and says so.
  const Case idler =
      geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/idler_train.toml");
  Case quasi = idler;
  geardyn::set_case_value(quasi, {"train.torque[0].harmonics", "[[5, 1.41421356237, 0]]"});
  std::string no_period;
  ASSERT_FALSE(geardyn::assembled_train(quasi).system_period_s(&no_period)) << "a period";
  // (To the engine's tolerance: the torque's frequency joins the cells' forced responses.)
  const geardyn::ode::Matrix with = geardyn::contact_monodromy(quasi),
                             without = geardyn::contact_monodromy(idler);
  EXPECT_LT((with - without).cwiseAbs().maxCoeff(), 1e-10 * without.cwiseAbs().maxCoeff());
  Case still = c;
  geardyn::set_case_value(still, {"train.speed[0].acceleration_harmonics", "[]"});
  try {
    (void)geardyn::contact_monodromy(still);
    ADD_FAILURE() << "a train in which nothing varies was charted";
  } catch (const geardyn::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nothing in the train varies"), std::string::npos)
        << e.what();
  }
  for (const auto& [key, why] : {std::pair{"train.gear[0].teeth", "unknown key"},
                                 std::pair{"train.mesh[0].name", "not a real number"},
                                 std::pair{"train.mesh.damping_ratio", "train.<kind>[i].<key>"}}) {
    o.axis = {key, 0.01, 0.1, 4};
    try {
      (void)geardyn::stability(c, o);
      ADD_FAILURE() << key << " accepted";
    } catch (const geardyn::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
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
