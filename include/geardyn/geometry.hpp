// geardyn: gear-pair geometry, pipeline stage 2 (case -> geometry).
//
// The standard involute relations of ISO 21771 for an external helical pair (docs/model.md,
// "Geometry"): transverse and working pressure angles, reference and base circles, base helix
// angle, contact and overlap ratios, and the inertias and equivalent mass of the torsional model
// (eq. 6); and for an internal pair, a pinion in its ring (internal_geometry), and the centre
// distance of shifted gears (shifted_center_distance). All members are SI (m, rad, kg); the
// suffix names the unit.
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

// Two gears of z1 and z2 teeth shifted by x1 and x2, meshing without backlash (ISO 21771):
// inv(alpha_wt) = inv(alpha_t) + 2 tan(alpha_n) (x1 + x2) / (z1 + z2) and a = |a_0| cos(alpha_t)
// / cos(alpha_wt), a_0 = m_t (z1 + z2) / 2, with z2 negative for an internal pair (gear 2 the
// ring). A ring's shift has ISO 21771's sign: positive thickens its teeth and moves its tip
// circle inwards, |d_a| = |d| - 2 m_n (1 + x). Unshifted (x1 + x2 = 0), alpha_t and a_0 exactly.
// The centre distance is in the module's unit. Throws InputError when no working pressure angle
// exists (shifts too negative).
struct ShiftedCenterDistance {
  double working_pressure_angle_rad = 0;
  double center_distance = 0;  // in the unit of the module given
};
ShiftedCenterDistance shifted_center_distance(bool internal, int z1, int z2, double x1, double x2,
                                              double normal_module,
                                              double normal_pressure_angle_rad,
                                              double helix_angle_rad);

// How far a given diameter may lie from the one the gear data give before it is worth a warning:
// centre distances and outside diameters are made to about 0.01 m_n (DIN 3964's classes).
constexpr double kDimensionToleranceModules = 0.01;

// An internal pair at work, g's gear 0 the pinion and gear 1 the ring (ISO 21771): the ring's
// profile shift g.profile_shift[1] in ISO 21771's sign (shifted_center_distance), its tip (inner)
// diameter g.outside_diameter_mm[1] (|d_2| - 2 m_n (1 + x2) for the standard basic rack), the
// centre distance g.center_distance_mm (0: the one the shifts give). Transverse radii (m), the
// working pressure angle, the path of contact [s_a, s_e] on the line of action measured from the
// pinion's base tangent point T1 (the ring's T2 lies t1t2 = a sin(alpha_wt) beyond it, on the
// same side) and the transverse base pitch. Throws InputError for a ring of fewer teeth than its
// pinion, a ring's tip diameter outside its reference circle or matching the shift of the other
// sign (a convention some sources use), a ring's tip inside its base circle, involute
// interference (s_a <= 0) or no path of contact; a centre distance or tip diameter off the
// gear data by more than kDimensionToleranceModules m_n is a warning naming both values (the
// ring's tip; the pinion's is often shortened for its other mesh).
struct InternalGeometry {
  double transverse_pressure_angle_rad = 0, base_helix_angle_rad = 0;
  double working_pressure_angle_rad = 0, center_distance_m = 0;
  double rb1 = 0, rb2 = 0, ra1 = 0, ra2 = 0;
  double t1t2 = 0, s_a = 0, s_e = 0, pbt = 0;
  std::vector<std::string> warnings;

  double transverse_contact_ratio() const { return (s_e - s_a) / pbt; }
};
InternalGeometry internal_geometry(const GearData& g);

// The involute function inv(alpha) = tan(alpha) - alpha and its inverse on (0, pi/2).
double involute(double alpha_rad);
double inverse_involute(double inv);

}  // namespace geardyn
