// Work-precision comparison for the coupled model (docs/performance.md): CPU time to reach
// max |(d - e)/b - reference| <= 1e-6 and <= 1e-9 at 2001 output times over the window, for
//
//   - a plain Boost.Odeint program, written as a user would write it: the coupled equations
//     M q'' + C_b q' + K_b q + V^T F_n = Q(t) by hand with Eigen (M^-1 formed once, k(t), e(t),
//     T1(t) and T2(t) with std::cos), dopri5 with dense output, the mesh's contact guard at
//     every step end and TOMS 748 on the dense output (user_event_loop of user_odeint.hpp);
//   - geardyn's exact engine through CoupledSolver::read, the coupled model's own reading;
//   - the same case through TrainSolver::read, the path `geardyn run` takes (the case as its
//     train of elements, its assembly and stiffness curve built inside every run);
//
// each over a ladder of tolerances, the cheapest that meets the target counting. The reference
// is the exact engine at tolerance 1e-14, cross-checked against the Odeint program at 1e-13.
// Times are the best of `--repeat` runs (default 3): the user program's constants and geardyn's
// mesh stiffness curve are computed outside the clock; geardyn's CoupledSolver (the model's
// assembly and the exact engine with its cells) is built inside each run, as `geardyn run`
// builds it. One part of the setup is not repeated: the engine remembers a region's rate (the
// eigenvalues of A(t) at 16 phases, about 1 ms at dof 12) after the first run. Cases:
// cases/park2010_coupled.toml at dof 3 and 12 (bearings without clearance: the mesh is the
// only nonlinearity the Odeint program has to locate).
//
//   ./build/release/bench/coupled_work_precision [--repeat N] [--window S]
#include <Eigen/Core>
#include <Eigen/LU>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "geardyn/coupled_run.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_run.hpp"
#include "timing.hpp"
#include "user_odeint.hpp"

namespace {

// The user's copy of the model's constants (read from geardyn's, so that both solve the same
// equations).
struct UserCoupled {
  int n = 0;
  Eigen::MatrixXd minv;
  Eigen::VectorXd kb, cb, drive_gain, load_gain;
  Eigen::RowVectorXd v;
  double b = 0, c = 0, k_m = 0, e_0 = 0, t1_mean = 0, t2_mean = 0;
  std::vector<std::array<double, 3>> k_terms, e_terms, t1_terms, t2_terms;
};

std::vector<std::array<double, 3>> terms(const geardyn::HarmonicSeries& h) {
  std::vector<std::array<double, 3>> out;
  for (const auto& x : h.terms)
    out.push_back({x.amplitude, x.angular_frequency_rad_s, x.phase_rad});
  return out;
}

UserCoupled user_coupled(const geardyn::CoupledParameters& p) {
  UserCoupled u;
  u.n = static_cast<int>(p.size());
  u.minv = p.mass.inverse();
  u.kb = p.bearing_stiffness;
  u.cb = p.bearing_damping;
  u.drive_gain = p.drive_gain;
  u.load_gain = p.load_gain;
  u.v = p.mesh_vector;
  u.b = p.backlash_m;
  u.c = p.mesh_damping_n_s_per_m;
  u.k_m = p.stiffness_n_per_m.offset;
  u.k_terms = terms(p.stiffness_n_per_m);
  u.e_0 = p.transmission_error_m.offset;
  u.e_terms = terms(p.transmission_error_m);
  u.t1_mean = p.drive_torque_nm.offset;
  u.t1_terms = terms(p.drive_torque_nm);
  u.t2_mean = p.load_torque_nm.offset;
  u.t2_terms = terms(p.load_torque_nm);
  return u;
}

double series(double mean, const std::vector<std::array<double, 3>>& t, double time) {
  for (const auto& h : t) mean += h[0] * std::cos(h[1] * time + h[2]);
  return mean;
}

// (d - e) / b at `times`, from rest in the middle of the backlash (the mesh apart).
std::vector<double> user_run(const UserCoupled& u, double t1, const std::vector<double>& times,
                             double tol) {
  using X = std::vector<double>;
  const int n = u.n;
  int side = 0;
  // (d - e) / b with the constant transmission error of these cases (main checks it).
  auto deflection = [&](const X& x) {
    return (u.v * Eigen::Map<const Eigen::VectorXd>(x.data(), n) - u.e_0) / u.b;
  };
  auto rhs = [&](const X& x, X& dx, double t) {
    const Eigen::Map<const Eigen::VectorXd> q(x.data(), n), qd(x.data() + n, n);
    double e_rate = 0;
    for (const auto& h : u.e_terms) e_rate -= h[0] * h[1] * std::sin(h[1] * t + h[2]);
    const double d = u.v * q - series(u.e_0, u.e_terms, t), dd = u.v * qd - e_rate;
    double fn = 0;
    if (side != 0) fn = series(u.k_m, u.k_terms, t) * (d - side * u.b) + u.c * dd;
    Eigen::VectorXd force = u.drive_gain * series(u.t1_mean, u.t1_terms, t) +
                            u.load_gain * series(u.t2_mean, u.t2_terms, t) - u.kb.cwiseProduct(q) -
                            u.cb.cwiseProduct(qd) - u.v.transpose() * fn;
    dx.resize(x.size());
    Eigen::Map<Eigen::VectorXd>(dx.data(), n) = qd;
    Eigen::Map<Eigen::VectorXd>(dx.data() + n, n) = u.minv * force;
  };
  auto guard = [&](const X& x) {  // >= 0 while in `side`
    const double s = deflection(x);
    if (side == 1) return s - 1;
    if (side == -1) return -1 - s;
    return std::min(1 - s, s + 1);
  };
  auto next_side = [&](const X& x) {
    const double s = deflection(x);
    return side != 0 ? 0 : (s > 0 ? 1 : -1);
  };
  X x(2 * n, 0.0);
  std::vector<double> out;
  bench::user_event_loop<X>(
      rhs, guard, next_side, [&](const X& y) { return deflection(y); }, side, x, 0.0, t1, times,
      tol, out);
  return out;
}

std::vector<double> geardyn_run(const geardyn::CoupledSolver& solver, double t1,
                                const geardyn::ode::OutputGrid& grid) {
  const geardyn::CoupledRunResult r =
      solver.read(0, solver.initial_state(geardyn::InitialCondition::kCenter), t1, grid, t1);
  if (!r.ok()) std::fprintf(stderr, "failed: %s\n", r.message.c_str());
  return r.samples.deflection_bar;
}

// The train path: the coupled case as its train form, read as `geardyn run` reads it.
std::vector<double> train_run(const geardyn::Case& c, double t1,
                              const geardyn::ode::OutputGrid& grid) {
  const geardyn::TrainSolver solver(c);
  const geardyn::TrainRunResult r = solver.read(
      0, solver.initial_state(geardyn::InitialCondition::kCenter), t1, grid, t1, std::nullopt);
  if (!r.ok()) std::fprintf(stderr, "failed: %s\n", r.message.c_str());
  std::vector<double> out;
  for (const auto d : r.samples.deflection_bar) out.push_back(d[0]);
  return out;
}

using bench::best_time;
using bench::max_error;

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  double window = 0.02;
  for (int i = 1; i + 1 < argc; ++i) {
    if (!std::strcmp(argv[i], "--repeat")) repeat = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--window")) window = std::atof(argv[i + 1]);
  }
  const std::vector<double> targets = {1e-6, 1e-9};
  const std::vector<double> tols = {1e-3, 1e-4,  1e-5,  1e-6,  1e-7, 1e-8,
                                    1e-9, 1e-10, 1e-11, 1e-12, 1e-13};
  std::printf("%-6s %-8s %12s %12s %12s %8s %8s  (s to reach max|(d - e)/b - ref| <= target)\n",
              "dof", "target", "odeint", "exact", "train", "ratio", "ratio");
  for (const int dof : {3, 12}) {
    geardyn::Case c =
        geardyn::load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010_coupled.toml");
    c.model.dof = dof;
    c.solver.duration_s = window;
    const geardyn::ode::OutputGrid grid{0, window / 2000, 2001};
    std::vector<double> times;
    for (std::int64_t k = 0; k < grid.count; ++k) times.push_back(grid.time(k));
    c.solver.tolerance = 1e-14;
    const std::vector<double> ref = geardyn_run(geardyn::CoupledSolver(c), window, grid);
    const UserCoupled u = user_coupled(geardyn::CoupledSolver(c).model().parameters());
    if (!u.e_terms.empty()) {
      std::fprintf(stderr, "the user program's guard takes a constant transmission error\n");
      return 1;
    }
    const std::vector<double> tightest = user_run(u, window, times, 1e-13);
    const double check = max_error(tightest, ref);
    // Each program against itself one tolerance looser: how far each has converged.
    c.solver.tolerance = 1e-10;
    const double exact_self = max_error(geardyn_run(geardyn::CoupledSolver(c), window, grid), ref);
    const double odeint_self = max_error(user_run(u, window, times, 1e-12), tightest);
    std::printf("dof %d: exact at 1e-10 against 1e-14 %.1e; Odeint at 1e-12 against 1e-13 %.1e\n",
                dof, exact_self, odeint_self);
    const geardyn::MeshStiffness stiffness = geardyn::case_stiffness(c);
    std::vector<std::vector<double>> best(3, std::vector<double>(targets.size(), INFINITY));
    std::vector<std::vector<double>> chosen(3, std::vector<double>(targets.size(), 0));
    for (double tol : tols) {
      c.solver.tolerance = tol;
      std::vector<double> out;
      const double to = best_time(repeat, [&] { out = user_run(u, window, times, tol); });
      const double eo = max_error(out, ref);
      const double te = best_time(repeat, [&] {
        const geardyn::CoupledSolver solver(c, &stiffness);
        out = geardyn_run(solver, window, grid);
      });
      const double ee = max_error(out, ref);
      const double tt = best_time(repeat, [&] { out = train_run(c, window, grid); });
      const double et = max_error(out, ref);
      for (std::size_t j = 0; j < targets.size(); ++j) {
        if (et <= targets[j] && tt < best[2][j]) {
          best[2][j] = tt;
          chosen[2][j] = tol;
        }
        if (eo <= targets[j] && to < best[0][j]) {
          best[0][j] = to;
          chosen[0][j] = tol;
        }
        if (ee <= targets[j] && te < best[1][j]) {
          best[1][j] = te;
          chosen[1][j] = tol;
        }
      }
    }
    for (std::size_t j = 0; j < targets.size(); ++j)
      std::printf(
          "%-6d %-8.0e %12.3e %12.3e %12.3e %8.1f %8.1f  settings %.0e %.0e %.0e  (reference vs "
          "odeint at 1e-13: %.1e)\n",
          dof, targets[j], best[0][j], best[1][j], best[2][j], best[0][j] / best[1][j],
          best[0][j] / best[2][j], chosen[0][j], chosen[1][j], chosen[2][j], check);
  }
  return 0;
}
