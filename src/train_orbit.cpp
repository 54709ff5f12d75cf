#include "geardyn/train_orbit.hpp"

#include <fmt/format.h>

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
namespace {

// Counts each mesh's impacts (entries into contact from the backlash) along a flow.
class ImpactCounter : public ode::FlowObserver {
 public:
  explicit ImpactCounter(const train::Assembled& a)
      : a_(a), impacts_(a.train().meshes.size()), backside_(a.train().meshes.size()) {}
  void on_event(double /*t_s*/, const ode::Vector& /*y*/, int from, int to) override {
    const std::vector<int> s = a_.states(from), e = a_.states(to);
    for (std::size_t m = 0; m < s.size(); ++m)
      if (s[m] == 0 && e[m] != 0) {
        ++impacts_[m];
        if (e[m] < 0) ++backside_[m];
      }
  }
  const std::vector<std::int64_t>& impacts() const { return impacts_; }
  const std::vector<std::int64_t>& backside() const { return backside_; }

 private:
  const train::Assembled& a_;
  std::vector<std::int64_t> impacts_, backside_;
};

}  // namespace

TrainOrbit find_train_orbit(const Case& c, const OrbitOptions& options) {
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  const train::Assembled a = assembled_train(c);
  const train::Train& t = a.train();
  const int n = a.size();
  std::vector<Eigen::Index> free;  // indices into (theta, theta') of the unknowns
  std::vector<std::string> names;
  for (int i = 0; i < n; ++i)
    if (!a.prescribed(i)) free.push_back(i);
  if (static_cast<int>(free.size()) == n)
    throw InputError(with_origins(
        c,
        "model.form = \"train\": no body of this train has a prescribed speed, so the train "
        "turns freely and its periodic orbits form a family along that rotation; `geardyn "
        "orbit` takes trains with a [[train.speed]] (the others not yet)"));
  const std::size_t nf = free.size();
  for (std::size_t k = 0; k < nf; ++k) free.push_back(n + free[k]);
  for (const char* unit : {"_rad", "_rad_s"})
    for (std::size_t k = 0; k < nf; ++k)
      names.push_back(t.bodies[static_cast<std::size_t>(free[k])].name + unit);
  std::string why;
  const std::optional<double> t0_period = a.system_period_s(&why);
  if (!t0_period)
    throw InputError(with_origins(c, "the train has no periodic orbit to find: " + why));
  if (!(*t0_period > 0))
    throw InputError(
        with_origins(c, "nothing in the train varies in time: its one orbit is its static state"));

  // The unknowns' scale: b / (cos(beta_b) R) of each body's first mesh, the rates times the
  // highest natural frequency in contact.
  double w = 0;
  for (const train::TrainMode& m : train::modes(a))
    w = std::max(w, 2 * std::numbers::pi * m.frequency_hz);
  ode::Vector scale(static_cast<Eigen::Index>(free.size()));
  for (std::size_t k = 0; k < nf; ++k) {
    double angle = std::numeric_limits<double>::infinity();
    for (std::size_t m = 0; m < t.meshes.size(); ++m) {
      const double v = std::abs(a.mesh_vector(static_cast<int>(m))(free[k]));
      if (v > 0) angle = std::min(angle, t.meshes[m].backlash_m / v);
    }
    if (!std::isfinite(angle)) angle = 1e-3;  // a body joined by shafts alone: a milliradian
    scale(static_cast<Eigen::Index>(k)) = angle;
    scale(static_cast<Eigen::Index>(nf + k)) = angle * w;
  }

  ode::EngineOptions eo;
  eo.tolerance =
      std::max(ode::kRoundingLimit,
               std::min(c.solver.tolerance, options.tolerance * detail::kEngineToleranceFraction) *
                   kExactToleranceFraction);
  const ode::ExactEngine engine(a.linear_system(), eo);
  const int segments = options.segments > 0 ? options.segments : options.periods;
  const double period = options.periods * *t0_period, h = period / segments;
  // The full state of the unknowns at time ts: the prescribed bodies' from their prescription.
  const auto full = [&](double ts, const ode::Vector& z) {
    ode::Vector y = ode::Vector::Zero(2 * static_cast<Eigen::Index>(n));
    for (std::size_t k = 0; k < free.size(); ++k) y(free[k]) = z(static_cast<Eigen::Index>(k));
    a.prescribe(ts, y);
    return y;
  };
  const auto reduce = [&](const ode::Vector& y) {
    ode::Vector z(static_cast<Eigen::Index>(free.size()));
    for (std::size_t k = 0; k < free.size(); ++k) z(static_cast<Eigen::Index>(k)) = y(free[k]);
    return z;
  };
  const detail::Segments shooting(
      [&](int i, const ode::Vector& z) {
        const double ts = i * h;
        const ode::Vector y = full(ts, z);
        ode::FlowObserver nothing;
        ode::FlowResult r =
            engine.flow(ts, y, a.classify(ts, y), ts + h, ode::OutputGrid{}, nothing, true);
        // The free bodies' part: the prescribed ones' states do not depend on them.
        r.state = reduce(r.state);
        if (r.jacobian) {
          ode::Matrix j(static_cast<Eigen::Index>(free.size()),
                        static_cast<Eigen::Index>(free.size()));
          for (std::size_t p = 0; p < free.size(); ++p)
            for (std::size_t q = 0; q < free.size(); ++q)
              j(static_cast<Eigen::Index>(p), static_cast<Eigen::Index>(q)) =
                  (*r.jacobian)(free[p], free[q]);
          r.jacobian = j;
        }
        return r;
      },
      segments, scale);

  TrainOrbit orbit;
  orbit.coordinates = names;
  orbit.periods = options.periods;
  orbit.segments = segments;
  orbit.system_period_s = *t0_period;
  orbit.period_s = period;
  for (const train::Mesh& m : t.meshes) orbit.meshes.push_back(m.name);
  // The first guess: the case's start settled over whole system periods.
  ode::Vector y0 = ode::Vector::Zero(2 * static_cast<Eigen::Index>(n));
  if (c.solver.initial == InitialCondition::kStatic) {
    std::string no_static;
    const auto rest = static_state(a, &no_static, 0.0);
    if (!rest) throw InputError(with_origins(c, "solver.initial = \"static\": " + no_static));
    y0 = *rest;
  }
  a.prescribe(0.0, y0);
  if (options.settle_periods > 0) {
    ode::FlowObserver nothing;
    const double settle = options.settle_periods * *t0_period;
    const ode::FlowResult settled =
        engine.flow(0.0, y0, a.classify(0.0, y0), settle, ode::OutputGrid{}, nothing);
    if (!settled.ok()) {
      orbit.message = fmt::format("the settling simulation failed ({}): {}",
                                  ode::to_string(settled.termination), settled.message);
      return orbit;
    }
    y0 = settled.state;  // at a whole number of system periods: the section's phase
  }
  ode::Vector x;
  if (!shooting.guess(reduce(y0), x, why)) {
    orbit.message = why;
    return orbit;
  }
  const detail::NewtonOutcome newton = detail::solve_periodic(shooting, x, options);
  orbit.iterations = newton.iterations;
  orbit.residual = newton.residual;
  orbit.message = newton.message;
  if (!newton.converged) return orbit;
  detail::floquet(newton.jacobians, orbit.monodromy, orbit.multipliers);
  orbit.stable = orbit.max_multiplier() < 1;
  orbit.state = full(0.0, shooting.state(x, 0));
  // One period flown from the orbit: each mesh's impacts.
  ImpactCounter counter(a);
  const ode::FlowResult once = engine.flow(0.0, orbit.state, a.classify(0.0, orbit.state), period,
                                           ode::OutputGrid{}, counter);
  if (!once.ok()) {
    orbit.message = fmt::format("the orbit's period could not be flown ({}): {}",
                                ode::to_string(once.termination), once.message);
    return orbit;
  }
  orbit.impacts_per_period = counter.impacts();
  orbit.backside_impacts_per_period = counter.backside();
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
