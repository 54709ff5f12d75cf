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
#include "geardyn/train_statics.hpp"
#include "studies/shooting.hpp"

namespace geardyn {
namespace detail {

TrainShooting::TrainShooting(const Case& c, int periods, int segments, const ode::Vector& scale,
                             double engine_tolerance, const MeshStiffness* stiffness)
    : solver_(exact_case(c, engine_tolerance), stiffness),
      periods_(periods),
      segments_([this](int i, const ode::Vector& z) { return flow(i, z); }, segments,
                ode::Vector{}) {
  const train::Assembled& a = solver_.assembled();
  const train::Train& t = a.train();
  const int n = a.size();
  for (int i = 0; i < n; ++i)
    if (!a.prescribed(i)) free_.push_back(i);
  // A train turns freely when one motion no element resists is left (rigid_motions(): the
  // rigid rotation of a train of meshes and shafts, a planetary set about its held ring).
  const Eigen::MatrixXd rigid = a.rigid_motions();
  if (rigid.cols() > 1)
    throw InputError(with_origins(
        c, fmt::format("the train has {} rigid motions no element resists (a planetary set with "
                       "no member held): its orbits are defined modulo one at most; hold a "
                       "member (a shaft to the ground) or prescribe a speed",
                       rigid.cols())));
  free_turning_ = rigid.cols() == 1;
  const int ref = a.index(t.reference);
  const Eigen::VectorXd r = free_turning_ ? Eigen::VectorXd(rigid.col(0)) : Eigen::VectorXd();
  if (free_turning_ && !(std::abs(r(ref)) > 0))
    throw InputError(with_origins(c,
                                  "the train's rigid motion leaves its reference at rest: "
                                  "choose a reference that turns with it"));
  const bool viscous = a.damps_rigid_motions();
  if (free_turning_) {
    // Modulo the rigid rotation: the reference's angle is 0, and its rate follows the momentum
    // unless a viscous drag damps it (the class's comment).
    std::string why;
    if (!static_state(a, &why))
      throw InputError(with_origins(c, "the train turns freely and has no periodic orbit: " + why));
    free_.erase(std::find(free_.begin(), free_.end(), ref));
  }
  // The rates: those of the free coordinates, and the reference's when a viscous drag makes the
  // rigid rate an unknown of a freely turning train.
  const std::size_t nf = free_.size();
  if (free_turning_ && viscous) free_.push_back(n + ref);
  for (std::size_t k = 0; k < nf; ++k) free_.push_back(n + free_[k]);
  // F and R: a selection, but for the rigid rotation of a freely turning train.
  const auto k = static_cast<Eigen::Index>(free_.size());
  const Eigen::Index dim = 2 * static_cast<Eigen::Index>(n);
  lift_ = ode::Matrix::Zero(dim, k);
  project_ = ode::Matrix::Zero(k, dim);
  for (Eigen::Index j = 0; j < k; ++j) {
    const Eigen::Index i = free_[static_cast<std::size_t>(j)];
    lift_(i, j) = 1;
    project_(j, i) = 1;
    // An angle counted from the rigid turn that keeps the reference's at 0, and a rate from
    // the rigid rate that goes with the reference's: z_i = y_i - (r_i / r_ref) y_ref, so that
    // y_i = z_i + (r_i / r_ref) y_ref. Measured so, the unknowns of the pair as a train are the
    // one-degree model's deflection and its rate over the mesh's lever.
    const Eigen::Index at = i % n, own_ref = i < n ? ref : n + ref;
    if (free_turning_ && at != ref) project_(j, own_ref) -= r(at) / r(ref);
  }
  if (free_turning_ && viscous) {
    // The reference's rate is an unknown: each other rate follows it.
    const auto jr =
        static_cast<Eigen::Index>(std::find(free_.begin(), free_.end(), n + ref) - free_.begin());
    for (Eigen::Index j = 0; j < k; ++j) {
      const Eigen::Index i = free_[static_cast<std::size_t>(j)];
      if (i >= n && i != n + ref) lift_(i, jr) = r(i - n) / r(ref);
    }
  }
  if (free_turning_ && !viscous) {
    // The reference's rate carries the momentum: p(t) = sum_i r_i J_i theta'_i with each other
    // rate theta'_i = z_i + (r_i / r_ref) theta'_ref, so theta'_ref (r^T J r) / r_ref = p(t) -
    // sum_i r_i J_i z_i (the mass matrix is diagonal), and each other rate follows it.
    momentum_row_ = n + ref;
    const Eigen::MatrixXd& m = a.mass();
    const double own = r.dot(m.diagonal().cwiseProduct(r)) / r(ref);
    for (Eigen::Index j = 0; j < k; ++j) {
      const Eigen::Index i = free_[static_cast<std::size_t>(j)];
      if (i >= n) lift_(momentum_row_, j) = -r(i - n) * m(i - n, i - n) / own;
    }
    for (Eigen::Index j = 0; j < k; ++j) {
      const Eigen::Index i = free_[static_cast<std::size_t>(j)];
      if (i < n) continue;
      for (Eigen::Index col = 0; col < k; ++col)
        lift_(i, col) += r(i - n) / r(ref) * lift_(momentum_row_, col);
    }
    rigid_rates_ = r / r(ref);
    for (std::size_t q = 0; q < t.torques.size(); ++q) {
      const double rq = r(a.index(t.torques[q].body));
      for (const Harmonic& h : a.torque_series(static_cast<int>(q)).terms)
        if (h.amplitude != 0)
          momentum_rate_.terms.push_back({rq * h.amplitude / h.angular_frequency_rad_s / own,
                                          h.angular_frequency_rad_s,
                                          h.phase_rad - std::numbers::pi / 2});
    }
  }
  for (const Eigen::Index i : free_)
    names_.push_back(a.coordinate_names()[static_cast<std::size_t>(i % n)] + (i < n ? "" : "_s"));
  std::string why;
  const std::optional<double> t0 = a.system_period_s(&why);
  if (!t0) throw InputError(with_origins(c, "the case has no periodic orbit to find: " + why));
  if (!(*t0 > 0))
    throw InputError(
        with_origins(c,
                     "nothing in the model varies in time (no mesh stiffness harmonic, "
                     "transmission error or runout, no torque fluctuation, no prescribed speed "
                     "harmonic): "
                     "the motion settles to its static state and has no period"));
  system_period_s_ = *t0;
  period_s_ = periods * *t0;
  if (scale.size() > 0) {
    segments_ =
        Segments([this](int i, const ode::Vector& z) { return flow(i, z); }, segments, scale);
    return;
  }
  // Each free coordinate as train_state_scale measures it.
  const ode::Vector whole = train_state_scale(a, solver_.top_frequency_rad_s());
  ode::Vector own(static_cast<Eigen::Index>(free_.size()));
  for (std::size_t k = 0; k < free_.size(); ++k)
    own(static_cast<Eigen::Index>(k)) = whole(free_[k]);
  segments_ = Segments([this](int i, const ode::Vector& z) { return flow(i, z); }, segments, own);
}

ode::Vector TrainShooting::full(double t_s, const ode::Vector& z) const {
  ode::Vector y = lift_ * z;
  if (momentum_row_ >= 0) y.tail(rigid_rates_.size()) += momentum_rate_(t_s) * rigid_rates_;
  solver_.assembled().prescribe(t_s, y);
  return y;
}

ode::Vector TrainShooting::reduce(const ode::Vector& y) const { return project_ * y; }

ode::FlowResult TrainShooting::flow(int i, const ode::Vector& z) const {
  const double h = period_s_ / segments_.segments(), ts = i * h;
  ode::FlowResult r = solver_.advance_with_jacobian(ts, full(ts, z), ts + h);
  // The unknowns' part: R J F (a prescribed body's state does not depend on them; a freely
  // turning train's rigid rotation is taken out).
  r.state = reduce(r.state);
  if (r.jacobian) r.jacobian = ode::Matrix(project_ * *r.jacobian * lift_);
  return r;
}

ode::Vector TrainShooting::one_degree_state(const ode::Vector& z) const {
  const train::Assembled& a = solver_.assembled();
  const ode::Vector y = full(0.0, z);
  const Eigen::RowVectorXd v = a.mesh_vector(0);
  const HarmonicSeries e = a.error_series(0);
  const Eigen::Index n = v.size();
  return (ode::Vector(2) << v.dot(y.head(n)) - e(0.0), v.dot(y.tail(n)) - e.rate(0.0)).finished();
}

namespace {
// dx/dz of TrainShooting::one_degree_state (exact: x is affine in z), a 2 x 2 matrix.
ode::Matrix one_degree_derivative(const TrainShooting& s, const std::string& what) {
  const auto k = static_cast<Eigen::Index>(s.coordinates().size());
  if (k != 2 || s.solver().assembled().train().meshes.size() != 1)
    throw InputError(fmt::format(
        "{}: a one-degree state (delta, delta') is a state of a pair on "
        "one mesh; this train has {} unknowns ({}) and {} meshes",
        what, k, fmt::join(s.coordinates(), ", "), s.solver().assembled().train().meshes.size()));
  const ode::Vector x0 = s.one_degree_state(ode::Vector::Zero(k));
  ode::Matrix d(2, k);
  for (Eigen::Index j = 0; j < k; ++j) d.col(j) = s.one_degree_state(ode::Vector::Unit(k, j)) - x0;
  return d;
}
}  // namespace

ode::Vector TrainShooting::one_degree_unknowns(const ode::Vector& x,
                                               const std::string& what) const {
  const ode::Matrix d = one_degree_derivative(*this, what);
  const Eigen::FullPivLU<ode::Matrix> lu(d);
  if (!lu.isInvertible())
    throw InputError(
        fmt::format("{}: the pair's deflection and its rate do not determine its "
                    "train's unknowns ({})",
                    what, fmt::join(coordinates(), ", ")));
  return lu.solve(x - one_degree_state(ode::Vector::Zero(d.cols())));
}

Orbit one_degree_orbit(const TrainShooting& s, const TrainOrbit& t) {
  Orbit o;
  static_cast<PeriodicSolution&>(o) = t;
  if (!t.converged) return o;
  const train::Assembled& a = s.solver().assembled();
  const ode::Matrix d = one_degree_derivative(s, "the orbit's one-degree reading");
  o.monodromy = d * t.monodromy * d.inverse();
  const ode::Vector x = s.one_degree_state(t.unknowns);
  // The mesh's region at the section (its contact state, clipped or not, as the one-degree
  // model numbers them) and x'' = d'' - e'' there.
  const int region = a.classify(0.0, t.state);
  const Eigen::Index n = a.size();
  const ode::Vector rate = ode::derivative(a.linear_system(), region, 0.0, t.state);
  const double acceleration =
      a.mesh_vector(0).dot(rate.tail(n)) - a.error_series(0).second_rate(0.0);
  o.state = {0.0, x[0], x[1], acceleration, a.states(region)[0]};
  for (const TrainContactEvent& e : t.sequence)
    if (e.part == 0) o.sequence.push_back({e.t_s, e.kind, e.velocity_m_s});
  const TrainMeshReading& r = t.readings.front();
  const double b = r.backlash_m, bk = b * r.mean_stiffness_n_per_m;
  static_cast<ContactCounts&>(o.reading) = r;
  o.reading.max_impact_velocity_m_s = r.max_impact_velocity_m_s;
  o.reading.min_delta_bar = r.min_deflection_m / b;
  o.reading.max_delta_bar = r.max_deflection_m / b;
  o.reading.min_force_bar = r.min_force_n / bk;
  o.reading.max_force_bar = r.max_force_n / bk;
  return o;
}

bool TrainShooting::read(const ode::Vector& x, const std::vector<ode::Matrix>& segment_jacobians,
                         TrainOrbit& orbit, std::string& why) const {
  orbit.coordinates = names_;
  orbit.modulo_rotation = free_turning_;
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
  orbit.sequence = r.contact_events;
  orbit.clearances.clear();
  orbit.clearance_readings.clear();
  for (const TrainJointReading& j : r.joints) {
    orbit.clearances.push_back(j.name);
    orbit.clearance_readings.push_back(j.contact);
  }
  orbit.impacts_per_period.clear();
  orbit.backside_impacts_per_period.clear();
  for (const TrainMeshReading& m : r.meshes) {
    orbit.impacts_per_period.push_back(m.impacts);
    orbit.backside_impacts_per_period.push_back(m.backside_impacts);
  }
  return true;
}

}  // namespace detail

namespace {

// The segments of a shooting for `options`, and its engine's tolerance (finer than Newton's).
int segments_of(const OrbitOptions& options) {
  return options.segments > 0 ? options.segments : options.periods;
}
double engine_tolerance_of(const Case& c, const OrbitOptions& options) {
  return std::min(c.solver.tolerance, options.tolerance * detail::kEngineToleranceFraction);
}

// find_train_orbit on its shooting (built from c and options).
TrainOrbit train_orbit(const detail::TrainShooting& shooting, const Case& c,
                       const OrbitOptions& options, const std::optional<ode::Vector>& start) {
  const int segments = segments_of(options);
  TrainOrbit orbit;
  orbit.coordinates = shooting.coordinates();
  orbit.periods = options.periods;
  orbit.segments = segments;
  orbit.system_period_s = shooting.system_period_s();
  orbit.period_s = shooting.period_s();
  for (const train::Mesh& m : shooting.solver().assembled().train().meshes)
    orbit.meshes.push_back(m.name);
  // The first guess: the start given, or the case's start settled over whole system periods.
  ode::Vector z0, y0;
  if (start) {
    const auto n = static_cast<Eigen::Index>(orbit.coordinates.size());
    if (start->size() != n)
      throw InputError(fmt::format(
          "--state: {} value{} given; this train takes {} (its free coordinates, then their "
          "rates, SI: {}; an orbit's JSON gives them as \"unknowns\")",
          start->size(), start->size() == 1 ? "" : "s", n, fmt::join(orbit.coordinates, ", ")));
    z0 = *start;
  } else {
    // The case's start, on the orbits' side of the phase condition (a freely turning train's
    // rigid momentum; a prescribed train's start is already its lift).
    y0 =
        shooting.full(0.0, shooting.reduce(shooting.solver().initial_state(c.solver.initial, 0.0)));
    if (options.settle_periods > 0) {
      const ode::FlowResult settled =
          shooting.solver().advance(0.0, y0, options.settle_periods * orbit.system_period_s);
      if (!settled.ok()) {
        orbit.message = detail::settling_failed(settled.termination, settled.message);
        return orbit;
      }
      y0 = settled.state;  // at a whole number of system periods: the section's phase
    }
    z0 = shooting.reduce(y0);
  }
  // Without settling, the start given (or the case's) is the one start.
  const auto next = [&](ode::Vector& z, std::string& why) {
    // From the section state as the orbits read it (a prescribed body at its prescription).
    const ode::FlowResult later =
        shooting.solver().advance(0.0, shooting.full(0.0, shooting.reduce(y0)), orbit.period_s);
    if (!later.ok()) {
      why = detail::settling_failed(later.termination, later.message);
      return false;
    }
    y0 = later.state;
    z = shooting.reduce(y0);
    return true;
  };
  detail::find_periodic(shooting, z0, options, start || options.settle_periods == 0, next, orbit);
  return orbit;
}

}  // namespace

TrainOrbit find_train_orbit(const Case& c, const OrbitOptions& options,
                            const std::optional<ode::Vector>& start) {
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  const detail::TrainShooting shooting(c, options.periods, segments_of(options), ode::Vector{},
                                       engine_tolerance_of(c, options));
  return train_orbit(shooting, c, options, start);
}

Orbit find_orbit(const Case& c, const OrbitOptions& options,
                 const std::optional<ode::State>& start) {
  if (c.model.form != ModelForm::kGearPair && c.model.form != ModelForm::kNondimensional)
    throw InputError(
        fmt::format("find_orbit: model.form = \"{}\" is no one-degree form (\"gear_pair\", "
                    "\"nondimensional\"); find_train_orbit finds its orbits",
                    to_string(c.model.form)));
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  const detail::TrainShooting shooting(c, options.periods, segments_of(options), ode::Vector{},
                                       engine_tolerance_of(c, options));
  std::optional<ode::Vector> z0;
  if (start)
    z0 = shooting.one_degree_unknowns((ode::Vector(2) << start->q, start->v).finished(),
                                      "the start state");
  return detail::one_degree_orbit(shooting, train_orbit(shooting, c, options, z0));
}

ode::Vector train_orbit_state(const Case& c, const ode::Vector& unknowns) {
  const detail::TrainShooting s(c, 1, 1, ode::Vector{}, c.solver.tolerance);
  if (unknowns.size() != static_cast<Eigen::Index>(s.coordinates().size()))
    throw InputError(fmt::format("{} unknowns given; this train takes {} ({})", unknowns.size(),
                                 s.coordinates().size(), fmt::join(s.coordinates(), ", ")));
  return s.full(0.0, unknowns);
}

ode::Vector train_orbit_unknowns(const Case& c, const ode::Vector& state) {
  const detail::TrainShooting s(c, 1, 1, ode::Vector{}, c.solver.tolerance);
  const Eigen::Index size = 2 * static_cast<Eigen::Index>(s.solver().assembled().size());
  if (state.size() != size)
    throw InputError(
        fmt::format("a state of {} values given; this train's has {}", state.size(), size));
  return s.reduce(state);
}

namespace {
// One part's contact changes of an orbit's period, as the one-degree orbit's sequence (orbit.hpp):
// [{t_s, event, velocity_m_s}].
nlohmann::json sequence_json(const std::vector<TrainContactEvent>& sequence, int part) {
  nlohmann::json out = nlohmann::json::array();
  for (const TrainContactEvent& e : sequence)
    if (e.part == part)
      out.push_back(
          {{"t_s", e.t_s}, {"event", to_string(e.kind)}, {"velocity_m_s", e.velocity_m_s}});
  return out;
}
}  // namespace

std::string train_orbit_json(const TrainOrbit& o, int indent) {
  nlohmann::json j = detail::periodic_json(o);
  j["model"] = "train";
  j["coordinates"] = o.coordinates;
  j["modulo_rotation"] = o.modulo_rotation;
  j["state"] = std::vector<double>(o.state.data(), o.state.data() + o.state.size());
  j["unknowns"] = std::vector<double>(o.unknowns.data(), o.unknowns.data() + o.unknowns.size());
  nlohmann::json meshes = nlohmann::json::array();
  for (std::size_t m = 0; m < o.meshes.size(); ++m) {
    nlohmann::json mesh{{"name", o.meshes[m]},
                        {"impacts_per_period", nullptr},
                        {"backside_impacts_per_period", nullptr}};
    // Read over the period of a converged orbit, the extremes exact: d - e over b, and the force.
    if (o.converged) {
      mesh["impacts_per_period"] = o.impacts_per_period[m];
      mesh["backside_impacts_per_period"] = o.backside_impacts_per_period[m];
      const TrainMeshReading& x = o.readings[m];
      mesh["separations_per_period"] = x.separations;
      mesh["min_deflection_bar"] = x.min_deflection_m / x.backlash_m;
      mesh["max_deflection_bar"] = x.max_deflection_m / x.backlash_m;
      mesh["min_force_n"] = x.min_force_n;
      mesh["max_force_n"] = x.max_force_n;
      mesh["max_impact_velocity_m_s"] = x.max_impact_velocity_m_s;
      mesh["sequence"] = sequence_json(o.sequence, static_cast<int>(m));
    }
    meshes.push_back(mesh);
  }
  j["meshes"] = meshes;
  nlohmann::json clearances = nlohmann::json::array();
  for (std::size_t k = 0; k < o.clearances.size(); ++k)
    clearances.push_back(
        {{"name", o.clearances[k]},
         {"impacts_per_period", o.clearance_readings[k].impacts},
         {"separations_per_period", o.clearance_readings[k].separations},
         {"sequence", sequence_json(o.sequence, static_cast<int>(o.meshes.size() + k))}});
  j["clearances"] = clearances;
  return j.dump(indent);
}

}  // namespace geardyn
