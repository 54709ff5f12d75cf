// Periodic orbits (orbit.hpp): the linear oscillator's orbit and multipliers in closed form,
// the monodromy through impacts against central differences of the stroboscopic map, an
// orbit checked by an independent integrator, the system period, and failures reported.
#include "geardyn/orbit.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <complex>
#include <filesystem>
#include <numbers>

#include "geardyn/coupled_orbit.hpp"
#include "geardyn/one_degree_orbit.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_orbit.hpp"

namespace {

using geardyn::Case;
using geardyn::Orbit;
using geardyn::OrbitOptions;

// Few settling periods, so that Newton's method does the work.
OrbitOptions shooting(int periods = 1, int segments = 0) {
  OrbitOptions o;
  o.periods = periods;
  o.segments = segments;
  o.settle_periods = 3;
  return o;
}

Case nondimensional(double zeta, double fm, double fa, double omega) {
  Case c;
  c.model.form = geardyn::ModelForm::kNondimensional;
  c.model.zeta = zeta;
  c.model.force_mean = fm;
  c.model.force_alternating = fa;
  c.model.omega = omega;
  return c;
}

// The stroboscopic map over one period T from y at t = 0, by the exact engine.
geardyn::ode::Vector period_map(const geardyn::GearPairModel& model, const geardyn::Solver& solver,
                                double T, double q, double v) {
  geardyn::ode::State s{0, q, v, 0, model.classify(model.drive(0), q, v)};
  const auto r = solver.advance(s, T);
  EXPECT_TRUE(r.ok()) << r.message;
  geardyn::ode::Vector y(2);
  y << r.end_state.q, r.end_state.v;
  return y;
}

// The orbit's monodromy against central differences of its period map (steps 1e-6 of the
// state's scales, delta ~ q_scale, delta' ~ v_scale), compared in the scaled state to 1e-6.
void expect_monodromy_matches_differences(const geardyn::GearPairModel& model,
                                          const geardyn::Solver& solver, const Orbit& o,
                                          double q_scale, double v_scale) {
  const double scale[2] = {q_scale, v_scale};
  for (int j = 0; j < 2; ++j) {
    const double h = 1e-6 * scale[j];
    const double dq = j == 0 ? h : 0, dv = j == 1 ? h : 0;
    const auto plus = period_map(model, solver, o.period_s, o.state.q + dq, o.state.v + dv);
    const auto minus = period_map(model, solver, o.period_s, o.state.q - dq, o.state.v - dv);
    const geardyn::ode::Vector column = (plus - minus) / (2 * h);
    for (int i = 0; i < 2; ++i) {
      const double to_scaled = scale[j] / scale[i];
      EXPECT_NEAR(o.monodromy(i, j) * to_scaled, column[i] * to_scaled, 1e-6)
          << "entry (" << i << ", " << j << ")";
    }
  }
}

TEST(Orbit, LinearOscillatorInContactMatchesItsClosedForm) {
  // Always in contact (F_m 1 against an oscillation of 0.13): x'' + 2 zeta x' + (x - 1) =
  // F_m + F_a cos(Omega t). Orbit: x = 1 + F_m + Re(H e^{i Omega t}); multipliers
  // exp(lambda T), lambda = -zeta +- i sqrt(1 - zeta^2).
  const double zeta = 0.05, fm = 1.0, fa = 0.1, omega = 0.5;
  const Case c = nondimensional(zeta, fm, fa, omega);
  const Orbit o = geardyn::find_orbit(c, shooting());
  ASSERT_TRUE(o.converged) << o.message;
  EXPECT_GE(o.iterations, 1);
  const double T = 2 * std::numbers::pi / omega;
  EXPECT_NEAR(o.period_s, T, 1e-14 * T);
  const std::complex<double> H = fa / std::complex<double>(1 - omega * omega, 2 * zeta * omega);
  EXPECT_NEAR(o.state.q, 1 + fm + H.real(), 1e-11);
  EXPECT_NEAR(o.state.v, -omega * H.imag(), 1e-11);
  ASSERT_EQ(o.multipliers.size(), 2U);
  const std::complex<double> lambda(-zeta, std::sqrt(1 - zeta * zeta));
  const std::complex<double> mu = std::exp(lambda * T);
  for (const auto& m : o.multipliers) {
    EXPECT_NEAR(std::abs(m), std::abs(mu), 1e-12);
    EXPECT_NEAR(std::abs(m.imag()), std::abs(mu.imag()), 1e-12);
    EXPECT_NEAR(m.real(), mu.real(), 1e-12);
  }
  EXPECT_TRUE(o.stable);
  EXPECT_EQ(o.reading.impacts, 0);
  EXPECT_TRUE(o.sequence.empty());
  EXPECT_NEAR(o.reading.max_delta_bar, 1 + fm + std::abs(H), 1e-11);
  EXPECT_NEAR(o.reading.min_delta_bar, 1 + fm - std::abs(H), 1e-11);
}

TEST(Orbit, MonodromyThroughImpactsMatchesFiniteDifferences) {
  // The Kahraman-Singh oscillator at Omega 0.95 rattles on one side (an impact and a
  // separation per period). The monodromy (saltation at both events) against central
  // differences of the stroboscopic map.
  const Case c = nondimensional(0.05, 0.1, 0.02, 0.95);
  const Orbit o = geardyn::find_orbit(c, shooting());
  ASSERT_TRUE(o.converged) << o.message;
  EXPECT_GE(o.iterations, 3);
  EXPECT_EQ(o.reading.impacts, 1);
  EXPECT_EQ(o.reading.separations, 1);
  ASSERT_EQ(o.sequence.size(), 2U);
  const geardyn::GearPairModel model = geardyn::build_model(c);
  geardyn::SolverData sd = c.solver;
  sd.tolerance = 1e-12;
  const geardyn::Solver solver(model, sd);
  expect_monodromy_matches_differences(model, solver, o, 1.0, 1.0);
  EXPECT_TRUE(o.stable);
  EXPECT_LT(o.max_multiplier(), 1.0);
}

TEST(Orbit, ReturnsToItselfUnderAnIndependentIntegrator) {
  // The rattling orbit, one period by dopri5 at 1e-12: back on the section state.
  const Case c = nondimensional(0.05, 0.1, 0.02, 0.95);
  const Orbit o = geardyn::find_orbit(c, shooting());
  ASSERT_TRUE(o.converged) << o.message;
  const geardyn::GearPairModel model = geardyn::build_model(c);
  geardyn::SolverData sd = c.solver;
  sd.method = geardyn::Method::kDopri5;
  sd.tolerance = 1e-12;
  const geardyn::Solver solver(model, sd);
  const auto r = solver.advance(o.state, o.period_s);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(r.end_state.q, o.state.q, 1e-9);
  EXPECT_NEAR(r.end_state.v, o.state.v, 1e-9);
  EXPECT_EQ(r.transitions, 2);
}

TEST(Orbit, MultipleShootingFindsTheSameOrbit) {
  // Period 2 T0 on 2 segments and on 1: the period-1 orbit again, with the multipliers
  // squared.
  const Case c = nondimensional(0.05, 0.1, 0.02, 0.95);
  const Orbit one = geardyn::find_orbit(c, shooting());
  const Orbit o2 = geardyn::find_orbit(c, shooting(2));
  const Orbit o1 = geardyn::find_orbit(c, shooting(2, 1));
  ASSERT_TRUE(one.converged && o2.converged && o1.converged);
  EXPECT_EQ(o2.segments, 2);
  for (const Orbit* o : {&o2, &o1}) {
    EXPECT_NEAR(o->state.q, one.state.q, 1e-10);
    EXPECT_NEAR(o->state.v, one.state.v, 1e-10);
    EXPECT_NEAR(o->max_multiplier(), one.max_multiplier() * one.max_multiplier(), 1e-9);
    EXPECT_EQ(o->reading.impacts, 2);
  }
}

TEST(Orbit, PaperGearAtFig4cRattlesOnceAPeriodWithTheMonodromyOfItsMap) {
  // The Table 1 gear at f_1 = 1 kHz (Fig. 4(c)): time-varying stiffness (56 mesh periods in
  // the system period 1 / f_1) and a torque of order 1. A stable one-sided rattle, one impact
  // a period; the monodromy against central differences of the period map.
  Case c = geardyn::load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases/park2010.toml");
  c.speed.shaft_frequency_hz = 1000;
  const Orbit o = geardyn::find_orbit(c, shooting());
  ASSERT_TRUE(o.converged) << o.message;
  EXPECT_NEAR(o.period_s, 1e-3, 1e-15);
  EXPECT_TRUE(o.stable);
  EXPECT_EQ(o.reading.impacts, 1);
  EXPECT_EQ(o.reading.backside_impacts, 0);
  const geardyn::GearPairModel model = geardyn::build_model(c);
  geardyn::SolverData sd = c.solver;
  sd.method = geardyn::Method::kExact;
  sd.tolerance = 1e-12;
  const geardyn::Solver solver(model, sd);
  const double b = c.mesh.backlash_um * 1e-6;
  expect_monodromy_matches_differences(model, solver, o, b,
                                       b * model.parameters().natural_angular_frequency_rad_s());
}

TEST(Orbit, AOneDegreeFormsOrbitIsItsTrainsReadAsTheOneDegreeModelsOwn) {
  // find_orbit finds a one-degree form's orbit on its train (the one path) and reads it in the
  // one-degree model's terms; find_one_degree_orbit finds it by the one-degree model's own
  // shooting. They agree on a one-sided rattle, a double-sided one, an unstable one, the
  // paper's gear at Fig. 4(c), and that gear with a transmission error that makes it impact
  // once a mesh cycle (56 times a period; x = d - e at the section needs e(0), x' needs e'(0),
  // x'' needs e''(0)): the section state, its region, the multipliers, the monodromy (scaled
  // by b and b w_n), the contact sequence and the reading. From the orbit's own state Newton
  // has at most one iteration to do (a start mapped to the train's unknowns without e(0) is
  // 4 um off). A mutant that drops e, e' or e'' from the reading, or the offset from the
  // start's map, fails.
  struct Row {
    const char* name;
    Case c;
    OrbitOptions o;
  };
  Case paper =
      geardyn::load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases/park2010.toml");
  paper.speed.shaft_frequency_hz = 1000;
  Case te = paper;
  geardyn::set_case_value(te, {"mesh.transmission_error_um", "[[5, 30], [2, 0]]"});
  OrbitOptions settled;
  settled.settle_periods = 40;
  const std::vector<Row> rows = {
      {"one-sided rattle", nondimensional(0.05, 0.1, 0.02, 0.95), shooting()},
      {"double-sided rattle", nondimensional(0.05, 0.02, 0.5, 0.5), shooting()},
      {"unstable", nondimensional(0.05, 0.1, 0.2, 1.0), shooting()},
      {"paper, Fig. 4(c)", paper, shooting()},
      {"transmission error", te, settled},
  };
  for (const Row& row : rows) {
    SCOPED_TRACE(row.name);
    const Orbit one = geardyn::find_one_degree_orbit(row.c, row.o);
    const Orbit two = geardyn::find_orbit(row.c, row.o);
    ASSERT_TRUE(one.converged) << one.message;
    ASSERT_TRUE(two.converged) << two.message;
    const geardyn::GearPairModel model = geardyn::build_model(row.c);
    const double b = model.parameters().backlash_m;
    const double w = model.parameters().natural_angular_frequency_rad_s();
    EXPECT_NEAR(two.state.q / b, one.state.q / b, 1e-9);
    EXPECT_NEAR(two.state.v / (b * w), one.state.v / (b * w), 1e-9);
    EXPECT_NEAR(two.state.a / (b * w * w), one.state.a / (b * w * w), 1e-7);
    EXPECT_EQ(two.state.region, one.state.region);
    ASSERT_EQ(two.multipliers.size(), 2U);
    for (const std::complex<double>& mu : one.multipliers)
      EXPECT_LT(std::min(std::abs(mu - two.multipliers[0]), std::abs(mu - two.multipliers[1])),
                1e-8 * std::max(1.0, std::abs(mu)));
    EXPECT_EQ(two.stable, one.stable);
    const Eigen::Vector2d s(b, b * w);
    const Eigen::Matrix2d scaled_one =
        s.cwiseInverse().asDiagonal() * one.monodromy * s.asDiagonal();
    const Eigen::Matrix2d scaled_two =
        s.cwiseInverse().asDiagonal() * two.monodromy * s.asDiagonal();
    EXPECT_LT((scaled_two - scaled_one).cwiseAbs().maxCoeff(), 1e-7 * scaled_one.norm());
    ASSERT_EQ(two.sequence.size(), one.sequence.size());
    for (std::size_t k = 0; k < one.sequence.size(); ++k) {
      EXPECT_EQ(two.sequence[k].kind, one.sequence[k].kind) << k;
      EXPECT_NEAR(two.sequence[k].t_s / one.period_s, one.sequence[k].t_s / one.period_s, 1e-9);
      EXPECT_NEAR(two.sequence[k].velocity_m_s / (b * w), one.sequence[k].velocity_m_s / (b * w),
                  1e-8);
    }
    EXPECT_EQ(two.reading.impacts, one.reading.impacts);
    EXPECT_EQ(two.reading.backside_impacts, one.reading.backside_impacts);
    EXPECT_EQ(two.reading.separations, one.reading.separations);
    EXPECT_NEAR(two.reading.min_delta_bar, one.reading.min_delta_bar, 1e-9);
    EXPECT_NEAR(two.reading.max_delta_bar, one.reading.max_delta_bar, 1e-9);
    EXPECT_NEAR(two.reading.min_force_bar, one.reading.min_force_bar, 1e-9);
    EXPECT_NEAR(two.reading.max_force_bar, one.reading.max_force_bar, 1e-9);
    OrbitOptions from_state = row.o;
    from_state.settle_periods = 0;
    const Orbit again = geardyn::find_orbit(row.c, from_state, one.state);
    ASSERT_TRUE(again.converged) << again.message;
    EXPECT_LE(again.iterations, 1);
    EXPECT_NEAR(again.state.q / b, one.state.q / b, 1e-9);
  }
  EXPECT_EQ(geardyn::find_orbit(te, settled).reading.impacts, 56);
}

TEST(FlowSensitivity, KeyDerivativesOfTheLinearOscillatorMatchTheClosedForm) {
  // Always in contact, x'' + 2 zeta x' + (x - 1) = F_m + F_a cos(Omega t) from (x0, v0): the
  // response is linear in F_m and F_a, d/dF_a the response from rest to cos(Omega t), d/dF_m
  // the step response. The state Jacobian: the free vibration's fundamental matrix.
  const double zeta = 0.05, omega = 0.7, t1 = 23.0;
  const Case c = nondimensional(zeta, 1.0, 0.1, omega);
  const geardyn::ode::State y0{0.0, 2.1, -0.05, 0.0, geardyn::kDriveContact};
  const double wd = std::sqrt(1 - zeta * zeta), e = std::exp(-zeta * t1);
  const double cs = std::cos(wd * t1), sn = std::sin(wd * t1);
  // d/dF_a: Re(H e^{i Omega t}) - free vibration from Re(H), Re(i Omega H), H = 1/(1 - W^2 + 2 i
  // zeta W).
  const std::complex<double> H = 1.0 / std::complex<double>(1 - omega * omega, 2 * zeta * omega);
  const std::complex<double> p = H * std::exp(std::complex<double>(0, omega * t1));
  auto free = [&](double x0, double v0) {  // (x, v) of the free vibration at t1
    const double A = x0, B = (v0 + zeta * x0) / wd;
    return std::array<double, 2>{e * (A * cs + B * sn),
                                 e * (-zeta * (A * cs + B * sn) + wd * (-A * sn + B * cs))};
  };
  const auto fa0 = free(H.real(), -omega * H.imag());
  const double dx_dfa = p.real() - fa0[0];
  const double dv_dfa = (std::complex<double>(0, omega) * p).real() - fa0[1];
  const auto step = free(1.0, 0.0);  // the step response is 1 - free(1, 0)
  const geardyn::FlowSensitivity sa =
      geardyn::flow_sensitivity(c, y0, t1, "model.force_alternating");
  EXPECT_NEAR(sa.d_key[0], dx_dfa, 1e-9);
  EXPECT_NEAR(sa.d_key[1], dv_dfa, 1e-9);
  EXPECT_LT(sa.d_key_error, 1e-9);
  const geardyn::FlowSensitivity sm = geardyn::flow_sensitivity(c, y0, t1, "model.force_mean");
  EXPECT_NEAR(sm.d_key[0], 1 - step[0], 1e-9);
  EXPECT_NEAR(sm.d_key[1], -step[1], 1e-9);
  const auto jx = free(1, 0), jv = free(0, 1);
  EXPECT_NEAR(sm.d_state(0, 0), jx[0], 1e-12);
  EXPECT_NEAR(sm.d_state(1, 0), jx[1], 1e-12);
  EXPECT_NEAR(sm.d_state(0, 1), jv[0], 1e-12);
  EXPECT_NEAR(sm.d_state(1, 1), jv[1], 1e-12);
}

TEST(FlowSensitivity, KeyDerivativeThroughImpactsAgreesWithAnIndependentIntegrator) {
  // The Kahraman-Singh rattle over 3 periods (6 contact events), d/dOmega and d/dzeta: the
  // exact engine's extrapolated differences against dopri5 at 1e-13 differenced at the same
  // steps.
  const Case c = nondimensional(0.05, 0.1, 0.02, 0.95);
  const Orbit o = geardyn::find_orbit(c, shooting());
  ASSERT_TRUE(o.converged);
  const double t1 = 3 * o.period_s;
  for (const char* key : {"model.omega", "model.zeta"}) {
    const geardyn::FlowSensitivity s = geardyn::flow_sensitivity(c, o.state, t1, key);
    EXPECT_EQ(s.events, 6);
    auto dopri = [&](double value) {
      Case d = c;
      geardyn::set_case_value(d, {key, fmt::format("{:.17g}", value)});
      const geardyn::GearPairModel model = geardyn::build_model(d);
      geardyn::SolverData sd = d.solver;
      sd.method = geardyn::Method::kDopri5;
      sd.tolerance = 1e-13;
      const geardyn::Solver solver(model, sd);
      geardyn::ode::State y = o.state;
      y.region = model.classify(model.drive(0), y.q, y.v);
      const auto r = solver.advance(y, t1);
      EXPECT_TRUE(r.ok());
      return std::array<double, 2>{r.end_state.q, r.end_state.v};
    };
    const double p = std::string(key) == "model.omega" ? 0.95 : 0.05, h = s.key_step;
    const auto a = dopri(p + h), b = dopri(p - h), a2 = dopri(p + 2 * h), b2 = dopri(p - 2 * h);
    for (int i = 0; i < 2; ++i) {
      const double d1 = (a[i] - b[i]) / (2 * h), d2 = (a2[i] - b2[i]) / (4 * h);
      const double ref = (4 * d1 - d2) / 3;
      EXPECT_NEAR(s.d_key[i], ref, 1e-6 * (1 + std::abs(ref))) << key << " entry " << i;
    }
  }
}

TEST(FlowSensitivity, ABadKeyIsAnInputError) {
  const Case c = nondimensional(0.05, 0.1, 0.02, 0.95);
  const geardyn::ode::State y0{0.0, 1.0, 0.0, 0.0, 0};
  EXPECT_THROW((void)geardyn::flow_sensitivity(c, y0, 1.0, "solver.method"), geardyn::InputError);
  EXPECT_THROW((void)geardyn::flow_sensitivity(c, y0, 1.0, "model.nothing"), geardyn::InputError);
}

TEST(Floquet, BalancingIsAnExactSimilarityThatEvensTheScales) {
  // Positions and rates a frequency of 1e4 apart in scale, as a monodromy's: D^-1 M D with
  // D's entries powers of 2 (each entry scaled exactly), the spectrum kept, and each row and
  // column's off-diagonal sums brought within a factor 4 of each other.
  const Eigen::Index n = 6;
  geardyn::ode::Matrix m(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      m(i, j) = std::sin(1.0 + 3.0 * static_cast<double>(i) + 7.0 * static_cast<double>(j)) *
                std::pow(1e4, static_cast<double>(i >= 3) - static_cast<double>(j >= 3));
  geardyn::ode::Matrix b = m;
  const geardyn::ode::Vector d = geardyn::balance(b);
  for (Eigen::Index i = 0; i < n; ++i) {
    int e = 0;
    EXPECT_EQ(std::frexp(d[i], &e), 0.5) << d[i];
    double c = 0, r = 0;
    for (Eigen::Index j = 0; j < n; ++j) {
      EXPECT_EQ(b(i, j), m(i, j) * d[j] / d[i]);
      if (j != i) {
        c += std::abs(b(j, i));
        r += std::abs(b(i, j));
      }
    }
    EXPECT_LT(std::max(c / r, r / c), 4.0) << i;
  }
  EXPECT_GT(d.maxCoeff() / d.minCoeff(), 1e3);  // the scales were evened
}

TEST(Floquet, MultipliersOnTheUnitCircleStayOnItInABadlyScaledMonodromy) {
  // Three rotations (multipliers e^{+-i theta_k}, an undamped system's) mixed by an orthogonal
  // matrix and scaled as positions and rates 1e4 apart: the multipliers' moduli are 1 to 1e-12
  // (without balancing, ~1e-9), largest first.
  const Eigen::Index n = 6;
  geardyn::ode::Matrix t = geardyn::ode::Matrix::Zero(n, n);
  for (Eigen::Index k = 0; k < 3; ++k) {
    const double th = 0.4 + 0.9 * static_cast<double>(k);
    t.block(2 * k, 2 * k, 2, 2) << std::cos(th), -std::sin(th), std::sin(th), std::cos(th);
  }
  geardyn::ode::Vector v(n);
  v << 1.0, -2.0, 0.5, 3.0, -1.5, 2.5;
  const geardyn::ode::Matrix q =
      geardyn::ode::Matrix::Identity(n, n) - 2 * v * v.transpose() / v.squaredNorm();
  geardyn::ode::Vector scale(n);
  scale << 1.0, 1.0, 1.0, 1e4, 1e4, 1e4;
  const geardyn::ode::Matrix m =
      scale.asDiagonal() * q * t * q.transpose() * scale.cwiseInverse().asDiagonal();
  const auto mu = geardyn::floquet_multipliers(m);
  ASSERT_EQ(mu.size(), static_cast<std::size_t>(n));
  for (const auto& z : mu) EXPECT_NEAR(std::abs(z), 1.0, 1e-12) << z;
  for (std::size_t k = 0; k + 1 < mu.size(); ++k) EXPECT_GE(std::abs(mu[k]), std::abs(mu[k + 1]));
}

TEST(Orbit, SystemPeriodIsTheCommonPeriodOfTheExcitations) {
  // The Table 1 gear: mesh z1 f1 = 56 f1 and a torque of order 3: common period 1 / f1
  // (gcd(56, 3) = 1); order 4: 1 / (4 f1); steady torque: the mesh period.
  Case c;
  c.speed.shaft_frequency_hz = 100;
  c.load.fluctuation_order = 3;
  EXPECT_NEAR(geardyn::system_period_s(geardyn::build_model(c).parameters()), 1.0 / 100, 1e-15);
  c.load.fluctuation_order = 4;
  EXPECT_NEAR(geardyn::system_period_s(geardyn::build_model(c).parameters()), 1.0 / 400, 1e-15);
  c.load.fluctuation_ratio = 0;
  EXPECT_NEAR(geardyn::system_period_s(geardyn::build_model(c).parameters()), 1.0 / 5600, 1e-16);
  // Nothing varies: no period.
  c.mesh.stiffness_source = geardyn::StiffnessSource::kHarmonics;
  c.mesh.stiffness_harmonics.clear();
  EXPECT_THROW(geardyn::system_period_s(geardyn::build_model(c).parameters()), geardyn::InputError);
}

TEST(Orbit, EachFinderStartsAgainOnePeriodOnFromTheSettledMotion) {
  // One Newton iteration from each of three settled states (OrbitOptions::starts): not
  // converged, three iterations counted, and the last start is the state settled two periods
  // longer (its one iteration leaves the residual a single start leaves from there). A mutant
  // that starts again from the same state, or from a state two periods on, fails the last.
  OrbitOptions o = shooting();
  o.max_iterations = 1;
  o.starts = 3;
  OrbitOptions longer = shooting();
  longer.max_iterations = 1;
  longer.settle_periods = o.settle_periods + 2;
  longer.starts = 1;
  const auto check = [&](const geardyn::PeriodicSolution& r, const geardyn::PeriodicSolution& one) {
    EXPECT_FALSE(r.converged);
    EXPECT_EQ(r.iterations, 3);
    EXPECT_NE(r.message.find("(from 3 settled states one orbit period apart)"), std::string::npos)
        << r.message;
    EXPECT_EQ(one.iterations, 1);
    EXPECT_EQ(one.message.find("settled state"), std::string::npos) << one.message;
    EXPECT_NEAR(r.residual, one.residual, 1e-8 * one.residual);
    EXPECT_GT(one.residual, 1e-6);  // far from converged: a start's difference shows
  };
  {
    SCOPED_TRACE("one degree");
    const Case c = nondimensional(0.05, 0.1, 0.02, 0.95);
    check(geardyn::find_orbit(c, o), geardyn::find_orbit(c, longer));
  }
  {
    SCOPED_TRACE("coupled, dof 3");
    Case c = geardyn::load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) /
                                "cases/park2010_coupled.toml");
    geardyn::set_case_value(c, {"model.dof", "3"});
    check(geardyn::find_coupled_orbit(c, o), geardyn::find_coupled_orbit(c, longer));
  }
}

TEST(Orbit, FailuresAreReportedWithTheirReason) {
  const Case c = nondimensional(0.05, 0.1, 0.02, 0.95);
  OrbitOptions o;
  o.periods = 0;
  try {
    (void)geardyn::find_orbit(c, o);
    ADD_FAILURE() << "periods = 0 accepted";
  } catch (const geardyn::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--periods = 0"), std::string::npos) << e.what();
  }
  // One iteration from rest mid-backlash, unsettled: not converged, and says so.
  o = shooting();
  o.settle_periods = 0;
  o.max_iterations = 1;
  const Orbit r = geardyn::find_orbit(c, o);
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.message.find("no convergence in 1 Newton iterations"), std::string::npos)
      << r.message;
}

}  // namespace
