// The automatic time step, shown converged: for the paper's cases, the readings at k points per
// fastest period against dopri5 at a tolerance of 1e-12. Prints a Markdown table
// (docs/numerics.md).
//
//   ./build/release/bench/step_study
#include <cmath>
#include <cstdio>

#include "geardyn/run.hpp"

namespace {

struct Named {
  const char* name;
  geardyn::Case c;
};

geardyn::Case make(double f1_hz, double duration_s) {
  geardyn::Case c;
  c.speed.shaft_frequency_hz = f1_hz;
  c.solver.duration_s = duration_s;
  return c;
}

}  // namespace

int main() {
  const Named cases[] = {{"Fig. 4(a), 10 Hz, 0.1 s", make(10, 0.1)},
                         {"Fig. 4(c), 1 kHz, 0.05 s", make(1000, 0.05)},
                         {"Fig. 4(d), 10 kHz, 0.02 s", make(10000, 0.02)}};
  std::printf(
      "| case | points per period | dt (s) | impacts | last separation rel. error | "
      "max F_bar rel. error |\n|---|---|---|---|---|---|\n");
  for (const Named& n : cases) {
    geardyn::Case ref = n.c;
    ref.solver.method = geardyn::Method::kDopri5;
    ref.solver.tolerance = 1e-12;
    const geardyn::RunResult r_ref = geardyn::run(ref);
    std::printf("| %s | dopri5 1e-12 | - | %lld | - | - |\n", n.name,
                static_cast<long long>(r_ref.reading.impacts));
    const double period = geardyn::fastest_period_s(geardyn::build_model(n.c).parameters());
    for (double k : {50.0, 100.0, 200.0, 400.0, 800.0}) {
      geardyn::Case c = n.c;
      c.solver.time_step_s = period / k;
      const geardyn::RunResult r = geardyn::run(c);
      const double ls = *r.reading.last_separation_s, ls_ref = *r_ref.reading.last_separation_s;
      std::printf("| %s | %g%s | %.3g | %lld | %.2e | %.2e |\n", n.name, k,
                  k == geardyn::kStepsPerFastestPeriod ? " (automatic)" : "", c.solver.time_step_s,
                  static_cast<long long>(r.reading.impacts), std::abs(ls - ls_ref) / ls_ref,
                  std::abs(r.reading.max_force_bar - r_ref.reading.max_force_bar) /
                      r_ref.reading.max_force_bar);
    }
  }
}
