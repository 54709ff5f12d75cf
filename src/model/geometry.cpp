#include "geardyn/geometry.hpp"

#include <fmt/format.h>

#include <boost/math/tools/roots.hpp>
#include <cmath>
#include <numbers>

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kMmToM = 1e-3;
// Bits of the inverse involute: the angle to about 1e-15 rad.
constexpr int kInvoluteBits = 50;

}  // namespace

double involute(double alpha_rad) { return std::tan(alpha_rad) - alpha_rad; }

ShiftedCenterDistance shifted_center_distance(bool internal, int z1, int z2, double x1, double x2,
                                              double normal_module,
                                              double normal_pressure_angle_rad,
                                              double helix_angle_rad) {
  const double an = normal_pressure_angle_rad, beta = helix_angle_rad;
  const double at = std::atan(std::tan(an) / std::cos(beta));
  const double z = internal ? static_cast<double>(z1) - z2 : static_cast<double>(z1) + z2;
  ShiftedCenterDistance out;
  if (x1 + x2 == 0) {
    out.working_pressure_angle_rad = at;
    out.center_distance = 0.5 * std::abs(z) * normal_module / std::cos(beta);
    return out;
  }
  const double inv_wt = involute(at) + 2 * std::tan(an) * (x1 + x2) / z;
  if (!(inv_wt > 0))
    throw InputError(fmt::format(
        "gear.profile_shift = [{}, {}]: too negative for {} and {} teeth{} (no working pressure "
        "angle)",
        x1, x2, z1, z2, internal ? " of an internal pair" : ""));
  out.working_pressure_angle_rad = inverse_involute(inv_wt);
  out.center_distance = 0.5 * std::abs(z) * normal_module / std::cos(beta) * std::cos(at) /
                        std::cos(out.working_pressure_angle_rad);
  return out;
}

InternalGeometry internal_geometry(const GearData& g) {
  const int z1 = g.teeth[0], z2 = g.teeth[1];
  if (z2 <= z1)
    throw InputError(fmt::format(
        "gear.teeth = [{}, {}]: an internal pair needs a ring of more teeth than its pinion", z1,
        z2));
  InternalGeometry p;
  const double beta = g.helix_angle_deg * kPi / 180, an = g.normal_pressure_angle_deg * kPi / 180;
  const double mn = g.normal_module_mm * kMmToM, mt = mn / std::cos(beta);
  const double at = std::atan(std::tan(an) / std::cos(beta));
  p.transverse_pressure_angle_rad = at;
  p.base_helix_angle_rad = std::asin(std::sin(beta) * std::cos(an));
  const double r1 = 0.5 * z1 * mt, r2 = 0.5 * z2 * mt;
  p.rb1 = r1 * std::cos(at);
  p.rb2 = r2 * std::cos(at);
  p.pbt = kPi * mt * std::cos(at);
  const double x1 = g.profile_shift[0], x2 = g.profile_shift[1];
  const double tol = kDimensionToleranceModules * mn;

  // The tips: the pinion's d_1 + 2 m_n (1 + x1), the ring's |d_2| - 2 m_n (1 + x2).
  p.ra1 = 0.5 * g.outside_diameter_mm[0] * kMmToM;
  p.ra2 = 0.5 * g.outside_diameter_mm[1] * kMmToM;
  const double ra2_rack = r2 - mn * (1 + x2);
  if (!(p.ra2 < r2))
    throw InputError(fmt::format(
        "gear.outside_diameter_mm[1] = {}: a ring's tip diameter lies inside its reference "
        "circle, {:.6g} mm (with profile shift {} the standard basic rack gives {:.6g} mm); the "
        "rim's outside diameter is not read",
        g.outside_diameter_mm[1], 2 * r2 / kMmToM, x2, 2 * ra2_rack / kMmToM));
  const double ra2_flipped = r2 - mn * (1 - x2);
  if (x2 != 0 && std::abs(p.ra2 - ra2_flipped) <= tol && std::abs(p.ra2 - ra2_rack) > tol)
    throw InputError(fmt::format(
        "gear.profile_shift[1] = {0}: the ring's tip diameter, {1} mm, is that of a shift of {2} "
        "in ISO 21771's sign, where a positive shift thickens a ring's teeth and moves its tip "
        "circle inwards (|d_a| = |d| - 2 m_n (1 + x) = {3:.6g} mm for {0}); if the tip diameter "
        "is right, write the ring's profile_shift = {2}",
        x2, g.outside_diameter_mm[1], -x2, 2 * ra2_rack / kMmToM));
  // (The pinion's tip is its own: often shortened for its mesh with a sun, which says so.)
  if (std::abs(p.ra2 - ra2_rack) > tol)
    p.warnings.push_back(fmt::format(
        "gear.outside_diameter_mm[1] = {} disagrees with the {:.4f} mm of a ring's standard "
        "basic rack (addendum 1 m_n) with profile shift {} (tolerance {:.4f} mm); the given "
        "diameter is used",
        g.outside_diameter_mm[1], 2 * ra2_rack / kMmToM, x2, 2 * tol / kMmToM));

  // The centre distance: the shifts' (zero backlash), or the given one.
  const ShiftedCenterDistance shifted = shifted_center_distance(true, z1, z2, x1, x2, mn, an, beta);
  p.center_distance_m = shifted.center_distance;
  p.working_pressure_angle_rad = shifted.working_pressure_angle_rad;
  if (g.center_distance_mm > 0) {
    p.center_distance_m = g.center_distance_mm * kMmToM;
    const double cos_w = (r2 - r1) * std::cos(at) / p.center_distance_m;
    if (!(cos_w > 0 && cos_w < 1))
      throw InputError(
          fmt::format("gear.center_distance_mm = {}: no working pressure angle for "
                      "an internal pair of standard centre distance {:.6g} mm",
                      g.center_distance_mm, (r2 - r1) / kMmToM));
    p.working_pressure_angle_rad = std::acos(cos_w);
    if (std::abs(p.center_distance_m - shifted.center_distance) > tol)
      p.warnings.push_back(fmt::format(
          "gear.center_distance_mm = {} disagrees with the {:.4f} mm that the profile shifts "
          "x1 + x2 = {} of the internal pair imply (tolerance {:.4f} mm); the given centre "
          "distance is used",
          g.center_distance_mm, shifted.center_distance / kMmToM, x1 + x2, tol / kMmToM));
  }
  p.t1t2 = p.center_distance_m * std::sin(p.working_pressure_angle_rad);

  if (!(p.ra1 > p.rb1))
    throw InputError(fmt::format(
        "gear.outside_diameter_mm[0] = {}: must exceed the pinion's base diameter {:.6g} mm",
        g.outside_diameter_mm[0], 2 * p.rb1 / kMmToM));
  if (!(p.ra2 > p.rb2))
    throw InputError(fmt::format(
        "gear.teeth[1] = {}: the ring's tip circle ({:.6g} mm) lies inside its base circle "
        "({:.6g} mm): too few teeth for an involute ring, or too large a profile shift ({})",
        z2, 2 * p.ra2 / kMmToM, 2 * p.rb2 / kMmToM, x2));
  p.s_e = std::sqrt(p.ra1 * p.ra1 - p.rb1 * p.rb1);
  p.s_a = std::sqrt(p.ra2 * p.ra2 - p.rb2 * p.rb2) - p.t1t2;
  if (!(p.s_a > 0))
    throw InputError(fmt::format(
        "gear.teeth = [{}, {}]: the ring's tip reaches below the pinion's base circle (involute "
        "interference: the path of contact would start {:.4g} mm before it)",
        z1, z2, -p.s_a / kMmToM));
  if (!(p.s_e > p.s_a))
    throw InputError(fmt::format("gear.teeth = [{}, {}]: the pair has no path of contact", z1, z2));
  return p;
}

double inverse_involute(double inv) {
  // inv(alpha) is increasing on (0, pi/2) with derivative tan^2(alpha); start from the
  // series inversion alpha ~ (3 inv)^(1/3), good for the angles of gearing.
  auto f = [inv](double a) {
    const double t = std::tan(a);
    return std::make_pair(t - a - inv, t * t);
  };
  const double guess = std::cbrt(3.0 * inv);
  std::uintmax_t iterations = 100;
  return boost::math::tools::newton_raphson_iterate(f, guess, 1e-9, kPi / 2 - 1e-9, kInvoluteBits,
                                                    iterations);
}

Geometry compute_geometry(const GearData& g) {
  Geometry out;
  const double mn = g.normal_module_mm * kMmToM;
  const double an = g.normal_pressure_angle_deg * kPi / 180.0;
  const double beta = g.helix_angle_deg * kPi / 180.0;
  const double z1 = g.teeth[0], z2 = g.teeth[1];
  out.normal_module_m = mn;
  out.normal_pressure_angle_rad = an;
  out.helix_angle_rad = beta;
  out.transverse_module_m = mn / std::cos(beta);
  out.transverse_pressure_angle_rad = std::atan(std::tan(an) / std::cos(beta));
  out.base_helix_angle_rad = std::asin(std::sin(beta) * std::cos(an));
  const double at = out.transverse_pressure_angle_rad;
  out.face_width_m = g.face_width_mm * kMmToM;
  out.center_distance_m = g.center_distance_mm * kMmToM;
  out.transverse_base_pitch_m = kPi * out.transverse_module_m * std::cos(at);

  for (int i = 0; i < 2; ++i) {
    out.reference_diameter_m[i] = g.teeth[i] * out.transverse_module_m;
    out.base_radius_m[i] = 0.5 * out.reference_diameter_m[i] * std::cos(at);
    out.tip_radius_m[i] = 0.5 * g.outside_diameter_mm[i] * kMmToM;
    out.root_diameter_m[i] =
        out.reference_diameter_m[i] - 2.0 * mn * (g.basic_rack_dedendum[i] - g.profile_shift[i]);
  }
  out.reference_center_distance_m =
      0.5 * (out.reference_diameter_m[0] + out.reference_diameter_m[1]);

  const double a = out.center_distance_m;
  const double rb_sum = out.base_radius_m[0] + out.base_radius_m[1];
  if (!(a > rb_sum)) {
    throw InputError(fmt::format(
        "gear.center_distance_mm = {:.6g}: must exceed the sum of the base radii, {:.4f} mm, for "
        "the "
        "teeth to mesh",
        g.center_distance_mm, rb_sum / kMmToM));
  }
  out.working_pressure_angle_rad = std::acos(out.reference_center_distance_m * std::cos(at) / a);

  const double inv_wt =
      involute(at) + 2.0 * std::tan(an) * (g.profile_shift[0] + g.profile_shift[1]) / (z1 + z2);
  if (!(inv_wt > 0)) {
    throw InputError(fmt::format(
        "gear.profile_shift = [{}, {}]: the shifts are too negative for {} and {} teeth (no "
        "working pressure angle exists)",
        g.profile_shift[0], g.profile_shift[1], g.teeth[0], g.teeth[1]));
  }
  out.shift_working_pressure_angle_rad = inverse_involute(inv_wt);
  out.shift_center_distance_m = out.reference_center_distance_m * std::cos(at) /
                                std::cos(out.shift_working_pressure_angle_rad);

  const double tol_m = kDimensionToleranceModules * mn;
  if (std::abs(out.shift_center_distance_m - a) > tol_m) {
    out.warnings.push_back(fmt::format(
        "gear.center_distance_mm = {} disagrees with the {:.4f} mm that the profile shifts "
        "x1 + x2 = {} imply (tolerance {:.4f} mm); the given centre distance is used, and the "
        "backlash is mesh.backlash_um as given",
        g.center_distance_mm, out.shift_center_distance_m / kMmToM,
        g.profile_shift[0] + g.profile_shift[1], tol_m / kMmToM));
  }

  // Tip shortening k m_n: the part of the shifts the centre distance does not take up.
  const double y = (a - out.reference_center_distance_m) / mn;
  const double k = std::max(0.0, g.profile_shift[0] + g.profile_shift[1] - y);
  for (int i = 0; i < 2; ++i) {
    out.expected_outside_diameter_m[i] =
        out.reference_diameter_m[i] + 2.0 * mn * (1.0 + g.profile_shift[i] - k);
    const double given = g.outside_diameter_mm[i] * kMmToM;
    if (std::abs(given - out.expected_outside_diameter_m[i]) > tol_m) {
      out.warnings.push_back(fmt::format(
          "gear.outside_diameter_mm[{}] = {} disagrees with the {:.4f} mm of a standard basic "
          "rack (addendum 1 m_n) with profile shift {} and tip shortening {:.4f} m_n "
          "(tolerance {:.4f} mm); the given diameter is used",
          i, g.outside_diameter_mm[i], out.expected_outside_diameter_m[i] / kMmToM,
          g.profile_shift[i], k, tol_m / kMmToM));
    }
    if (!(out.tip_radius_m[i] > out.base_radius_m[i])) {
      throw InputError(fmt::format(
          "gear.outside_diameter_mm[{}] = {}: must exceed the base diameter {:.4f} mm, or the "
          "tooth has no involute flank",
          i, g.outside_diameter_mm[i], 2 * out.base_radius_m[i] / kMmToM));
    }
    // The tooth must keep a positive thickness up to its tip: s_a = d_a (s / d + inv a_t -
    // inv a_a), s = m_t (pi / 2 + 2 x tan a_n) at the reference circle.
    const double alpha_a = std::acos(out.base_radius_m[i] / out.tip_radius_m[i]);
    const double s_ref =
        out.transverse_module_m * (kPi / 2 + 2 * g.profile_shift[i] * std::tan(an));
    const double tip_thickness =
        2 * out.tip_radius_m[i] *
        (s_ref / out.reference_diameter_m[i] + involute(at) - involute(alpha_a));
    if (!(tip_thickness > 0)) {
      throw InputError(fmt::format(
          "gear.outside_diameter_mm[{0}] = {1}: the tooth comes to a point below it (tip "
          "thickness {2:.4g} mm); with gear.normal_module_mm = {3}, gear.profile_shift[{0}] = {4} "
          "and gear.teeth[{0}] = {5} the outside diameter is about {6:.6g} mm",
          i, g.outside_diameter_mm[i], tip_thickness / kMmToM, g.normal_module_mm,
          g.profile_shift[i], g.teeth[i], out.expected_outside_diameter_m[i] / kMmToM));
    }
    if (!(g.bore_diameter_mm[i] * kMmToM < out.root_diameter_m[i])) {
      throw InputError(fmt::format(
          "gear.bore_diameter_mm[{}] = {}: must be smaller than the root diameter {:.4f} mm", i,
          g.bore_diameter_mm[i], out.root_diameter_m[i] / kMmToM));
    }
  }

  const double ga1 = std::sqrt(out.tip_radius_m[0] * out.tip_radius_m[0] -
                               out.base_radius_m[0] * out.base_radius_m[0]);
  const double ga2 = std::sqrt(out.tip_radius_m[1] * out.tip_radius_m[1] -
                               out.base_radius_m[1] * out.base_radius_m[1]);
  const double path_of_contact = ga1 + ga2 - a * std::sin(out.working_pressure_angle_rad);
  out.transverse_contact_ratio = path_of_contact / out.transverse_base_pitch_m;
  out.overlap_ratio = out.face_width_m * std::sin(beta) / (kPi * mn);
  if (!(out.total_contact_ratio() >= 1.0)) {
    throw InputError(fmt::format(
        "gear: the total contact ratio eps_alpha + eps_beta = {:.4g} + {:.4g} is below 1 (tip "
        "diameters [{:.6g}, {:.6g}] mm at centre distance {:.6g} mm): the pair cannot transmit "
        "motion continuously; it must be at least 1",
        out.transverse_contact_ratio, out.overlap_ratio, g.outside_diameter_mm[0],
        g.outside_diameter_mm[1], g.center_distance_mm));
  }
  // A contact ratio far beyond any gear pair's (a module of nanometres, a face width of
  // kilometres) would make the energy method slice the face into as many tooth pairs.
  if (!(out.transverse_contact_ratio <= kMaxContactRatio)) {
    throw InputError(fmt::format(
        "gear.normal_module_mm = {:.6g}: the transverse contact ratio is {:.4g} with outside "
        "diameters [{:.6g}, {:.6g}] mm; at most {:g} describes a gear pair",
        g.normal_module_mm, out.transverse_contact_ratio, g.outside_diameter_mm[0],
        g.outside_diameter_mm[1], kMaxContactRatio));
  }
  if (!(out.overlap_ratio <= kMaxContactRatio)) {
    throw InputError(fmt::format(
        "gear.face_width_mm = {:.6g}: the overlap ratio b sin(beta) / (pi m_n) is {:.4g}; at most "
        "{:g} describes a gear pair",
        g.face_width_mm, out.overlap_ratio, kMaxContactRatio));
  }

  for (int i = 0; i < 2; ++i) {
    if (g.inertia_kg_m2) {
      out.inertia_kg_m2[i] = (*g.inertia_kg_m2)[i];
    } else {
      // Solid (or bored) steel cylinder of the reference diameter (docs/model.md, "Geometry").
      const double d = out.reference_diameter_m[i];
      const double di = g.bore_diameter_mm[i] * kMmToM;
      out.inertia_kg_m2[i] =
          g.density_kg_m3 * kPi * out.face_width_m * (std::pow(d, 4) - std::pow(di, 4)) / 32.0;
    }
  }
  const double J1 = out.inertia_kg_m2[0], J2 = out.inertia_kg_m2[1];
  const double R1 = out.base_radius_m[0], R2 = out.base_radius_m[1];
  out.equivalent_mass_kg = J1 * J2 / (J1 * R2 * R2 + J2 * R1 * R1);
  return out;
}

}  // namespace geardyn
