// Analytic references for the gear-pair model: free flight to the first impact, the linear
// forced response in permanent contact, and the logarithmic decrement of a free vibration.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

#include "geardyn/run.hpp"
#include "geardyn/validation.hpp"

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

// The forced response to a static transmission error in permanent contact with constant
// stiffness: with e = sum a_i cos(w_i t + phi_i), m delta'' + cb2 (k (delta - e - b) + c (delta' -
// e')) = F_m has the steady response delta = b + F_m / (cb2 k) + e_0 + sum |D_i| a_i cos(w_i t +
// phi_i + arg D_i), D = cb2 (k + i c w) / (cb2 k - m w^2 + i cb2 c w). Checked on the final fifth
// of a window long enough for the start to decay (e^-26), for every method and both forms.
struct ErrorCase {
  const char* name;
  Case c;
  double tolerance;  // on delta, relative to the response's dynamic amplitude
};

void PrintTo(const ErrorCase& e, std::ostream* out) { *out << e.name; }

class TransmissionErrorResponse : public ::testing::TestWithParam<ErrorCase> {};

TEST_P(TransmissionErrorResponse, MatchesTheClosedForm) {
  const Case& c = GetParam().c;
  const RunResult r = run(c);
  ASSERT_TRUE(r.integration.ok()) << r.integration.message;
  EXPECT_EQ(r.reading.impacts, 0);
  EXPECT_EQ(r.reading.regime, Regime::kNone);
  const GearPairModel model = build_model(c);
  const auto& p = model.parameters();
  const HarmonicSeries& e = p.transmission_error_m;
  ASSERT_EQ(e.terms.size(), 2U);
  const double cb2 = p.cos_base_helix * p.cos_base_helix, m = p.equivalent_mass_kg;
  const double k = p.mean_stiffness_n_per_m(), damping = p.damping_n_s_per_m, b = p.backlash_m;
  const double mean = b + p.mean_force_n() / (cb2 * k) + e.offset;
  const auto closed = [&](double t) {
    double delta = mean;
    for (const Harmonic& h : e.terms) {
      const double w = h.angular_frequency_rad_s;
      const std::complex<double> d = cb2 * std::complex<double>(k, damping * w) /
                                     std::complex<double>(cb2 * k - m * w * w, cb2 * damping * w);
      delta += std::abs(d) * h.amplitude * std::cos(w * t + h.phase_rad + std::arg(d));
    }
    return delta;
  };
  double worst = 0, lo = 1e300, hi = -1e300;
  const double from = 0.8 * c.solver.duration_s;
  int compared = 0;
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    const double t = r.samples.t_s[i];
    if (t < from) continue;
    const double delta = r.samples.delta_bar[i] * b + e(t);
    worst = std::max(worst, std::abs(delta - closed(t)));
    lo = std::min(lo, delta);
    hi = std::max(hi, delta);
    ++compared;
  }
  EXPECT_GT(compared, 100);
  // The response is well away from rest, and the teeth (x = delta - e) from the backlash.
  EXPECT_GT(hi - lo, 0.01 * b);
  EXPECT_LT(worst, GetParam().tolerance * (hi - lo)) << "amplitude " << (hi - lo);
}

// The paper's gear with constant stiffness, steady torque doubled, mesh at 0.71 of the contact
// natural frequency, 1 um at the mesh frequency and 0.3 um at twice it (above resonance).
Case gear_with_error(Method method) {
  Case c = gear_with_transmission_error();  // validation.hpp (its check te_response)
  c.solver.method = method;
  c.solver.time_step_s = 1e-8;
  return c;
}

// The non-dimensional form: x'' + 2 zeta x' + x = F_m - e'', e = 0.2 cos(0.7 tau) +
// 0.05 cos(1.4 tau + 45 deg).
Case nondimensional_with_error(Method method) {
  Case c = gear_with_error(method);
  c.model.form = ModelForm::kNondimensional;
  c.model.force_mean = 1.0;
  c.model.force_alternating = 0.0;
  c.model.omega = 0.7;
  c.model.transmission_error = {{0.2, 0.0}, {0.05, 45.0}};
  c.solver.duration_s = 1300;  // zeta 0.05: e^-65 of the start is left
  c.solver.time_step_s = 1e-3;
  c.solver.output_interval_s = 0.1;
  return c;
}

INSTANTIATE_TEST_SUITE_P(
    Error, TransmissionErrorResponse,
    ::testing::Values(
        ErrorCase{"gear_exact", gear_with_error(Method::kExact), 1e-9},
        ErrorCase{"gear_dopri5", gear_with_error(Method::kDopri5), 1e-8},
        // Newmark's steady amplitude and phase error, (w dt)^2 / 12: ~1e-8.
        ErrorCase{"gear_newmark", gear_with_error(Method::kNewmark), 1e-6},
        ErrorCase{"nondimensional_exact", nondimensional_with_error(Method::kExact), 1e-9},
        ErrorCase{"nondimensional_dopri5", nondimensional_with_error(Method::kDopri5), 1e-8}),
    [](const auto& info) { return std::string(info.param.name); });

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
