#include "geardyn/train_orbit.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "geardyn/engine.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_run.hpp"
#include "shooting.hpp"

namespace geardyn {
namespace detail {

TrainShooting::TrainShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                             double engine_tolerance, const MeshStiffness* /*stiffness*/)
    : solver_(exact_case(c, engine_tolerance)),
      periods_(periods),
      segments_([this](int i, const ode::Vector& z) { return flow(i, z); }, segments,
                ode::Vector{}) {
  const train::Assembled& a = solver_.assembled();
  const train::Train& t = a.train();
  const int n = a.size();
  for (int i = 0; i < n; ++i)
    if (!a.prescribed(i)) free_.push_back(i);
  if (static_cast<int>(free_.size()) == n)
    throw InputError(with_origins(
        c,
        "model.form = \"train\": no body of this train has a prescribed speed, so the train "
        "turns freely and its periodic orbits form a family along that rotation; orbits and "
        "continuation take trains with a [[train.speed]] (the others not yet)"));
  const std::size_t nf = free_.size();
  for (std::size_t k = 0; k < nf; ++k) free_.push_back(n + free_[k]);
  for (const char* rate : {"", "_s"})
    for (std::size_t k = 0; k < nf; ++k)
      names_.push_back(a.coordinate_names()[static_cast<std::size_t>(free_[k])] + rate);
  std::string why;
  const std::optional<double> t0 = a.system_period_s(&why);
  if (!t0) throw InputError(with_origins(c, "the train has no periodic orbit to find: " + why));
  if (!(*t0 > 0))
    throw InputError(
        with_origins(c, "nothing in the train varies in time: its one orbit is its static state"));
  system_period_s_ = *t0;
  period_s_ = periods * *t0;
  if (scale.size() > 0) {
    segments_ =
        Segments([this](int i, const ode::Vector& z) { return flow(i, z); }, segments, scale);
    return;
  }
  // Each free coordinate by b / (cos(beta_b) R) of its body's first mesh, the rates times the
  // highest natural frequency in contact.
  const double w = solver_.top_frequency_rad_s();
  ode::Vector own(static_cast<Eigen::Index>(free_.size()));
  for (std::size_t k = 0; k < nf; ++k) {
    double angle = std::numeric_limits<double>::infinity();
    for (std::size_t m = 0; m < t.meshes.size(); ++m) {
      const double v = std::abs(a.mesh_vector(static_cast<int>(m))(free_[k]));
      if (v > 0) angle = std::min(angle, t.meshes[m].backlash_m / v);
    }
    if (!std::isfinite(angle)) {
      // A body joined by shafts alone: a milliradian; a centre no mesh moves: the least b.
      angle = 1e-3;
      if (free_[k] >= a.body_count())
        for (const train::Mesh& x : t.meshes) angle = std::min(angle, x.backlash_m);
    }
    own(static_cast<Eigen::Index>(k)) = angle;
    own(static_cast<Eigen::Index>(nf + k)) = angle * w;
  }
  segments_ = Segments([this](int i, const ode::Vector& z) { return flow(i, z); }, segments, own);
}

ode::Vector TrainShooting::full(double t_s, const ode::Vector& z) const {
  ode::Vector y = ode::Vector::Zero(2 * static_cast<Eigen::Index>(solver_.assembled().size()));
  for (std::size_t k = 0; k < free_.size(); ++k) y(free_[k]) = z(static_cast<Eigen::Index>(k));
  solver_.assembled().prescribe(t_s, y);
  return y;
}

ode::Vector TrainShooting::reduce(const ode::Vector& y) const {
  ode::Vector z(static_cast<Eigen::Index>(free_.size()));
  for (std::size_t k = 0; k < free_.size(); ++k) z(static_cast<Eigen::Index>(k)) = y(free_[k]);
  return z;
}

ode::FlowResult TrainShooting::flow(int i, const ode::Vector& z) const {
  const double h = period_s_ / segments_.segments(), ts = i * h;
  ode::FlowResult r = solver_.advance_with_jacobian(ts, full(ts, z), ts + h);
  // The free bodies' part: the prescribed ones' states do not depend on them.
  r.state = reduce(r.state);
  if (r.jacobian) {
    const auto f = static_cast<Eigen::Index>(free_.size());
    ode::Matrix j(f, f);
    for (Eigen::Index p = 0; p < f; ++p)
      for (Eigen::Index q = 0; q < f; ++q)
        j(p, q) =
            (*r.jacobian)(free_[static_cast<std::size_t>(p)], free_[static_cast<std::size_t>(q)]);
    r.jacobian = j;
  }
  return r;
}

bool TrainShooting::read(const ode::Vector& x, const std::vector<ode::Matrix>& segment_jacobians,
                         TrainOrbit& orbit, std::string& why) const {
  orbit.coordinates = names_;
  orbit.periods = periods_;
  orbit.segments = segments_.segments();
  orbit.system_period_s = system_period_s_;
  orbit.period_s = period_s_;
  orbit.meshes.clear();
  for (const train::Mesh& m : solver_.assembled().train().meshes) orbit.meshes.push_back(m.name);
  floquet(segment_jacobians, orbit.monodromy, orbit.multipliers);
  orbit.stable = orbit.max_multiplier() < 1;
  orbit.unknowns = segments_.state(x, 0);
  orbit.state = full(0.0, orbit.unknowns);
  // One period flown and read: nothing counts as "sustained" (final_from = the period's end).
  const TrainRunResult r =
      solver_.read(0.0, orbit.state, period_s_, ode::OutputGrid{}, period_s_, std::nullopt);
  if (!r.ok()) {
    why = fmt::format("the orbit's period could not be flown ({}): {}",
                      ode::to_string(r.termination), r.message);
    return false;
  }
  orbit.readings = r.meshes;
  orbit.impacts_per_period.clear();
  orbit.backside_impacts_per_period.clear();
  for (const TrainMeshReading& m : r.meshes) {
    orbit.impacts_per_period.push_back(m.impacts);
    orbit.backside_impacts_per_period.push_back(m.backside_impacts);
  }
  return true;
}

}  // namespace detail

TrainOrbit find_train_orbit(const Case& c, const OrbitOptions& options,
                            const std::optional<ode::Vector>& start) {
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  const int segments = options.segments > 0 ? options.segments : options.periods;
  const detail::TrainShooting shooting(
      c, options.periods, segments, ode::Vector{},
      std::min(c.solver.tolerance, options.tolerance * detail::kEngineToleranceFraction));
  TrainOrbit orbit;
  orbit.coordinates = shooting.coordinates();
  orbit.periods = options.periods;
  orbit.segments = segments;
  orbit.system_period_s = shooting.system_period_s();
  orbit.period_s = shooting.period_s();
  for (const train::Mesh& m : shooting.solver().assembled().train().meshes)
    orbit.meshes.push_back(m.name);
  // The first guess: the start given, or the case's start settled over whole system periods.
  ode::Vector z0;
  if (start) {
    const auto n = static_cast<Eigen::Index>(orbit.coordinates.size());
    if (start->size() != n)
      throw InputError(fmt::format(
          "the start state has {} values; this train takes {} (its free bodies' angles, then "
          "their rates, SI: {})",
          start->size(), n, fmt::join(orbit.coordinates, ", ")));
    z0 = *start;
  } else {
    ode::Vector y0 = shooting.solver().initial_state(c.solver.initial, 0.0);
    if (options.settle_periods > 0) {
      const ode::FlowResult settled =
          shooting.solver().advance(0.0, y0, options.settle_periods * orbit.system_period_s);
      if (!settled.ok()) {
        orbit.message = fmt::format("the settling simulation failed ({}): {}",
                                    ode::to_string(settled.termination), settled.message);
        return orbit;
      }
      y0 = settled.state;  // at a whole number of system periods: the section's phase
    }
    z0 = shooting.reduce(y0);
  }
  ode::Vector x;
  std::string why;
  if (!shooting.shooting().guess(z0, x, why)) {
    orbit.message = why;
    return orbit;
  }
  const detail::NewtonOutcome newton = detail::solve_periodic(shooting.shooting(), x, options);
  orbit.iterations = newton.iterations;
  orbit.residual = newton.residual;
  orbit.message = newton.message;
  if (!newton.converged) return orbit;
  if (!shooting.read(x, newton.jacobians, orbit, why)) {
    orbit.message = why;
    return orbit;
  }
  orbit.converged = true;
  return orbit;
}

std::string train_orbit_json(const TrainOrbit& o, int indent) {
  nlohmann::json j = detail::periodic_json(o);
  j["model"] = "train";
  j["coordinates"] = o.coordinates;
  j["state"] = std::vector<double>(o.state.data(), o.state.data() + o.state.size());
  nlohmann::json meshes = nlohmann::json::array();
  for (std::size_t m = 0; m < o.meshes.size(); ++m) {
    const bool read = o.converged;
    meshes.push_back(
        {{"name", o.meshes[m]},
         {"impacts_per_period",
          read ? nlohmann::json(o.impacts_per_period[m]) : nlohmann::json(nullptr)},
         {"backside_impacts_per_period",
          read ? nlohmann::json(o.backside_impacts_per_period[m]) : nlohmann::json(nullptr)}});
  }
  j["meshes"] = meshes;
  return j.dump(indent);
}

}  // namespace geardyn
