#include "geardyn/model.hpp"

#include <cmath>
#include <numbers>

namespace geardyn {

double GearPairParameters::natural_angular_frequency_rad_s() const {
  return std::sqrt(cos_base_helix * cos_base_helix * mean_stiffness_n_per_m() / equivalent_mass_kg);
}

double GearPairParameters::static_mesh_force_n() const {
  return mean_force_n() / (cos_base_helix * cos_base_helix);
}

GearPairParameters gear_pair_parameters(const Case& c, const Geometry& g,
                                        const HarmonicSeries& stiffness_n_per_m) {
  GearPairParameters p;
  p.equivalent_mass_kg = g.equivalent_mass_kg;
  p.cos_base_helix = std::cos(g.base_helix_angle_rad);
  p.backlash_m = c.mesh.backlash_um * 1e-6;
  p.stiffness_n_per_m = stiffness_n_per_m;
  // Damping ratio of the linearised contact oscillator (MODEL.md section 2).
  p.damping_n_s_per_m = 2.0 * c.mesh.damping_ratio *
                        std::sqrt(p.equivalent_mass_kg * stiffness_n_per_m.offset) /
                        p.cos_base_helix;
  p.damping = c.mesh.damping;
  p.tension = c.mesh.tension;

  // Right side of eq. 6: m_eq cos(beta_b) (R_b1 T1(t) / J1 + R_b2 T2 / J2). With the matched
  // load of eq. 7 this is T1(t) cos(beta_b) / R_b1 (eq. 8); the fluctuation is on T1.
  const double R1 = g.base_radius_m[0], R2 = g.base_radius_m[1];
  const double J1 = g.inertia_kg_m2[0], J2 = g.inertia_kg_m2[1];
  const double T1 = c.load.torque_nm;
  const double m = p.equivalent_mass_kg, cb = p.cos_base_helix;
  double mean, per_t1;
  if (c.load.load_torque_nm) {
    per_t1 = m * cb * R1 / J1;
    mean = per_t1 * T1 + m * cb * R2 * (*c.load.load_torque_nm) / J2;
  } else {
    per_t1 = cb / R1;
    mean = per_t1 * T1;
  }
  p.force_n.offset = mean;
  const double amplitude = per_t1 * T1 * c.load.fluctuation_ratio;
  if (amplitude != 0.0) {
    p.force_n.terms.push_back(
        {amplitude, 2.0 * std::numbers::pi * c.load.fluctuation_order * c.speed.shaft_frequency_hz,
         c.load.fluctuation_phase_deg * std::numbers::pi / 180.0});
  }
  return p;
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
      clip_(p_.tension == TensionRule::kClip) {}

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
