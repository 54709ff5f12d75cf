// Analytic references for the gear-pair model: free flight to the first impact, the linear
// forced response in permanent contact, and the logarithmic decrement of a free vibration.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "geardyn/run.hpp"

namespace geardyn {
namespace {

// The analytic references hold for a constant mesh stiffness.
Case with_method(Case c, Method m) {
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.solver.method = m;
  c.solver.tolerance = 1e-12;
  return c;
}

class BothIntegrators : public ::testing::TestWithParam<Method> {};

TEST_P(BothIntegrators, FreeFlightToTheFirstImpact) {
  // From rest in the middle of the backlash under a steady F_m: m_eq delta'' = F_m until
  // delta = b, so t = sqrt(2 b m_eq / F_m) and the impact velocity is sqrt(2 b F_m / m_eq).
  Case c = with_method(Case{}, GetParam());
  c.load.fluctuation_ratio = 0.0;
  c.solver.duration_s = 2e-3;
  const RunResult r = run(c);
  ASSERT_TRUE(r.integration.ok());
  ASSERT_FALSE(r.events.empty());
  const double b = 100e-6, m = r.derived.m_eq_kg, F = r.derived.mean_force_n;
  const double t_exact = std::sqrt(2 * b * m / F);
  constexpr double kRelTol = 1e-9;
  EXPECT_EQ(r.events[0].kind, EventKind::kImpact);
  EXPECT_NEAR(r.events[0].t_s, t_exact, kRelTol * t_exact);
  EXPECT_NEAR(r.events[0].velocity_m_s, std::sqrt(2 * b * F / m),
              kRelTol * std::sqrt(2 * b * F / m));
}

TEST_P(BothIntegrators, LinearForcedResponseInPermanentContact) {
  // Start at the static contact deflection with a small fluctuation: the teeth never separate
  // and delta - delta_s obeys m y'' + C y' + K y = F_a cos(W t), y(0) = y'(0) = 0.
  Case c = with_method(Case{}, GetParam());
  c.load.fluctuation_ratio = 0.1;
  c.solver.initial = InitialCondition::kStatic;
  c.solver.duration_s = 0.01;
  c.solver.time_step_s = 1e-8;
  c.solver.output_interval_s = 1e-5;
  const RunResult r = run(c);
  ASSERT_TRUE(r.integration.ok());
  EXPECT_EQ(r.reading.regime, Regime::kNone);
  EXPECT_EQ(r.reading.impacts, 0);

  const GearPairModel model = build_model(c);
  const auto& p = model.parameters();
  const double cb2 = p.cos_base_helix * p.cos_base_helix;
  const double m = p.equivalent_mass_kg, K = cb2 * p.mean_stiffness_n_per_m(),
               C = cb2 * p.damping_n_s_per_m, Fa = p.force_n.terms[0].amplitude,
               W = p.force_n.terms[0].angular_frequency_rad_s;
  const double wn = std::sqrt(K / m), z = C / (2 * std::sqrt(K * m)),
               wd = wn * std::sqrt(1 - z * z);
  const double X = Fa / std::hypot(K - m * W * W, C * W), th = std::atan2(C * W, K - m * W * W);
  const double A = -X * std::cos(th), B = (z * wn * A - X * W * std::sin(th)) / wd;
  const double b = p.backlash_m, delta_s = b + p.mean_force_n() / K;
  double worst = 0, peak = 0;
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    const double t = r.samples.t_s[i];
    const double y = X * std::cos(W * t - th) +
                     std::exp(-z * wn * t) * (A * std::cos(wd * t) + B * std::sin(wd * t));
    worst = std::max(worst, std::abs(r.samples.delta_bar[i] * b - delta_s - y));
    peak = std::max(peak, std::abs(y));
  }
  // Newmark's phase error over 0.01 s at dt = 1e-8 is ~4e-6 rad; dopri5 is far tighter.
  constexpr double kRelTol = 2e-5;
  EXPECT_LT(worst, kRelTol * peak) << "peak " << peak;
}

INSTANTIATE_TEST_SUITE_P(Gear, BothIntegrators,
                         ::testing::Values(Method::kNewmark, Method::kDopri5),
                         [](const auto& info) {
                           return info.param == Method::kNewmark ? "Newmark" : "Dopri5";
                         });

struct Samples {
  std::vector<ode::State> s;
  void on_step(const ode::State&, const GearPairModel::Drive&) {}
  void on_transition(const ode::State&, int) {}
  void on_sample(const ode::State& x) { s.push_back(x); }
  bool on_progress(double) { return true; }
};

TEST(LogarithmicDecrement, MatchesTheDampingRatio) {
  // A free vibration in drive-side contact (steady F_m, displaced 1 um from the static
  // deflection): y(t + T_d) = exp(-zeta w_n T_d) y(t), so ln(y(t) / y(t + T_d)) =
  // 2 pi zeta / sqrt(1 - zeta^2) for every t.
  for (double zeta : {0.02, 0.07}) {
    Case c;
    c.mesh.stiffness_source = StiffnessSource::kHarmonics;  // constant k_m
    c.mesh.damping_ratio = zeta;
    c.load.fluctuation_ratio = 0.0;
    const GearPairModel model = build_model(c);
    const auto& p = model.parameters();
    const double K = p.cos_base_helix * p.cos_base_helix * p.mean_stiffness_n_per_m();
    const double wn = p.natural_angular_frequency_rad_s();
    const double Td = 2 * std::numbers::pi / (wn * std::sqrt(1 - zeta * zeta));
    const double delta_s = p.backlash_m + p.mean_force_n() / K;
    constexpr int kPerPeriod = 16, kPeriods = 5;
    Samples rec;
    ode::integrate_newmark(model, {0, delta_s + 1e-6, 0, 0, kDriveContact}, kPeriods * Td,
                           Td / 4000, ode::make_output_grid(0, kPeriods * Td, Td / kPerPeriod),
                           rec);
    ASSERT_EQ(rec.s.size(), static_cast<std::size_t>(kPeriods * kPerPeriod + 1));
    const double expected = 2 * std::numbers::pi * zeta / std::sqrt(1 - zeta * zeta);
    for (int i = 0; i + kPerPeriod < static_cast<int>(rec.s.size()); i += 3) {
      const double y0 = rec.s[i].q - delta_s, y1 = rec.s[i + kPerPeriod].q - delta_s;
      if (std::abs(y0) < 0.3e-6) continue;  // near a zero crossing the ratio is ill-conditioned
      EXPECT_NEAR(std::log(y0 / y1), expected, 1e-4 * expected) << "zeta " << zeta << " i " << i;
    }
  }
}

}  // namespace
}  // namespace geardyn
