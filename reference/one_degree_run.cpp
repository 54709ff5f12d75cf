// The one-degree model's own run (one_degree_run.hpp): its solver (the exact engine, dopri5 or
// Newmark-beta on the model's state), its start state, and the run integrated once with its
// steady part found on the way.
#include "geardyn/one_degree_run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <optional>

#include "geardyn/steady.hpp"

namespace geardyn {

Solver::Solver(const GearPairModel& model, const SolverData& s, double period_s)
    : model_(model), s_(s) {
  const GearPairParameters& p = model.parameters();
  switch (s.method) {
    case Method::kNewmark: {
      const double wanted = s.time_step_s > 0 ? s.time_step_s : automatic_time_step_s(p);
      // An integer number of steps fits the period (or the window).
      dt_ = period_s > 0 ? period_s / std::max(1.0, std::ceil(period_s / wanted - 1e-9)) : wanted;
      break;
    }
    case Method::kExact: {
      ode::EngineOptions o;
      o.tolerance = std::max(ode::kRoundingLimit, s.tolerance * kExactToleranceFraction);
      try {
        engine_ = std::make_unique<ode::ExactEngine>(model.linear_system(), o);
      } catch (const std::invalid_argument& e) {
        throw InputError(std::string("solver.method = \"exact\": ") + e.what());
      }
      break;
    }
    case Method::kDopri5:
      break;
  }
}

Solver::~Solver() = default;

ode::IntegrationSummary Solver::run(const ode::State& initial, double t1,
                                    const ode::OutputGrid& grid, RunReader& reader,
                                    CellExtremes* extremes) const {
  switch (s_.method) {
    case Method::kNewmark:
      return ode::integrate_newmark(model_, initial, t1, dt_, grid, reader);
    case Method::kDopri5:
      return ode::integrate_dopri5(model_, initial, t1, grid, reader, dopri5_options());
    case Method::kExact:
      break;
  }
  std::optional<CellExtremes> own;
  if (!extremes) extremes = &own.emplace(model_, reader, *engine_);
  RunFlowObserver observer(model_, reader, grid, *extremes);
  const ode::FlowResult flow =
      engine_->flow(initial.t, to_vector(initial), initial.region - GearPairModel::kFirstRegion, t1,
                    grid, observer);
  if (own) own->finish();
  return summary(flow);
}

ode::Dopri5Options Solver::dopri5_options() const {
  const GearPairParameters& p = model_.parameters();
  ode::Dopri5Options o;
  o.relative_tolerance = s_.tolerance;
  o.absolute_tolerance = s_.tolerance * p.backlash_m;
  o.initial_step_s = fastest_period_s(p) * 1e-4;
  return o;
}

ode::Vector Solver::to_vector(const ode::State& s) {
  ode::Vector y(2);
  y << s.q, s.v;
  return y;
}

ode::IntegrationSummary Solver::summary(const ode::FlowResult& f) const {
  const GearPairParameters& p = model_.parameters();
  ode::IntegrationSummary sum;
  sum.termination = f.termination;
  sum.message = f.message;
  sum.steps = f.cells;
  sum.transitions = f.events;
  sum.end_time_s = f.end_time_s;
  const int region = f.region + GearPairModel::kFirstRegion;
  const double q = f.state[0], v = f.state[1];
  sum.end_state = {
      f.end_time_s, q, v,
      model_.force(model_.drive(f.end_time_s), q, v, region).value / p.equivalent_mass_kg, region};
  return sum;
}

namespace {
// An observer of the steppers that looks at nothing.
struct Unread {
  void on_step(const ode::State&, const GearPairModel::Drive&) {}
  void on_transition(const ode::State&, int) {}
  void on_sample(const ode::State&) {}
  bool on_progress(double) { return true; }
};
}  // namespace

ode::IntegrationSummary Solver::advance(const ode::State& initial, double t1) const {
  Unread unread;
  switch (s_.method) {
    case Method::kNewmark:
      return ode::integrate_newmark(model_, initial, t1, dt_, ode::OutputGrid{}, unread);
    case Method::kDopri5: {
      return ode::integrate_dopri5(model_, initial, t1, ode::OutputGrid{}, unread,
                                   dopri5_options());
    }
    case Method::kExact:
      break;
  }
  ode::FlowObserver nothing;
  return summary(engine_->flow(initial.t, to_vector(initial),
                               initial.region - GearPairModel::kFirstRegion, t1, ode::OutputGrid{},
                               nothing));
}

ode::State initial_state(const Case& c, const GearPairModel& model, double t0_s) {
  const GearPairParameters& p = model.parameters();
  ode::State s{t0_s, 0.0, 0.0, 0.0, kSeparated};
  if (c.solver.initial == InitialCondition::kStatic) {
    const double cb2 = p.cos_base_helix * p.cos_base_helix;
    const double sign = p.mean_force_n() >= 0 ? 1.0 : -1.0;
    s.q = sign * p.backlash_m + p.mean_force_n() / (cb2 * p.mean_stiffness_n_per_m());
  }
  s.region = model.classify(model.drive(t0_s), s.q, s.v);
  return s;
}

namespace {

// A run over [initial.t, t1] integrated once: `reader` reads the whole of it while the response
// is followed on the section t = t0 + k T0 until steady (steady.hpp, to kSteadyTolerance, leaving
// at least one period to read), and reads the steady part from there in the same pass (a mark,
// RunReader::mark); without a steady state, the final half (kSteadyFraction), marked at its
// start (integrate_watching). Until then the run is integrated a period at a time, so that the
// section states are the integrator's own; the pieces' samples are the grid's, bit for bit.
struct OnePass {
  ode::IntegrationSummary integration;
  SteadyPart steady;  // its reading is valid only when the integration completed
  double time_step_s = 0;
};

OnePass integrate_once(const Case& c, const GearPairModel& model, const ode::State& initial,
                       double t1, const ode::OutputGrid& grid, RunReader& reader) {
  OnePass out;
  const GearPairParameters& p = model.parameters();
  double period = 0;
  try {
    period = section_period_s(p);
  } catch (const InputError&) {
    period = 0;  // no common period: aperiodic
  }
  const Solver solver(model, c.solver, period > 0 ? period : t1 - initial.t);
  out.time_step_s = solver.time_step_s();
  reader.reserve_samples(static_cast<std::size_t>(std::max<std::int64_t>(0, grid.count)));

  // One deferred search of the cells' extremes for the pieces between two marks.
  std::optional<CellExtremes> extremes;
  if (solver.engine()) extremes.emplace(model, reader, *solver.engine());
  CellExtremes* deferred = extremes ? &*extremes : nullptr;
  SectionSeries sections(p.backlash_m, p.natural_angular_frequency_rad_s(), c.solver.tolerance);
  ode::State s = initial;
  std::int64_t sampled = 0;  // grid samples emitted
  ode::IntegrationSummary& total = out.integration;
  const auto judge = [&] {
    sections.add(s);
    return sections.judge(kSteadyTolerance);
  };
  const auto advance = [&](double stop) {
    const std::int64_t until = stop < t1 ? grid.count_until(stop) : grid.count;
    const ode::IntegrationSummary piece =
        solver.run(s, stop, grid.stretch(sampled, std::max(until, sampled)), reader, deferred);
    sampled = std::max(until, sampled);
    total.termination = piece.termination;
    total.message = piece.message;
    total.steps += piece.steps;
    total.transitions += piece.transitions;
    total.unsplit_steps += piece.unsplit_steps;
    total.end_time_s = piece.end_time_s;
    total.end_state = piece.end_state;
    if (!piece.ok()) return false;
    s = piece.end_state;
    // A piece may be shorter than the integrators' interval between progress calls.
    if (stop < t1 && !reader.on_progress(stop)) {
      total.termination = ode::Termination::kCancelled;
      total.message = fmt::format("cancelled at t = {:.9g} s", stop);
      return false;
    }
    return true;
  };
  const auto mark = [&](double t) {
    if (deferred) deferred->finish();  // the stretches before t belong to the whole alone
    reader.mark(t);
  };
  const SteadyStart start = integrate_watching(initial.t, t1, period, judge, advance, mark);
  if (deferred) deferred->finish();
  static_cast<SteadyStart&>(out.steady) = start;
  if (start.marked) out.steady.reading = reader.part_reading();
  return out;
}

}  // namespace

RunResult run_one_degree_model(const Case& c, const RunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  RunResult result;
  const GearPairModel model = begin_pair_run(c, options.stiffness, result);
  Derived& d = result.derived;
  const double t0 = 0.0, t1 = c.solver.duration_s;
  const ode::OutputGrid grid = ode::make_output_grid(t0, t1, d.output_interval_s);

  const ode::State initial = initial_state(c, model, t0);
  RunReader reader(model, t0, t1, c.solver.final_fraction, options.keep_events,
                   options.keep_samples, options.progress);
  OnePass pass = integrate_once(c, model, initial, t1, grid, reader);
  result.integration = std::move(pass.integration);
  d.time_step_s = pass.time_step_s;
  result.reading = reader.reading();
  if (result.integration.ok()) refuse_non_finite(result.reading, result.integration);
  result.events = reader.events();
  result.samples = std::move(reader.samples());
  if (result.integration.ok()) result.steady = pass.steady;
  result.steady_start_s =
      result.integration.ok() ? result.steady.from_s : t1 - kSteadyFraction * (t1 - t0);
  if (options.keep_samples) compute_spectra(result);
  result.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace geardyn
