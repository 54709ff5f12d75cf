// Convergence of the Newmark integrator through impacts, and agreement with dopri5.
#include <gtest/gtest.h>

#include <cmath>

#include "geardyn/run.hpp"

namespace geardyn {
namespace {

TEST(NewmarkConvergence, SecondOrderAtAFixedEndTimeThroughImpacts) {
  // The paper's gear at 1 kHz: in 3 ms the teeth leave the backlash centre, strike, separate,
  // strike again... (six located transitions). Error of delta at t1 against dopri5 at 1e-13.
  Case c;
  c.solver.method = Method::kNewmark;
  c.solver.duration_s = 3e-3;
  c.solver.output_interval_s = 3e-3;
  Case ref = c;
  ref.solver.method = Method::kDopri5;
  ref.solver.tolerance = 1e-13;
  const RunResult r_ref = run(ref);
  ASSERT_GE(r_ref.integration.transitions, 5);
  const double delta_ref = r_ref.samples.delta_bar.back();

  constexpr double kExpectedOrder = 2.0;
  std::vector<double> errors;
  for (double dt : {4e-7, 2e-7, 1e-7, 5e-8}) {
    c.solver.time_step_s = dt;
    const RunResult r = run(c);
    ASSERT_EQ(r.integration.transitions, r_ref.integration.transitions) << dt;
    errors.push_back(std::abs(r.samples.delta_bar.back() - delta_ref));
  }
  for (std::size_t i = 1; i < errors.size(); ++i) {
    const double order = std::log2(errors[i - 1] / errors[i]);
    EXPECT_NEAR(order, kExpectedOrder, 0.1) << "between dt ladder rungs " << i - 1 << " and " << i;
  }
}

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
