#include "geardyn/model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <vector>

namespace geardyn {

double GearPairParameters::natural_angular_frequency_rad_s() const {
  return std::sqrt(cos_base_helix * cos_base_helix * mean_stiffness_n_per_m() / equivalent_mass_kg);
}

double GearPairParameters::static_mesh_force_n() const {
  return mean_force_n() / (cos_base_helix * cos_base_helix);
}

namespace {
// A frequency is a multiple of the fundamental when its ratio is this close to an integer.
constexpr double kCommensurability = 1e-9;
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// The angular frequencies that vary in time, rad/s.
std::vector<double> excitation_frequencies(const GearPairParameters& p) {
  std::vector<double> w;
  for (const Harmonic& h : p.stiffness_n_per_m.terms)
    if (h.amplitude != 0 && h.angular_frequency_rad_s > 0) w.push_back(h.angular_frequency_rad_s);
  for (const Harmonic& h : p.force_n.terms)
    if (h.amplitude != 0 && h.angular_frequency_rad_s > 0) w.push_back(h.angular_frequency_rad_s);
  return w;
}
}  // namespace

bool varies_in_time(const GearPairParameters& p) { return !excitation_frequencies(p).empty(); }

double system_period_s(const GearPairParameters& p) {
  const std::vector<double> w = excitation_frequencies(p);
  if (w.empty())
    throw InputError(
        "nothing in the model varies in time (no stiffness harmonics, no torque fluctuation): "
        "the motion settles to rest and has no period");
  const double w_min = *std::min_element(w.begin(), w.end());
  for (int m = 1; m <= kMaxPeriodRatio; ++m) {
    const double w0 = w_min / m;
    const bool common = std::all_of(w.begin(), w.end(), [w0](double wi) {
      const double ratio = wi / w0;
      return std::abs(ratio - std::round(ratio)) <= kCommensurability * ratio;
    });
    if (common) return kTwoPi / w0;
  }
  throw InputError(
      fmt::format("the excitation frequencies have no common period within {} periods of the "
                  "slowest ({:.9g} rad/s): the motion is quasi-periodic, not periodic",
                  kMaxPeriodRatio, w_min));
}

double section_period_s(const GearPairParameters& p) {
  return varies_in_time(p) ? system_period_s(p) : kTwoPi / p.natural_angular_frequency_rad_s();
}

GearPairParameters gear_pair_parameters(const Case& c, const Geometry& g,
                                        const HarmonicSeries& stiffness_n_per_m) {
  GearPairParameters p;
  p.equivalent_mass_kg = g.equivalent_mass_kg;
  p.cos_base_helix = std::cos(g.base_helix_angle_rad);
  p.backlash_m = c.mesh.backlash_um * 1e-6;
  p.stiffness_n_per_m = stiffness_n_per_m;
  // Damping ratio of the linearised contact oscillator (docs/model.md, "Equation of motion").
  p.damping_n_s_per_m = 2.0 * c.mesh.damping_ratio *
                        std::sqrt(p.equivalent_mass_kg * stiffness_n_per_m.offset) /
                        p.cos_base_helix;
  p.damping = c.mesh.damping;
  p.tension = c.mesh.tension;

  // Right side of eq. 6: m_eq cos(beta_b) (R_b1 T1(t) / J1 + R_b2 T2 / J2). With the matched
  // load of eq. 7 this is T1(t) cos(beta_b) / R_b1 (eq. 8); the fluctuation is on T1.
  const double R1 = g.base_radius_m[0], R2 = g.base_radius_m[1];
  const double J1 = g.inertia_kg_m2[0], J2 = g.inertia_kg_m2[1];
  const double m = p.equivalent_mass_kg, cb = p.cos_base_helix;
  const double per_t1 = c.load.load_torque_nm ? m * cb * R1 / J1 : cb / R1;
  p.force_n = drive_torque_nm(c);
  p.force_n.offset *= per_t1;
  for (Harmonic& h : p.force_n.terms) h.amplitude *= per_t1;
  const double per_t2 = m * cb * R2 / J2;
  const HarmonicSeries t2 = load_torque_nm(c);
  p.force_n.offset += per_t2 * t2.offset;
  for (Harmonic h : t2.terms) {
    h.amplitude *= per_t2;
    p.force_n.terms.push_back(h);
  }
  return p;
}

HarmonicSeries load_torque_nm(const Case& c) {
  HarmonicSeries t;
  if (!c.load.load_torque_nm) return t;
  t.offset = *c.load.load_torque_nm;
  if (c.load.load_fluctuation_nm != 0.0)
    t.terms.push_back(
        {c.load.load_fluctuation_nm,
         2.0 * std::numbers::pi * c.load.load_fluctuation_order * c.speed.shaft_frequency_hz,
         c.load.load_fluctuation_phase_deg * std::numbers::pi / 180.0});
  return t;
}

HarmonicSeries drive_torque_nm(const Case& c) {
  HarmonicSeries t;
  t.offset = c.load.torque_nm;
  const double amplitude = c.load.torque_nm * c.load.fluctuation_ratio;
  if (amplitude != 0.0)
    t.terms.push_back(
        {amplitude, 2.0 * std::numbers::pi * c.load.fluctuation_order * c.speed.shaft_frequency_hz,
         c.load.fluctuation_phase_deg * std::numbers::pi / 180.0});
  return t;
}

void add_transmission_error(GearPairParameters& p, const HarmonicSeries& e) {
  p.transmission_error_m = e;
  // e = sum a cos(w t + phi): - m e'' = sum m w^2 a cos(w t + phi).
  for (const Harmonic& h : e.terms)
    p.force_n.terms.push_back(
        {p.equivalent_mass_kg * h.angular_frequency_rad_s * h.angular_frequency_rad_s * h.amplitude,
         h.angular_frequency_rad_s, h.phase_rad});
  assert(p.force_n.terms.size() <= static_cast<std::size_t>(HarmonicSeries::kMaxTerms));
}

GearPairParameters nondimensional_parameters(const ModelData& m) {
  GearPairParameters p;
  p.equivalent_mass_kg = 1.0;
  p.cos_base_helix = 1.0;
  p.backlash_m = 1.0;
  p.stiffness_n_per_m.offset = 1.0;
  for (std::size_t i = 0; i < m.stiffness_harmonics.size(); ++i)
    p.stiffness_n_per_m.terms.push_back(
        {m.stiffness_harmonics[i].ratio, static_cast<double>(i + 1) * m.omega,
         m.stiffness_harmonics[i].phase_deg * std::numbers::pi / 180});
  p.damping_n_s_per_m = 2.0 * m.zeta;
  p.damping = DampingForm::kAlways;
  p.tension = TensionRule::kAllow;
  p.force_n.offset = m.force_mean;
  if (m.force_alternating != 0) p.force_n.terms.push_back({m.force_alternating, m.omega, 0.0});
  return p;
}

GearPairModel::GearPairModel(GearPairParameters p)
    : p_(std::move(p)),
      b_(p_.backlash_m),
      c_(p_.damping_n_s_per_m),
      c_free_(p_.damping == DampingForm::kAlways ? p_.damping_n_s_per_m : 0.0),
      cb2_(p_.cos_base_helix * p_.cos_base_helix),
      // With damping at all times the damper is a viscous element beside the teeth (Kahraman
      // and Singh): the teeth carry k(t) f(delta) alone, which cannot pull, so there is nothing
      // to clip, and F_G = k f(delta) + c delta' stays continuous through separation.
      clip_(p_.tension == TensionRule::kClip && p_.damping != DampingForm::kAlways) {}

int GearPairModel::classify(const Drive& d, double delta_m, double velocity_m_s) const {
  if (delta_m >= b_) {
    const double fg = d.stiffness_n_per_m * (delta_m - b_) + c_ * velocity_m_s;
    return (clip_ && fg < 0) ? kDriveClipped : kDriveContact;
  }
  if (delta_m <= -b_) {
    const double fg = d.stiffness_n_per_m * (delta_m + b_) + c_ * velocity_m_s;
    return (clip_ && fg > 0) ? kBackClipped : kBackContact;
  }
  return kSeparated;
}

}  // namespace geardyn

namespace geardyn {
namespace {

// Adds the terms of `s` (times `scale`) to a Fourier series over the frequency table `w`,
// writing them as cos and sin parts: A cos(wt + phi) = A cos(phi) cos(wt) - A sin(phi) sin(wt).
int frequency_index(std::vector<double>& w, double omega) {
  for (std::size_t f = 0; f < w.size(); ++f)
    if (std::abs(w[f] - omega) <= 1e-12 * omega) return static_cast<int>(f);
  w.push_back(omega);
  return static_cast<int>(w.size()) - 1;
}

}  // namespace

ode::LinearSwitchedSystem GearPairModel::linear_system() const {
  using ode::Matrix;
  using ode::RowVector;
  using ode::Vector;
  ode::LinearSwitchedSystem sys;
  sys.dimension = 2;
  const double m = p_.equivalent_mass_kg;
  const HarmonicSeries& k = p_.stiffness_n_per_m;
  const HarmonicSeries& F = p_.force_n;
  // The frequency table: the stiffness harmonics first (they set the coefficient period).
  std::vector<int> k_index, f_index;
  double k_lowest = 0;
  for (const Harmonic& h : k.terms) {
    if (h.amplitude == 0) {
      k_index.push_back(-1);
      continue;
    }
    k_index.push_back(frequency_index(sys.frequencies_rad_s, h.angular_frequency_rad_s));
    if (k_lowest == 0 || h.angular_frequency_rad_s < k_lowest) k_lowest = h.angular_frequency_rad_s;
  }
  for (const Harmonic& h : F.terms)
    f_index.push_back(
        h.amplitude == 0 ? -1 : frequency_index(sys.frequencies_rad_s, h.angular_frequency_rad_s));
  sys.coefficient_period_s = k_lowest > 0 ? 2.0 * std::numbers::pi / k_lowest : 0.0;
  const std::size_t nf = sys.frequencies_rad_s.size();

  // A series x(t) = scale * (offset + terms of s) into FourierTerms of T, placing each value
  // with `put(T&, double)`.
  auto add_series = [&](auto& terms, const HarmonicSeries& s, const std::vector<int>& index,
                        double scale, bool with_offset, auto put) {
    if (with_offset) put(terms.constant, scale * s.offset);
    for (std::size_t j = 0; j < s.terms.size(); ++j) {
      if (index[j] < 0) continue;
      const Harmonic& h = s.terms[j];
      put(terms.cos[index[j]], scale * h.amplitude * std::cos(h.phase_rad));
      put(terms.sin[index[j]], -scale * h.amplitude * std::sin(h.phase_rad));
    }
  };
  auto zero_matrix_terms = [&] {
    ode::FourierTerms<Matrix> a;
    a.constant = Matrix::Zero(2, 2);
    a.constant(0, 1) = 1.0;
    a.cos.assign(nf, Matrix::Zero(2, 2));
    a.sin.assign(nf, Matrix::Zero(2, 2));
    return a;
  };
  auto zero_vector_terms = [&] {
    ode::FourierTerms<Vector> u;
    u.constant = Vector::Zero(2);
    u.cos.assign(nf, Vector::Zero(2));
    u.sin.assign(nf, Vector::Zero(2));
    return u;
  };
  auto put_a10 = [](Matrix& a, double v) { a(1, 0) += v; };
  auto put_u1 = [](Vector& u, double v) { u(1) += v; };
  auto put_row0 = [](RowVector& g, double v) { g(0) += v; };
  auto put_scalar = [](double& g, double v) { g += v; };

  // A guard on delta alone: sign (delta - edge) >= 0 inside.
  auto delta_guard = [&](double sign, double edge, int target) {
    ode::LinearGuard g;
    g.row.constant = RowVector::Zero(2);
    g.row.constant(0) = sign;
    g.offset.constant = -sign * edge;
    g.target = target - kFirstRegion;
    g.scale = b_;
    return g;
  };
  // A guard on the contact force: sign (k(t)(delta - edge) + c delta') >= 0 inside.
  auto force_guard = [&](double sign, double edge, int target) {
    ode::LinearGuard g;
    g.row.constant = RowVector::Zero(2);
    g.row.cos.assign(nf, RowVector::Zero(2));
    g.row.sin.assign(nf, RowVector::Zero(2));
    g.offset.cos.assign(nf, 0.0);
    g.offset.sin.assign(nf, 0.0);
    add_series(g.row, k, k_index, sign, true, put_row0);
    g.row.constant(1) = sign * c_;
    add_series(g.offset, k, k_index, -sign * edge, true, put_scalar);
    g.target = target - kFirstRegion;
    g.scale = b_ * p_.mean_stiffness_n_per_m();
    return g;
  };

  sys.regions.resize(kRegionCount);
  for (int region = kBackClipped; region <= kDriveClipped; ++region) {
    ode::LinearRegion& r = sys.regions[region - kFirstRegion];
    r.a = zero_matrix_terms();
    r.u = zero_vector_terms();
    add_series(r.u, F, f_index, 1.0 / m, true, put_u1);  // F(t) / m
    const bool contact = region == kDriveContact || region == kBackContact;
    if (contact) {
      // m delta'' = F - cb2 (k(t) (delta -+ b) + c delta').
      const double edge = region == kDriveContact ? b_ : -b_;
      add_series(r.a, k, k_index, -cb2_ / m, true, put_a10);
      r.a.constant(1, 1) = -cb2_ * c_ / m;
      add_series(r.u, k, k_index, cb2_ * edge / m, true, put_u1);
    } else if (region == kSeparated) {
      r.a.constant(1, 1) = -cb2_ * c_free_ / m;
    }
    switch (region) {
      case kSeparated:
        r.guards.push_back(delta_guard(-1, b_, kDriveContact));
        r.guards.push_back(delta_guard(1, -b_, kBackContact));
        break;
      case kDriveContact:
        r.guards.push_back(delta_guard(1, b_, kSeparated));
        if (clip_) r.guards.push_back(force_guard(1, b_, kDriveClipped));
        break;
      case kDriveClipped:
        r.guards.push_back(delta_guard(1, b_, kSeparated));
        r.guards.push_back(force_guard(-1, b_, kDriveContact));
        break;
      case kBackContact:
        r.guards.push_back(delta_guard(-1, -b_, kSeparated));
        if (clip_) r.guards.push_back(force_guard(-1, -b_, kBackClipped));
        break;
      case kBackClipped:
        r.guards.push_back(delta_guard(-1, -b_, kSeparated));
        r.guards.push_back(force_guard(1, -b_, kBackContact));
        break;
      default:
        break;
    }
    // The observables: delta, and F_G (eqs. 3a-3c with the options).
    ode::LinearGuard delta = delta_guard(1, 0, kSeparated);
    ode::LinearGuard force;
    if (contact) {
      force = force_guard(1, region == kDriveContact ? b_ : -b_, kSeparated);
    } else {
      force.row.constant = RowVector::Zero(2);
      if (region == kSeparated) force.row.constant(1) = c_free_;
    }
    r.observables = {delta, force};
    // Terms that are zero at every frequency are dropped: constant coefficients let the
    // engine take any cell grid.
    ode::drop_zero_terms(r);
  }
  return sys;
}

}  // namespace geardyn
