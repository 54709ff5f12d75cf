#include "geardyn/geometry.hpp"

#include <fmt/format.h>

#include <boost/math/tools/roots.hpp>
#include <cmath>
#include <numbers>

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kMmToM = 1e-3;
// Centre distance and outside diameters are made to 0.01 m_n in practice (DIN 3964 tolerance
// classes are of that order for this size); a larger disagreement is worth a warning.
constexpr double kDimensionToleranceModules = 0.01;
// Bits of the inverse involute: the angle to about 1e-15 rad.
constexpr int kInvoluteBits = 50;

}  // namespace

double involute(double alpha_rad) { return std::tan(alpha_rad) - alpha_rad; }

double internal_contact_ratio(int z1, int z2, double normal_module_m,
                              double normal_pressure_angle_rad, double helix_angle_rad) {
  if (z2 <= z1)
    throw InputError(fmt::format(
        "an internal pair needs a ring of more teeth than its pinion ({} and {} teeth)", z1, z2));
  const double mt = normal_module_m / std::cos(helix_angle_rad);
  const double at = std::atan(std::tan(normal_pressure_angle_rad) / std::cos(helix_angle_rad));
  const double r1 = z1 * mt / 2, r2 = z2 * mt / 2;
  const double rb1 = r1 * std::cos(at), rb2 = r2 * std::cos(at);
  const double ra1 = r1 + normal_module_m, ra2 = r2 - normal_module_m;
  if (!(ra2 > rb2))
    throw InputError(
        fmt::format("the ring of {} teeth has its tip circle ({:.6g} mm) inside its base circle "
                    "({:.6g} mm): too few teeth for an involute ring",
                    z2, 2e3 * ra2, 2e3 * rb2));
  const double path = std::sqrt(ra1 * ra1 - rb1 * rb1) - std::sqrt(ra2 * ra2 - rb2 * rb2) +
                      (r2 - r1) * std::sin(at);
  return path / (std::numbers::pi * mt * std::cos(at));
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
