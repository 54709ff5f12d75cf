#include "geardyn/coupled_orbit.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "geardyn/model.hpp"
#include "studies/shooting.hpp"

namespace geardyn {
namespace detail {

// The coupled model's counterpart of Shooting: one case value, its exact engine (the case's
// solver with method "exact" at engine_tolerance) and the residual of M segments over T = N T0.
// Not copyable (the flow refers to the solver).
class CoupledShooting {
 public:
  // `scale` and `stiffness` as for Shooting (empty scale: coupled_orbit_scale of this case;
  // without a stiffness the case's is computed once for the pair and the solver). Throws
  // InputError.
  CoupledShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                  double engine_tolerance, const MeshStiffness* stiffness = nullptr);
  CoupledShooting(const CoupledShooting&) = delete;
  CoupledShooting& operator=(const CoupledShooting&) = delete;

  const CoupledSolver& solver() const { return solver_; }
  double system_period_s() const { return system_period_s_; }
  double period_s() const { return period_s_; }
  const Segments& shooting() const { return segments_; }

  // Fills an orbit's coordinates, section state, monodromy, multipliers, stability and reading
  // (one period flown and read). False with `why` when that flow fails.
  bool read(const ode::Vector& x, const std::vector<ode::Matrix>& segment_jacobians,
            CoupledOrbit& orbit, std::string& why) const;

 private:
  CoupledShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                  double engine_tolerance, const MeshStiffness& stiffness);
  CoupledShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                  double engine_tolerance, const MeshStiffness& stiffness,
                  const GearPairParameters& pair);
  CoupledSolver solver_;
  int periods_;
  double system_period_s_, period_s_;
  Segments segments_;
};

// The coupled model's unknowns' scale: b for a coordinate in m, b / R_b1 for one in rad, a
// rate by the same times the one-degree contact natural frequency w_n.
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

CoupledShooting::CoupledShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                                 double engine_tolerance, const MeshStiffness* stiffness)
    : CoupledShooting(c, periods, segments, scale, engine_tolerance,
                      stiffness ? *stiffness : case_stiffness(c)) {}

CoupledShooting::CoupledShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                                 double engine_tolerance, const MeshStiffness& stiffness)
    : CoupledShooting(c, periods, segments, scale, engine_tolerance, stiffness,
                      build_model(gear_pair_of(c), nullptr, &stiffness).parameters()) {}

CoupledShooting::CoupledShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                                 double engine_tolerance, const MeshStiffness& stiffness,
                                 const GearPairParameters& pair)
    : solver_(exact_case(c, engine_tolerance), &stiffness),
      periods_(periods),
      system_period_s_(geardyn::system_period_s(pair)),
      period_s_(periods * system_period_s_),
      segments_(
          [this](int i, const ode::Vector& y) {
            const int m = segments_.segments();
            return solver_.advance_with_jacobian(period_s_ * i / m, y, period_s_ * (i + 1) / m);
          },
          segments,
          scale.size() > 0 ? scale
                           : coupled_orbit_scale(solver_.model().parameters(),
                                                 pair.natural_angular_frequency_rad_s())) {}

bool CoupledShooting::read(const ode::Vector& x, const std::vector<ode::Matrix>& segment_jacobians,
                           CoupledOrbit& orbit, std::string& why) const {
  orbit.coordinates = solver_.model().parameters().coordinates;
  orbit.periods = periods_;
  orbit.segments = segments_.segments();
  orbit.system_period_s = system_period_s_;
  orbit.period_s = period_s_;
  floquet(segment_jacobians, orbit.monodromy, orbit.multipliers);
  orbit.stable = orbit.max_multiplier() < 1.0;
  orbit.state = segments_.state(x, 0);
  // One period read: nothing counts as "sustained" (final_from = the period's end).
  orbit.reading = solver_.read(0.0, orbit.state, period_s_, ode::OutputGrid{}, period_s_);
  if (!orbit.reading.ok()) {
    why = fmt::format("reading the orbit failed ({}): {}",
                      ode::to_string(orbit.reading.termination), orbit.reading.message);
    return false;
  }
  return true;
}

}  // namespace detail

CoupledOrbit find_coupled_orbit(const Case& c, const OrbitOptions& options,
                                const std::optional<ode::Vector>& start) {
  if (c.model.form != ModelForm::kCoupled)
    throw InputError("find_coupled_orbit: the case's model.form is not \"coupled\"");
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  const int segments = options.segments > 0 ? options.segments : options.periods;
  const detail::CoupledShooting shooting(
      c, options.periods, segments, ode::Vector{},
      std::min(c.solver.tolerance, options.tolerance * detail::kEngineToleranceFraction));
  const CoupledSolver& solver = shooting.solver();
  const Eigen::Index n = solver.model().parameters().size();

  CoupledOrbit orbit;
  orbit.coordinates = solver.model().parameters().coordinates;
  orbit.periods = options.periods;
  orbit.segments = segments;
  orbit.system_period_s = shooting.system_period_s();
  orbit.period_s = shooting.period_s();
  // The first guess: the start state, or the settled simulation's, on the section.
  ode::Vector y0;
  if (start) {
    if (start->size() != 2 * n)
      throw InputError(fmt::format(
          "--state: {} value{} given; this coupled case takes {} (its {} coordinates, then "
          "their rates, SI)",
          start->size(), start->size() == 1 ? "" : "s", 2 * n, n));
    y0 = *start;
  } else {
    y0 = solver.initial_state(c.solver.initial);
    if (options.settle_periods > 0) {
      const ode::FlowResult settled =
          solver.advance(0.0, y0, options.settle_periods * orbit.system_period_s);
      if (!settled.ok()) {
        orbit.message = detail::settling_failed(settled.termination, settled.message);
        return orbit;
      }
      y0 = settled.state;
    }
  }
  // Without settling, the start given (or the case's) is the one start.
  const auto next = [&](ode::Vector& y, std::string& why) {
    const ode::FlowResult later = solver.advance(0.0, y0, orbit.period_s);
    if (!later.ok()) {
      why = detail::settling_failed(later.termination, later.message);
      return false;
    }
    y = y0 = later.state;
    return true;
  };
  detail::find_periodic(shooting, y0, options, start || options.settle_periods == 0, next, orbit);
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
