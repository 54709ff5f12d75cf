#include "geardyn/geometry.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "test_support.hpp"

namespace geardyn {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

TEST(Involute, MatchesTheInvoluteTableAndInverts) {
  // inv 20 deg = 0.014904 (involute function tables).
  EXPECT_NEAR(involute(20 * kDeg), 0.0149044, 1e-7);
  for (double a : {5.0, 14.5, 20.0, 22.5, 30.0, 40.0})
    EXPECT_NEAR(inverse_involute(involute(a * kDeg)), a * kDeg, 1e-13);
}

TEST(Geometry, Table1OfThePaperIsSelfConsistent) {
  const Geometry g = compute_geometry(GearData{});
  // Table 1: pitch diameter 148.98 mm, outside diameter 154.98 mm, centre distance 150 mm.
  EXPECT_NEAR(g.reference_diameter_m[0] * 1e3, 148.98, 0.005);
  EXPECT_NEAR(g.expected_outside_diameter_m[0] * 1e3, 154.98, 0.01);
  EXPECT_NEAR(g.shift_center_distance_m * 1e3, 150.0, 0.025);
  EXPECT_TRUE(g.warnings.empty()) << g.warnings.front();
  // beta_b = asin(sin 20 cos 20), alpha_t = atan(tan 20 / cos 20).
  EXPECT_NEAR(g.base_helix_angle_rad, std::asin(std::sin(20 * kDeg) * std::cos(20 * kDeg)), 1e-15);
  EXPECT_NEAR(g.transverse_pressure_angle_rad / kDeg, 21.17283, 1e-5);
  EXPECT_NEAR(g.overlap_ratio, 20 * std::sin(20 * kDeg) / (std::numbers::pi * 2.5), 1e-14);
  // Solid cylinder J = rho pi b d^4 / 32 and m_eq = J / (2 R_b^2) for equal gears.
  const double d = g.reference_diameter_m[0];
  const double J = 7850 * std::numbers::pi * 0.02 * std::pow(d, 4) / 32;
  EXPECT_NEAR(g.inertia_kg_m2[0], J, 1e-15);
  EXPECT_NEAR(g.equivalent_mass_kg, J / (2 * g.base_radius_m[0] * g.base_radius_m[0]), 1e-12);
}

TEST(Geometry, KhkHelicalNormalSystemExample) {
  // KHK Gear Technical Reference, "calculation of profile shifted helical gears in the normal
  // system": m_n = 3, alpha_n = 20, beta = 30, z = 12 / 60, x_n = 0.09809 / 0, a = 125 mm.
  // Printed: alpha_t = 22.79588 deg, alpha_wt = 23.1126 deg, d = 41.569 / 207.846,
  // d_b = 38.322 / 191.611, d_a = 48.153 / 213.842.
  GearData gd;
  gd.normal_module_mm = 3;
  gd.helix_angle_deg = 30;
  gd.teeth = {12, 60};
  gd.profile_shift = {0.09809, 0.0};
  gd.center_distance_mm = 125.0;
  gd.outside_diameter_mm = {48.153, 213.842};
  gd.face_width_mm = 30;
  const Geometry g = compute_geometry(gd);
  EXPECT_NEAR(g.transverse_pressure_angle_rad / kDeg, 22.79588, 1e-5);
  EXPECT_NEAR(g.shift_working_pressure_angle_rad / kDeg, 23.1126, 1e-4);
  EXPECT_NEAR(g.working_pressure_angle_rad / kDeg, 23.1126, 1e-4);
  EXPECT_NEAR(g.shift_center_distance_m * 1e3, 125.0, 1e-3);
  EXPECT_NEAR(g.reference_diameter_m[0] * 1e3, 41.569, 1e-3);
  EXPECT_NEAR(g.reference_diameter_m[1] * 1e3, 207.846, 1e-3);
  EXPECT_NEAR(2 * g.base_radius_m[0] * 1e3, 38.322, 1e-3);
  EXPECT_NEAR(2 * g.base_radius_m[1] * 1e3, 191.611, 1e-3);
  EXPECT_NEAR(g.expected_outside_diameter_m[0] * 1e3, 48.153, 1e-3);
  EXPECT_NEAR(g.expected_outside_diameter_m[1] * 1e3, 213.842, 1e-3);
  EXPECT_TRUE(g.warnings.empty());
}

TEST(Geometry, SpurContactRatioOfAStandardPair) {
  // z = 20 / 40, m = 2, alpha = 20, x = 0, a = 60, r_b = 18.79385 / 37.58770:
  // eps_alpha = (11.43639 + 18.73939 - 60 sin 20) / (2 pi cos 20) = 9.65457 / 5.90440 = 1.63519.
  GearData gd;
  gd.normal_module_mm = 2;
  gd.helix_angle_deg = 0;
  gd.teeth = {20, 40};
  gd.profile_shift = {0, 0};
  gd.center_distance_mm = 60;
  gd.outside_diameter_mm = {44, 84};
  const Geometry g = compute_geometry(gd);
  EXPECT_NEAR(g.transverse_contact_ratio, 1.63519, 1e-5);
  EXPECT_EQ(g.overlap_ratio, 0.0);
  EXPECT_NEAR(g.working_pressure_angle_rad, 20 * kDeg, 1e-12);
}

TEST(Geometry, WarnsWhenTheDataDisagreeAndNamesBothValues) {
  GearData gd;
  gd.center_distance_mm = 150.5;
  const Geometry g = compute_geometry(gd);
  ASSERT_FALSE(g.warnings.empty());
  EXPECT_NE(g.warnings[0].find("150.5"), std::string::npos) << g.warnings[0];
  EXPECT_NE(g.warnings[0].find("149.9998"), std::string::npos) << g.warnings[0];

  GearData od;
  od.outside_diameter_mm = {156.0, 154.98};
  const Geometry g2 = compute_geometry(od);
  ASSERT_EQ(g2.warnings.size(), 1u);
  EXPECT_NE(g2.warnings[0].find("outside_diameter_mm[0] = 156"), std::string::npos);
  EXPECT_NE(g2.warnings[0].find("154.97"), std::string::npos) << g2.warnings[0];
}

using geardyn::testing::error_of;

TEST(Geometry, ErrorsWhereNoGearPairExists) {
  GearData close;
  close.center_distance_mm = 120;  // below the sum of the base radii, 138.9 mm
  EXPECT_NE(error_of([&] { compute_geometry(close); }).find("sum of the base radii"),
            std::string::npos);

  GearData stub;
  stub.outside_diameter_mm = {130, 154.98};  // inside the base circle, 138.9 mm
  EXPECT_NE(error_of([&] { compute_geometry(stub); }).find("outside_diameter_mm[0] = 130"),
            std::string::npos);

  GearData short_teeth;
  short_teeth.helix_angle_deg = 0;
  short_teeth.center_distance_mm = 149.4;
  short_teeth.outside_diameter_mm = {146, 146};  // path of contact shorter than a base pitch
  const std::string msg = error_of([&] { compute_geometry(short_teeth); });
  EXPECT_NE(msg.find("total contact ratio"), std::string::npos) << msg;

  // A tip far beyond the module: the tooth would come to a point below it.
  GearData pointed;
  pointed.outside_diameter_mm = {300, 154.98};
  const std::string point = error_of([&] { compute_geometry(pointed); });
  EXPECT_NE(point.find("gear.outside_diameter_mm[0] = 300: the tooth comes to a point"),
            std::string::npos)
      << point;
  // A contact ratio no gear pair has (a face width of kilometres): refused by its key.
  GearData wide;
  wide.face_width_mm = 1e308;
  EXPECT_NE(error_of([&] { compute_geometry(wide); }).find("gear.face_width_mm = 1e+308"),
            std::string::npos);
  GearData tiny_module;
  tiny_module.normal_module_mm = 1e-9;
  EXPECT_NE(error_of([&] { compute_geometry(tiny_module); }).find("comes to a point"),
            std::string::npos);

  GearData bored;
  bored.bore_diameter_mm = {150, 0};
  EXPECT_NE(error_of([&] { compute_geometry(bored); }).find("root diameter"), std::string::npos);
}

TEST(Geometry, GivenInertiasOverrideTheDensity) {
  GearData gd;
  gd.inertia_kg_m2 = std::array<double, 2>{0.01, 0.03};
  const Geometry g = compute_geometry(gd);
  const double R = g.base_radius_m[0];
  EXPECT_NEAR(g.equivalent_mass_kg, 0.01 * 0.03 / (0.01 * R * R + 0.03 * R * R), 1e-15);
}

}  // namespace
}  // namespace geardyn
