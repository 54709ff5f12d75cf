// The integrators on systems that are not gears: they know nothing of gears.
#include "geardyn/integrator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace geardyn::ode {
namespace {

struct TimeDrive {
  double t;
};
struct TimeGrid {
  double t0, dt;
  std::int64_t n = 0;
  TimeDrive next() { return {t0 + static_cast<double>(++n) * dt}; }
};

// m q'' = -k q - c q' + F0 cos(W t), one region.
struct Oscillator {
  using Drive = TimeDrive;
  static constexpr bool kPiecewiseLinear = true;
  double m = 2.0, k = 800.0, c = 0.4, F0 = 3.0, W = 7.0;
  double mass() const { return m; }
  Drive drive(double t) const { return {t}; }
  TimeGrid drive_grid(double t0, double dt) const { return {t0, dt}; }
  Force force(const Drive& d, double q, double v, int) const {
    return {-k * q - c * v + F0 * std::cos(W * d.t), -k, -c};
  }
  Guards guards(const Drive&, double, double, int) const { return {}; }

  // Closed form from q(0) = q0, q'(0) = 0.
  double exact(double t, double q0) const {
    const double wn = std::sqrt(k / m), z = c / (2 * std::sqrt(k * m));
    const double wd = wn * std::sqrt(1 - z * z);
    const double X = F0 / std::hypot(k - m * W * W, c * W);
    const double th = std::atan2(c * W, k - m * W * W);
    const double A = q0 - X * std::cos(th);
    const double B = (z * wn * A - X * W * std::sin(th)) / wd;
    return X * std::cos(W * t - th) +
           std::exp(-z * wn * t) * (A * std::cos(wd * t) + B * std::sin(wd * t));
  }
};

// A ball on a stiff damped floor: region 0 free flight under gravity above q = 0, region 1
// in contact below it.
struct Ball {
  using Drive = TimeDrive;
  static constexpr bool kPiecewiseLinear = true;
  double m = 1.0, g = 9.81, k = 1e6, c = 20.0;
  double mass() const { return m; }
  Drive drive(double t) const { return {t}; }
  TimeGrid drive_grid(double t0, double dt) const { return {t0, dt}; }
  Force force(const Drive&, double q, double v, int r) const {
    if (r == 0) return {-m * g, 0, 0};
    return {-m * g - k * q - c * v, -k, -c};
  }
  Guards guards(const Drive&, double q, double, int r) const {
    Guards gs;
    if (r == 0)
      gs.add(q, 1);
    else
      gs.add(-q, 0);
    return gs;
  }
};

// A hardening (Duffing) spring: nonlinear inside its one region.
struct Duffing {
  using Drive = TimeDrive;
  static constexpr bool kPiecewiseLinear = false;
  double mass() const { return 1.0; }
  Drive drive(double t) const { return {t}; }
  TimeGrid drive_grid(double t0, double dt) const { return {t0, dt}; }
  Force force(const Drive&, double q, double v, int) const {
    return {-q - 5.0 * q * q * q - 0.1 * v, -1.0 - 15.0 * q * q, -0.1};
  }
  Guards guards(const Drive&, double, double, int) const { return {}; }
};

// q'' = +w^2 q: grows without bound.
struct Unstable {
  using Drive = TimeDrive;
  static constexpr bool kPiecewiseLinear = true;
  double mass() const { return 1.0; }
  Drive drive(double t) const { return {t}; }
  TimeGrid drive_grid(double t0, double dt) const { return {t0, dt}; }
  Force force(const Drive&, double q, double, int) const { return {1e6 * q, 1e6, 0}; }
  Guards guards(const Drive&, double, double, int) const { return {}; }
};

struct Recorder {
  std::vector<State> samples, transitions;
  std::int64_t steps = 0;
  double cancel_after_t = 1e300;
  template <class D>
  void on_step(const State&, const D&) {
    ++steps;
  }
  void on_transition(const State& s, int) { transitions.push_back(s); }
  void on_sample(const State& s) { samples.push_back(s); }
  bool on_progress(double t) { return t < cancel_after_t; }
};

TEST(Newmark, LinearOscillatorIsSecondOrderAgainstTheClosedForm) {
  const Oscillator sys;
  const double t1 = 1.0, q0 = 0.01;
  constexpr double kExpectedOrder = 2.0;
  std::vector<double> errors;
  for (double dt : {2e-3, 1e-3, 5e-4, 2.5e-4}) {
    Recorder rec;
    const auto sum =
        integrate_newmark(sys, {0, q0, 0, 0, 0}, t1, dt, make_output_grid(0, t1, 0.5), rec);
    ASSERT_TRUE(sum.ok());
    errors.push_back(std::abs(rec.samples.back().q - sys.exact(t1, q0)));
  }
  for (std::size_t i = 1; i < errors.size(); ++i)
    EXPECT_NEAR(std::log2(errors[i - 1] / errors[i]), kExpectedOrder, 0.1);
}

TEST(Dopri5, LinearOscillatorMatchesTheClosedForm) {
  const Oscillator sys;
  Recorder rec;
  Dopri5Options o;
  o.relative_tolerance = o.absolute_tolerance = 1e-12;
  const auto sum =
      integrate_dopri5(sys, {0, 0.01, 0, 0, 0}, 1.0, make_output_grid(0, 1.0, 0.01), rec, o);
  ASSERT_TRUE(sum.ok());
  ASSERT_EQ(rec.samples.size(), 101u);
  for (const State& s : rec.samples) EXPECT_NEAR(s.q, sys.exact(s.t, 0.01), 1e-10);
}

TEST(Newmark, SamplesAreAtExactMultiplesOfTheInterval) {
  const Oscillator sys;
  Recorder rec;
  // dt does not divide the interval: samples are interpolated inside steps.
  integrate_newmark(sys, {0, 0.01, 0, 0, 0}, 0.3, 7e-4, make_output_grid(0, 0.3, 0.01), rec);
  ASSERT_EQ(rec.samples.size(), 31u);
  for (std::size_t i = 0; i < rec.samples.size(); ++i) {
    EXPECT_EQ(rec.samples[i].t, 0.01 * static_cast<double>(i));
    // Interpolation keeps the accuracy of the method (error ~ (w dt)^2 of the amplitude).
    EXPECT_NEAR(rec.samples[i].q, sys.exact(rec.samples[i].t, 0.01), 2e-4);
  }
}

TEST(Newmark, LocatesTheTouchdownOfAFallingBallExactly) {
  // Constant acceleration in flight: Newmark is exact there, so the located impact time is
  // sqrt(2 h / g) to the root finder's accuracy even with a coarse step.
  const Ball sys;
  const double h = 0.2;
  Recorder rec;
  integrate_newmark(sys, {0, h, 0, 0, 0}, 0.25, 3e-3, make_output_grid(0, 0.25, 0.25), rec);
  ASSERT_GE(rec.transitions.size(), 1u);
  EXPECT_NEAR(rec.transitions[0].t, std::sqrt(2 * h / sys.g), 1e-13);
  EXPECT_NEAR(rec.transitions[0].v, -std::sqrt(2 * h * sys.g), 1e-12);
  EXPECT_EQ(rec.transitions[0].region, 1);
}

TEST(Newmark, KeepsSecondOrderThroughImpacts) {
  // Ball bouncing on a damped floor: several contact episodes before t1. Reference: dopri5 at a
  // tight tolerance.
  const Ball sys;
  const double t1 = 1.0;
  Recorder ref;
  Dopri5Options o;
  o.relative_tolerance = o.absolute_tolerance = 1e-13;
  o.max_step_s = 1e-3;
  integrate_dopri5(sys, {0, 0.2, 0, 0, 0}, t1, make_output_grid(0, t1, t1), ref, o);
  ASSERT_GE(ref.transitions.size(), 4u);
  constexpr double kExpectedOrder = 2.0;
  std::vector<double> errors;
  for (double dt : {4e-5, 2e-5, 1e-5, 5e-6}) {
    Recorder rec;
    integrate_newmark(sys, {0, 0.2, 0, 0, 0}, t1, dt, make_output_grid(0, t1, t1), rec);
    ASSERT_EQ(rec.transitions.size(), ref.transitions.size());
    errors.push_back(std::abs(rec.samples.back().v - ref.samples.back().v));
  }
  for (std::size_t i = 1; i < errors.size(); ++i)
    EXPECT_NEAR(std::log2(errors[i - 1] / errors[i]), kExpectedOrder, 0.1) << i;
}

TEST(Newmark, IteratesNewtonOnANonlinearRegion) {
  const Duffing sys;
  Recorder ref, rec;
  Dopri5Options o;
  o.relative_tolerance = o.absolute_tolerance = 1e-12;
  integrate_dopri5(sys, {0, 0.5, 0, 0, 0}, 5.0, make_output_grid(0, 5, 5), ref, o);
  const auto sum =
      integrate_newmark(sys, {0, 0.5, 0, 0, 0}, 5.0, 1e-4, make_output_grid(0, 5, 5), rec);
  ASSERT_TRUE(sum.ok());
  EXPECT_NEAR(rec.samples.back().q, ref.samples.back().q, 1e-6);
}

TEST(Newmark, ReportsNewtonFailure) {
  const Duffing sys;
  Recorder rec;
  NewmarkOptions o;
  o.newton_max_iterations = 1;
  const auto sum =
      integrate_newmark(sys, {0, 0.5, 0, 0, 0}, 1.0, 1e-2, make_output_grid(0, 1, 1), rec, o);
  EXPECT_EQ(sum.termination, Termination::kNewtonFailed);
  EXPECT_NE(sum.message.find("Newton-Raphson did not converge"), std::string::npos);
}

TEST(Integrators, ReportDivergence) {
  const Unstable sys;
  Recorder a, b;
  const auto sn = integrate_newmark(sys, {0, 1, 0, 0, 0}, 2.0, 1e-3, make_output_grid(0, 2, 1), a);
  EXPECT_EQ(sn.termination, Termination::kDiverged);
  const auto sd = integrate_dopri5(sys, {0, 1, 0, 0, 0}, 2.0, make_output_grid(0, 2, 1), b);
  EXPECT_NE(sd.termination, Termination::kCompleted);
}

TEST(Integrators, ObserverCanCancel) {
  const Oscillator sys;
  Recorder rec;
  rec.cancel_after_t = 0.0;
  NewmarkOptions o;
  o.progress_interval_steps = 8;
  const auto sum =
      integrate_newmark(sys, {0, 0.01, 0, 0, 0}, 1.0, 1e-3, make_output_grid(0, 1, 1), rec, o);
  EXPECT_EQ(sum.termination, Termination::kCancelled);
  EXPECT_LT(sum.end_time_s, 0.1);
}

}  // namespace
}  // namespace geardyn::ode
