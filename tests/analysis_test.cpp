#include "geardyn/analysis.hpp"

#include <gtest/gtest.h>

#include "geardyn/run.hpp"

namespace geardyn {
namespace {

// Feeds a reader a scripted sequence of steps: (end time, region) and transitions.
struct Script {
  const GearPairModel model = build_model(Case{});
  RunReader reader{model, 0.0, 1.0, 0.1};
  double b = 100e-6;
  void step(double t, int region) {
    const double q = region == 0 ? 0.0 : region * 1.01 * b;
    reader.on_step({t, q, 0.0, 0.0, region}, model.drive(t));
  }
  void transition(double t, int from, int to, double v) {
    reader.on_transition({t, to == 0 ? 0.0 : to * b, v, 0.0, to}, from);
  }
};

TEST(RunReader, CountsImpactsSeparationsAndTimeSeparated) {
  Script s;
  s.step(0.1, kSeparated);
  s.step(0.2, kSeparated);
  s.transition(0.2, kSeparated, kDriveContact, 0.3);
  s.step(0.5, kDriveContact);
  s.transition(0.5, kDriveContact, kSeparated, -0.2);
  s.step(0.6, kSeparated);
  s.transition(0.6, kSeparated, kDriveContact, 0.4);
  s.step(1.0, kDriveContact);
  const RunReading r = s.reader.reading();
  EXPECT_EQ(r.impacts, 2);
  EXPECT_EQ(r.backside_impacts, 0);
  EXPECT_EQ(r.separations, 1);
  EXPECT_DOUBLE_EQ(*r.last_separation_s, 0.5);
  EXPECT_NEAR(r.separated_fraction, 0.3, 1e-15);
  EXPECT_DOUBLE_EQ(r.max_impact_velocity_m_s, 0.4);
  EXPECT_EQ(r.regime, Regime::kTransient);
  EXPECT_FALSE(r.double_sided);
  ASSERT_EQ(s.reader.events().size(), 3u);
  EXPECT_EQ(s.reader.events()[1].kind, EventKind::kSeparation);
}

TEST(RunReader, SeparationInTheFinalPartIsSustained) {
  Script s;
  s.step(0.95, kDriveContact);
  s.transition(0.95, kDriveContact, kSeparated, -0.1);
  s.step(1.0, kSeparated);
  EXPECT_EQ(s.reader.reading().regime, Regime::kSustained);
}

TEST(RunReader, BackSideContactMakesItDoubleSided) {
  Script s;
  s.step(0.3, kSeparated);
  s.transition(0.3, kSeparated, kBackContact, -0.3);
  s.step(0.4, kBackContact);
  s.transition(0.4, kBackContact, kSeparated, 0.2);
  s.step(0.5, kSeparated);
  s.transition(0.5, kSeparated, kDriveContact, 0.3);
  s.step(1.0, kDriveContact);
  const RunReading r = s.reader.reading();
  EXPECT_TRUE(r.double_sided);
  EXPECT_EQ(r.impacts, 2);
  EXPECT_EQ(r.backside_impacts, 1);
  EXPECT_EQ(r.regime, Regime::kTransient);
}

TEST(RunReader, NeverSeparatedIsNone) {
  Script s;
  s.step(0.5, kDriveContact);
  s.transition(0.5, kDriveContact, kDriveClipped, 0.0);  // clipping is still contact
  s.step(1.0, kDriveClipped);
  const RunReading r = s.reader.reading();
  EXPECT_EQ(r.regime, Regime::kNone);
  EXPECT_EQ(r.separations, 0);
  EXPECT_FALSE(r.last_separation_s.has_value());
  // Steady mesh force over the static one is the dynamic factor.
  ASSERT_TRUE(r.dynamic_factor.has_value());
  EXPECT_GT(*r.dynamic_factor, 0);
}

TEST(RunReader, StaticStartStaysInContactWithDynamicFactorOne) {
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;  // constant k_m: no parametric excitation
  c.load.fluctuation_ratio = 0;
  c.solver.initial = InitialCondition::kStatic;
  c.solver.duration_s = 0.005;
  const RunResult r = run(c);
  EXPECT_EQ(r.reading.regime, Regime::kNone);
  EXPECT_NEAR(*r.reading.dynamic_factor, 1.0, 1e-9);
  EXPECT_NEAR(r.reading.mean_delta_bar, r.derived.static_delta_bar, 1e-9);
}

}  // namespace
}  // namespace geardyn
