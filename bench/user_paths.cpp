// The user's paths against the engine's own loop, measured in one program so that the ratios
// compare times of one machine at one moment.
//
// Runs: the paper's 11 cases over 20 ms with 2001 samples, the exact engine at tolerance 1e-3
// (its setting for 1e-6, bench/work_precision). Timed per case, the best of --repeat rounds in
// which every column runs once in turn (bench::best_times_interleaved):
//   - engine: the engine's loop alone, as bench/work_precision times it: the model built
//     outside the clock, the Solver (its cells) and a RunReader keeping the samples inside;
//   - run(): geardyn::run on the case, as `geardyn run` calls it: the case as its train of
//     elements (train_form_of), the whole reading per mesh, the events, the steady part (read in
//     the same pass), read back in the pair's terms, and the spectra;
//   - a study sample: geardyn::run with neither samples nor events kept (RunOptions), as a
//     study's run batch calls it;
//   - files: write_run of that result into a scratch folder (summary.json, timeseries.csv,
//     events.csv, case.toml);
//   - odeint: the plain Boost.Odeint program at 1e-9, its setting for 1e-6;
// With --one-degree, two more columns: the same run and study sample on the one-degree model's
// own reader (run_one_degree_model, the reference run() is checked against), and run() over it.
// Sweep: the Kahraman-Singh sweep of bench/ks_sweep (401 points up and down, 240 periods settled
// and 10 read a point at 64 samples a period, from static contact), through geardyn::sweep on
// one thread with the same settling (settle_periods = max_settle_periods = 240), against
// bench/ks_sweep's engine loop (build_model, Solver, advance 240 periods, read 10).
//
//   ./build/release/bench/user_paths [--repeat N] [--case ID] [--one-degree]
// --case times that paper case alone and skips the sweep (for a profiler).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string_view>
#include <vector>

#include "geardyn/one_degree_run.hpp"
#include "geardyn/output.hpp"
#include "geardyn/reproduce.hpp"
#include "geardyn/run.hpp"
#include "geardyn/sweep.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/validation.hpp"
#include "timing.hpp"
#include "user_odeint.hpp"

namespace {

constexpr double kWindowS = 0.02;
constexpr std::int64_t kSamples = 2001;
constexpr double kEngineTolerance = 1e-3;
constexpr double kOdeintTolerance = 1e-9;

// Out of line, so that a profiler can count it (callgrind --toggle-collect).
[[gnu::noinline]] double engine_loop(const geardyn::GearPairModel& model,
                                     const geardyn::SolverData& s) {
  const geardyn::ode::OutputGrid grid{0, kWindowS / (kSamples - 1), kSamples};
  geardyn::RunReader reader(model, 0, kWindowS, 0.1, true, true);
  const geardyn::Solver solver(model, s, kWindowS);
  const geardyn::ode::State initial{0, 0, 0, 0, geardyn::kSeparated};
  const auto sum = solver.run(initial, kWindowS, grid, reader);
  if (!sum.ok()) std::fprintf(stderr, "engine loop failed: %s\n", sum.message.c_str());
  return reader.samples().delta_bar.back();
}

// bench/ks_sweep's engine loop: one direction, the state carried from point to point.
constexpr int kSweepPoints = 401, kSettlePeriods = 240, kReadPeriods = 10, kPerPeriod = 64;

geardyn::Case ks_case(double omega) {
  geardyn::Case c = geardyn::kahraman_singh_case(omega);
  c.solver.method = geardyn::Method::kExact;
  c.solver.tolerance = kEngineTolerance;
  return c;
}

std::vector<double> ks_engine(bool up, geardyn::ode::State& carry) {
  std::vector<double> amplitudes;
  for (int i = 0; i < kSweepPoints; ++i) {
    const int j = up ? i : kSweepPoints - 1 - i;
    const double w = 0.5 + 1.0 * j / (kSweepPoints - 1);
    const geardyn::Case c = ks_case(w);
    const geardyn::GearPairModel model = geardyn::build_model(c);
    const geardyn::Solver solver(model, c.solver);
    const double T = 2 * std::numbers::pi / w;
    geardyn::ode::State start = carry;
    start.t = 0;
    const auto settled = solver.advance(start, kSettlePeriods * T);
    const double t0 = kSettlePeriods * T, t1 = t0 + kReadPeriods * T;
    const geardyn::ode::OutputGrid grid{t0, T / kPerPeriod,
                                        std::int64_t{kReadPeriods} * kPerPeriod};
    geardyn::RunReader reader(model, t0, t1, 0.1, false, true);
    const auto sum = solver.run(settled.end_state, t1, grid, reader);
    carry = sum.end_state;
    amplitudes.push_back(0.5 * (reader.max_delta_m() - reader.min_delta_m()));
  }
  return amplitudes;
}

geardyn::SweepResult ks_sweep() {
  geardyn::SweepOptions o;
  o.axis = {"model.omega", 0.5, 1.5, kSweepPoints};
  o.direction = geardyn::SweepDirection::kBoth;
  o.settle_periods = o.max_settle_periods = kSettlePeriods;
  o.measure_periods = kReadPeriods;
  o.samples_per_period = kPerPeriod;
  o.threads = 1;
  return geardyn::sweep(ks_case(1.0), o);
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  std::string_view only;
  bool with_one_degree = false;
  for (int i = 1; i < argc; ++i)
    if (std::string_view(argv[i]) == "--one-degree") with_one_degree = true;
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::string_view(argv[i]) == "--repeat") repeat = std::max(1, std::atoi(argv[i + 1]));
    if (std::string_view(argv[i]) == "--case") only = argv[i + 1];
  }
  const std::filesystem::path scratch =
      std::filesystem::temp_directory_path() / "geardyn_user_paths";
  std::filesystem::create_directories(scratch);

  std::printf("runs: 20 ms, %lld samples, exact engine at %g; ms, best of %d\n",
              static_cast<long long>(kSamples), kEngineTolerance, repeat);
  std::printf("%-8s %9s %9s %9s %9s %9s %12s", "case", "engine", "run()", "sample", "files",
              "odeint", "run/engine");
  if (with_one_degree) std::printf(" %9s %9s %12s", "1-dof", "its smpl", "run()/1-dof");
  std::printf("\n");
  // A row: the five columns and run() / engine, then the one-degree model's two and run() over it.
  const auto row = [&](const char* id, double engine, double run, double sample, double files,
                       double odeint, double one_degree, double one_degree_sample) {
    std::printf("%-8s %9.2f %9.2f %9.2f %9.2f %9.2f %12.2f", id, 1e3 * engine, 1e3 * run,
                1e3 * sample, 1e3 * files, 1e3 * odeint, run / engine);
    if (with_one_degree)
      std::printf(" %9.2f %9.2f %12.2f", 1e3 * one_degree, 1e3 * one_degree_sample,
                  run / one_degree);
    std::printf("\n");
  };
  double engine_sum = 0, run_sum = 0, sample_sum = 0, files_sum = 0, odeint_sum = 0,
         one_degree_sum = 0, one_degree_sample_sum = 0;
  for (const geardyn::StudyCase& sc : geardyn::park2010_study().cases) {
    if (!only.empty() && sc.id != only) continue;
    geardyn::Case c = sc.input;
    c.solver.duration_s = kWindowS;
    c.solver.output_interval_s = kWindowS / (kSamples - 1);
    c.solver.method = geardyn::Method::kExact;
    c.solver.tolerance = kEngineTolerance;
    c.solver.initial = geardyn::InitialCondition::kCenter;
    const geardyn::GearPairModel model = geardyn::build_model(c);
    geardyn::RunResult result = geardyn::run(c);
    geardyn::RunOptions study;
    study.keep_samples = study.keep_events = false;
    std::vector<double> times;
    for (std::int64_t k = 0; k < kSamples; ++k)
      times.push_back(kWindowS * static_cast<double>(k) / (kSamples - 1));
    const bench::UserModel um = bench::user_model(model.parameters());
    const std::vector<double> best = bench::best_times_interleaved(
        repeat, [&] { engine_loop(model, c.solver); }, [&] { result = geardyn::run(c); },
        [&] { geardyn::run(c, study); }, [&] { geardyn::write_run(scratch, result); },
        [&] { bench::user_odeint(um, kWindowS, times, kOdeintTolerance); },
        [&] {
          if (with_one_degree) geardyn::run_one_degree_model(c);
        },
        [&] {
          if (with_one_degree) geardyn::run_one_degree_model(c, study);
        });
    const double engine = best[0], run = best[1], sample = best[2], files = best[3],
                 odeint = best[4], one_degree = best[5], one_degree_sample = best[6];
    row(sc.id.c_str(), engine, run, sample, files, odeint, one_degree, one_degree_sample);
    one_degree_sum += one_degree;
    one_degree_sample_sum += one_degree_sample;
    engine_sum += engine;
    run_sum += run;
    sample_sum += sample;
    files_sum += files;
    odeint_sum += odeint;
  }
  row("all", engine_sum, run_sum, sample_sum, files_sum, odeint_sum, one_degree_sum,
      one_degree_sample_sum);
  std::filesystem::remove_all(scratch);
  if (!only.empty()) return 0;

  geardyn::SweepResult r;
  const std::vector<double> sweep_best = bench::best_times_interleaved(
      repeat,
      [&] {
        geardyn::ode::State carry{0, 1.1, 0, 0, geardyn::kDriveContact};  // static contact
        ks_engine(true, carry);
        ks_engine(false, carry);
      },
      [&] { r = ks_sweep(); });
  const double engine_sweep = sweep_best[0], user = sweep_best[1];
  std::printf("\nKahraman-Singh sweep, 401 points up and down, %d periods settled and %d read:\n",
              kSettlePeriods, kReadPeriods);
  std::printf("  engine loop (bench/ks_sweep) %.3f s, geardyn::sweep %.3f s (%zu points): %.2f\n",
              engine_sweep, user, r.points.size(), user / engine_sweep);
  return 0;
}
