// Agreement of the Newmark integrator with dopri5 through impacts, and the automatic step.
#include <gtest/gtest.h>

#include <cmath>

#include "geardyn/run.hpp"

namespace geardyn {
namespace {

// Newmark's second order through impacts (the paper's gear at 1 kHz over 3 ms, steps 4e-7 to
// 5e-8 s against dopri5 at 1e-13) is the shipped check newmark_order (validation.hpp), run by
// cli_test's Validate tests.

Case fig4a() {
  Case c;
  c.solver.method = Method::kNewmark;
  c.speed.shaft_frequency_hz = 10.0;
  c.solver.duration_s = 0.1;
  return c;
}

TEST(IntegratorsAgree, OnTheFig4aCase) {
  Case n = fig4a();
  n.solver.time_step_s = 1e-7;
  Case d = fig4a();
  d.solver.method = Method::kDopri5;
  d.solver.tolerance = 1e-12;
  const RunResult rn = run(n), rd = run(d);
  ASSERT_TRUE(rn.integration.ok());
  ASSERT_TRUE(rd.integration.ok());
  EXPECT_GT(rn.reading.impacts, 10);
  EXPECT_EQ(rn.reading.impacts, rd.reading.impacts);
  EXPECT_EQ(rn.reading.separations, rd.reading.separations);
  ASSERT_TRUE(rn.reading.last_separation_s && rd.reading.last_separation_s);
  EXPECT_NEAR(*rn.reading.last_separation_s, *rd.reading.last_separation_s,
              1e-6 * *rd.reading.last_separation_s);
  EXPECT_EQ(rn.reading.regime, Regime::kTransient);
}

TEST(AutomaticStep, ReadsTheFig4aCaseAsTheConvergedSolutionDoes) {
  // The automatic step (fastest period / 200) against dopri5 at 1e-12: the same impacts and
  // regime, the last separation within 1e-4 relative (docs/numerics.md has the full study).
  const RunResult ra = run(fig4a());
  Case d = fig4a();
  d.solver.method = Method::kDopri5;
  d.solver.tolerance = 1e-12;
  const RunResult rd = run(d);
  EXPECT_EQ(ra.reading.impacts, rd.reading.impacts);
  EXPECT_EQ(ra.reading.regime, rd.reading.regime);
  EXPECT_NEAR(*ra.reading.last_separation_s, *rd.reading.last_separation_s,
              1e-4 * *rd.reading.last_separation_s);
  EXPECT_NEAR(ra.reading.max_force_bar, rd.reading.max_force_bar, 1e-3 * rd.reading.max_force_bar);
}

}  // namespace
}  // namespace geardyn
