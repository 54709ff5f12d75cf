// geardyn: the gear-pair model, pipeline stage 4 (mesh stiffness -> model).
//
// The one-degree-of-freedom torsional model of Park (2010), eqs. 1-11 (docs/model.md), in
// the dynamic transmission error along the line of action, normal to the tooth,
// delta = cos(beta_b) (R_b1 theta_1 + R_b2 theta_2):
//
//     m_eq delta'' + cos^2(beta_b) F_G(t, delta, delta') = F(t)                  (eq. 6, 8)
//     F(t)  = F_m + F_a cos(omega t + phi)                                        (eq. 10)
//     k(t)  = k_m + sum_i k_ai cos(i z1 omega_1 t + phi_i)                        (eq. 11)
//     F_G   = k(t) (delta - b) + c delta'   drive side,  delta >= b               (eq. 3a)
//           = 0 (or c delta' with damping "always")      |delta| < b              (eq. 3b)
//           = k(t) (delta + b) + c delta'   back side,   delta <= -b              (eq. 3c)
//
// A static transmission error e(t) (transmission_error.hpp) enters the deflection,
// F_G = k(t) (delta - e - b) + c (delta' - e'). The model then integrates the deflection relative
// to it, x = delta - e, whose equation is the one above in x with the forcing F(t) - m_eq e''(t):
// the teeth, the backlash band |x| < b and every reading (contact, impacts, delta_bar) are in x;
// delta = x + e(t).
//
// It holds physics only; it is a SwitchedSystem for the integrators (integrator.hpp), its
// regions being the contact states. Everything is SI.
#pragma once

#include <cstdint>

#include "geardyn/case.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/harmonic_series.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn {

// Regions of the model. The contact state a run is read by (drive, separated, back) is the sign;
// the clipped regions exist only with tension = "clip": the teeth overlap (|delta| >= b) but the
// damper would pull, so F_G is held at 0.
enum Region : int {
  kBackClipped = -2,
  kBackContact = -1,
  kSeparated = 0,
  kDriveContact = 1,
  kDriveClipped = 2,
};

// Contact state of a region: 1 drive side, 0 separated, -1 back side.
constexpr int contact_state(int region) { return (region > 0) - (region < 0); }

// The model's constants, SI, derived once from the case, the geometry and the stiffness.
struct GearPairParameters {
  double equivalent_mass_kg = 0;     // m_eq of eq. 6
  double cos_base_helix = 1;         // cos(beta_b)
  double backlash_m = 0;             // b, half the total normal backlash
  HarmonicSeries stiffness_n_per_m;  // k(t), eq. 11
  double damping_n_s_per_m = 0;      // c = 2 xi sqrt(m_eq k_m) / cos(beta_b)
  DampingForm damping = DampingForm::kContact;
  TensionRule tension = TensionRule::kAllow;
  // F(t) = F_m + F_a cos(omega t + phi), eq. 10 (right side of eq. 6), and - m_eq e''(t)
  HarmonicSeries force_n;
  HarmonicSeries transmission_error_m;  // e(t); no terms without a transmission error

  double mean_stiffness_n_per_m() const { return stiffness_n_per_m.offset; }
  double mean_force_n() const { return force_n.offset; }
  // Linearised contact natural frequency sqrt(cos^2(beta_b) k_m / m_eq), rad/s.
  double natural_angular_frequency_rad_s() const;
  // Static drive-side contact: F_G = F_m / cos^2(beta_b).
  double static_mesh_force_n() const;
};

GearPairParameters gear_pair_parameters(const Case& c, const Geometry& g,
                                        const HarmonicSeries& stiffness_n_per_m);

// The driving torque T1(t) = T1 (1 + ratio cos(order 2 pi f_1 t + phi)) of a case, N m.
HarmonicSeries drive_torque_nm(const Case& c);
// The independent load torque T2(t) = T2 + amplitude cos(order 2 pi f_1 t + phase), N m (0
// when the load is matched: load.load_torque_nm absent).
HarmonicSeries load_torque_nm(const Case& c);

// Adds a static transmission error e(t) (in m; in units of b in the non-dimensional form) to
// the parameters: kept as transmission_error_m, and its forcing - m_eq e''(t) added to force_n.
// Requires at most HarmonicSeries::kMaxTerms force terms in all (the case's bounds keep it).
void add_transmission_error(GearPairParameters& p, const HarmonicSeries& e);

// The largest multiple of the slowest excitation period searched for a common period.
constexpr int kMaxPeriodRatio = 1000;

// True when a stiffness harmonic or a force term varies in time.
bool varies_in_time(const GearPairParameters& p);

// T0, the system's period in s: the smallest common period of the stiffness harmonics and the
// force terms (each within a relative 1e-9 of an integer multiple of 1 / T0): with torque order
// 3 on a 56-tooth pinion, 1 / f_1, not the torque period. Stroboscopic sections, sweep blocks
// and orbits are taken at it. Throws InputError when nothing varies in time (the motion settles
// to rest) or no common period exists within kMaxPeriodRatio periods of the slowest
// excitation (quasi-periodic forcing).
double system_period_s(const GearPairParameters& p);

// The period stroboscopic sections are taken at: system_period_s, or, when nothing varies in
// time, the linearised contact period 2 pi / w_n (any period shows rest). Throws InputError for
// quasi-periodic forcing.
double section_period_s(const GearPairParameters& p);

// The non-dimensional form ([model] form = "nondimensional"): m = 1, b = 1, cos(beta_b) = 1,
// k(tau) = 1 + sum_i kappa_i cos(i Omega tau + phi_i), c = 2 zeta acting at all times,
// F(tau) = F_m + F_a cos(Omega tau).
GearPairParameters nondimensional_parameters(const ModelData& m);

class GearPairModel {
 public:
  // The time-dependent inputs at one instant.
  struct Drive {
    double stiffness_n_per_m;  // k(t)
    double force_n;            // F(t)
  };

  class DriveGrid {
   public:
    DriveGrid(const GearPairParameters& p, double t0_s, double dt_s)
        : k_(p.stiffness_n_per_m, t0_s, dt_s), f_(p.force_n, t0_s, dt_s) {}
    Drive next() { return {k_.next(), f_.next()}; }

   private:
    HarmonicGrid k_, f_;
  };

  static constexpr bool kPiecewiseLinear = true;

  explicit GearPairModel(GearPairParameters p);

  const GearPairParameters& parameters() const { return p_; }
  double mass() const { return p_.equivalent_mass_kg; }
  Drive drive(double t_s) const { return {p_.stiffness_n_per_m(t_s), p_.force_n(t_s)}; }
  DriveGrid drive_grid(double t0_s, double dt_s) const { return DriveGrid(p_, t0_s, dt_s); }

  // F_G, the mesh force normal to the tooth (eqs. 3a-3c with the options), in N.
  double mesh_force(const Drive& d, double delta_m, double velocity_m_s, int region) const {
    switch (region) {
      case kDriveContact:
        return d.stiffness_n_per_m * (delta_m - b_) + c_ * velocity_m_s;
      case kBackContact:
        return d.stiffness_n_per_m * (delta_m + b_) + c_ * velocity_m_s;
      case kSeparated:
        return c_free_ * velocity_m_s;
      default:
        return 0.0;  // clipped
    }
  }

  ode::Force force(const Drive& d, double delta_m, double velocity_m_s, int region) const {
    const double fg = mesh_force(d, delta_m, velocity_m_s, region);
    double dk = 0, dc = c_free_;
    if (region == kDriveContact || region == kBackContact) {
      dk = d.stiffness_n_per_m;
      dc = c_;
    } else if (region != kSeparated) {
      dc = 0;
    }
    return {d.force_n - cb2_ * fg, -cb2_ * dk, -cb2_ * dc};
  }

  ode::Guards guards(const Drive& d, double delta_m, double velocity_m_s, int region) const {
    ode::Guards g;
    const double k = d.stiffness_n_per_m;
    switch (region) {
      case kSeparated:
        g.add(b_ - delta_m, kDriveContact);
        g.add(delta_m + b_, kBackContact);
        break;
      case kDriveContact:
        g.add(delta_m - b_, kSeparated);
        if (clip_) g.add(k * (delta_m - b_) + c_ * velocity_m_s, kDriveClipped);
        break;
      case kDriveClipped:
        g.add(delta_m - b_, kSeparated);
        g.add(-(k * (delta_m - b_) + c_ * velocity_m_s), kDriveContact);
        break;
      case kBackContact:
        g.add(-b_ - delta_m, kSeparated);
        if (clip_) g.add(-(k * (delta_m + b_) + c_ * velocity_m_s), kBackClipped);
        break;
      case kBackClipped:
        g.add(-b_ - delta_m, kSeparated);
        g.add(k * (delta_m + b_) + c_ * velocity_m_s, kBackContact);
        break;
      default:
        break;
    }
    return g;
  }

  // The region a state belongs to with no history (used for initial conditions).
  int classify(const Drive& d, double delta_m, double velocity_m_s) const;

  // The model as a piecewise-linear system with periodic coefficients (linear_system.hpp), for
  // the exact engine: the state is (delta, delta') in m and m/s, the engine's region index is
  // region - kFirstRegion; the coefficient period is the mesh period (0 for constant k). The
  // observables are kObservableDelta (m) and kObservableForce (F_G, N).
  static constexpr int kFirstRegion = kBackClipped;
  static constexpr int kRegionCount = kDriveClipped - kBackClipped + 1;
  static constexpr int kObservableDelta = 0;
  static constexpr int kObservableForce = 1;
  ode::LinearSwitchedSystem linear_system() const;

 private:
  GearPairParameters p_;
  double b_, c_, c_free_, cb2_;
  bool clip_;
};

static_assert(ode::SwitchedSystem<GearPairModel>);

}  // namespace geardyn
