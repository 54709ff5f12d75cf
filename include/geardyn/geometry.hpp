// geardyn: gear-pair geometry, pipeline stage 2 (case -> geometry).
//
// The standard involute relations of ISO 21771 for an external helical pair (docs/model.md,
// "Geometry"): transverse and working pressure angles, reference and base circles, base helix
// angle, contact and overlap ratios, and the inertias and equivalent mass of the torsional model
// (eq. 6). All members are SI (m, rad, kg); the suffix names the unit.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "geardyn/case.hpp"

namespace geardyn {

struct Geometry {
  double normal_module_m = 0;
  double normal_pressure_angle_rad = 0;
  double helix_angle_rad = 0;
  double transverse_module_m = 0;
  double transverse_pressure_angle_rad = 0;      // alpha_t = atan(tan alpha_n / cos beta)
  double base_helix_angle_rad = 0;               // beta_b = asin(sin beta cos alpha_n)
  std::array<double, 2> reference_diameter_m{};  // d = z m_n / cos beta
  std::array<double, 2> base_radius_m{};         // R_b = d cos alpha_t / 2
  std::array<double, 2> tip_radius_m{};          // the given outside diameters / 2
  std::array<double, 2> root_diameter_m{};       // d - 2 m_n (h_fP/m_n - x)
  // Outside diameter the standard basic rack gives with the profile shifts and the tip
  // shortening needed at the given centre distance: d + 2 m_n (1 + x - k).
  std::array<double, 2> expected_outside_diameter_m{};
  double reference_center_distance_m = 0;  // a_0 = (d1 + d2) / 2
  double center_distance_m = 0;            // a, as given
  // Working transverse pressure angle at the given centre distance: cos a_wt = a_0 cos a_t / a.
  double working_pressure_angle_rad = 0;
  // The same from the profile shifts: inv a_wt = inv a_t + 2 tan a_n (x1 + x2) / (z1 + z2).
  double shift_working_pressure_angle_rad = 0;
  double shift_center_distance_m = 0;   // the centre distance the profile shifts imply
  double transverse_base_pitch_m = 0;   // p_bt = pi m_t cos alpha_t
  double transverse_contact_ratio = 0;  // eps_alpha at the given centre distance and tip circles
  double overlap_ratio = 0;             // eps_beta = b sin beta / (pi m_n)
  double face_width_m = 0;
  std::array<double, 2> inertia_kg_m2{};  // J1, J2
  double equivalent_mass_kg = 0;          // m_eq = J1 J2 / (J1 R_b2^2 + J2 R_b1^2)
  // Disagreements in the user's data that still describe a gear pair, each naming both values.
  std::vector<std::string> warnings;

  double total_contact_ratio() const { return transverse_contact_ratio + overlap_ratio; }
};

// The largest transverse contact ratio and overlap ratio accepted: far above real gear pairs
// (helical pairs reach 2 and 3), far below what exhausts the energy method's slicing.
constexpr double kMaxContactRatio = 20.0;

// Derives the geometry of the pair. Throws InputError when the data cannot describe a working
// external gear pair (centre distance not above the sum of base radii, tip circle inside the
// base circle, total contact ratio below 1, bore not inside the root circle).
Geometry compute_geometry(const GearData& gear);

// The transverse contact ratio of an internal pair of unshifted gears, a pinion of z1 teeth in
// a ring of z2, at their reference centre distance a = m_t (z2 - z1) / 2 and with the standard
// addendum m_n (ISO 21771): eps_alpha = (sqrt(r_a1^2 - r_b1^2) - sqrt(r_a2^2 - r_b2^2) +
// a sin(alpha_t)) / p_bt, the ring's tip circle r_a2 = r_2 - m_n inside its reference circle.
// Throws InputError when z2 <= z1 or the ring's tip circle falls inside its base circle.
double internal_contact_ratio(int z1, int z2, double normal_module_m,
                              double normal_pressure_angle_rad, double helix_angle_rad);

// The involute function inv(alpha) = tan(alpha) - alpha and its inverse on (0, pi/2).
double involute(double alpha_rad);
double inverse_involute(double inv);

}  // namespace geardyn
