#include "geardyn/model.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "geardyn/run.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {
namespace {

GearPairModel model_of(const Case& c, Geometry* g = nullptr) { return build_model(c, g); }

TEST(GearPairModel, MeanForceIsEq8ForTheMatchedLoad) {
  Geometry g;
  const GearPairModel m = model_of(Case{}, &g);
  const double cb = std::cos(g.base_helix_angle_rad);
  EXPECT_NEAR(m.parameters().mean_force_n(), 49.5 * cb / g.base_radius_m[0], 1e-12);
  ASSERT_EQ(m.parameters().force_n.terms.size(), 1u);
  EXPECT_NEAR(m.parameters().force_n.terms[0].amplitude, 0.25 * 49.5 * cb / g.base_radius_m[0],
              1e-12);
  EXPECT_NEAR(m.parameters().force_n.terms[0].angular_frequency_rad_s, 2 * M_PI * 1000, 1e-9);
}

TEST(GearPairModel, Eq6WithAnIndependentLoadReducesToEq8WhenMatched) {
  Geometry g;
  Case c;
  c.load.load_torque_nm = 49.5;  // R_b2 T1 / R_b1 with equal gears
  const GearPairModel independent = model_of(c, &g);
  const GearPairModel matched = model_of(Case{}, nullptr);
  EXPECT_NEAR(independent.parameters().mean_force_n(), matched.parameters().mean_force_n(), 1e-9);
  // The fluctuation of T1 alone enters through R_b1 / J1 only.
  const double cb = std::cos(g.base_helix_angle_rad);
  EXPECT_NEAR(independent.parameters().force_n.terms[0].amplitude,
              g.equivalent_mass_kg * cb * g.base_radius_m[0] * 0.25 * 49.5 / g.inertia_kg_m2[0],
              1e-9);
}

TEST(GearPairModel, AFluctuatingLoadTorqueEntersEq6ThroughTheWheel) {
  // F(t) = m_eq cos(beta_b) (R_b1 T1(t) / J1 + R_b2 T2(t) / J2) at any t, with T1 and T2 each
  // fluctuating at their own order and phase; the matched load takes no T2 fluctuation.
  Geometry g;
  Case c;
  c.gear.inertia_kg_m2 = std::array<double, 2>{0.04, 0.09};
  c.load.load_torque_nm = 30;
  c.load.load_fluctuation_nm = 6;
  c.load.load_fluctuation_order = 2.5;
  c.load.load_fluctuation_phase_deg = -35;
  const GearPairModel m = model_of(c, &g);
  const double cb = std::cos(g.base_helix_angle_rad), w1 = 2 * M_PI * 1000;
  for (const double t : {0.0, 1.3e-4, 7.7e-4, 2.9e-3}) {
    const double t1 = 49.5 * (1 + 0.25 * std::cos(w1 * t));
    const double t2 = 30 + 6 * std::cos(2.5 * w1 * t - 35 * M_PI / 180);
    const double f = g.equivalent_mass_kg * cb *
                     (g.base_radius_m[0] * t1 / 0.04 + g.base_radius_m[1] * t2 / 0.09);
    EXPECT_NEAR(m.parameters().force_n(t), f, 1e-9 * std::abs(f)) << t;
  }
  Case matched;
  matched.load.load_fluctuation_nm = 6;  // without load_torque_nm: refused, named
  try {
    (void)model_of(matched);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("load.load_fluctuation_nm = 6"), std::string::npos)
        << e.what();
  }
}

TEST(GearPairModel, DampingFromTheLinearisedContactOscillator) {
  Geometry g;
  const GearPairModel m = model_of(Case{}, &g);
  const auto& p = m.parameters();
  // zeta of m d'' + cos^2 c d' + cos^2 k d equals the case's damping ratio.
  const double cb2 = p.cos_base_helix * p.cos_base_helix;
  const double zeta = cb2 * p.damping_n_s_per_m /
                      (2 * std::sqrt(p.equivalent_mass_kg * cb2 * p.mean_stiffness_n_per_m()));
  EXPECT_NEAR(zeta, 0.02, 1e-15);
}

TEST(GearPairModel, MeshForceFollowsEqs3) {
  const GearPairModel m = model_of(Case{});
  const double b = m.parameters().backlash_m, k = 2.34e8, c = m.parameters().damping_n_s_per_m;
  const GearPairModel::Drive d{k, 0};
  const double expected = k * 1e-6 + c * 0.1;
  EXPECT_NEAR(m.mesh_force(d, b + 1e-6, 0.1, kDriveContact), expected, 1e-11 * expected);
  EXPECT_NEAR(m.mesh_force(d, -b - 1e-6, -0.1, kBackContact), -expected, 1e-11 * expected);
  EXPECT_EQ(m.mesh_force(d, 0.0, 0.3, kSeparated), 0.0);
  // The elastic part is continuous across the contact surfaces.
  EXPECT_EQ(m.mesh_force(d, b, 0.0, kDriveContact), 0.0);
  EXPECT_EQ(m.mesh_force(d, -b, 0.0, kBackContact), 0.0);
}

TEST(GearPairModel, DampingAlwaysActsInSeparation) {
  Case c;
  c.mesh.damping = DampingForm::kAlways;
  const GearPairModel m = model_of(c);
  const GearPairModel::Drive d{2.34e8, 0};
  EXPECT_DOUBLE_EQ(m.mesh_force(d, 0.0, 0.3, kSeparated), m.parameters().damping_n_s_per_m * 0.3);
}

TEST(GearPairModel, ClipWithDampingAlwaysLeavesTheDamperAlone) {
  // With the paper's damping, clip keeps F_G from pulling; with damping at all times the
  // teeth alone are clipped, which never pull, so clip changes nothing and F_G stays
  // continuous (the damper's c delta' on both sides of each separation).
  Case c;
  c.solver.duration_s = 0.01;
  Case clipped = c;
  clipped.mesh.tension = TensionRule::kClip;
  const RunReading paper = run(c).reading, paper_clipped = run(clipped).reading;
  EXPECT_LT(paper.min_force_bar, -1e-3);  // the contact damper pulls (the paper's eqs.)
  EXPECT_GE(paper_clipped.min_force_bar, -1e-12);
  Case always = c;
  always.mesh.damping = DampingForm::kAlways;
  Case always_clipped = always;
  always_clipped.mesh.tension = TensionRule::kClip;
  const RunResult a = run(always), b = run(always_clipped);
  EXPECT_EQ(a.reading.min_force_bar, b.reading.min_force_bar);
  EXPECT_EQ(a.reading.impacts, b.reading.impacts);
  EXPECT_EQ(a.samples.force_bar, b.samples.force_bar);
  const GearPairModel m = model_of(always_clipped);
  const GearPairModel::Drive d{2.34e8, 0};
  const double b_m = m.parameters().backlash_m, v = -0.2;
  EXPECT_DOUBLE_EQ(m.mesh_force(d, b_m, v, kDriveContact), m.mesh_force(d, b_m, v, kSeparated));
  EXPECT_EQ(m.classify(d, b_m * (1 + 1e-9), v), kDriveContact);
}

TEST(GearPairModel, ForceDerivativesMatchFiniteDifferences) {
  Case c;
  c.mesh.damping = DampingForm::kAlways;
  const GearPairModel m = model_of(c);
  const GearPairModel::Drive d{2.2e8, 700};
  for (int r : {kBackContact, kSeparated, kDriveContact}) {
    const double q = r * 120e-6, v = 0.2, hq = 1e-9, hv = 1e-4;
    const ode::Force f = m.force(d, q, v, r);
    const double dq = (m.force(d, q + hq, v, r).value - m.force(d, q - hq, v, r).value) / (2 * hq);
    const double dv = (m.force(d, q, v + hv, r).value - m.force(d, q, v - hv, r).value) / (2 * hv);
    EXPECT_NEAR(f.d_dq, dq, 1e-6 * std::abs(dq) + 1e-3) << r;
    EXPECT_NEAR(f.d_dv, dv, 1e-6 * std::abs(dv) + 1e-9) << r;
  }
}

TEST(GearPairModel, GuardsChangeSignOnTheContactSurfaces) {
  Case c;
  c.mesh.tension = TensionRule::kClip;
  const GearPairModel m = model_of(c);
  const GearPairModel::Drive d{2.34e8, 0};
  const double b = 100e-6;
  // Separated: positive inside the backlash, negative beyond either surface.
  EXPECT_GT(m.guards(d, 0, 0, kSeparated).items[0].value, 0);
  EXPECT_LT(m.guards(d, b * 1.01, 0, kSeparated).items[0].value, 0);
  EXPECT_EQ(m.guards(d, b * 1.01, 0, kSeparated).items[0].target, kDriveContact);
  EXPECT_LT(m.guards(d, -b * 1.01, 0, kSeparated).items[1].value, 0);
  EXPECT_EQ(m.guards(d, -b * 1.01, 0, kSeparated).items[1].target, kBackContact);
  // Drive contact with clip: a pulling damper sends the state to the clipped region.
  const ode::Guards g = m.guards(d, b + 1e-9, -1.0, kDriveContact);
  ASSERT_EQ(g.count, 2);
  EXPECT_LT(g.items[1].value, 0);
  EXPECT_EQ(g.items[1].target, kDriveClipped);
  EXPECT_EQ(m.classify(d, b + 1e-9, -1.0), kDriveClipped);
  EXPECT_EQ(m.classify(d, b + 1e-9, 1.0), kDriveContact);
  EXPECT_EQ(contact_state(kDriveClipped), 1);
  EXPECT_EQ(contact_state(kBackClipped), -1);
}

TEST(GearPairModel, StiffnessHarmonicsAreAtMultiplesOfTheMeshFrequency) {
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.mesh.stiffness_harmonics = {{0.05, 30}, {0.02, 0}};
  Geometry g = compute_geometry(c.gear);
  const HarmonicSeries k = mesh_stiffness_series(c, g);
  ASSERT_EQ(k.terms.size(), 2u);
  EXPECT_NEAR(k.terms[1].angular_frequency_rad_s, 2 * 2 * M_PI * 56 * 1000, 1e-6);
  EXPECT_NEAR(k.terms[0].amplitude, 0.05 * 2.34e8, 1e-6);
  EXPECT_NEAR(k.terms[0].phase_rad, M_PI / 6, 1e-15);
}

}  // namespace
}  // namespace geardyn
