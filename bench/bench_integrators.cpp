// Newmark's and dopri5's speed on the paper's default case (Table 1, Fig. 4(c)): steps per
// second for Newmark (the automatic step and a fine step, decimated output) and dopri5; and the
// time of the energy-method stiffness over one mesh cycle. The exact engine is measured by time
// to accuracy instead (work_precision.cpp, ks_sweep.cpp).
//
//   ./build/release/bench/bench_integrators
#include <benchmark/benchmark.h>

#include "geardyn/run.hpp"
#include "geardyn/stiffness.hpp"

namespace {

void run_case(benchmark::State& state, geardyn::Case c) {
  std::int64_t steps = 0;
  for (auto _ : state) {
    const geardyn::RunResult r = geardyn::run(c);
    benchmark::DoNotOptimize(r.reading.max_force_bar);
    steps += r.integration.steps;
  }
  state.counters["steps_per_s"] =
      benchmark::Counter(static_cast<double>(steps), benchmark::Counter::kIsRate);
}

void BM_NewmarkDefaultCase(benchmark::State& state) {
  geardyn::Case c;
  c.solver.method =
      geardyn::Method::kNewmark;  // 0.05 s, automatic step, 5000 samples, constant stiffness
  c.mesh.stiffness_source = geardyn::StiffnessSource::kHarmonics;
  run_case(state, c);
}
BENCHMARK(BM_NewmarkDefaultCase)->Unit(benchmark::kMillisecond);

void BM_NewmarkFineStepDecimated(benchmark::State& state) {
  geardyn::Case c;
  c.solver.method = geardyn::Method::kNewmark;
  c.mesh.stiffness_source = geardyn::StiffnessSource::kHarmonics;
  c.solver.time_step_s = 1e-9;  // 5e7 steps, 5000 samples
  run_case(state, c);
}
BENCHMARK(BM_NewmarkFineStepDecimated)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_NewmarkWithStiffnessHarmonics(benchmark::State& state) {
  geardyn::Case c;
  c.solver.method =
      geardyn::Method::kNewmark;  // the default: energy-method stiffness, two harmonics
  run_case(state, c);
}
BENCHMARK(BM_NewmarkWithStiffnessHarmonics)->Unit(benchmark::kMillisecond);

void BM_Dopri5DefaultCase(benchmark::State& state) {
  geardyn::Case c;
  c.solver.method = geardyn::Method::kDopri5;
  run_case(state, c);
}
BENCHMARK(BM_Dopri5DefaultCase)->Unit(benchmark::kMillisecond);

// The energy method over one mesh cycle: 256 positions by 64 slices (the default), and by 256.
void BM_EnergyMethodCycle(benchmark::State& state) {
  geardyn::Case c;
  c.mesh.stiffness_slices = static_cast<int>(state.range(0));
  const geardyn::Geometry g = geardyn::compute_geometry(c.gear);
  for (auto _ : state) {
    const geardyn::StiffnessCycle k = geardyn::energy_method_cycle(c, g);
    benchmark::DoNotOptimize(k.total_n_per_m.data());
  }
}
BENCHMARK(BM_EnergyMethodCycle)->Arg(64)->Arg(256)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
