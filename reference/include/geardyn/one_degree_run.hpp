// geardyn: the one-degree model's own run (one_degree_run.cpp), a reference implementation in
// the geardyn_reference library (reference/): its integrator choice, start state and run, read
// by its own reader (one_degree_reader.hpp). No study goes through it: a pair's run is its
// train's (run.hpp); the tests, the benchmarks and `geardyn validate` hold that train to it.
#pragma once

#include <memory>

#include "geardyn/analysis.hpp"
#include "geardyn/case.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/model.hpp"
#include "geardyn/one_degree_reader.hpp"
#include "geardyn/run.hpp"

namespace geardyn {

// Integrates the one-degree model with a case's [solver] (method, tolerance, time step): its own
// run, its shooting and the validation's references call it. The exact engine's cells are
// computed once, at construction.
class Solver {
 public:
  // `period_s`, when > 0, makes the Newmark step divide it (a sweep's blocks end on period
  // ends). Throws InputError if the model cannot be put in the exact engine's form.
  Solver(const GearPairModel& model, const SolverData& s, double period_s = 0);
  ~Solver();

  // From `initial` to t1, samples on `grid`, read by `reader`. With the exact engine the
  // extremes inside its cells are searched at the end of the flow, or, given `extremes` (of
  // this solver's engine and `reader`), left to it: the caller's to finish, so that one search
  // serves several pieces of a run.
  ode::IntegrationSummary run(const ode::State& initial, double t1, const ode::OutputGrid& grid,
                              RunReader& reader, CellExtremes* extremes = nullptr) const;
  // From `initial` to t1 with nothing read (a settling phase): the end state and the outcome.
  ode::IntegrationSummary advance(const ode::State& initial, double t1) const;
  // The Newmark step actually taken (0 for the other methods).
  double time_step_s() const { return dt_; }
  const ode::ExactEngine* engine() const { return engine_.get(); }

 private:
  ode::Dopri5Options dopri5_options() const;
  static ode::Vector to_vector(const ode::State& s);
  ode::IntegrationSummary summary(const ode::FlowResult& f) const;

  const GearPairModel& model_;
  SolverData s_;
  double dt_ = 0;
  std::unique_ptr<ode::ExactEngine> engine_;
};

// The state a case starts from at t0_s (solver.initial: at rest mid-backlash, or in static
// contact), with its region.
ode::State initial_state(const Case& c, const GearPairModel& model, double t0_s = 0);

// A pair's run (run.hpp's run()) integrated on the one-degree model itself (model.hpp: its own
// reader, cells and closed-form extremes), kept as the independent reference that run()'s train is
// checked against (tests, docs/performance.md); its integration summary carries the end state.
RunResult run_one_degree_model(const Case& c, const RunOptions& options = {});

}  // namespace geardyn
