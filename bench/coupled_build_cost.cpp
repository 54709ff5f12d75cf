// What one residual of a coupled orbit costs, and where: building the model and its exact
// engine (CoupledSolver) with the case's own mesh stiffness and with one computed beforehand
// (a study whose key leaves the curve alone shares it: shared_stiffness), the first flow of
// one system period with its Jacobian on a model of the shared stiffness (the engine builds
// the cells of every region it enters), and the same flow again on the built cells, on the
// coupled model's own solver. A continuation builds a model at each value of the key it
// evaluates (docs/performance.md); since 236678c it builds the pair's train (TrainSolver), not
// this one.
//
//   coupled_build_cost [f1_hz]    (default 650; cases/park2010_coupled.toml, dof 12)
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>

#include "geardyn/case.hpp"
#include "geardyn/coupled_run.hpp"
#include "geardyn/run.hpp"
#include "timing.hpp"

int main(int argc, char** argv) {
  const double f1_hz = argc > 1 ? std::atof(argv[1]) : 650.0;
  const geardyn::Case c =
      geardyn::load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases/park2010_coupled.toml",
                         {{"speed.shaft_frequency_hz", fmt::format("{}", f1_hz)}});
  const double period_s = 1.0 / f1_hz;  // the torque's period: the system period
  geardyn::ode::Vector y;
  {
    const geardyn::CoupledSolver s(c);
    y = s.advance(0, s.initial_state(geardyn::InitialCondition::kCenter), 100 * period_s).state;
  }
  constexpr int kRepeat = 5;
  const double build = bench::best_time(kRepeat, [&] { const geardyn::CoupledSolver s(c); });
  const geardyn::MeshStiffness k = geardyn::case_stiffness(c);
  const double shared = bench::best_time(kRepeat, [&] { const geardyn::CoupledSolver s(c, &k); });
  const double first = bench::best_time(kRepeat, [&] {
    const geardyn::CoupledSolver s(c, &k);
    s.advance_with_jacobian(0, y, period_s);
  });
  const geardyn::CoupledSolver built(c);
  built.advance_with_jacobian(0, y, period_s);
  const double again =
      bench::best_time(kRepeat, [&] { built.advance_with_jacobian(0, y, period_s); });
  fmt::print(
      "f1 = {} Hz, dof 12: build {:.2f} ms, build on a shared stiffness {:.2f} ms, that and "
      "the first flow {:.2f} ms, flow on built cells {:.2f} ms (best of {})\n",
      f1_hz, 1e3 * build, 1e3 * shared, 1e3 * first, 1e3 * again, kRepeat);
}
