// The exact engine (engine.hpp): closed forms, the period map against dopri5, sensitivities
// against finite differences through impacts, the saltation matrix, and the no-progress check.
#include "geardyn/engine.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "geardyn/adaptive.hpp"
#include "geardyn/model.hpp"
#include "geardyn/reproduce.hpp"
#include "geardyn/run.hpp"

namespace {

using geardyn::ode::EngineOptions;
using geardyn::ode::ExactEngine;
using geardyn::ode::FlowObserver;
using geardyn::ode::FlowResult;
using geardyn::ode::LinearGuard;
using geardyn::ode::LinearRegion;
using geardyn::ode::LinearSwitchedSystem;
using geardyn::ode::Matrix;
using geardyn::ode::OutputGrid;
using geardyn::ode::RowVector;
using geardyn::ode::Termination;
using geardyn::ode::Vector;

// Closed forms are met to this relative error: a few hundred roundings of the state.
constexpr double kClosedFormTolerance = 1e-13;

struct Recorder : FlowObserver {
  std::vector<double> t;
  std::vector<Vector> y;
  std::vector<double> event_t;
  void on_sample(double t_s, const Vector& v, int) override {
    t.push_back(t_s);
    y.push_back(v);
  }
  void on_event(double t_s, const Vector&, int, int) override { event_t.push_back(t_s); }
};

// One region, x'' + c x' + k x = F0 + Fa cos(w t), no guards that can fire.
LinearSwitchedSystem oscillator(double k, double c, double F0, double Fa, double w) {
  LinearSwitchedSystem s;
  s.dimension = 2;
  s.frequencies_rad_s = {w};
  LinearRegion r;
  r.a.constant = Matrix::Zero(2, 2);
  r.a.constant << 0, 1, -k, -c;
  r.u.constant = Vector::Zero(2);
  r.u.constant(1) = F0;
  r.u.cos = {Vector::Zero(2)};
  r.u.sin = {Vector::Zero(2)};
  r.u.cos[0](1) = Fa;
  s.regions = {r, r};  // a second region that is never entered
  LinearGuard g;
  g.row.constant = RowVector::Zero(2);
  g.offset.constant = 1.0;  // always positive
  g.target = 1;
  s.regions[0].guards = {g};
  g.target = 0;
  s.regions[1].guards = {g};
  return s;
}

// A functional of six states over three frequencies: constant, varying and zero row entries
// of both signs, and an offset with its own harmonics.
LinearSwitchedSystem six_state_functional(LinearGuard& g) {
  LinearSwitchedSystem s;
  s.dimension = 6;
  s.frequencies_rad_s = {3.0, 7.5, 11.0};
  g.row.constant = RowVector::Zero(6);
  g.row.constant << 1.5, -2.0, 0.0, 0.25, 0.0, -0.75;
  g.row.cos.assign(3, RowVector::Zero(6));
  g.row.sin.assign(3, RowVector::Zero(6));
  g.row.cos[0](1) = 0.5;
  g.row.sin[2](1) = -0.3;
  g.row.cos[1](4) = -1.25;  // an entry that is zero on average
  g.offset.constant = -0.4;
  g.offset.cos = {0.2, 0.0, -0.1};
  g.offset.sin = {0.0, 0.05, 0.0};
  return s;
}

TEST(LinearSystem, FunctionalValuesAreEachFunctionalsValueToTheLastBit) {
  LinearGuard g;
  const LinearSwitchedSystem s = six_state_functional(g);
  LinearGuard constant;
  constant.row.constant = RowVector::LinSpaced(6, -1.0, 1.5);
  constant.offset.constant = 0.3;
  // One harmonic in the offset alone, and one in the row alone (the reader keeps, per
  // functional, the harmonics either holds).
  LinearGuard offset_only = constant;
  offset_only.offset.cos = {0.0, 0.0, 0.35};
  offset_only.offset.sin = {0.0, -0.2, 0.0};
  LinearGuard row_only = constant;
  row_only.row.cos.assign(3, RowVector::Zero(6));
  row_only.row.sin.assign(3, RowVector::Zero(6));
  row_only.row.sin[1](3) = 0.8;
  const std::vector<LinearGuard> gs = {g, constant, offset_only, row_only, g};
  const geardyn::ode::FunctionalValues read(s, gs);
  std::vector<double> values;
  for (int i = 0; i < 50; ++i) {
    const double t = 0.137 * i - 2.0;
    const Vector y = Vector::LinSpaced(6, -0.5 + 0.01 * i, 2.0 - 0.03 * i);
    read(t, y, values);
    ASSERT_EQ(values.size(), gs.size());
    for (std::size_t k = 0; k < gs.size(); ++k)
      EXPECT_EQ(values[k], geardyn::ode::functional_value(s, gs[k], t, y)) << k << " at " << t;
  }
}

TEST(LinearSystem, PhasesAreTheDirectOnesOrThoseGivenForTheirTableAndTime) {
  // phases_at computes cos(w t) and sin(w t) to the bit, and returns what a GivenPhases gave only
  // for the same table (that one, or an equal one) and time, and only while it lives: a reader
  // at another time, or of another table at that time, or after the giver's end, is not handed
  // them, nor is a reader of kept_direct_phases. A PhaseGrid's rotation stays within 1e-13 of
  // the direct values over three resynchronisations and equals them at each; a mutant that
  // rotates by -w dt, or never resynchronises, fails.
  using geardyn::ode::PhaseGrid;
  const std::vector<double> w = {3.0, 1234.5, 2.0e4};
  using geardyn::ode::phases_at;
  const geardyn::ode::Phases direct = phases_at(w, 0.731);
  ASSERT_EQ(direct.cos_wt.size(), w.size());
  ASSERT_EQ(direct.sin_wt.size(), w.size());
  for (std::size_t f = 0; f < w.size(); ++f) {
    EXPECT_EQ(direct.cos_wt[f], std::cos(w[f] * 0.731));
    EXPECT_EQ(direct.sin_wt[f], std::sin(w[f] * 0.731));
  }
  const std::vector<double> given_c = {0.5, -0.25, 1.0}, given_z = {0.125, 0.75, -1.0};
  const geardyn::ode::Phases given_phases{given_c, given_z};
  const std::vector<double> other = {3.0, 1234.5, 2.0e4 + 1.0};
  {
    geardyn::ode::GivenPhases given;
    given.give(w, 0.9, given_phases);
    EXPECT_EQ(phases_at(w, 0.9).cos_wt, given_c);
    EXPECT_EQ(phases_at(w, 0.9).sin_wt, given_z);
    EXPECT_EQ(&phases_at(w, 0.9), &given_phases);  // handed out, not copied
    const std::vector<double> equal = w;           // an equal table elsewhere
    EXPECT_EQ(phases_at(equal, 0.9).cos_wt, given_c);
    EXPECT_EQ(phases_at(other, 0.9).cos_wt[2], std::cos(other[2] * 0.9));
    EXPECT_EQ(phases_at(w, 0.9).cos_wt[1], std::cos(w[1] * 0.9));  // another table was asked
    given.give(w, 0.9, given_phases);
    EXPECT_EQ(phases_at(w, 0.9 + 1e-15).cos_wt[0], std::cos(w[0] * (0.9 + 1e-15)));
    given.give(w, 0.9, given_phases);
  }
  // Its end forgets them: the same table and time are then the direct phases.
  EXPECT_EQ(phases_at(w, 0.9).cos_wt[0], std::cos(w[0] * 0.9));
  EXPECT_EQ(phases_at(w, 0.9).sin_wt[2], std::sin(w[2] * 0.9));
  // kept_direct_phases hands back only what phases_at computed, for its table and time: not
  // what a GivenPhases gave, not another time's, not another table's.
  using geardyn::ode::kept_direct_phases;
  (void)phases_at(w, 0.5);
  const geardyn::ode::Phases* kept = kept_direct_phases(w, 0.5);
  ASSERT_NE(kept, nullptr);
  for (std::size_t f = 0; f < w.size(); ++f) {
    EXPECT_EQ(kept->cos_wt[f], std::cos(w[f] * 0.5));
    EXPECT_EQ(kept->sin_wt[f], std::sin(w[f] * 0.5));
  }
  EXPECT_EQ(kept_direct_phases(w, 0.5 + 1e-15), nullptr);
  EXPECT_EQ(kept_direct_phases(other, 0.5), nullptr);
  {
    geardyn::ode::GivenPhases given;
    given.give(w, 0.5, given_phases);
    EXPECT_EQ(kept_direct_phases(w, 0.5), nullptr);
  }
  EXPECT_EQ(kept_direct_phases(w, 0.5), nullptr);

  const double t0 = 0.0123, dt = 1.0e-6;
  PhaseGrid grid(w, t0, dt);
  double worst = 0;
  for (std::int64_t k = 1; k <= 3 * PhaseGrid::kResyncSteps + 5; ++k) {
    grid.advance(k);
    const double t = t0 + static_cast<double>(k) * dt;
    for (std::size_t f = 0; f < w.size(); ++f) {
      worst = std::max({worst, std::abs(grid.cos_wt()[f] - std::cos(w[f] * t)),
                        std::abs(grid.sin_wt()[f] - std::sin(w[f] * t))});
      if (k % PhaseGrid::kResyncSteps == 0) {
        EXPECT_EQ(grid.cos_wt()[f], std::cos(w[f] * t)) << k;
        EXPECT_EQ(grid.sin_wt()[f], std::sin(w[f] * t)) << k;
      }
    }
  }
  EXPECT_LT(worst, 1e-13);
  EXPECT_GT(worst, 0.0);  // the rotation is not the direct evaluation
}

TEST(LinearSystem, FunctionalBoundsHoldEveryPhaseAndStateOfTheBox) {
  LinearGuard g;
  const LinearSwitchedSystem s = six_state_functional(g);
  const geardyn::ode::FunctionalBounds b(g);
  Vector lo(6), hi(6);
  lo << -1.0, 0.5, -3.0, -2.0, 1.0, -0.25;
  hi << 2.0, 1.5, 3.0, -1.0, 4.0, 0.75;
  double low = 0, high = 0;
  b.bounds(lo, hi, low, high);
  // Every phase and state inside, including the box's corners.
  double seen_low = INFINITY, seen_high = -INFINITY;
  for (int i = 0; i < 4000; ++i) {
    const double t = 0.0173 * i;
    Vector y(6);
    for (int j = 0; j < 6; ++j) {
      const double u = std::fmod(0.618034 * (i + 1) * (j + 2), 1.0);
      y(j) = (i % 3 == 0) ? ((((i / 3) >> j) & 1) ? hi(j) : lo(j)) : lo(j) + u * (hi(j) - lo(j));
    }
    const double v = geardyn::ode::functional_value(s, g, t, y);
    seen_low = std::min(seen_low, v);
    seen_high = std::max(seen_high, v);
  }
  EXPECT_LE(low, seen_low);
  EXPECT_GE(high, seen_high);
  // Attained where the functional is constant: at the corner each entry's sign picks.
  LinearGuard constant;
  constant.row.constant = g.row.constant;
  constant.offset.constant = g.offset.constant;
  const geardyn::ode::FunctionalBounds cb(constant);
  cb.bounds(lo, hi, low, high);
  Vector at_low(6), at_high(6);
  for (int j = 0; j < 6; ++j) {
    const bool up = constant.row.constant(j) > 0;
    at_low(j) = up ? lo(j) : hi(j);
    at_high(j) = up ? hi(j) : lo(j);
  }
  EXPECT_NEAR(low, geardyn::ode::functional_value(s, constant, 0, at_low), 1e-15);
  EXPECT_NEAR(high, geardyn::ode::functional_value(s, constant, 0, at_high), 1e-15);
}

// A mesh force in contact, F = k(t) (d - b) + c d' on the state (d, d'), with k(t) = k0 +
// sum over f of k_cos[f] cos(w_f t) + k_sin[f] sin(w_f t), over two frequencies.
constexpr double kForceK0 = 2.3e8, kForceB = 100e-6, kForceC = 800.0;
LinearGuard rippling_force(const std::array<double, 2>& k_cos, const std::array<double, 2>& k_sin,
                           LinearSwitchedSystem& s) {
  s.dimension = 2;
  s.frequencies_rad_s = {6283.0, 12566.0};
  LinearGuard f;
  f.row.constant = RowVector::Zero(2);
  f.row.constant << kForceK0, kForceC;
  f.row.cos = {RowVector::Zero(2), RowVector::Zero(2)};
  f.row.sin = {RowVector::Zero(2), RowVector::Zero(2)};
  f.offset.constant = -kForceK0 * kForceB;
  f.offset.cos = {0.0, 0.0};
  f.offset.sin = {0.0, 0.0};
  for (std::size_t k = 0; k < 2; ++k) {
    f.row.cos[k](0) = k_cos[k];
    f.row.sin[k](0) = k_sin[k];
    f.offset.cos[k] = -k_cos[k] * kForceB;
    f.offset.sin[k] = -k_sin[k] * kForceB;
  }
  return f;
}

// Every sampled time and state of the box [lo, hi] inside [low, high], to `rounding`.
void expect_samples_inside(const LinearSwitchedSystem& s, const LinearGuard& f, const Vector& lo,
                           const Vector& hi, double low, double high, double rounding) {
  for (int i = 0; i < 2000; ++i) {
    const double t = 1.3e-5 * i;
    Vector y(2);
    y << lo(0) + (hi(0) - lo(0)) * std::fmod(0.618034 * i, 1.0),
        lo(1) + (hi(1) - lo(1)) * std::fmod(0.414214 * i, 1.0);
    const double v = geardyn::ode::functional_value(s, f, t, y);
    EXPECT_LE(low, v + rounding);
    EXPECT_GE(high, v - rounding);
  }
}

TEST(LinearSystem, AForceWhoseStiffnessRipplesBoundsByItsDeflectionNotItsBacklash) {
  // rippling_force with k(t) = k0 + k1 cos(w1 t) + k2 sin(w2 t) and d a few um past a backlash
  // of 100 um. Row and offset vary together: bounded apart, each would range over k's ripple
  // times d and b (tens of times F's swing); bounded harmonic by harmonic, over k's ripple
  // times d - b.
  const double k0 = kForceK0, k1 = 0.3 * k0, k2 = 0.1 * k0, b = kForceB, c = kForceC;
  LinearSwitchedSystem s;
  const LinearGuard f = rippling_force({k1, 0.0}, {0.0, k2}, s);
  Vector lo(2), hi(2);
  lo << b + 2e-6, -0.01;
  hi << b + 5e-6, 0.02;
  double low = 0, high = 0;
  geardyn::ode::FunctionalBounds(f).bounds(lo, hi, low, high);
  // The closed form over the box: (d - b) in [2, 5] um, k in [k0 - k1 - k2, k0 + k1 + k2]
  // (attained: the two phases are independent over time), c d' in [-8, 16] N.
  const double true_low = (k0 - k1 - k2) * 2e-6 - c * 0.01;
  const double true_high = (k0 + k1 + k2) * 5e-6 + c * 0.02;
  const double rounding = 1e-12 * k0 * b;
  EXPECT_LE(low, true_low + rounding);
  EXPECT_GE(high, true_high - rounding);
  // Close to it: here 276 N below (the ripple's amplitude is taken at the box's largest
  // d - b, where the true low has it at the smallest), 0 above, against a span of 1358 N.
  // Bounded entry by entry, k's ripple times b alone (9.2e3 N) is nearly seven spans.
  const double span = true_high - true_low;
  EXPECT_LT(true_low - low, 0.4 * span);
  EXPECT_LT(high - true_high, 0.4 * span);
  expect_samples_inside(s, f, lo, hi, low, high, rounding);
}

TEST(LinearSystem, AForceWhoseHarmonicsShareOnePatternBoundsAsHarmonicByHarmonic) {
  // rippling_force with k(t) = k0 + k1 cos(w1 t - phi) + k2 sin(w2 t): every harmonic of row and
  // offset is (1, -b) scaled, so FunctionalBounds takes their amplitude at once,
  // (hypot(k1 cos phi, k1 sin phi) + k2) max|d - b|. The same functional with one harmonic's
  // offset moved by 1e-9 of itself (no longer the pattern) is bounded harmonic by harmonic: the
  // two bounds agree to within what that moves, and both equal the closed form. A mutant that
  // sums |c_f| + |s_f| for hypot(c_f, s_f), or drops a frequency's scale, fails.
  const double k0 = kForceK0, k1 = 0.3 * k0, k2 = 0.1 * k0, b = kForceB, c = kForceC, phi = 0.7;
  LinearSwitchedSystem s;
  const LinearGuard f = rippling_force({k1 * std::cos(phi), 0.0}, {k1 * std::sin(phi), k2}, s);
  Vector lo(2), hi(2);
  lo << b + 2e-6, -0.01;
  hi << b + 5e-6, 0.02;
  double low = 0, high = 0;
  geardyn::ode::FunctionalBounds(f).bounds(lo, hi, low, high);
  LinearGuard apart = f;
  apart.offset.cos[0] *= 1 + 1e-9;
  double apart_low = 0, apart_high = 0;
  geardyn::ode::FunctionalBounds(apart).bounds(lo, hi, apart_low, apart_high);
  const double span = (k0 + k1 + k2) * 5e-6 + c * 0.02 - ((k0 - k1 - k2) * 2e-6 - c * 0.01);
  EXPECT_NEAR(low, apart_low, 1e-8 * span);
  EXPECT_NEAR(high, apart_high, 1e-8 * span);
  // The closed form: the constant part over the box, then the ripple's amplitude (k1 + k2)
  // times the box's largest d - b (5 um); tighter here than entry by entry.
  const double rounding = 1e-12 * k0 * b;
  EXPECT_NEAR(low, k0 * 2e-6 - c * 0.01 - (k1 + k2) * 5e-6, rounding);
  EXPECT_NEAR(high, k0 * 5e-6 + c * 0.02 + (k1 + k2) * 5e-6, rounding);
  expect_samples_inside(s, f, lo, hi, low, high, rounding);
}

TEST(ExactEngine, FreeFlightMatchesItsClosedForm) {
  // x'' = F0 + Fa cos(w t): x = x0 + v0 t + F0 t^2 / 2 + Fa (1 - cos w t) / w^2.
  const double F0 = 3.0, Fa = 2.0, w = 7.0, x0 = 0.3, v0 = -1.1;
  const ExactEngine e(oscillator(0, 0, F0, Fa, w));
  Recorder rec;
  Vector y0(2);
  y0 << x0, v0;
  const FlowResult r = e.flow(0, y0, 0, 20.0, OutputGrid{0, 0.37, 55}, rec);
  ASSERT_TRUE(r.ok()) << r.message;
  for (std::size_t i = 0; i < rec.t.size(); ++i) {
    const double t = rec.t[i];
    const double x = x0 + v0 * t + F0 * t * t / 2 + Fa * (1 - std::cos(w * t)) / (w * w);
    const double v = v0 + F0 * t + Fa * std::sin(w * t) / w;
    EXPECT_NEAR(rec.y[i][0], x, kClosedFormTolerance * (1 + std::abs(x))) << "t = " << t;
    EXPECT_NEAR(rec.y[i][1], v, kClosedFormTolerance * (1 + std::abs(v))) << "t = " << t;
  }
}

TEST(ExactEngine, ARegionsRateIsItsOwnWhateverWasBuiltBefore) {
  // A constant region's cells are 1.5 / (its largest eigenvalue modulus) long, a modulus the
  // engine remembers for a system built again (a study builds one per key value): engines of
  // x'' + k x = 1 with k = 4, 9 and 4 again have cells of 1.5 / 2, 1.5 / 3 and 1.5 / 2 s.
  for (const double k : {4.0, 9.0, 4.0, 9.0}) {
    const ExactEngine e(oscillator(k, 0, 1.0, 0, 1.0));
    EXPECT_NEAR(e.cell_length_s(0), 1.5 / std::sqrt(k), 1e-14) << k;
  }
}

TEST(ExactEngine, AMovingWallIsMetWhereItsClosedFormSays) {
  // Free flight x = v0 t towards a wall at b + a sin(w t) (a guard whose offset varies, as a
  // transmission error moves the contact edge): the state's series end at order 1, the wall's
  // need many more; the crossing is the root of v0 t = b + a sin(w t), and the flow goes on
  // past the wall without coming back.
  const double v0 = 1.0, b = 1.0, a = 0.01, w = 50.0;
  LinearSwitchedSystem s;
  s.dimension = 2;
  s.frequencies_rad_s = {w};
  LinearRegion r;
  r.a.constant = Matrix::Zero(2, 2);
  r.a.constant(0, 1) = 1;
  r.u.constant = Vector::Zero(2);
  s.regions = {r, r};
  LinearGuard g;  // inside: sign (b + a sin(w t) - x) >= 0
  g.row.constant = RowVector::Zero(2);
  g.offset.cos = {0.0};
  g.scale = b;
  g.row.constant(0) = -1;
  g.offset.constant = b;
  g.offset.sin = {a};
  g.target = 1;
  s.regions[0].guards = {g};
  g.row.constant(0) = 1;
  g.offset.constant = -b;
  g.offset.sin = {-a};
  g.target = 0;
  s.regions[1].guards = {g};
  const ExactEngine e(s);
  Recorder rec;
  Vector y0(2);
  y0 << 0.0, v0;
  const FlowResult res = e.flow(0, y0, 0, 2.0, OutputGrid{}, rec);
  ASSERT_TRUE(res.ok()) << res.message;
  double t = b / v0;  // Newton on v0 t - b - a sin(w t)
  for (int i = 0; i < 50; ++i)
    t -= (v0 * t - b - a * std::sin(w * t)) / (v0 - a * w * std::cos(w * t));
  ASSERT_EQ(rec.event_t.size(), 1U);
  EXPECT_NEAR(rec.event_t[0], t, 1e-12);
  EXPECT_EQ(res.region, 1);
}

TEST(ExactEngine, DampedForcedOscillatorMatchesItsClosedForm) {
  // x'' + 2 zeta wn x' + wn^2 x = F cos(W t) from rest at x0: the steady response plus the
  // damped free vibration, in complex form.
  const double wn = 50.0, zeta = 0.03, F = 4.0, W = 37.0, x0 = 0.02;
  const ExactEngine e(oscillator(wn * wn, 2 * zeta * wn, 0, F, W));
  Recorder rec;
  Vector y0(2);
  y0 << x0, 0;
  const FlowResult r = e.flow(0, y0, 0, 3.0, OutputGrid{0, 0.0123, 244}, rec);
  ASSERT_TRUE(r.ok()) << r.message;
  const std::complex<double> H = F / std::complex<double>(wn * wn - W * W, 2 * zeta * wn * W);
  const double wd = wn * std::sqrt(1 - zeta * zeta);
  // x = Re(H e^{iWt}) + e^{-zeta wn t} (A cos wd t + B sin wd t).
  const double A = x0 - H.real();
  const double B = (0 - (-W * H.imag()) + zeta * wn * A) / wd;
  double amplitude = 0;
  for (std::size_t i = 0; i < rec.t.size(); ++i) {
    const double t = rec.t[i];
    const std::complex<double> p = H * std::exp(std::complex<double>(0, W * t));
    const double x =
        p.real() + std::exp(-zeta * wn * t) * (A * std::cos(wd * t) + B * std::sin(wd * t));
    amplitude = std::max(amplitude, std::abs(x));
    EXPECT_NEAR(rec.y[i][0], x, kClosedFormTolerance * (x0 + std::abs(H))) << "t = " << t;
  }
  EXPECT_GT(amplitude, 0.01);
}

// x'' + 2 zeta wn x' + wn^2 x = F cos(W t) from (x0, v0): the steady response Re(H e^{iWt})
// plus the damped free vibration.
struct ForcedOscillator {
  double wn, zeta, F, W;
  std::complex<double> H() const {
    return F / std::complex<double>(wn * wn - W * W, 2 * zeta * wn * W);
  }
  // (x, v) at t.
  std::array<double, 2> at(double t, double x0, double v0) const {
    const double wd = wn * std::sqrt(1 - zeta * zeta), s = zeta * wn;
    const std::complex<double> h = H();
    const double A = x0 - h.real();
    const double B = (v0 + W * h.imag() + s * A) / wd;
    const std::complex<double> p = h * std::exp(std::complex<double>(0, W * t));
    const std::complex<double> dp = std::complex<double>(0, W) * p;
    const double e = std::exp(-s * t), c = std::cos(wd * t), si = std::sin(wd * t);
    return {p.real() + e * (A * c + B * si),
            dp.real() + e * (-s * (A * c + B * si) + wd * (-A * si + B * c))};
  }
};

TEST(ExactEngine, SteadyJumpsOfAConstantRegionMatchTheClosedForm) {
  // Constant coefficients under harmonic forcing: without samples the engine jumps blocks of
  // one forcing period around the periodic response. The end state and the Jacobian (the
  // free vibration's fundamental matrix) match the closed form.
  const ForcedOscillator o{50.0, 0.03, 4.0, 37.0};
  const ExactEngine e(oscillator(o.wn * o.wn, 2 * o.zeta * o.wn, 0, o.F, o.W));
  FlowObserver none;
  Vector y0(2);
  y0 << 0.02, -0.3;
  for (double t1 : {0.5, 3.0, 30.0}) {
    const FlowResult r = e.flow(0, y0, 0, t1, OutputGrid{}, none, true);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_GT(r.periods, 0) << "t1 = " << t1;  // the blocks were jumped
    const auto y = o.at(t1, y0[0], y0[1]);
    const double scale = std::abs(o.H()) + std::abs(y0[0]);
    EXPECT_NEAR(r.state[0], y[0], kClosedFormTolerance * scale) << "t1 = " << t1;
    EXPECT_NEAR(r.state[1], y[1], kClosedFormTolerance * scale * o.wn) << "t1 = " << t1;
    // Columns of the Jacobian: the free vibration from unit x0 and unit v0.
    const ForcedOscillator free{o.wn, o.zeta, 0.0, o.W};
    const auto jx = free.at(t1, 1, 0), jv = free.at(t1, 0, 1);
    ASSERT_TRUE(r.jacobian);
    const Matrix& J = *r.jacobian;
    EXPECT_NEAR(J(0, 0), jx[0], kClosedFormTolerance) << "t1 = " << t1;
    EXPECT_NEAR(J(1, 0), jx[1], kClosedFormTolerance * o.wn) << "t1 = " << t1;
    EXPECT_NEAR(J(0, 1), jv[0], kClosedFormTolerance / o.wn) << "t1 = " << t1;
    EXPECT_NEAR(J(1, 1), jv[1], kClosedFormTolerance) << "t1 = " << t1;
  }
}

TEST(ExactEngine, SteadyJumpsDoNotSkipALateCrossing) {
  // Negative damping: the state starts a hair off the periodic response and the deviation
  // grows, so the blocks are jumped at first and a guard at x = -1.1 |H| is crossed only
  // after many forcing periods. The event is found at the closed form's first crossing.
  const ForcedOscillator o{50.0, -0.01, 4.0, 10.0};
  const std::complex<double> H = o.H();
  const double level = -1.1 * std::abs(H);
  LinearSwitchedSystem s = oscillator(o.wn * o.wn, 2 * o.zeta * o.wn, 0, o.F, o.W);
  s.regions[0].guards[0].row.constant << 1, 0;
  s.regions[0].guards[0].offset.constant = -level;
  s.regions[0].guards[0].scale = std::abs(H);
  const ExactEngine e(s);
  const double x0 = H.real() + 1e-6 * std::abs(H), v0 = -o.W * H.imag();
  // The closed form's first crossing: a fine scan, then bisection.
  const double dt = 1e-4;
  double t = 0;
  while (o.at(t + dt, x0, v0)[0] > level) t += dt;
  double lo = t, hi = t + dt;
  for (int i = 0; i < 200 && hi - lo > 1e-15; ++i) {
    const double mid = 0.5 * (lo + hi);
    (o.at(mid, x0, v0)[0] > level ? lo : hi) = mid;
  }
  ASSERT_GT(lo, 20 * 2 * std::numbers::pi / o.W);  // many periods from the start
  Recorder rec;
  Vector y0(2);
  y0 << x0, v0;
  const FlowResult r = e.flow(0, y0, 0, lo + 1.0, OutputGrid{}, rec);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GT(r.periods, 5);
  ASSERT_FALSE(rec.event_t.empty());
  EXPECT_NEAR(rec.event_t.front(), lo, 1e-9);
}

TEST(ExactEngine, PeriodMapAgreesWithDopri5OverManyMeshPeriods) {
  // The paper's gear at 10 kHz from static contact: it stays in contact, so the run is the
  // linear periodic system of the mesh, 2000 mesh periods; dopri5 at 1e-13 beside it.
  geardyn::Case c;
  c.speed.shaft_frequency_hz = 10000;
  c.mesh.stiffness_source = geardyn::StiffnessSource::kHarmonics;
  c.mesh.stiffness_harmonics = {{0.08, 30}, {0.03, -40}};
  c.load.fluctuation_ratio = 0.1;
  c.solver.initial = geardyn::InitialCondition::kStatic;
  c.solver.duration_s = 2000 / (56 * 1e4);
  c.solver.output_interval_s = c.solver.duration_s / 400;
  geardyn::Case d = c;
  d.solver.method = geardyn::Method::kDopri5;
  d.solver.tolerance = 1e-13;
  const geardyn::RunResult re = geardyn::run(c), rd = geardyn::run(d);
  ASSERT_TRUE(re.integration.ok() && rd.integration.ok());
  EXPECT_EQ(re.reading.separations, 0);
  ASSERT_EQ(re.samples.size(), rd.samples.size());
  double err = 0;
  for (std::size_t i = 0; i < re.samples.size(); ++i)
    err = std::max(err, std::abs(re.samples.delta_bar[i] - rd.samples.delta_bar[i]));
  EXPECT_LT(err, 1e-10);
}

TEST(ExactEngine, MeetsTheDefaultAccuracyOnEveryPaperCase) {
  // The default tolerance against dopri5 at 1e-13, the 11 cases over 20 ms: max |delta/b|
  // difference <= 1e-8 (the promise of docs/numerics.md).
  const geardyn::Study study = geardyn::park2010_study();
  for (const geardyn::StudyCase& sc : study.cases) {
    geardyn::Case c = sc.input;
    c.solver.duration_s = 0.02;
    c.solver.output_interval_s = 1e-5;
    geardyn::Case d = c;
    d.solver.method = geardyn::Method::kDopri5;
    d.solver.tolerance = 1e-13;
    const geardyn::RunResult re = geardyn::run(c), rd = geardyn::run(d);
    ASSERT_TRUE(re.integration.ok() && rd.integration.ok()) << sc.id;
    ASSERT_EQ(re.samples.size(), rd.samples.size()) << sc.id;
    double err = 0;
    for (std::size_t i = 0; i < re.samples.size(); ++i)
      err = std::max(err, std::abs(re.samples.delta_bar[i] - rd.samples.delta_bar[i]));
    EXPECT_LT(err, 1e-8) << sc.id;
    EXPECT_EQ(re.reading.impacts, rd.reading.impacts) << sc.id;
    // dopri5 reads the force at its step ends and points inside its steps, below the true
    // peak; the exact engine finds the peak inside its cells: never below dopri5's, and within
    // dopri5's sampling error of it.
    EXPECT_GE(re.reading.max_force_bar, rd.reading.max_force_bar * (1 - 1e-12)) << sc.id;
    EXPECT_NEAR(re.reading.max_force_bar, rd.reading.max_force_bar, 1e-4 * rd.reading.max_force_bar)
        << sc.id;
    // Looser tolerances hold too: the error never exceeds the tolerance asked for.
    for (double tol : {1e-3, 1e-6}) {
      geardyn::Case l = c;
      l.solver.tolerance = tol;
      const geardyn::RunResult rl = geardyn::run(l);
      ASSERT_TRUE(rl.integration.ok()) << sc.id;
      double e = 0;
      for (std::size_t i = 0; i < rl.samples.size(); ++i)
        e = std::max(e, std::abs(rl.samples.delta_bar[i] - rd.samples.delta_bar[i]));
      EXPECT_LT(e, tol) << sc.id << " at tolerance " << tol;
    }
  }
}

TEST(ExactEngine, ResultsDoNotDependOnTheCellLength) {
  // The cell length is a cost setting: events and samples must not move with it (a state handed
  // over at a region's edge once read as across it when cells were long).
  const geardyn::Study study = geardyn::park2010_study();
  for (const char* id : {"fig4a", "fig4c", "fig6c"}) {
    geardyn::Case c;
    for (const geardyn::StudyCase& sc : study.cases)
      if (sc.id == id) c = sc.input;
    const geardyn::GearPairModel model = geardyn::build_model(c);
    const double t1 = 0.02;
    const OutputGrid grid{0, t1 / 500, 501};
    std::vector<std::vector<double>> samples;
    std::vector<std::vector<double>> events;
    for (double rate : {0.5, 1.5, 3.0}) {
      EngineOptions o;
      o.cell_rate_product = rate;
      const ExactEngine e(model.linear_system(), o);
      Recorder rec;
      Vector y0 = Vector::Zero(2);
      const FlowResult r =
          e.flow(0, y0, geardyn::kSeparated - geardyn::GearPairModel::kFirstRegion, t1, grid, rec);
      ASSERT_TRUE(r.ok()) << id << ": " << r.message;
      std::vector<double> d;
      for (const Vector& y : rec.y) d.push_back(y[0] / model.parameters().backlash_m);
      samples.push_back(d);
      events.push_back(rec.event_t);
    }
    for (std::size_t j = 1; j < samples.size(); ++j) {
      ASSERT_EQ(events[j].size(), events[0].size()) << id;
      for (std::size_t i = 0; i < events[0].size(); ++i)
        EXPECT_NEAR(events[j][i], events[0][i], 1e-10) << id;
      for (std::size_t i = 0; i < samples[0].size(); ++i)
        EXPECT_NEAR(samples[j][i], samples[0][i], 1e-8) << id;  // the default accuracy
    }
  }
}

// x'' + x' + k0 (1 + 0.9 sin(2 pi t)) x = 1000 (m, s): a stiffness that peaks a quarter period
// in, so that the cells there swing further from the static state than the first; a guard that
// never fires (x + 1e9 >= 0) of the given scale.
LinearSwitchedSystem stiffening_oscillator(double guard_scale) {
  const double w = 2 * std::numbers::pi, k0 = std::pow(3 * w, 2);
  LinearSwitchedSystem s;
  s.dimension = 2;
  s.frequencies_rad_s = {w};
  s.coefficient_period_s = 1.0;
  LinearRegion r;
  r.a.constant = Matrix::Zero(2, 2);
  r.a.constant << 0, 1, -k0, -1;
  r.a.cos = {Matrix::Zero(2, 2)};
  r.a.sin = {Matrix::Zero(2, 2)};
  r.a.sin[0](1, 0) = -0.9 * k0;
  r.u.constant = Vector::Zero(2);
  r.u.constant(1) = 1000;
  LinearGuard g;
  g.row.constant = RowVector::Zero(2);
  g.row.constant(0) = 1;
  g.offset.constant = 1e9;
  g.scale = guard_scale;
  g.target = 1;
  r.guards = {g};
  s.regions = {r, r};  // a second region that is never entered
  s.regions[1].guards[0].target = 0;
  return s;
}

TEST(ExactEngine, EveryCellOfAPeriodIsHeldToItsGuardsExcursionBound) {
  // A cell whose forced excursion along a guard exceeds the guard's scale is halved, with every
  // cell of the period judged, not only the first (whose stiffness is the mean here): the
  // smaller the scale, the shorter the cells, and the flow the same whatever they are.
  std::vector<int> cells;
  std::vector<Vector> ends;
  for (const double scale : {1e12, 1.0, 0.3}) {
    const ExactEngine e(stiffening_oscillator(scale));
    cells.push_back(e.cells_per_period(0));
    Recorder rec;
    const FlowResult r = e.flow(0, Vector::Zero(2), 0, 2.0, OutputGrid{}, rec);
    ASSERT_TRUE(r.ok()) << r.message;
    ends.push_back(r.state);
  }
  EXPECT_GE(cells[1], 2 * cells[0]) << "a guard of scale 1 m against excursions of about 1 m";
  EXPECT_GE(cells[2], 2 * cells[1]) << "a guard of scale 0.3 m";
  for (std::size_t j = 1; j < ends.size(); ++j)
    for (int i = 0; i < 2; ++i)
      EXPECT_NEAR(ends[j][i], ends[0][i], 1e-11 * ends[0].cwiseAbs().maxCoeff());
}

// The flow map y(t1) of a system and its Jacobian against central differences.
void expect_jacobian_matches_differences(const ExactEngine& e, const Vector& y0, int region,
                                         double t1, const Vector& step, int min_events) {
  Recorder rec;
  const FlowResult r = e.flow(0, y0, region, t1, OutputGrid{}, rec, true);
  ASSERT_TRUE(r.ok()) << r.message;
  ASSERT_GE(r.events, min_events);
  ASSERT_TRUE(r.jacobian);
  const int n = static_cast<int>(y0.size());
  for (int j = 0; j < n; ++j) {
    Vector yp = y0, ym = y0;
    yp[j] += step[j];
    ym[j] -= step[j];
    Recorder a, b;
    const FlowResult rp = e.flow(0, yp, region, t1, OutputGrid{}, a);
    const FlowResult rm = e.flow(0, ym, region, t1, OutputGrid{}, b);
    ASSERT_EQ(rp.events, r.events) << "a difference step changed the event sequence";
    ASSERT_EQ(rm.events, r.events);
    const Vector column = (rp.state - rm.state) / (2 * step[j]);
    for (int i = 0; i < n; ++i) {
      const double scale = column.cwiseAbs().maxCoeff() + std::abs((*r.jacobian)(i, j));
      EXPECT_NEAR((*r.jacobian)(i, j), column[i], 1e-6 * scale) << "d y" << i << " / d y0_" << j;
    }
  }
}

// The non-dimensional gear (Kahraman-Singh) rattling between both flanks, with a stiffness
// harmonic: several impacts from (0.2, 0.1) in its separated region.
LinearSwitchedSystem rattling_oscillator() {
  geardyn::Case c;
  c.model.form = geardyn::ModelForm::kNondimensional;
  c.model.zeta = 0.02;
  c.model.force_mean = 0.05;
  c.model.force_alternating = 0.6;
  c.model.omega = 1.3;
  c.model.stiffness_harmonics = {{0.2, 10}};
  return geardyn::build_model(c).linear_system();
}

TEST(ExactEngine, JacobianMatchesFiniteDifferencesThroughImpacts) {
  // The rattling oscillator: several impacts, each with its saltation.
  const ExactEngine e(rattling_oscillator());
  Vector y0(2), step(2);
  y0 << 0.2, 0.1;
  step << 1e-6, 1e-6;
  expect_jacobian_matches_differences(
      e, y0, geardyn::kSeparated - geardyn::GearPairModel::kFirstRegion, 25.0, step, 6);
}

// Two masses on springs to ground with a gap between them: x2 - x1 <= gap, else a contact
// spring kc pushes them apart. State (x1, x2, v1, v2); region 0 open, 1 in contact. With a
// `variation`, mass 1's spring is k1 (1 + variation cos(6 w t)), w the force's frequency.
LinearSwitchedSystem two_masses(double variation = 0) {
  const double k1 = 1.0, k2 = 1.7, kc = 40.0, c = 0.01, gap = 0.5, m2 = 1.3, w = 0.9;
  LinearSwitchedSystem s;
  s.dimension = 4;
  s.frequencies_rad_s = {w};
  if (variation != 0) {
    s.frequencies_rad_s.push_back(6 * w);
    s.coefficient_period_s = 2 * std::numbers::pi / w;
  }
  const std::size_t nf = s.frequencies_rad_s.size();
  s.regions.resize(2);
  for (int r = 0; r < 2; ++r) {
    LinearRegion& g = s.regions[r];
    Matrix A = Matrix::Zero(4, 4);
    A(0, 2) = A(1, 3) = 1;
    A(2, 0) = -k1;
    A(2, 2) = -c;
    A(3, 1) = -k2 / m2;
    A(3, 3) = -c / m2;
    Vector u = Vector::Zero(4);
    if (r == 1) {  // contact force kc (x2 - x1 - gap) on mass 1, the opposite on mass 2
      A(2, 0) -= kc;
      A(2, 1) += kc;
      A(3, 0) += kc / m2;
      A(3, 1) -= kc / m2;
      u(2) = -kc * gap;
      u(3) = kc * gap / m2;
    }
    g.a.constant = A;
    if (variation != 0) {
      g.a.cos.assign(nf, Matrix::Zero(4, 4));
      g.a.sin.assign(nf, Matrix::Zero(4, 4));
      g.a.cos[1](2, 0) = -variation * k1;
    }
    g.u.constant = u;
    g.u.cos.assign(nf, Vector::Zero(4));
    g.u.sin.assign(nf, Vector::Zero(4));
    g.u.cos[0](2) = 0.8;  // a force on mass 1
    LinearGuard q;
    q.row.constant = RowVector::Zero(4);
    q.row.constant(0) = r == 0 ? 1 : -1;
    q.row.constant(1) = r == 0 ? -1 : 1;
    q.offset.constant = r == 0 ? gap : -gap;
    q.target = 1 - r;
    q.scale = gap;
    g.guards = {q};
  }
  return s;
}

TEST(ExactEngine, JacobianMatchesFiniteDifferencesForTwoDegreesOfFreedom) {
  const ExactEngine e(two_masses());
  Vector y0(4), step(4);
  y0 << 0.0, 0.0, 0.9, -0.4;
  step << 1e-6, 1e-6, 1e-6, 1e-6;
  expect_jacobian_matches_differences(e, y0, 0, 12.0, step, 4);
}

// The system with one more state that nothing moves (a zero row and column, a zero entry in
// every forcing and guard row): the same flow in the first states, on the engine's general
// (dynamic-size) path, where s itself may take a fixed-size one (ExactEngine's dimensions 2 and 4).
LinearSwitchedSystem with_a_still_state(LinearSwitchedSystem s) {
  const int n = s.dimension;
  const auto grow_matrix = [n](Matrix& a) {
    a.conservativeResize(n + 1, n + 1);
    a.row(n).setZero();
    a.col(n).setZero();
  };
  const auto grow_vector = [n](Vector& v) {
    v.conservativeResize(n + 1);
    v(n) = 0;
  };
  const auto grow_row = [n](RowVector& r) {
    r.conservativeResize(n + 1);
    r(n) = 0;
  };
  for (LinearRegion& r : s.regions) {
    grow_matrix(r.a.constant);
    for (Matrix& a : r.a.cos) grow_matrix(a);
    for (Matrix& a : r.a.sin) grow_matrix(a);
    grow_vector(r.u.constant);
    for (Vector& u : r.u.cos) grow_vector(u);
    for (Vector& u : r.u.sin) grow_vector(u);
    for (std::vector<LinearGuard>* gs : {&r.guards, &r.observables})
      for (LinearGuard& g : *gs) {
        grow_row(g.row.constant);
        for (RowVector& q : g.row.cos) grow_row(q);
        for (RowVector& q : g.row.sin) grow_row(q);
      }
  }
  s.dimension = n + 1;
  return s;
}

TEST(ExactEngine, FixedSizeFlowsStepAsTheGeneralOne) {
  // Two states (the non-dimensional gear rattling on both flanks, a stiffness harmonic) and
  // four (two masses with a gap, one spring varying): each flow, its events, samples, end state
  // and Jacobian, against the same system with a still fifth or third state, which the engine
  // steps on its general path. They differ by rounding only: the same cells, another order of
  // the sums.
  struct Trial {
    LinearSwitchedSystem sys;
    Vector y0;
    int region;
    double t1;
  };
  Vector y2(2), y4(4);
  y2 << 0.2, 0.1;
  y4 << 0.0, 0.0, 0.9, -0.4;
  const std::vector<Trial> trials{
      {rattling_oscillator(), y2, geardyn::kSeparated - geardyn::GearPairModel::kFirstRegion, 60.0},
      {two_masses(0.3), y4, 0, 40.0}};
  for (const Trial& trial : trials) {
    const int n = trial.sys.dimension;
    SCOPED_TRACE(n);
    const ExactEngine fixed(trial.sys), general(with_a_still_state(trial.sys));
    Vector y0g = Vector::Zero(n + 1);
    y0g.head(n) = trial.y0;
    const OutputGrid grid{0, trial.t1 / 400, 401};
    Recorder a, b;
    const FlowResult ra = fixed.flow(0, trial.y0, trial.region, trial.t1, grid, a, true);
    const FlowResult rb = general.flow(0, y0g, trial.region, trial.t1, grid, b, true);
    ASSERT_TRUE(ra.ok()) << ra.message;
    ASSERT_TRUE(rb.ok()) << rb.message;
    ASSERT_GE(ra.events, 6);
    EXPECT_EQ(ra.cells, rb.cells);
    ASSERT_EQ(a.event_t.size(), b.event_t.size());
    for (std::size_t i = 0; i < a.event_t.size(); ++i)
      EXPECT_NEAR(a.event_t[i], b.event_t[i], 1e-12 * trial.t1);
    ASSERT_EQ(a.y.size(), b.y.size());
    const double scale = trial.y0.cwiseAbs().maxCoeff() + 1.0;
    for (std::size_t i = 0; i < a.y.size(); ++i) {
      EXPECT_NEAR((a.y[i] - b.y[i].head(n)).cwiseAbs().maxCoeff(), 0.0, 1e-11 * scale) << i;
      EXPECT_EQ(b.y[i](n), 0.0);
    }
    EXPECT_NEAR((ra.state - rb.state.head(n)).cwiseAbs().maxCoeff(), 0.0, 1e-11 * scale);
    const Matrix ja = *ra.jacobian, jb = rb.jacobian->topLeftCorner(n, n);
    EXPECT_NEAR((ja - jb).cwiseAbs().maxCoeff(), 0.0, 1e-9 * (ja.cwiseAbs().maxCoeff() + 1.0));
  }
}

TEST(ExactEngine, SamplesInsideCellsKeepTheTruncationOfTheCells) {
  // A sample alone in its cell sums only the terms its place in the cell needs
  // (Cell::term_weight); the rest of the cell's series must stay within the truncation the
  // engine was asked for. Samples about 1.2 cells apart (one per stretch, at every place in the
  // cell) through 28 impacts, against the engine at the rounding limit.
  const LinearSwitchedSystem s = two_masses(0.3);
  Vector y0(4);
  y0 << 0.0, 0.0, 0.9, -0.4;
  const double t1 = 58.0;
  const OutputGrid grid{0, 0.3173, 182};
  EngineOptions o;
  o.tolerance = geardyn::ode::kRoundingLimit;
  Recorder ref;
  ASSERT_TRUE(ExactEngine(s, o).flow(0, y0, 0, t1, grid, ref).ok());
  double scale = 0;
  for (const Vector& y : ref.y) scale = std::max(scale, y.cwiseAbs().maxCoeff());
  for (double tol : {1e-6, 1e-8, 1e-10}) {
    o.tolerance = tol;
    const ExactEngine e(s, o);
    ASSERT_GT(grid.interval_s, e.cell_length_s(0));
    Recorder rec;
    const FlowResult r = e.flow(0, y0, 0, t1, grid, rec);
    ASSERT_TRUE(r.ok()) << r.message;
    ASSERT_EQ(r.events, 28);
    ASSERT_EQ(rec.y.size(), ref.y.size());
    double worst = 0;
    for (std::size_t i = 0; i < rec.y.size(); ++i)
      worst = std::max(worst, (rec.y[i] - ref.y[i]).cwiseAbs().maxCoeff());
    EXPECT_LE(worst, tol * scale) << "tolerance " << tol;
  }
}

// What an observer saw of every stretch inside the flow, and kept of it (CellView::keep).
struct StretchLog : FlowObserver {
  geardyn::ode::KeptStretches kept;
  std::vector<double> t_begin, t_end;
  std::vector<int> region;
  // Per stretch and observable: max, its time, min, its time, range's low and high (NaN
  // when none); the state at the stretch's middle.
  std::vector<std::array<double, 12>> seen;
  std::vector<Vector> middle;
  bool needs_detail(const geardyn::ode::CellView&) override { return true; }
  void on_cell(const geardyn::ode::CellView& cell) override {
    if (!(cell.t_end_s > cell.t_begin_s)) return;
    cell.keep(kept);
    t_begin.push_back(cell.t_begin_s);
    t_end.push_back(cell.t_end_s);
    region.push_back(cell.region);
    seen.push_back(look(cell));
    Vector y;
    cell.state_at(0.5 * (cell.t_begin_s + cell.t_end_s), y);
    middle.push_back(y);
  }
  static std::array<double, 12> look(const geardyn::ode::CellView& cell) {
    std::array<double, 12> v{};
    v.fill(std::nan(""));
    for (int o = 0; o < 2; ++o) {
      double* w = v.data() + 6 * o;
      if (!cell.extreme(o, true, -1e300, w[0], w[1])) w[0] = std::nan("");
      if (!cell.extreme(o, false, 1e300, w[2], w[3])) w[2] = std::nan("");
      if (!cell.range(o, w[4], w[5])) w[4] = w[5] = std::nan("");
    }
    return v;
  }
};

const geardyn::Case& paper_case(const char* id) {
  static const geardyn::Study study = geardyn::park2010_study();
  for (const geardyn::StudyCase& sc : study.cases)
    if (sc.id == id) return sc.input;
  throw std::invalid_argument(id);
}

// The stretches of a gear model's flow from rest mid-backlash over [0, t1].
StretchLog logged_flow(const ExactEngine& e, double t1) {
  StretchLog log;
  const FlowResult r =
      e.flow(0, Vector::Zero(2), geardyn::kSeparated - geardyn::GearPairModel::kFirstRegion, t1,
             OutputGrid{}, log);
  EXPECT_TRUE(r.ok()) << r.message;
  return log;
}

TEST(ExactEngine, KeptStretchesAreLookedAtAfterTheFlowAsInsideIt) {
  // Every stretch of a rattling paper case (fig4c) and a drifting one in contact (fig5a) kept
  // inside the flow and revisited after it: the same region and times, and the same extremes,
  // ranges and states, to the last bit, in the order asked for; `look` returning false stops.
  // The visits of one session share a scratch flow: a second visit in the opposite order, after
  // one stopped early, sees every stretch as the first did, as does a visit of a new session.
  for (const char* id : {"fig4c", "fig5a"}) {
    const geardyn::GearPairModel model = geardyn::build_model(paper_case(id));
    const ExactEngine e(model.linear_system());
    const StretchLog log = logged_flow(e, 0.01);
    ASSERT_EQ(log.kept.size(), log.seen.size());
    ASSERT_GT(log.kept.size(), 100u) << id;
    std::vector<std::size_t> reversed(log.kept.size()), forward(log.kept.size());
    for (std::size_t i = 0; i < reversed.size(); ++i) {
      reversed[i] = reversed.size() - 1 - i;
      forward[i] = i;
    }
    std::vector<std::size_t> visited;
    const ExactEngine::Look check = [&](std::size_t i, const geardyn::ode::CellView& cell) {
      visited.push_back(i);
      EXPECT_EQ(cell.t_begin_s, log.t_begin[i]);
      EXPECT_EQ(cell.t_end_s, log.t_end[i]);
      EXPECT_EQ(cell.region, log.region[i]);
      EXPECT_EQ(cell.lower, nullptr);
      const std::array<double, 12> v = StretchLog::look(cell);
      for (std::size_t j = 0; j < v.size(); ++j)
        if (std::isnan(log.seen[i][j]))
          EXPECT_TRUE(std::isnan(v[j])) << id << " stretch " << i << " entry " << j;
        else
          EXPECT_EQ(v[j], log.seen[i][j]) << id << " stretch " << i << " entry " << j;
      Vector y;
      cell.state_at(0.5 * (cell.t_begin_s + cell.t_end_s), y);
      EXPECT_EQ(y, log.middle[i]) << id << " stretch " << i;
      return true;
    };
    std::size_t looked = 0;
    e.revisit(log.kept, [&](const ExactEngine::Visit& visit) {
      visit(reversed, check);
      EXPECT_EQ(visited, reversed);
      visit(reversed, [&](std::size_t, const geardyn::ode::CellView&) { return ++looked < 3; });
      EXPECT_EQ(looked, 3u);
      visited.clear();
      visit(forward, check);
      EXPECT_EQ(visited, forward);
    });
    visited.clear();
    e.revisit(log.kept, [&](const ExactEngine::Visit& visit) { visit(reversed, check); });
    EXPECT_EQ(visited, reversed);
  }
}

TEST(ExactEngine, AnObservablesRangeHoldsItsExtremesOverEveryStretch) {
  // CellView::range sums the first terms of an observable's series exactly and bounds the
  // rest: its bounds must hold the extremes found on the whole series (to its rounding) over
  // every stretch, whole cells and cells cut by an impact alike, of a rattling case (fig4c), one
  // in contact (fig5a) and one with the back side (fig6c); and be tight enough to skip cells: a
  // bound lies on average within 5e-3 of the observable's swing over the flow beyond the
  // extreme (measured: 1e-5 to 2e-3).
  for (const char* id : {"fig4c", "fig5a", "fig6c"}) {
    const geardyn::GearPairModel model = geardyn::build_model(paper_case(id));
    const ExactEngine e(model.linear_system());
    const StretchLog log = logged_flow(e, 0.02);
    int cut = 0;
    std::array<int, 2> bounds{};
    std::array<double, 2> excess{}, highest{-1e300, -1e300}, lowest{1e300, 1e300};
    for (std::size_t i = 0; i < log.seen.size(); ++i) {
      if (log.t_end[i] - log.t_begin[i] < 0.999 * e.cell_length_s(log.region[i])) ++cut;
      for (std::size_t o = 0; o < 2; ++o) {
        const double* w = log.seen[i].data() + 6 * o;
        if (std::isnan(w[4])) continue;
        const double slack = 1e-11 * (std::abs(w[0]) + std::abs(w[2]));
        EXPECT_LE(w[0], w[5] + slack) << id << " stretch " << i << " observable " << o;
        EXPECT_GE(w[2], w[4] - slack) << id << " stretch " << i << " observable " << o;
        excess[o] += (w[5] - w[0]) + (w[2] - w[4]);
        bounds[o] += 2;
        highest[o] = std::max(highest[o], w[0]);
        lowest[o] = std::min(lowest[o], w[2]);
      }
    }
    EXPECT_GT(cut, 10) << id;
    for (std::size_t o = 0; o < 2; ++o) {
      ASSERT_GT(bounds[o], 400) << id;
      EXPECT_LT(excess[o] / bounds[o], 5e-3 * (highest[o] - lowest[o])) << id << " " << o;
    }
  }
}

TEST(ExactEngine, SaltationAtAnImpactIsTheAnalyticMatrix) {
  // Free flight x'' = F into a contact x >= b with x'' = F - k (x - b): at the impact
  // (velocity v) S = [[1, 0], [(a+ - a-) / v, 1]] with a+ - a- = -k (x - b) = 0, plus the
  // flow over the tiny intervals on either side; so over [t_e - h, t_e + h] the Jacobian
  // tends to S = I for this continuous force. With a force jump (contact preload P) the
  // acceleration jumps by -P: S(1, 0) = -P / v.
  const double F = 2.0, k = 100.0, P = 5.0, b = 1.0, v0 = 0.7;
  LinearSwitchedSystem s;
  s.dimension = 2;
  s.regions.resize(2);
  for (int r = 0; r < 2; ++r) {
    LinearRegion& g = s.regions[r];
    g.a.constant = Matrix::Zero(2, 2);
    g.a.constant(0, 1) = 1;
    g.u.constant = Vector::Zero(2);
    g.u.constant(1) = F;
    if (r == 1) {
      g.a.constant(1, 0) = -k;
      g.u.constant(1) = F + k * b - P;
    }
    LinearGuard q;
    q.row.constant = RowVector::Zero(2);
    q.row.constant(0) = r == 0 ? -1 : 1;
    q.offset.constant = r == 0 ? b : -b;
    q.target = 1 - r;
    q.scale = b;
    g.guards = {q};
  }
  const ExactEngine e(s);
  // Start just before the impact so that the flow on either side is nearly the identity.
  const double eps = 1e-9;
  Vector y0(2);
  y0 << b - v0 * eps, v0;
  Recorder rec;
  const FlowResult r = e.flow(0, y0, 0, 2 * eps, OutputGrid{}, rec, true);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r.events, 1);
  const Matrix& J = *r.jacobian;
  EXPECT_NEAR(J(0, 0), 1.0, 1e-6);
  EXPECT_NEAR(J(0, 1), 2 * eps, 1e-6);
  EXPECT_NEAR(J(1, 0), -P / v0, 1e-6 * P / v0);
  EXPECT_NEAR(J(1, 1), 1.0, 1e-6);
}

TEST(ExactEngine, ChatteringEndsWithNoProgressAtOnce) {
  // x' = -1 above 0 and x' = +1 below: every crossing sends the state straight back.
  LinearSwitchedSystem s;
  s.dimension = 1;
  s.regions.resize(2);
  for (int r = 0; r < 2; ++r) {
    LinearRegion& g = s.regions[r];
    g.a.constant = Matrix::Zero(1, 1);
    g.u.constant = Vector::Constant(1, r == 0 ? -1.0 : 1.0);
    LinearGuard q;
    q.row.constant = RowVector::Constant(1, r == 0 ? 1.0 : -1.0);
    q.offset.constant = 0;
    q.target = 1 - r;
    g.guards = {q};
  }
  const ExactEngine e(s);
  Recorder rec;
  const auto start = std::chrono::steady_clock::now();
  const FlowResult r = e.flow(0, Vector::Constant(1, 0.5), 0, 1e6, OutputGrid{}, rec);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(r.termination, Termination::kNoProgress);
  EXPECT_NE(r.message.find("chattering"), std::string::npos) << r.message;
  EXPECT_NEAR(r.end_time_s, 0.5, 1e-6);
  EXPECT_LT(seconds, 1.0);
}

TEST(ExactEngine, InvalidSystemsAndOptionsAreRejectedWithTheirReason) {
  LinearSwitchedSystem s = oscillator(1, 0, 0, 0, 1);
  s.regions[0].guards[0].target = 0;
  try {
    ExactEngine e(s);
    FAIL() << "accepted a guard whose target is its own region";
  } catch (const std::invalid_argument& ex) {
    EXPECT_NE(std::string(ex.what()).find("target 0"), std::string::npos) << ex.what();
  }
  EngineOptions o;
  o.tolerance = 0.5;
  EXPECT_NE(o.validate().find("tolerance = 0.5"), std::string::npos);
}

TEST(ExactEngine, AFlowFromAStateOfTheWrongSizeOrABadRegionOrTimeIsRefused) {
  // Both flows check their arguments in every build: a state longer than the system's dimension
  // used to be read past the system's rows, silently.
  const LinearSwitchedSystem s = oscillator(1, 0, 0, 0, 1);
  const ExactEngine e(s);
  const auto refused = [&](const Vector& y0, int region, double t1, const std::string& what) {
    for (const bool adaptive : {false, true}) {
      SCOPED_TRACE(adaptive ? "dopri5" : "exact");
      Recorder rec;
      try {
        if (adaptive)
          (void)adaptive_flow(s, 0, y0, region, t1, OutputGrid{0, 0.1, 3}, rec);
        else
          (void)e.flow(0, y0, region, t1, OutputGrid{0, 0.1, 3}, rec);
        ADD_FAILURE() << "accepted: " << what;
      } catch (const std::invalid_argument& ex) {
        EXPECT_NE(std::string(ex.what()).find(what), std::string::npos) << ex.what();
      }
    }
  };
  refused(Vector::Zero(3), 0, 1.0, "the initial state has 3 entries, the system's dimension is 2");
  refused(Vector::Zero(2), 2, 1.0, "region 2 is not one of the system's 2");
  refused(Vector::Zero(2), 0, -1.0, "from 0 s to -1 s");
  EXPECT_EQ(check_flow_arguments(s, 0, Vector::Zero(2), 0, 1.0), "");
}

// What reads extremes from an adaptive flow: the greatest x at step ends and, apart, at the
// points inside the steps, every call's time checked against the last.
struct CrestReader : FlowObserver {
  double last_t = 0, at_ends = -1e300, at_points = -1e300;
  std::int64_t ends = 0, points = 0;
  bool in_order = true, inside = true;
  void on_step(double t_s, const Vector& y, int) override {
    in_order = in_order && t_s >= last_t;
    last_t = t_s;
    at_ends = std::max(at_ends, y(0));
    ++ends;
  }
  void on_point(double t_s, const Vector& y, int) override {
    inside = inside && t_s > last_t;  // strictly after the step's start
    last_t = t_s;
    at_points = std::max(at_points, y(0));
    ++points;
  }
};

TEST(AdaptiveFlow, ThePointsInsideEachStepReadACrestItsStepEndsMiss) {
  // x'' + x = 0 from (0, 1): x = sin t, one crest of 1 at pi/2 in [0, 3]. At a loose tolerance
  // the steps are long, and their ends miss the crest by the step's curvature; the dense
  // output's points inside each step read it to (1 + points)^-2 of that.
  const LinearSwitchedSystem s = oscillator(1, 0, 0, 0, 1);
  const Vector y0 = (Vector(2) << 0.0, 1.0).finished();
  geardyn::ode::AdaptiveOptions o;
  o.tolerance = 1e-6;
  o.points_per_step = 0;
  CrestReader ends_only;
  ASSERT_TRUE(adaptive_flow(s, 0, y0, 0, 3.0, OutputGrid{}, ends_only, o).ok());
  EXPECT_EQ(ends_only.points, 0);
  const double missed = 1.0 - ends_only.at_ends;
  EXPECT_GT(missed, 1e-4) << "the steps are too short to show the points' worth";
  o.points_per_step = 3;
  CrestReader reader;
  ASSERT_TRUE(adaptive_flow(s, 0, y0, 0, 3.0, OutputGrid{}, reader, o).ok());
  EXPECT_EQ(reader.points, 3 * reader.ends);
  EXPECT_TRUE(reader.in_order && reader.inside);
  EXPECT_DOUBLE_EQ(reader.at_ends, ends_only.at_ends);  // the same steps
  const double read = 1.0 - std::max(reader.at_ends, reader.at_points);
  EXPECT_GE(read, -1e-6);  // the dense output's own error
  EXPECT_LT(read, missed / 8) << "missed at step ends " << missed;
}

TEST(Dopri5, TheNondimensionalCaseThatLoopedForeverEndsAtOnce) {
  // It used to switch forever at one instant until memory ran out.
  geardyn::Case c;
  c.model.form = geardyn::ModelForm::kNondimensional;
  c.model.force_alternating = 0.0755;
  c.model.omega = 0.5;
  c.solver.initial = geardyn::InitialCondition::kStatic;
  c.solver.duration_s = 30;
  for (geardyn::Method m : {geardyn::Method::kDopri5, geardyn::Method::kExact}) {
    c.solver.method = m;
    const auto start = std::chrono::steady_clock::now();
    const geardyn::RunResult r = geardyn::run(c);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_TRUE(r.integration.ok()) << r.integration.message;
    EXPECT_LT(seconds, 1.0);
  }
}

}  // namespace
