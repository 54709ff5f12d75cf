// A 401-point up-and-down frequency sweep of the Kahraman-Singh oscillator (the
// non-dimensional gear: zeta 0.05, F_m 0.1, F_a 0.02, Omega 0.5 to 1.5), 250 excitation periods
// a point, each point continuing from the previous one's end state. The amplitude of a point
// is (max - min) / 2 of delta/b at 64 samples per period over its last 10 periods: the same
// times for every method, so that amplitudes compare to rounding.
//
// Methods: geardyn's exact engine (its Solver, as sweeps use it) at tolerance 1e-3, and the
// plain Boost.Odeint program of user_odeint.hpp at a ladder of tolerances. The reference is the
// Odeint program at 1e-12 (independent of geardyn's integrators). Printed: time per direction
// and the largest amplitude difference from the reference; the Odeint setting that counts is
// the cheapest within 1e-6.
//
//   ./build/release/bench/ks_sweep [--repeat N]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <string_view>
#include <vector>

#include "geardyn/one_degree_run.hpp"
#include "geardyn/run.hpp"
#include "geardyn/validation.hpp"
#include "user_odeint.hpp"

namespace {

constexpr int kPoints = 401;
constexpr int kPeriods = 250;
constexpr int kMeasuredPeriods = 10;
constexpr int kSamplesPerPeriod = 64;

std::vector<double> omegas(bool up) {
  std::vector<double> w;
  for (int i = 0; i < kPoints; ++i) {
    const double o = 0.5 + 1.0 * i / (kPoints - 1);
    w.push_back(o);
  }
  if (!up) std::reverse(w.begin(), w.end());
  return w;
}

double amplitude(const std::vector<double>& x) {
  if (x.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  return 0.5 * (*hi - *lo);
}

// One direction with geardyn: amplitudes, and the state carried to the next direction.
std::vector<double> sweep_geardyn(bool up, geardyn::ode::State& carry, double tol) {
  std::vector<double> amps;
  for (double w : omegas(up)) {
    const geardyn::Case c = geardyn::kahraman_singh_case(w);
    const geardyn::GearPairModel model = geardyn::build_model(c);
    geardyn::SolverData s = c.solver;
    s.method = geardyn::Method::kExact;
    s.tolerance = tol;
    const geardyn::Solver solver(model, s);
    const double T = 2 * std::numbers::pi / w;
    const double t1 = kPeriods * T;
    const geardyn::ode::OutputGrid grid{(kPeriods - kMeasuredPeriods) * T, T / kSamplesPerPeriod,
                                        kMeasuredPeriods * kSamplesPerPeriod + 1};
    // Settle unread, then read the last periods (as geardyn sweep does).
    geardyn::ode::State start = carry;
    start.t = 0;
    const double t_read = (kPeriods - kMeasuredPeriods) * T;
    const auto settled = solver.advance(start, t_read);
    geardyn::RunReader reader(model, t_read, t1, 0.1, false, true);
    const auto sum = settled.ok() ? solver.run(settled.end_state, t1, grid, reader) : settled;
    if (!sum.ok())
      std::fprintf(stderr, "geardyn failed at Omega = %g: %s\n", w, sum.message.c_str());
    carry = sum.end_state;
    amps.push_back(amplitude(reader.samples().delta_bar));
  }
  return amps;
}

// NaN amplitudes from the point on where the program stalled.
std::vector<double> sweep_odeint(bool up, bench::UserState& carry, double tol) {
  std::vector<double> amps;
  for (double w : omegas(up)) {
    if (carry.stalled) {
      amps.push_back(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    const geardyn::GearPairModel model = geardyn::build_model(geardyn::kahraman_singh_case(w));
    const bench::UserModel um = bench::user_model(model.parameters());
    const double T = 2 * std::numbers::pi / w;
    std::vector<double> times;
    for (int k = 0; k <= kMeasuredPeriods * kSamplesPerPeriod; ++k)
      times.push_back((kPeriods - kMeasuredPeriods) * T + k * T / kSamplesPerPeriod);
    std::vector<double> out;
    carry = bench::user_odeint(um, carry, 0.0, kPeriods * T, times, tol, out);
    amps.push_back(carry.stalled ? std::numeric_limits<double>::quiet_NaN() : amplitude(out));
  }
  return amps;
}

template <class F>
double seconds(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Infinite where either has no amplitude (a stalled program).
double max_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double e = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double d = std::abs(a[i] - b[i]);
    e = std::isnan(d) ? std::numeric_limits<double>::infinity() : std::max(e, d);
  }
  return e;
}

}  // namespace

int main(int argc, char** argv) {
  // --repeat N: every method is timed N times, interleaved, and its fastest run counts (the
  // machine is shared: the minimum is the least disturbed).
  int repeat = 1;
  for (int i = 1; i + 1 < argc; ++i)
    if (std::string_view(argv[i]) == "--repeat") repeat = std::max(1, std::atoi(argv[i + 1]));
  // The reference, up then down from the static contact state.
  const double x_static = 1.0 + 0.1;  // b + F_m / k, non-dimensional
  bench::UserState ref_carry{x_static, 0.0, 1};
  const std::vector<double> ref_up = sweep_odeint(true, ref_carry, 1e-12);
  const std::vector<double> ref_down = sweep_odeint(false, ref_carry, 1e-12);
  if (ref_carry.stalled) std::printf("the reference stalled\n");
  std::setvbuf(stdout, nullptr, _IOLBF, 0);

  const std::vector<double> tols{1e-6, 1e-7, 1e-8, 1e-9, 1e-10};
  const double inf = std::numeric_limits<double>::infinity();
  struct Timing {
    double up = std::numeric_limits<double>::infinity();
    double down = std::numeric_limits<double>::infinity();
    double error = 0;
    bool stalled = false;
  };
  Timing geardyn_t;
  std::vector<Timing> odeint_t(tols.size());
  for (int r = 0; r < repeat; ++r) {
    geardyn::ode::State carry{0, x_static, 0, 0, geardyn::kDriveContact};
    std::vector<double> up, down;
    geardyn_t.up = std::min(geardyn_t.up, seconds([&] { up = sweep_geardyn(true, carry, 1e-3); }));
    geardyn_t.down =
        std::min(geardyn_t.down, seconds([&] { down = sweep_geardyn(false, carry, 1e-3); }));
    geardyn_t.error = std::max(max_difference(up, ref_up), max_difference(down, ref_down));
    for (std::size_t i = 0; i < tols.size(); ++i) {
      bench::UserState c{x_static, 0.0, 1};
      Timing& o = odeint_t[i];
      o.up = std::min(o.up, seconds([&] { up = sweep_odeint(true, c, tols[i]); }));
      o.down = std::min(o.down, seconds([&] { down = sweep_odeint(false, c, tols[i]); }));
      o.error = std::max(max_difference(up, ref_up), max_difference(down, ref_down));
      o.stalled = c.stalled;
    }
  }
  std::printf("fastest of %d runs\n", repeat);
  std::printf("%-22s %12s %12s %12s\n", "method", "up_s", "down_s", "max_amp_err");
  std::printf("%-22s %12.3f %12.3f %12.1e\n", "geardyn exact 1e-3", geardyn_t.up, geardyn_t.down,
              geardyn_t.error);
  double best = inf;
  for (std::size_t i = 0; i < tols.size(); ++i) {
    const Timing& o = odeint_t[i];
    char label[32];
    std::snprintf(label, sizeof label, "odeint %g", tols[i]);
    if (o.stalled)
      std::printf("%-22s %12s %12s %12s  (stalled: a chattering contact)\n", label, "-", "-", "-");
    else
      std::printf("%-22s %12.3f %12.3f %12.1e\n", label, o.up, o.down, o.error);
    if (o.error <= 1e-6) best = std::min(best, o.up + o.down);
  }
  // The jump: where the up sweep's amplitude changes most between neighbours.
  std::size_t jump = 0;
  for (std::size_t i = 1; i < ref_up.size(); ++i)
    if (std::abs(ref_up[i] - ref_up[i - 1]) > std::abs(ref_up[jump + 1] - ref_up[jump]))
      jump = i - 1;
  std::printf("up sweep's largest jump between Omega = %.4f and %.4f\n", omegas(true)[jump],
              omegas(true)[jump + 1]);
  std::printf("odeint within 1e-6 / geardyn exact, both directions: %.1f\n",
              best / (geardyn_t.up + geardyn_t.down));
  return 0;
}
