// Work-precision comparison for a gear train (docs/performance.md): CPU time to reach
// max |(d - e)/b - reference| <= 1e-6 over every mesh at 2001 output times, for
//
//   - a plain Boost.Odeint program, written as a user would write it: the train's equations
//     M theta'' + C_s theta' + K_s theta + sum_m V_m^T F_m = Q(t) by hand with Eigen (M^-1
//     formed once, each mesh's k(t), e(t) and every torque with std::cos), dopri5 with dense
//     output, every mesh's contact guard at each step end and TOMS 748 on the dense output
//     (user_event_loop of user_odeint.hpp, the mesh states packed in its side);
//   - geardyn's run_train, the path `geardyn run` takes (the train's assembly and its
//     integrator built inside each run), with the exact engine and with solver.method =
//     "dopri5" (adaptive.hpp);
//
// each over a ladder of tolerances, the cheapest that meets the target counting. The reference
// is the exact engine at tolerance 1e-13, cross-checked against the Odeint program at 1e-12.
// Both start from the static state (every mesh in contact at the mean loads). Times are the
// best of `--repeat` runs (default 3). Case: cases/two_stage_reducer.toml (or --case).
//
//   ./build/release/bench/train_work_precision [--repeat N] [--window S] [--case FILE]
#include <Eigen/Core>
#include <Eigen/LU>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "geardyn/train_case.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_statics.hpp"
#include "timing.hpp"
#include "user_odeint.hpp"

namespace {

using Terms = std::vector<std::array<double, 3>>;  // amplitude, angular frequency, phase

Terms terms(const geardyn::HarmonicSeries& h) {
  Terms out;
  for (const auto& x : h.terms)
    out.push_back({x.amplitude, x.angular_frequency_rad_s, x.phase_rad});
  return out;
}

double series(double mean, const Terms& t, double time) {
  for (const auto& h : t) mean += h[0] * std::cos(h[1] * time + h[2]);
  return mean;
}

double series_rate(const Terms& t, double time) {
  double r = 0;
  for (const auto& h : t) r -= h[0] * h[1] * std::sin(h[1] * time + h[2]);
  return r;
}

// The user's copy of the train (read from geardyn's elements, so that both solve the same
// equations).
struct UserTrain {
  int n = 0;
  Eigen::MatrixXd minv, ks, cs;
  struct Mesh {
    Eigen::RowVectorXd v;
    double b = 0, c = 0, k_m = 0;
    Terms k, e;
  };
  std::vector<Mesh> meshes;
  std::vector<std::pair<int, std::pair<double, Terms>>> torques;  // body, mean, harmonics
};

UserTrain user_train(const geardyn::train::Assembled& a) {
  const geardyn::train::Train& t = a.train();
  UserTrain u;
  u.n = a.size();
  u.minv = a.mass().inverse();
  u.ks = Eigen::MatrixXd::Zero(u.n, u.n);
  u.cs = Eigen::MatrixXd::Zero(u.n, u.n);
  // Shafts (to the ground too) and bearings (on the ground or a carrier's pin) as geardyn's
  // elements place them, as the meshes' vectors below.
  for (std::size_t k = 0; k < t.shafts.size(); ++k) {
    const Eigen::RowVectorXd v = a.shaft_vector(static_cast<int>(k));
    u.ks += t.shafts[k].stiffness_n_m_per_rad * v.transpose() * v;
    u.cs += t.shafts[k].damping_n_m_s_per_rad * v.transpose() * v;
  }
  Eigen::VectorXd seat_loads = Eigen::VectorXd::Zero(u.n);
  for (std::size_t k = 0; k < t.bearings.size(); ++k) {
    const Eigen::MatrixXd b = a.bearing_matrix(static_cast<int>(k));
    u.ks += t.bearings[k].stiffness_n_per_m * b.transpose() * b;
    u.cs += t.bearings[k].damping_n_s_per_m * b.transpose() * b;
    seat_loads +=
        t.bearings[k].stiffness_n_per_m * b.transpose() * a.bearing_offset(static_cast<int>(k));
  }
  for (int i = 0; i < u.n; ++i)
    if (seat_loads(i) != 0) u.torques.push_back({i, {seat_loads(i), {}}});
  // The joints of one stage (a drag): their damping, and their constant force below. (A
  // bearing's clearance is its bearing's, stamped above as if it had none.)
  for (const geardyn::train::Joint& j : a.joints()) {
    if (!j.linearised) continue;
    if (j.stage_count() != 1)
      throw std::invalid_argument(j.name + ": a joint of stages, which this program does not take");
    u.cs += j.stages[0].damping * j.row.transpose() * j.row;
    u.ks += j.stages[0].stiffness * j.row.transpose() * j.row;
  }
  for (std::size_t m = 0; m < t.meshes.size(); ++m) {
    const int i = static_cast<int>(m);
    const geardyn::HarmonicSeries k = a.stiffness_series(i), e = a.error_series(i);
    u.meshes.push_back({a.mesh_vector(i), t.meshes[m].backlash_m, t.meshes[m].damping_n_s_per_m,
                        k.offset, terms(k), terms(e)});
  }
  for (std::size_t q = 0; q < t.torques.size(); ++q) {
    const geardyn::HarmonicSeries s = a.torque_series(static_cast<int>(q));
    u.torques.push_back({a.index(t.torques[q].body), {s.offset, terms(s)}});
  }
  for (const geardyn::train::Joint& j : a.joints())
    for (Eigen::Index i = 0; j.linearised && i < j.row.size(); ++i)
      if (const double f = j.stages[0].stiffness * j.offset - j.stages[0].force_at_zero;
          f * j.row(i) != 0)
        u.torques.push_back({static_cast<int>(i), {f * j.row(i), {}}});
  return u;
}

// Each mesh's state (1, 0, -1) packed in one int, base 3, as user_event_loop's side.
int state_of(int side, std::size_t m) {
  for (std::size_t k = 0; k < m; ++k) side /= 3;
  return side % 3 - 1;
}

// (d - e) / b of each mesh at `times` (mesh-major: out[m][k]).
std::vector<std::vector<double>> user_run(const UserTrain& u, const Eigen::VectorXd& y0, double t1,
                                          const std::vector<double>& times, double tol) {
  using X = std::vector<double>;
  const int n = u.n;
  const std::size_t nm = u.meshes.size();
  const std::size_t time_index = 2 * static_cast<std::size_t>(n);
  int side = 0;
  for (std::size_t m = 0, p = 1; m < nm; ++m, p *= 3) side += 2 * static_cast<int>(p);  // drive
  // The state carries its time as its last entry (t' = 1), so that a guard, which sees the
  // state alone, reads e(t) at the state's time.
  const auto deflection = [&](const X& x, std::size_t m) {
    const UserTrain::Mesh& me = u.meshes[m];
    return (me.v * Eigen::Map<const Eigen::VectorXd>(x.data(), n) -
            series(0, me.e, x[time_index])) /
           me.b;
  };
  auto rhs = [&](const X& x, X& dx, double t) {
    const Eigen::Map<const Eigen::VectorXd> q(x.data(), n), qd(x.data() + n, n);
    Eigen::VectorXd force = -u.ks * q - u.cs * qd;
    for (const auto& [body, torque] : u.torques)
      force(body) += series(torque.first, torque.second, t);
    for (std::size_t m = 0; m < nm; ++m) {
      const int s = state_of(side, m);
      if (s == 0) continue;
      const UserTrain::Mesh& me = u.meshes[m];
      const double d = me.v * q - series(0, me.e, t), dd = me.v * qd - series_rate(me.e, t);
      force -= me.v.transpose() * (series(me.k_m, me.k, t) * (d - s * me.b) + me.c * dd);
    }
    dx.resize(x.size());
    Eigen::Map<Eigen::VectorXd>(dx.data(), n) = qd;
    Eigen::Map<Eigen::VectorXd>(dx.data() + n, n) = u.minv * force;
    dx[time_index] = 1;
  };
  const auto mesh_guard = [&](const X& x, std::size_t m) {
    const double s = deflection(x, m);
    const int st = state_of(side, m);
    if (st == 1) return s - 1;
    if (st == -1) return -1 - s;
    return std::min(1 - s, s + 1);
  };
  auto guard = [&](const X& x) {
    double g = INFINITY;
    for (std::size_t m = 0; m < nm; ++m) g = std::min(g, mesh_guard(x, m));
    return g;
  };
  auto next_side = [&](const X& x) {  // the mesh at its edge changes state
    std::size_t at = 0;
    for (std::size_t m = 1; m < nm; ++m)
      if (std::abs(mesh_guard(x, m)) < std::abs(mesh_guard(x, at))) at = m;
    const int st = state_of(side, at);
    const int to = st != 0 ? 0 : (deflection(x, at) > 0 ? 1 : -1);
    int p = 1;
    for (std::size_t k = 0; k < at; ++k) p *= 3;
    return side + (to - st) * p;
  };
  X x(y0.data(), y0.data() + y0.size());
  x.push_back(0.0);  // t
  std::vector<std::vector<double>> out(nm);
  std::vector<double> first;
  bench::user_event_loop<X>(
      rhs, guard, next_side,
      [&](const X& y) {
        for (std::size_t m = 1; m < nm; ++m) out[m].push_back(deflection(y, m));
        return deflection(y, 0);
      },
      side, x, 0.0, t1, times, tol, first);
  out[0] = first;
  return out;
}

std::vector<std::vector<double>> geardyn_run(const geardyn::Case& c) {
  const geardyn::TrainRunResult r = geardyn::run_train(c);
  if (!r.ok()) std::fprintf(stderr, "failed: %s\n", r.message.c_str());
  std::vector<std::vector<double>> out(r.meshes.size());
  for (const auto& d : r.samples.deflection_bar)
    for (std::size_t m = 0; m < d.size(); ++m) out[m].push_back(d[m]);
  return out;
}

double max_error(const std::vector<std::vector<double>>& a,
                 const std::vector<std::vector<double>>& b) {
  double e = 0;
  for (std::size_t m = 0; m < a.size(); ++m) e = std::max(e, bench::max_error(a[m], b[m]));
  return e;
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  double window = 0.1;
  std::string file = std::string(GEARDYN_SOURCE_DIR) + "/cases/two_stage_reducer.toml";
  for (int i = 1; i + 1 < argc; ++i) {
    if (!std::strcmp(argv[i], "--repeat")) repeat = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--window")) window = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--case")) file = argv[i + 1];
  }
  geardyn::Case c = geardyn::load_case(file);
  c.solver.duration_s = window;
  c.solver.output_interval_s = window / 2000;
  c.solver.initial = geardyn::InitialCondition::kStatic;
  const geardyn::train::Assembled a = geardyn::assembled_train(c);
  if (!a.train().speeds.empty()) {
    std::fprintf(stderr, "the user program takes no prescribed speed\n");
    return 1;
  }
  std::vector<double> times;
  for (int k = 0; k <= 2000; ++k) times.push_back(k * window / 2000);
  const Eigen::VectorXd y0 = *geardyn::static_state(a, nullptr, 0.0);
  const UserTrain u = user_train(a);
  // A train whose cells the exact engine cannot hold (a hunting-tooth gearbox's common period
  // of minutes) has dopri5 for its default: the reference and the "exact" column are then
  // dopri5's, and said so.
  c.origins.erase("solver.method");
  c.solver.method = geardyn::Method::kExact;
  const bool exact = geardyn::TrainSolver(c).method() == geardyn::Method::kExact;
  c.solver.tolerance = 1e-13;
  const auto ref = geardyn_run(c);
  const auto tightest = user_run(u, y0, window, times, 1e-12);
  std::printf("%s over %g s: reference (%s, 1e-13) against Odeint at 1e-12: %.1e\n", c.name.c_str(),
              window, exact ? "exact" : "dopri5: the default's choice", max_error(tightest, ref));
  const double target = 1e-6;
  // Each program's cheapest time to the target, and the tolerance it took.
  std::array<double, 3> best = {INFINITY, INFINITY, INFINITY}, chosen = {0, 0, 0};
  const char* names[] = {"odeint", exact ? "exact" : "default (dopri5)", "dopri5"};
  for (double tol : {1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10}) {
    std::vector<std::vector<double>> out;
    std::array<double, 3> time{}, error{};
    time[0] = bench::best_time(repeat, [&] { out = user_run(u, y0, window, times, tol); });
    error[0] = max_error(out, ref);
    c.solver.tolerance = tol;
    for (int k : {1, 2}) {
      c.solver.method = k == 1 ? geardyn::Method::kExact : geardyn::Method::kDopri5;
      time[k] = bench::best_time(repeat, [&] { out = geardyn_run(c); });
      error[k] = max_error(out, ref);
    }
    std::printf("tolerance %.0e:", tol);
    for (int k = 0; k < 3; ++k) {
      std::printf("  %s %.3e s (error %.1e)", names[k], time[k], error[k]);
      if (error[k] <= target && time[k] < best[k]) best[k] = time[k], chosen[k] = tol;
    }
    std::printf("\n");
  }
  std::printf("to %.0e:", target);
  for (int k = 0; k < 3; ++k)
    std::printf("  %s %.3e s (tolerance %.0e)", names[k], best[k], chosen[k]);
  std::printf("\n  odeint / exact %.3f, odeint / dopri5 %.3f\n", best[0] / best[1],
              best[0] / best[2]);
  return 0;
}
