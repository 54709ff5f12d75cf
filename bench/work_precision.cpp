// Work-precision comparison on the paper's 11 cases (20 ms windows): CPU time to reach
// max |delta/b - reference| <= 1e-6 and <= 1e-9 at 2000 output times, for
//
//   - a plain Boost.Odeint program, written as a user would write it (user_odeint.hpp);
//   - geardyn's exact engine (solver.method = "exact"), its Newmark and its dopri5,
//
// each over a ladder of tolerances (or steps); the cheapest setting that meets the accuracy
// counts, and is printed (tolerances; Newmark's step in s). The reference is the exact engine at
// its tightest tolerance, cross-checked against the Odeint program at 1e-13 (the largest difference
// is printed). Times are the best of
// `--repeat` runs (default 3) of the integration alone: the model (geometry and stiffness) is
// built once, outside the clock, for every method; the exact engine's cell setup is inside.
//
// With --windows: the cost against the window length instead, fig4c and fig4d over 0.02, 0.2
// and 2 s, the exact engine at tolerance 1e-3 and the Odeint program at 1e-9 (their settings
// for 1e-6 on the 20 ms windows), each with its error against the exact engine at 1e-14, and
// the cost per simulated second.
//
//   ./build/release/bench/work_precision [--repeat N] [--window S] [--windows]
#include <array>
#include <boost/math/tools/toms748_solve.hpp>
#include <boost/numeric/odeint.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "geardyn/one_degree_run.hpp"
#include "geardyn/reproduce.hpp"
#include "geardyn/run.hpp"
#include "timing.hpp"
#include "user_odeint.hpp"

namespace {

using bench::user_model;
using bench::user_odeint;
using bench::UserModel;

// ---- geardyn, through its Solver (the one the runs use).
std::vector<double> geardyn_run(const geardyn::GearPairModel& model, geardyn::SolverData s,
                                double t1, const geardyn::ode::OutputGrid& grid) {
  geardyn::RunReader reader(model, 0, t1, 0.1, false, true);
  const geardyn::Solver solver(model, s, t1);
  geardyn::ode::State initial{0, 0, 0, 0, geardyn::kSeparated};
  const auto sum = solver.run(initial, t1, grid, reader);
  if (!sum.ok()) std::fprintf(stderr, "failed: %s\n", sum.message.c_str());
  return reader.samples().delta_bar;
}

using bench::best_time;
using bench::max_error;

int windows(const geardyn::Study& study, int repeat) {
  std::printf("%-7s %8s %12s %10s %12s %10s %14s %14s\n", "case", "window_s", "exact_s",
              "exact_err", "odeint_s", "odeint_err", "exact_s_per_s", "odeint_s_per_s");
  for (const geardyn::StudyCase& sc : study.cases) {
    if (sc.id != "fig4c" && sc.id != "fig4d") continue;
    const geardyn::GearPairModel model = geardyn::build_model(sc.input);
    const UserModel um = user_model(model.parameters());
    for (double window : {0.02, 0.2, 2.0}) {
      const geardyn::ode::OutputGrid grid{0, window / 2000, 2001};
      std::vector<double> times;
      for (std::int64_t k = 0; k < grid.count; ++k) times.push_back(grid.time(k));
      geardyn::SolverData s = sc.input.solver;
      s.method = geardyn::Method::kExact;
      s.tolerance = 1e-14;
      const std::vector<double> ref = geardyn_run(model, s, window, grid);
      s.tolerance = 1e-3;
      std::vector<double> a, b;
      const double te = best_time(repeat, [&] { a = geardyn_run(model, s, window, grid); });
      const double to = best_time(repeat, [&] { b = user_odeint(um, window, times, 1e-9); });
      std::printf("%-7s %8.2f %12.3e %10.1e %12.3e %10.1e %14.3e %14.3e\n", sc.id.c_str(), window,
                  te, max_error(a, ref), to, max_error(b, ref), te / window, to / window);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  double window = 0.02;
  bool by_window = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--windows")) by_window = true;
    if (i + 1 >= argc) continue;
    if (!std::strcmp(argv[i], "--repeat")) repeat = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--window")) window = std::atof(argv[i + 1]);
  }
  const geardyn::Study study = geardyn::park2010_study();
  if (by_window) return windows(study, repeat);
  const std::vector<double> targets = {1e-6, 1e-9};
  const std::vector<double> tols = {1e-3, 1e-4,  1e-5,  1e-6,  1e-7, 1e-8,
                                    1e-9, 1e-10, 1e-11, 1e-12, 1e-13};
  const char* methods[] = {"odeint", "exact", "dopri5", "newmark"};
  std::vector<std::vector<double>> sums(4, std::vector<double>(targets.size(), 0));
  std::printf("%-7s %-8s %12s %12s %12s %12s  (s to reach max|delta/b - ref| <= target)\n", "case",
              "target", "odeint", "exact", "dopri5", "newmark");
  for (const geardyn::StudyCase& sc : study.cases) {
    geardyn::Case c = sc.input;
    c.solver.duration_s = window;
    const geardyn::GearPairModel model = geardyn::build_model(c);
    const geardyn::ode::OutputGrid grid{0, window / 2000, 2001};
    std::vector<double> times;
    for (std::int64_t k = 0; k < grid.count; ++k) times.push_back(grid.time(k));
    geardyn::SolverData s = c.solver;
    s.method = geardyn::Method::kExact;
    s.tolerance = 1e-14;
    const std::vector<double> ref = geardyn_run(model, s, window, grid);
    const UserModel um = user_model(model.parameters());
    const double check = max_error(user_odeint(um, window, times, 1e-13), ref);
    // Time to each target, per method: the cheapest setting that meets it.
    std::vector<std::vector<double>> best(4, std::vector<double>(targets.size(), INFINITY));
    std::vector<std::vector<double>> chosen(4, std::vector<double>(targets.size(), 0));
    double setting = 0;  // the tolerance (or step) being tried
    auto consider = [&](int m, double err, double time) {
      for (std::size_t j = 0; j < targets.size(); ++j)
        if (err <= targets[j] && time < best[m][j]) {
          best[m][j] = time;
          chosen[m][j] = setting;
        }
    };
    for (double tol : tols) {
      setting = tol;
      std::vector<double> out;
      double t = best_time(repeat, [&] { out = user_odeint(um, window, times, tol); });
      consider(0, max_error(out, ref), t);
      for (int m = 1; m <= 2; ++m) {
        s.method = m == 1 ? geardyn::Method::kExact : geardyn::Method::kDopri5;
        s.tolerance = tol;
        t = best_time(repeat, [&] { out = geardyn_run(model, s, window, grid); });
        consider(m, max_error(out, ref), t);
      }
    }
    s.method = geardyn::Method::kNewmark;
    const double dt0 = geardyn::automatic_time_step_s(model.parameters());
    for (double f : {4.0, 1.0, 0.25, 0.0625, 0.015625}) {
      s.time_step_s = dt0 * f;
      setting = s.time_step_s;
      std::vector<double> out;
      const double t = best_time(1, [&] { out = geardyn_run(model, s, window, grid); });
      consider(3, max_error(out, ref), t);
    }
    for (std::size_t j = 0; j < targets.size(); ++j) {
      std::printf("%-7s %-8.0e", sc.id.c_str(), targets[j]);
      for (int m = 0; m < 4; ++m) {
        std::printf(" %12.3e", best[m][j]);
        sums[m][j] += best[m][j];
      }
      std::printf("  settings %.0e %.0e %.0e %.1e", chosen[0][j], chosen[1][j], chosen[2][j],
                  chosen[3][j]);
      std::printf(j == 0 ? "  (reference vs odeint at 1e-13: %.1e)\n" : "\n", check);
    }
  }
  for (std::size_t j = 0; j < targets.size(); ++j) {
    std::printf("%-7s %-8.0e", "sum", targets[j]);
    for (int m = 0; m < 4; ++m) std::printf(" %12.3e", sums[m][j]);
    std::printf("   odeint / exact = %.1f\n", sums[0][j] / sums[1][j]);
  }
  (void)methods;
  return 0;
}
