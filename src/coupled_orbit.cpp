#include "geardyn/coupled_orbit.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "geardyn/model.hpp"
#include "shooting.hpp"

namespace geardyn {
namespace {

// The unknowns' scale (coupled_orbit.hpp): b for metres, b / R_b1 for radians, rates times w_n.
ode::Vector coupled_orbit_scale(const CoupledParameters& p, double natural_rad_s) {
  const Eigen::Index n = p.size();
  ode::Vector scale(2 * n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const std::string name = to_string(p.coordinates[j]);
    const bool angle = name.size() > 4 && name.compare(name.size() - 4, 4, "_rad") == 0;
    scale[j] = angle ? p.backlash_m / p.base_radius_m[0] : p.backlash_m;
    scale[n + j] = scale[j] * natural_rad_s;
  }
  return scale;
}

}  // namespace

CoupledOrbit find_coupled_orbit(const Case& c, const OrbitOptions& options,
                                const std::optional<ode::Vector>& start) {
  if (c.model.form != ModelForm::kCoupled)
    throw InputError("find_coupled_orbit: the case's model.form is not \"coupled\"");
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  const int segments = options.segments > 0 ? options.segments : options.periods;
  Case engine_case = c;
  engine_case.solver.method = Method::kExact;
  engine_case.solver.tolerance =
      std::min(c.solver.tolerance, options.tolerance * detail::kEngineToleranceFraction);
  const CoupledSolver solver(engine_case);
  const CoupledParameters& p = solver.model().parameters();
  const Eigen::Index n2 = 2 * p.size();
  const GearPairParameters pair = build_model(gear_pair_of(c)).parameters();

  CoupledOrbit orbit;
  orbit.coordinates = p.coordinates;
  orbit.periods = options.periods;
  orbit.segments = segments;
  orbit.system_period_s = system_period_s(pair);
  orbit.period_s = options.periods * orbit.system_period_s;
  const double period = orbit.period_s;
  const detail::Segments shooting(
      [&](int i, const ode::Vector& y) {
        return solver.advance_with_jacobian(period * i / segments, y, period * (i + 1) / segments);
      },
      segments, coupled_orbit_scale(p, pair.natural_angular_frequency_rad_s()));

  // The first guess: the start state, or the settled simulation's, on the section.
  ode::Vector y0;
  if (start) {
    if (start->size() != n2)
      throw InputError(fmt::format(
          "--state: {} values given; this coupled case takes {} (its {} coordinates, then their "
          "rates, SI)",
          start->size(), n2, p.size()));
    y0 = *start;
  } else {
    y0 = solver.initial_state(c.solver.initial);
    if (options.settle_periods > 0) {
      const ode::FlowResult settled =
          solver.advance(0.0, y0, options.settle_periods * orbit.system_period_s);
      if (!settled.ok()) {
        orbit.message = fmt::format("the settling simulation failed ({}): {}",
                                    ode::to_string(settled.termination), settled.message);
        return orbit;
      }
      y0 = settled.state;
    }
  }
  ode::Vector x;
  std::string why;
  if (!shooting.guess(y0, x, why)) {
    orbit.message = why;
    return orbit;
  }
  const detail::NewtonOutcome newton = detail::solve_periodic(shooting, x, options);
  orbit.iterations = newton.iterations;
  orbit.residual = newton.residual;
  if (!newton.converged) {
    orbit.message = newton.message;
    return orbit;
  }
  orbit.state = shooting.state(x, 0);
  detail::floquet(newton.jacobians, orbit.monodromy, orbit.multipliers);
  orbit.stable = orbit.max_multiplier() < 1.0;
  // One period read: nothing counts as "sustained" (final_from = the period's end).
  orbit.reading = solver.read(0.0, orbit.state, period, ode::OutputGrid{}, period);
  if (!orbit.reading.ok()) {
    orbit.message = fmt::format("reading the orbit failed ({}): {}",
                                ode::to_string(orbit.reading.termination), orbit.reading.message);
    return orbit;
  }
  orbit.converged = true;
  orbit.message = newton.message;
  return orbit;
}

std::string coupled_orbit_json(const CoupledOrbit& o, int indent) {
  nlohmann::json j = detail::periodic_json(o);
  j["model"] = "coupled";
  nlohmann::json coords = nlohmann::json::array();
  for (Coordinate x : o.coordinates) coords.push_back(to_string(x));
  j["coordinates"] = coords;
  j["state"] = std::vector<double>(o.state.data(), o.state.data() + o.state.size());
  const CoupledRunResult& r = o.reading;
  const double b = r.parameters.backlash_m, bk = b * r.parameters.stiffness_n_per_m.offset;
  const bool read = o.converged;
  j["impacts_per_period"] = r.mesh.impacts;
  j["backside_impacts_per_period"] = r.mesh.backside_impacts;
  j["separations_per_period"] = r.mesh.separations;
  const auto number = [&](double v) { return read ? nlohmann::json(v) : nlohmann::json(nullptr); };
  j["min_delta_bar"] = number(read ? r.min_deflection_m / b : 0);
  j["max_delta_bar"] = number(read ? r.max_deflection_m / b : 0);
  j["min_force_bar"] = number(read ? r.min_force_n / bk : 0);
  j["max_force_bar"] = number(read ? r.max_force_n / bk : 0);
  nlohmann::json bearings = nlohmann::json::array();
  for (int i = 0; i < 2; ++i)
    bearings.push_back({{"gear", i + 1},
                        {"impacts_per_period", r.bearing[i].impacts},
                        {"separations_per_period", r.bearing[i].separations},
                        {"max_line_force_n", number(r.max_bearing_force_n[i])}});
  j["bearings"] = bearings;
  return j.dump(indent);
}

}  // namespace geardyn
