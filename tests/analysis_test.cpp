#include "geardyn/analysis.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>

#include "geardyn/engine.hpp"
#include "geardyn/one_degree_orbit.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/reproduce.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_orbit.hpp"

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
  // The largest mesh force met over the static one is the dynamic factor.
  const double b = s.b;
  const double largest =
      std::max(s.model.mesh_force(s.model.drive(0.5), 1.01 * b, 0.0, kDriveContact),
               s.model.mesh_force(s.model.drive(1.0), 1.01 * b, 0.0, kDriveClipped));
  ASSERT_TRUE(r.dynamic_factor.has_value());
  EXPECT_DOUBLE_EQ(*r.dynamic_factor, largest / s.model.parameters().static_mesh_force_n());
}

// A mark reads the rest of a run as a reader of the rest alone would, while the whole is read
// as without it: through the exact engine (its extremes searched inside cells against the
// part's) and through a stepper. The case rattles on both sides of the mark.
void expect_same(const RunReading& a, const RunReading& b, double tol) {
  EXPECT_EQ(a.impacts, b.impacts);
  EXPECT_EQ(a.backside_impacts, b.backside_impacts);
  EXPECT_EQ(a.separations, b.separations);
  EXPECT_EQ(a.last_separation_s, b.last_separation_s);
  EXPECT_EQ(a.regime, b.regime);
  EXPECT_EQ(a.double_sided, b.double_sided);
  EXPECT_NEAR(a.separated_fraction, b.separated_fraction, tol);
  EXPECT_NEAR(a.max_impact_velocity_m_s, b.max_impact_velocity_m_s, tol);
  for (const auto& [x, y] : {std::pair{a.max_force_bar, b.max_force_bar},
                             {a.min_force_bar, b.min_force_bar},
                             {a.max_delta_bar, b.max_delta_bar},
                             {a.min_delta_bar, b.min_delta_bar},
                             {a.mean_force_bar, b.mean_force_bar},
                             {a.rms_force_bar, b.rms_force_bar},
                             {a.mean_delta_bar, b.mean_delta_bar},
                             {a.rms_delta_bar, b.rms_delta_bar}})
    EXPECT_NEAR(x, y, tol * std::max(1.0, std::abs(y)));
  ASSERT_EQ(a.dynamic_factor.has_value(), b.dynamic_factor.has_value());
  if (a.dynamic_factor) EXPECT_NEAR(*a.dynamic_factor, *b.dynamic_factor, tol);
}

class RunReaderMark : public ::testing::TestWithParam<Method> {};

TEST_P(RunReaderMark, ReadsTheRestAsAFreshReaderWhileTheWholeIsUnchanged) {
  Case c;
  c.speed.shaft_frequency_hz = 100;
  c.mesh.backlash_um = 150;
  c.solver.method = GetParam();
  const GearPairModel model = build_model(c);
  const Solver solver(model, c.solver);
  const double t1 = 0.02, tm = 0.011;
  const ode::OutputGrid grid = ode::make_output_grid(0, t1, t1 / 1000);
  const std::int64_t split = grid.count_until(tm);
  const ode::State start{0, 0, 0, 0, kSeparated};

  RunReader marked(model, 0, t1, 0.1), whole(model, 0, t1, 0.1), rest(model, tm, t1, 1.0);
  const auto a = solver.run(start, tm, grid.stretch(0, split), marked);
  ASSERT_TRUE(solver.run(start, tm, grid.stretch(0, split), whole).ok());
  ASSERT_TRUE(a.ok()) << a.message;
  marked.mark(tm);
  ASSERT_TRUE(marked.marked());
  ASSERT_TRUE(solver.run(a.end_state, t1, grid.stretch(split, grid.count), marked).ok());
  ASSERT_TRUE(solver.run(a.end_state, t1, grid.stretch(split, grid.count), whole).ok());
  ASSERT_TRUE(solver.run(a.end_state, t1, grid.stretch(split, grid.count), rest).ok());

  const RunReading part = marked.part_reading(), fresh = rest.reading();
  ASSERT_GT(fresh.impacts, 3);                        // the rest rattles
  ASSERT_GT(whole.reading().impacts, fresh.impacts);  // and so did the start
  expect_same(part, fresh, 1e-12);
  expect_same(marked.reading(), whole.reading(), 1e-12);
  EXPECT_EQ(marked.events().size(), whole.events().size());
  EXPECT_EQ(marked.samples().size(), whole.samples().size());
  // The part starts afresh at a later mark.
  marked.mark(t1);
  EXPECT_EQ(marked.part_reading().impacts, 0);
}

INSTANTIATE_TEST_SUITE_P(Methods, RunReaderMark,
                         ::testing::Values(Method::kExact, Method::kNewmark));

TEST(Run, TheDynamicFactorIsTheSteadyOneWithTheStartUpBeside) {
  // At f1 = 10 kHz the teeth rattle while the start from rest mid-backlash dies out, then stay
  // in contact: the whole window's dynamic factor (9.1) is the start-up's; the steady part,
  // from where the response is periodic to 1e-6 b, reads the periodic orbit's.
  Case c;
  c.speed.shaft_frequency_hz = 10000;
  const RunResult r = run(c);
  ASSERT_TRUE(r.integration.ok());
  const SteadyPart& st = r.steady;
  EXPECT_EQ(st.basis, SteadyBasis::kSettled);
  EXPECT_EQ(st.period_multiple, 1);
  EXPECT_LE(st.error, 0.5 * kSteadyTolerance);
  EXPECT_EQ(r.reading.regime, Regime::kTransient);
  EXPECT_GT(st.from_s, *r.reading.last_separation_s);
  EXPECT_EQ(st.reading.regime, Regime::kNone);
  EXPECT_EQ(st.reading.impacts, 0);
  EXPECT_GT(*r.reading.dynamic_factor, 9.0);
  OrbitOptions o;
  o.settle_periods = 600;  // past the start-up (the run settles after some 480 periods)
  const Orbit orbit = find_orbit(c, o);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  EXPECT_NEAR(st.reading.max_force_bar, orbit.reading.max_force_bar, 1e-5);
  EXPECT_NEAR(st.reading.min_delta_bar, orbit.reading.min_delta_bar, 1e-5);
  EXPECT_NEAR(*st.reading.dynamic_factor,
              *r.reading.dynamic_factor * st.reading.max_force_bar / r.reading.max_force_bar,
              1e-12);
  EXPECT_LT(*st.reading.dynamic_factor, 1.1);
  EXPECT_EQ(r.steady_start_s, st.from_s);  // the spectra are of the steady part
}

TEST(Run, WithoutASteadyStateTheFinalHalfIsReadAndSaidSoAndWithoutAPeriodItsStatistics) {
  Case c;
  c.speed.shaft_frequency_hz = 100;
  c.mesh.backlash_um = 150;
  const RunResult r = run(c);
  EXPECT_EQ(r.steady.basis, SteadyBasis::kNotSettled);
  EXPECT_DOUBLE_EQ(r.steady.from_s, 0.5 * c.solver.duration_s);
  EXPECT_GT(r.steady.error, 0.5 * kSteadyTolerance);
  // Torque order sqrt(2) against 56 teeth: no common period, no section. The pair is judged by
  // its statistics (train_steadiness.hpp) over windows of whole torque periods holding 200
  // cycles of its fastest excitation (the stiffness' second harmonic, 2 x 56 x f), its steady
  // part starting at a whole window.
  c.load.fluctuation_order = std::sqrt(2.0);
  c.speed.shaft_frequency_hz = 1000;
  const RunResult q = run(c);
  EXPECT_EQ(q.steady.basis, SteadyBasis::kStatistics);
  const double torque_hz = std::sqrt(2.0) * c.speed.shaft_frequency_hz;
  EXPECT_NEAR(q.steady.window_s * torque_hz, std::ceil(200 * torque_hz / (2 * 56 * 1000.0)), 1e-9);
  EXPECT_NEAR(std::remainder(q.steady.from_s / q.steady.window_s, 1.0), 0, 1e-9);
  EXPECT_LE(q.steady.from_s + q.steady.window_s, c.solver.duration_s + 1e-12);
}

// The extremes of delta and F_G over every cell of a flow, each cell searched.
struct EveryCell : ode::FlowObserver {
  std::array<double, 2> max{-1e300, -1e300}, min{1e300, 1e300};
  bool needs_detail(const ode::CellView&) override { return true; }
  void on_cell(const ode::CellView& cell) override {
    if (!(cell.t_end_s > cell.t_begin_s)) return;
    for (int o = 0; o < 2; ++o) {
      double v = 0, t = 0;
      if (cell.extreme(o, true, max[o], v, t)) max[o] = v;
      if (cell.extreme(o, false, min[o], v, t)) min[o] = v;
    }
  }
};

TEST(Run, TheDeferredSearchFindsTheExtremesOfSearchingEveryCell) {
  // A run keeps the cells that may hold a new extreme and searches them at the end, in the
  // order of their bounds, only while a bound still reaches the best found (CellExtremes): its
  // readings of the whole and of the steady part must be those of an observer that searches
  // every cell. Fig. 5(a) over 0.2 s drifts in contact, each crest a little beyond the last,
  // and keeps more stretches than one search holds (so some are searched during the flow);
  // Fig. 4(c) rattles.
  const Study study = park2010_study();
  for (const char* id : {"fig5a", "fig4c"}) {
    Case c;
    for (const StudyCase& sc : study.cases)
      if (sc.id == id) c = sc.input;
    c.solver.duration_s = std::string(id) == "fig5a" ? 0.2 : 0.02;
    const RunResult r = run(c);
    ASSERT_TRUE(r.integration.ok()) << r.integration.message;
    const GearPairModel model = build_model(c);
    const ode::ExactEngine engine(model.linear_system());
    const ode::State s0 = initial_state(c, model, 0);
    ode::Vector y(2);
    y << s0.q, s0.v;
    EveryCell start, part;
    const double from = r.steady.from_s;
    const ode::FlowResult a =
        engine.flow(0, y, s0.region - GearPairModel::kFirstRegion, from, ode::OutputGrid{}, start);
    ASSERT_TRUE(a.ok()) << a.message;
    ASSERT_TRUE(
        engine.flow(from, a.state, a.region, c.solver.duration_s, ode::OutputGrid{}, part).ok());
    const double b = model.parameters().backlash_m;
    const double f = b * model.parameters().mean_stiffness_n_per_m();
    const auto same = [&](double got, double want, double scale, const char* what) {
      EXPECT_NEAR(got, want / scale, 1e-9 * std::abs(want / scale)) << id << " " << what;
    };
    const RunReading& w = r.reading;
    const RunReading& p = r.steady.reading;
    same(w.max_delta_bar, std::max(start.max[0], part.max[0]), b, "max delta");
    same(w.min_delta_bar, std::min(start.min[0], part.min[0]), b, "min delta");
    same(w.max_force_bar, std::max(start.max[1], part.max[1]), f, "max force");
    same(w.min_force_bar, std::min(start.min[1], part.min[1]), f, "min force");
    same(p.max_delta_bar, part.max[0], b, "steady max delta");
    same(p.min_delta_bar, part.min[0], b, "steady min delta");
    same(p.max_force_bar, part.max[1], f, "steady max force");
    same(p.min_force_bar, part.min[1], f, "steady min force");
    // The steady part's extremes are not the start-up's: the part is searched on its own.
    EXPECT_NE(p.max_force_bar, w.max_force_bar) << id;
  }
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
