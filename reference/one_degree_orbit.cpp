// The one-degree model's own periodic orbits (one_degree_orbit.hpp): its multiple shooting on
// the exact engine, the orbit found from a settled start, and the flow's sensitivities.
#include "geardyn/one_degree_orbit.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <vector>

#include "geardyn/case_keys.hpp"
#include "one_degree_shooting.hpp"

namespace geardyn {
namespace {

SolverData exact_solver(const Case& c, double engine_tolerance) {
  SolverData sd = c.solver;
  sd.method = Method::kExact;
  sd.tolerance = engine_tolerance;
  return sd;
}

}  // namespace

namespace detail {

ode::Vector orbit_scale(const GearPairModel& model) {
  const GearPairParameters& p = model.parameters();
  ode::Vector scale(2);
  scale << p.backlash_m, p.backlash_m * p.natural_angular_frequency_rad_s();
  return scale;
}

Shooting::Shooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                   double engine_tolerance, const MeshStiffness* stiffness)
    : model_(build_model(c, nullptr, stiffness)),
      solver_(model_, exact_solver(c, engine_tolerance)),
      system_period_s_(geardyn::system_period_s(model_.parameters())),
      period_s_(periods * system_period_s_),
      segments_([this](int i, const ode::Vector& y) { return flow(i, y); }, segments,
                scale.size() == 2 ? scale : orbit_scale(model_)) {}

ode::FlowResult Shooting::flow(int i, const ode::Vector& y) const {
  const int m = segments_.segments();
  const double t0 = period_s_ * i / m, t1 = period_s_ * (i + 1) / m;
  const int region = model_.classify(model_.drive(t0), y[0], y[1]);
  ode::FlowObserver nothing;
  return solver_.engine()->flow(t0, y, region - GearPairModel::kFirstRegion, t1, ode::OutputGrid{},
                                nothing, true);
}

bool Shooting::read(const ode::Vector& x, const std::vector<ode::Matrix>& segment_jacobians,
                    Orbit& orbit, std::string& why) const {
  orbit.system_period_s = system_period_s_;
  orbit.period_s = period_s_;
  orbit.segments = segments_.segments();
  floquet(segment_jacobians, orbit.monodromy, orbit.multipliers);
  orbit.stable = orbit.max_multiplier() < 1.0;

  const ode::Vector y0 = state(x, 0);
  const GearPairModel::Drive d0 = model_.drive(0);
  const int region = model_.classify(d0, y0[0], y0[1]);
  orbit.state = {0.0, y0[0], y0[1], model_.force(d0, y0[0], y0[1], region).value / model_.mass(),
                 region};
  RunReader reader(model_, 0.0, period_s_, 1.0, true, false);
  const auto r = solver_.run(orbit.state, period_s_, ode::OutputGrid{}, reader);
  if (!r.ok()) {
    why =
        fmt::format("reading the orbit failed ({}): {}", ode::to_string(r.termination), r.message);
    return false;
  }
  orbit.sequence = reader.events();
  orbit.reading = reader.reading();
  return true;
}

}  // namespace detail

FlowSensitivity flow_sensitivity(const Case& c, const ode::State& y0, double t1_s,
                                 const std::string& key) {
  auto flow = [&](const Case& cc, bool jacobian) {
    const GearPairModel model = build_model(cc);
    const Solver solver(model, exact_solver(cc, cc.solver.tolerance));
    ode::Vector y(2);
    y << y0.q, y0.v;
    ode::FlowObserver nothing;
    const int region = model.classify(model.drive(y0.t), y0.q, y0.v);
    ode::FlowResult r = solver.engine()->flow(y0.t, y, region - GearPairModel::kFirstRegion, t1_s,
                                              ode::OutputGrid{}, nothing, jacobian);
    if (!r.ok())
      throw std::runtime_error(fmt::format("flow_sensitivity: the flow failed ({}): {}",
                                           ode::to_string(r.termination), r.message));
    return r;
  };
  const ode::FlowResult nominal = flow(c, true);
  FlowSensitivity s;
  s.state = nominal.state;
  s.d_state = *nominal.jacobian;
  s.events = nominal.events;
  if (key.empty()) return s;
  // The key's value: read back from the case written as TOML (in the case file's units).
  const toml::table t = toml::parse(to_toml(c));
  const std::optional<double> p = t.at_path(key).value<double>();
  if (!p)
    throw InputError(
        fmt::format("flow_sensitivity: {} is not a numeric key of this case (a number, or an "
                    "element of an array such as model.stiffness_harmonics[0][0])",
                    key));
  const double h = kKeyStep * (*p != 0 ? std::abs(*p) : 1.0);
  ode::Vector d[2];
  for (int k = 0; k < 2; ++k) {
    const double step = (k + 1) * h;
    Case plus = c, minus = c;
    set_case_value(plus, {key, fmt::format("{:.17g}", *p + step)});
    set_case_value(minus, {key, fmt::format("{:.17g}", *p - step)});
    const ode::FlowResult fp = flow(plus, false), fm = flow(minus, false);
    if (fp.events != nominal.events || fm.events != nominal.events)
      throw std::runtime_error(fmt::format(
          "flow_sensitivity: {} contact events at {} = {:.17g}, {} and {} at +-{:.3g}: a grazing "
          "within the step, where the flow is not differentiable in the key",
          nominal.events, key, *p, fp.events, fm.events, step));
    d[k] = (fp.state - fm.state) / (2 * step);
  }
  s.key_step = h;
  s.d_key = (4 * d[0] - d[1]) / 3;
  s.d_key_error = (d[0] - d[1]).lpNorm<Eigen::Infinity>() / 3;
  return s;
}

Orbit find_one_degree_orbit(const Case& c, const OrbitOptions& options,
                            const std::optional<ode::State>& start) {
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  const int segments = options.segments > 0 ? options.segments : options.periods;
  const double engine_tolerance =
      std::min(c.solver.tolerance, options.tolerance * detail::kEngineToleranceFraction);
  const detail::Shooting shooting(c, options.periods, segments, ode::Vector{}, engine_tolerance);
  Orbit orbit;
  orbit.system_period_s = shooting.system_period_s();
  orbit.periods = options.periods;
  orbit.period_s = shooting.period_s();
  orbit.segments = segments;

  // The first guess: the start state, or the settled simulation's, on the section.
  ode::State s0 = start ? *start : initial_state(c, shooting.model());
  if (!start && options.settle_periods > 0) {
    const auto settled =
        shooting.solver().advance(s0, options.settle_periods * orbit.system_period_s);
    if (!settled.ok()) {
      orbit.message = detail::settling_failed(settled.termination, settled.message);
      return orbit;
    }
    s0 = settled.end_state;
  }
  ode::Vector y0(2);
  y0 << s0.q, s0.v;
  // Without settling, the start given (or the case's) is the one start.
  const auto next = [&](ode::Vector& y, std::string& why) {
    const auto later = shooting.solver().advance(s0, s0.t + orbit.period_s);
    if (!later.ok()) {
      why = detail::settling_failed(later.termination, later.message);
      return false;
    }
    s0 = later.end_state;
    y.resize(2);
    y << s0.q, s0.v;
    return true;
  };
  detail::find_periodic(shooting, y0, options, start || options.settle_periods == 0, next, orbit);
  return orbit;
}

}  // namespace geardyn
