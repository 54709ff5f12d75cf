// The Newmark-beta flow of any piecewise-linear system (newmark_flow.hpp): the closed form of
// average acceleration on an oscillator, the energy it keeps, the one-degree model's own
// Newmark (integrator.hpp) on the gear pair run as its train, and the systems it refuses.
#include "geardyn/newmark_flow.hpp"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn::ode {
namespace {

// A linear system with constant coefficients and one region without guards: q'' = -M^-1 K q.
LinearSwitchedSystem undamped(const Matrix& m, const Matrix& k) {
  const Eigen::Index n = m.rows();
  LinearSwitchedSystem s;
  s.dimension = static_cast<int>(2 * n);
  LinearRegion r;
  r.a.constant = Matrix::Zero(2 * n, 2 * n);
  r.a.constant.topRightCorner(n, n) = Matrix::Identity(n, n);
  r.a.constant.bottomLeftCorner(n, n) = -m.inverse() * k;
  r.u.constant = Vector::Zero(2 * n);
  s.regions.push_back(r);
  return s;
}

// Keeps the state at every step end.
struct Ends : FlowObserver {
  std::vector<double> t;
  std::vector<Vector> y;
  void on_step(double t_s, const Vector& at, int /*region*/) override {
    t.push_back(t_s);
    y.push_back(at);
  }
};

// Average acceleration is the trapezoidal rule on (q, v): on q'' = -w^2 q it turns (q, v / w)
// by exactly theta = 2 atan(w h / 2) a step, so q_n = cos(n theta) from (1, 0). A beta or gamma
// other than 1/4 and 1/2, or a predictor's term left out, leaves this closed form at once.
TEST(NewmarkFlow, TurnsAnOscillatorByTheClosedFormOfAverageAcceleration) {
  const double w = 2 * 3.14159265358979 * 50.0;  // 50 Hz
  const LinearSwitchedSystem s = undamped(Matrix::Identity(1, 1), Matrix::Constant(1, 1, w * w));
  const double h = 1e-3;  // 20 steps a period: a visible period error
  const int steps = 1000;
  Ends ends;
  const FlowResult r = newmark_flow(s, 0, Vector{{1.0, 0.0}}, 0, steps * h, h, {}, ends);
  ASSERT_TRUE(r.ok()) << r.message;
  ASSERT_EQ(ends.y.size(), static_cast<std::size_t>(steps));
  const double theta = 2 * std::atan(w * h / 2);
  for (int n = 1; n <= steps; n += 37) {
    EXPECT_NEAR(ends.y[n - 1](0), std::cos(n * theta), 1e-11) << n;
    EXPECT_NEAR(ends.y[n - 1](1), -w * std::sin(n * theta), 1e-11 * w) << n;
  }
  // Not the exact solution: the period error of average acceleration is visible here.
  EXPECT_GT(std::abs(ends.y.back()(0) - std::cos(w * steps * h)), 1e-2);
  EXPECT_EQ(r.cells, steps);
  EXPECT_EQ(r.events, 0);
}

// On a linear system with constant coefficients, average acceleration is the trapezoidal rule
// on y' = A y: y_(k+1) = (I - h A / 2)^-1 (I + h A / 2) y_k. A damped chain of 1 to 8 bodies
// (the step's sizes fixed at compile time up to 6, dynamic above) steps as that map does, each
// body coupled to the next through stiffness and damping so that every entry of P and R acts.
// A mutant that takes R for P, drops the damping's rows or misreads a size fails.
TEST(NewmarkFlow, EverySizeStepsAsTheTrapezoidalRule) {
  for (int n = 1; n <= 8; ++n) {
    Matrix m = Matrix::Zero(n, n), k = Matrix::Zero(n, n), c = Matrix::Zero(n, n);
    for (int i = 0; i < n; ++i) {
      m(i, i) = 1.0 + 0.3 * i;
      k(i, i) += 2e4 * (1 + 0.1 * i);  // to the ground
      c(i, i) += 3.0;
      if (i + 1 < n) {
        const double ki = 1e4 * (1 + 0.2 * i), ci = 2.0 + i;
        k(i, i) += ki;
        k(i + 1, i + 1) += ki;
        k(i, i + 1) -= ki;
        k(i + 1, i) -= ki;
        c(i, i) += ci;
        c(i + 1, i + 1) += ci;
        c(i, i + 1) -= ci;
        c(i + 1, i) -= ci;
      }
    }
    LinearSwitchedSystem s = undamped(m, k);
    s.regions[0].a.constant.bottomRightCorner(n, n) = -m.inverse() * c;
    const Matrix a = s.regions[0].a.constant;
    const double h = 2e-3;
    const Matrix id = Matrix::Identity(2 * n, 2 * n);
    const Matrix map = (id - 0.5 * h * a).partialPivLu().solve(id + 0.5 * h * a);
    Vector y0(2 * n);
    for (int i = 0; i < 2 * n; ++i) y0(i) = (i % 2 == 0 ? 1e-3 : -2e-3) * (1 + 0.25 * i);
    Ends ends;
    const int steps = 300;
    const FlowResult r = newmark_flow(s, 0, y0, 0, steps * h, h, {}, ends);
    ASSERT_TRUE(r.ok()) << n << ": " << r.message;
    ASSERT_EQ(ends.y.size(), static_cast<std::size_t>(steps)) << n;
    Vector y = y0;
    double worst = 0, size = 0, moved = 0;
    for (int j = 0; j < steps; ++j) {
      y = map * y;
      worst = std::max(worst, (ends.y[static_cast<std::size_t>(j)] - y).cwiseAbs().maxCoeff());
      size = std::max(size, y.cwiseAbs().maxCoeff());
      moved = std::max(moved, std::abs(y(0) - y0(0)));
    }
    EXPECT_LT(worst, 1e-11 * size) << n;
    EXPECT_GT(moved, std::abs(y0(0))) << n;  // the first body swings through its rest
  }
}

// Two bodies on three springs, undamped: 1/2 v' M v + 1/2 q' K q is a quadratic invariant that
// the trapezoidal rule keeps exactly, whatever the step.
TEST(NewmarkFlow, KeepsTheEnergyOfAnUndampedLinearSystem) {
  const Matrix m{{2.0, 0.0}, {0.0, 0.5}};
  const Matrix k{{3e4, -1e4}, {-1e4, 1.5e4}};
  const LinearSwitchedSystem s = undamped(m, k);
  const auto energy = [&](const Vector& y) {
    return 0.5 * y.tail(2).dot(m * y.tail(2)) + 0.5 * y.head(2).dot(k * y.head(2));
  };
  const Vector y0{{1e-3, -2e-3, 0.1, 0.0}};
  Ends ends;
  const FlowResult r = newmark_flow(s, 0, y0, 0, 2.0, 7e-3, {}, ends);  // steps of ~ 1/4 period
  ASSERT_TRUE(r.ok());
  double worst = 0;
  for (const Vector& y : ends.y) worst = std::max(worst, std::abs(energy(y) / energy(y0) - 1));
  EXPECT_LT(worst, 1e-12);
  // The motion is not trivial: the energy moves between the two coordinates.
  EXPECT_GT(std::abs(ends.y[100](0) - y0(0)), 1e-4);
}

TEST(NewmarkFlow, RefusesASystemThatIsNotOfSecondOrder) {
  LinearSwitchedSystem s = undamped(Matrix::Identity(1, 1), Matrix::Identity(1, 1));
  s.regions[0].a.constant(0, 1) = 2.0;  // q' = 2 v
  Ends ends;
  EXPECT_NE(second_order_form_error(s, 0).find("row 0"), std::string::npos);
  EXPECT_THROW((void)newmark_flow(s, 0, Vector{{1.0, 0.0}}, 0, 1.0, 0.1, {}, ends),
               std::invalid_argument);
  s.regions[0].a.constant(0, 1) = 1.0;
  s.regions[0].u.constant(0) = 1.0;  // q' = v + 1
  EXPECT_FALSE(second_order_form_error(s, 0).empty());
  s.regions[0].u.constant(0) = 0.0;
  EXPECT_TRUE(second_order_form_error(s, 0).empty());
  EXPECT_THROW((void)newmark_flow(s, 0, Vector{{1.0, 0.0}}, 0, 1.0, 0.0, {}, ends),
               std::invalid_argument);
}

// Newmark-beta commutes with a constant change of coordinates, and the pair's train keeps its
// rigid rotation apart from the mesh (no element strains it): the gear pair run as its train of
// two bodies steps its mesh deflection as the one-degree model's own Newmark steps delta, on
// the same grid, through the same located impacts (Park's Fig. 4(c) case: 10 impacts in 10 ms).
TEST(NewmarkFlow, StepsThePairAsItsTrainAsTheOneDegreeModelsNewmark) {
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "park2010.toml");
  set_case_value(c, {"solver.method", "newmark"});
  set_case_value(c, {"solver.duration_s", "0.01"});   // 10 torque periods of 1 ms
  set_case_value(c, {"solver.time_step_s", "1e-7"});  // 89 steps of the 112 kHz harmonic
  set_case_value(c, {"solver.output_interval_s", "1e-5"});
  const RunResult pair = run_one_degree_model(c);
  const TrainRunResult as_train = run_train(c);
  ASSERT_TRUE(pair.integration.ok()) << pair.integration.message;
  ASSERT_TRUE(as_train.ok()) << as_train.message;
  ASSERT_GE(pair.reading.impacts, 10);
  ASSERT_EQ(as_train.samples.t_s.size(), pair.samples.size());
  double worst = 0;
  for (std::size_t i = 0; i < pair.samples.size(); ++i) {
    ASSERT_EQ(as_train.samples.t_s[i], pair.samples.t_s[i]);
    worst = std::max(worst,
                     std::abs(as_train.samples.deflection_bar[i][0] - pair.samples.delta_bar[i]));
  }
  EXPECT_LT(worst, 1e-11);  // 2.3e-13 measured (1.7e-13 with each phase computed directly)
  EXPECT_EQ(as_train.meshes[0].impacts, pair.reading.impacts);
  EXPECT_EQ(as_train.meshes[0].backside_impacts, pair.reading.backside_impacts);
  EXPECT_EQ(as_train.events, pair.integration.transitions);
}

}  // namespace
}  // namespace geardyn::ode
