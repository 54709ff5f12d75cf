// Work-precision comparison on the paper's 11 cases (20 ms windows): CPU time to reach
// max |delta/b - reference| <= 1e-6 and <= 1e-9 at 2000 output times, for
//
//   - a plain Boost.Odeint program, written as a user would write it: dopri5 with dense output,
//     the guards checked at every step end, a crossing located by TOMS 748 on the dense output
//     and the stepper restarted there; k(t) and F(t) evaluated with std::cos;
//   - geardyn's exact engine (solver.method = "exact"), its Newmark and its dopri5,
//
// each over a ladder of tolerances (or steps); the cheapest setting that meets the accuracy
// counts, and is printed (tolerances; Newmark's step in s). The reference is the exact engine at
// its tightest tolerance, cross-checked against the Odeint program at 1e-13 (the largest difference
// is printed). Times are the best of
// `--repeat` runs (default 3) of the integration alone: the model (geometry and stiffness) is
// built once, outside the clock, for every method; the exact engine's cell setup is inside.
//
//   ./build/release/bench/work_precision [--repeat N] [--window S]
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

#include "geardyn/reproduce.hpp"
#include "geardyn/run.hpp"

namespace {

using Clock = std::chrono::steady_clock;

// ---- The user's program: the model written out by hand, Odeint's dopri5, events by TOMS 748.
struct UserModel {
  double m, cb2, b, c, c_free;
  double k_m;
  std::vector<std::array<double, 3>> k_terms;  // amplitude, omega, phase
  double F_m;
  std::vector<std::array<double, 3>> F_terms;
};

UserModel user_model(const geardyn::GearPairParameters& p) {
  UserModel u;
  u.m = p.equivalent_mass_kg;
  u.cb2 = p.cos_base_helix * p.cos_base_helix;
  u.b = p.backlash_m;
  u.c = p.damping_n_s_per_m;
  u.c_free = p.damping == geardyn::DampingForm::kAlways ? u.c : 0.0;
  u.k_m = p.stiffness_n_per_m.offset;
  for (const auto& h : p.stiffness_n_per_m.terms)
    u.k_terms.push_back({h.amplitude, h.angular_frequency_rad_s, h.phase_rad});
  u.F_m = p.force_n.offset;
  for (const auto& h : p.force_n.terms)
    u.F_terms.push_back({h.amplitude, h.angular_frequency_rad_s, h.phase_rad});
  return u;
}

// Returns delta/b at the output times.
std::vector<double> user_odeint(const UserModel& u, double t1, const std::vector<double>& times,
                                double tol) {
  namespace odeint = boost::numeric::odeint;
  using X = std::array<double, 2>;  // delta / b, delta' / b
  int side = 0;                     // 1 drive contact, 0 separated, -1 back contact
  auto rhs = [&](const X& x, X& dx, double t) {
    double k = u.k_m, F = u.F_m;
    for (const auto& h : u.k_terms) k += h[0] * std::cos(h[1] * t + h[2]);
    for (const auto& h : u.F_terms) F += h[0] * std::cos(h[1] * t + h[2]);
    double fg = u.c_free * x[1];  // per unit b
    if (side == 1) fg = k * (x[0] - 1) + u.c * x[1];
    if (side == -1) fg = k * (x[0] + 1) + u.c * x[1];
    dx[0] = x[1];
    dx[1] = (F / u.b - u.cb2 * fg) / u.m;
  };
  auto guard = [&](const X& x) {  // >= 0 while in `side`
    if (side == 1) return x[0] - 1;
    if (side == -1) return -1 - x[0];
    return std::min(1 - x[0], x[0] + 1);
  };
  auto stepper = odeint::make_dense_output(tol, tol, odeint::runge_kutta_dopri5<X>());
  X x{0, 0};
  double t = 0;
  stepper.initialize(x, t, 1e-8);
  std::vector<double> out;
  std::size_t next = 0;
  while (next < times.size() && times[next] <= t) {
    out.push_back(x[0]);
    ++next;
  }
  while (t < t1) {
    stepper.do_step(rhs);
    double te = stepper.current_time();
    X xe = stepper.current_state();
    if (guard(xe) < 0) {  // locate the crossing on the dense output
      auto g = [&](double tt) {
        X xx;
        stepper.calc_state(tt, xx);
        return guard(xx);
      };
      std::uintmax_t it = 100;
      const double ta = stepper.previous_time();
      te = boost::math::tools::toms748_solve(g, ta, te,
                                             boost::math::tools::eps_tolerance<double>(50), it)
               .second;
      stepper.calc_state(te, xe);
      while (next < times.size() && times[next] <= te) {
        X xs;
        stepper.calc_state(times[next], xs);
        out.push_back(xs[0]);
        ++next;
      }
      side = side != 0 ? 0 : (xe[0] > 0 ? 1 : -1);
      x = xe;
      t = te;
      stepper.initialize(x, t, stepper.current_time_step());
      continue;
    }
    while (next < times.size() && times[next] <= te) {
      X xs;
      stepper.calc_state(times[next], xs);
      out.push_back(xs[0]);
      ++next;
    }
    x = xe;
    t = te;
  }
  return out;
}

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

double max_error(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return std::numeric_limits<double>::infinity();
  double e = 0;
  for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, std::abs(a[i] - b[i]));
  return e;
}

template <class F>
double best_time(int repeat, F&& f) {
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  double window = 0.02;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--repeat")) repeat = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--window")) window = std::atof(argv[i + 1]);
  }
  const geardyn::Study study = geardyn::park2010_study();
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
