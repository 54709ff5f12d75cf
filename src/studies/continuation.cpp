#include "geardyn/continuation.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "geardyn/case_keys.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/train_case.hpp"
#include "studies/shooting.hpp"

namespace geardyn {
namespace {

// Newton iterations of one correction at most; after this many or fewer the step grows.
constexpr int kCorrectorIterations = 8;
constexpr int kEasyCorrection = 3;
constexpr double kStepGrowth = 1.5;
// A new tangent more than this angle from the last one means the step was too long.
constexpr double kMinTangentCosine = 0.9;
// Bisections of a bracket at most when locating a bifurcation.
constexpr int kMaxBisections = 60;
// A branch switch at a period doubling: how far beyond it in p (relative to p_scale), the
// displacements along the eigenvector tried (scaled units), and how far from returning
// after one period N a period-doubled orbit must be (scaled).
constexpr double kSwitchStep = 1e-3;
constexpr double kSwitchDisplacements[] = {1e-2, 3e-2, 1e-1};
constexpr double kDistinctOrbit = 1e-6;
// A period-doubled branch steps across a period-N orbit where its half-period difference turns
// to its opposite between two points: the cosine of their angle is below -this.
constexpr double kOppositeCosine = 0.99;
// Doublings of the step either side of a doubled branch's meeting with a period-N orbit in
// which the crossing of that orbit's multiplier through -1 is sought (kSwitchStep p_scale and up).
constexpr int kMeetingBracketSteps = 4;

// The contact sequence of one period, the grazing test's signature: cyclic, so the least of
// its rotations (an event that moves across the section time changes nothing).
std::vector<std::int64_t> signature(const std::vector<ContactEvent>& sequence) {
  std::vector<std::int64_t> s;
  s.reserve(sequence.size());
  for (const ContactEvent& e : sequence) s.push_back(static_cast<std::int64_t>(e.kind));
  std::vector<std::int64_t> best = s;
  for (std::size_t i = 1; i < s.size(); ++i) {
    std::rotate(s.begin(), s.begin() + 1, s.end());
    best = std::min(best, s);
  }
  return best;
}

// A one-degree orbit as the continuation keeps it: its state (x, x'), reading and contact
// sequence.
void to_branch(const Orbit& orbit, BranchOrbit& o, std::size_t /*mesh*/) {
  o.state = (ode::Vector(2) << orbit.state.q, orbit.state.v).finished();
  o.reading = orbit.reading;
  o.signature = signature(orbit.sequence);
  o.contacts = {{"", orbit.reading.impacts, orbit.reading.separations}};
}

// The one-degree forms: their orbits are their train's (find_orbit), kept and written in the
// one-degree model's terms (state (delta, delta'), its contact sequence the grazing test).
bool one_degree(const Case& c) {
  return c.model.form == ModelForm::kGearPair || c.model.form == ModelForm::kNondimensional;
}

// A train's orbit as the continuation keeps it: the unknowns (its free coordinates' state),
// the reading of mesh `mesh` (ContinuationOptions::mesh) in the one-degree units (its b and
// mean stiffness), and every mesh's counts (its grazing is a change in any).
void to_branch(const TrainOrbit& orbit, BranchOrbit& o, std::size_t mesh) {
  o.state = orbit.unknowns;
  o.reading = RunReading{};
  o.signature.clear();
  o.contacts.clear();
  for (std::size_t m = 0; m < orbit.readings.size(); ++m) {
    const TrainMeshReading& r = orbit.readings[m];
    if (m == mesh) {
      const double b = r.backlash_m, bk = b * r.mean_stiffness_n_per_m;
      static_cast<ContactCounts&>(o.reading) = r;
      o.reading.min_delta_bar = r.min_deflection_m / b;
      o.reading.max_delta_bar = r.max_deflection_m / b;
      o.reading.min_force_bar = r.min_force_n / bk;
      o.reading.max_force_bar = r.max_force_n / bk;
    }
    o.signature.insert(o.signature.end(), {r.impacts, r.backside_impacts, r.separations});
    o.contacts.push_back({"mesh " + r.name, r.impacts, r.separations});
  }
  // Each bearing clearance direction's counts: its grazing is a change in them too.
  for (std::size_t k = 0; k < orbit.clearances.size(); ++k) {
    const ContactReading& g = orbit.clearance_readings[k];
    o.signature.insert(o.signature.end(), {g.impacts, g.separations});
    o.contacts.push_back({"clearance " + orbit.clearances[k], g.impacts, g.separations});
  }
}

// The orbits at one value of the key, of any form (its train's: TrainShooting): their
// multiple shooting, and how a converged one is read.
class Family {
 public:
  // Scale and stiffness as for TrainShooting (empty scale: this case's; no stiffness: this
  // case's); `mesh` the mesh read.
  Family(const Case& c, int periods, int segments, const ode::Vector& scale,
         double engine_tolerance, const MeshStiffness* stiffness, std::size_t mesh)
      : s_(c, periods, segments, scale, engine_tolerance, stiffness),
        periods_(periods),
        mesh_(mesh),
        one_degree_(one_degree(c)) {}
  const detail::Segments& shooting() const { return s_.shooting(); }
  const detail::TrainShooting& train() const { return s_; }
  // Reads the converged unknowns x (segments' Jacobians `seg`) into `o` and, when `json` is
  // given, the orbit as `geardyn orbit --json` prints it. False with `why`. The periodic
  // solution kept (its monodromy) is in the unknowns, as BranchOrbit::unknowns.
  bool read(const ode::Vector& x, const std::vector<ode::Matrix>& seg, BranchOrbit& o,
            std::string* json, std::string& why) const {
    TrainOrbit orbit;
    if (!s_.read(x, seg, orbit, why)) return false;
    orbit.converged = true;
    orbit.periods = periods_;
    static_cast<PeriodicSolution&>(o) = orbit;
    if (one_degree_) {
      const Orbit one = detail::one_degree_orbit(s_, orbit);
      if (json) *json = orbit_json(one, -1);
      to_branch(one, o, mesh_);
    } else {
      if (json) *json = train_orbit_json(orbit, -1);
      to_branch(orbit, o, mesh_);
    }
    o.unknowns = orbit.unknowns;
    return true;
  }

 private:
  detail::TrainShooting s_;
  int periods_;
  std::size_t mesh_;  // the train's mesh read
  bool one_degree_;
};

// The family of case c; scale and stiffness as for Family.
std::unique_ptr<Family> family(const Case& c, int periods, int segments, const ode::Vector& scale,
                               double engine_tolerance, const MeshStiffness* stiffness,
                               std::size_t mesh) {
  return std::make_unique<Family>(c, periods, segments, scale, engine_tolerance, stiffness, mesh);
}

// The names of a case's state entries (ContinuationResult::state_names).
std::vector<std::string> state_names(const Case& c) {
  if (one_degree(c)) return {"delta_m", "velocity_m_s"};
  return detail::TrainShooting(c, 1, 1, ode::Vector{}, c.solver.tolerance).coordinates();
}

// The periodic orbit of case c (period and segments of `o`) from a state y0 on the section:
// Newton on its shooting, read; nullopt when Newton fails.
std::optional<BranchOrbit> orbit_from(const Case& c, const OrbitOptions& o, const ode::Vector& y0,
                                      const ode::Vector& scale, std::size_t mesh) {
  const int segments = o.segments > 0 ? o.segments : o.periods;
  const auto f = family(
      c, o.periods, segments, scale,
      std::min(c.solver.tolerance, o.tolerance * detail::kEngineToleranceFraction), nullptr, mesh);
  ode::Vector x;
  std::string why;
  if (!f->shooting().guess(y0, x, why)) return std::nullopt;
  const detail::NewtonOutcome n = detail::solve_periodic(f->shooting(), x, o);
  BranchOrbit out;
  if (!n.converged || !f->read(x, n.jacobians, out, nullptr, why)) return std::nullopt;
  out.converged = true;
  out.iterations = n.iterations;
  out.residual = n.residual;
  return out;
}

// A grazing's detail: the counts that changed from a to b, e.g. "bearing 1 impacts 1 -> 0,
// separations 1 -> 0 per period".
std::string contact_change(const BranchOrbit& a, const BranchOrbit& b) {
  std::string s;
  for (std::size_t i = 0; i < std::min(a.contacts.size(), b.contacts.size()); ++i) {
    const BranchOrbit::Contacts &x = a.contacts[i], &y = b.contacts[i];
    if (x.impacts == y.impacts && x.separations == y.separations) continue;
    fmt::format_to(std::back_inserter(s), "{}{}{}impacts {} -> {}, separations {} -> {}",
                   s.empty() ? "" : "; ", x.name, x.name.empty() ? "" : " ", x.impacts, y.impacts,
                   x.separations, y.separations);
  }
  return s.empty() ? "the contact sequence changes, its counts do not" : s + " per period";
}

// det(M - sign I), real.
double shifted_determinant(const BranchOrbit& o, double sign) {
  const auto n = o.monodromy.rows();
  return (o.monodromy - sign * ode::Matrix::Identity(n, n)).determinant();
}

// |mu|^2 - 1 of the complex pair (Neimark-Sacker test); nullopt without one.
std::optional<double> complex_pair_test(const BranchOrbit& o) {
  for (const auto& m : o.multipliers)
    if (std::abs(m.imag()) > 1e-12 * std::max(1.0, std::abs(m))) return std::norm(m) - 1;
  return std::nullopt;
}

// A converged point of the branch: its unknowns, tangent and orbit.
struct Point {
  ode::Vector z;        // (x, p / p_scale)
  ode::Vector tangent;  // unit, pointing onward
  BranchOrbit orbit;
  int iterations = 0;
};

class Continuer {
 public:
  // The branch stays within [lo, hi] (from and to, or wider for a switched branch that may
  // run back past its start to the period doubling it came from).
  Continuer(const Case& base, const ContinuationOptions& o, double lo, double hi)
      : base_(base),
        o_(o),
        stiffness_(base.model.form == ModelForm::kTrain ? std::nullopt  // its meshes' own
                                                        : shared_stiffness(base, {o.key})),
        p_scale_(hi - lo),
        lo_(lo),
        hi_(hi),
        mesh_(mesh_to_read(base, o.mesh)) {
    segments_ = o.orbit.segments > 0 ? o.orbit.segments : o.orbit.periods;
    engine_tolerance_ =
        std::min(base.solver.tolerance, o.orbit.tolerance * detail::kEngineToleranceFraction);
  }

  double param(const ode::Vector& z) const { return z[z.size() - 1] * p_scale_; }

  Case case_at(double p) const {
    Case c = base_;
    set_case_value(c,
                   {o_.key, fmt::format("{:.17g}", p), fmt::format("--param {} at {}", o_.key, p)});
    return c;
  }

  // The family at p; null with `why` where the key's value is not allowed there (a corrector
  // that strays past a bound fails like one that does not converge: the step is halved).
  std::unique_ptr<Family> family_at(double p, std::string& why) const {
    try {
      return family(case_at(p), o_.orbit.periods, segments_, scale_, engine_tolerance_,
                    stiffness_ ? &*stiffness_ : nullptr, mesh_);
    } catch (const InputError& e) {
      why = e.what();
      return nullptr;
    }
  }

  // The first point: find_orbit (find_train_orbit) at `from`, then one correction at fixed p.
  bool start(Point& pt, std::string& why) {
    const Case c0 = case_at(o_.from);
    OrbitOptions oo = o_.orbit;
    oo.segments = segments_;
    const auto s = family(c0, o_.orbit.periods, segments_, ode::Vector{}, engine_tolerance_,
                          stiffness_ ? &*stiffness_ : nullptr, mesh_);
    // The start given: a one-degree form's (delta, delta'), its train's unknowns.
    std::optional<ode::Vector> start = o_.start;
    if (start && one_degree(c0)) {
      if (start->size() != 2)
        throw InputError(fmt::format(
            "the start state has {} values; a one-degree case takes 2 (delta and delta', SI)",
            start->size()));
      start = s->train().one_degree_unknowns(*start, "the start state");
    }
    const TrainOrbit first = find_train_orbit(c0, oo, start);
    if (!first.converged) {
      why = fmt::format("no orbit at {} = {:.17g}: {}", o_.key, o_.from, first.message);
      return false;
    }
    const ode::Vector y0 = first.unknowns;
    scale_ = s->shooting().scale();
    ode::Vector x;
    if (!s->shooting().guess(y0, x, why)) return false;
    const Eigen::Index n = x.size();
    ode::Vector z(n + 1);
    z << x, o_.from / p_scale_;
    ode::Vector along = ode::Vector::Zero(n + 1);
    along[n] = o_.to > o_.from ? 1.0 : -1.0;
    if (!correct(z, along, pt, why)) return false;
    return tangent(pt, along, why);
  }

  // Newton on F(z) = 0, t . (z - z_pred) = 0 from z_pred. Fills pt.z, pt.orbit (read) and
  // pt.iterations, and leaves dF/dx at pt.z and dF/dp at the first iterate for its tangent;
  // false with `why`.
  bool correct(const ode::Vector& z_pred, const ode::Vector& t, Point& pt, std::string& why) {
    ode::Vector z = z_pred, f, step;
    const Eigen::Index n = z.size() - 1;
    ode::Matrix jac(n + 1, n + 1);
    std::vector<ode::Matrix> seg;
    for (int it = 0;; ++it) {
      const auto s = family_at(param(z), why);
      // dF/dp (two more models built) at the predicted point only; the corrector's later
      // iterations keep it (a chord in that one column).
      if (!s || !s->shooting().residual(z.head(n), f, &last_jx_, &seg, why) ||
          (it == 0 && !param_derivative(z, f, why)))
        return false;
      const double norm = f.lpNorm<Eigen::Infinity>();
      const double plane = t.dot(z - z_pred);
      if (norm <= o_.orbit.tolerance && std::abs(plane) <= o_.orbit.tolerance) {
        pt.z = z;
        pt.iterations = it;
        return s->read(z.head(n), seg, pt.orbit, nullptr, why);
      }
      if (it >= kCorrectorIterations) {
        why = fmt::format("the corrector did not converge in {} iterations (residual {:.3g})",
                          kCorrectorIterations, norm);
        return false;
      }
      jac.topLeftCorner(n, n) = last_jx_;
      jac.topRightCorner(n, 1) = last_fp_;
      jac.bottomRows(1) = t.transpose();
      ode::Vector g(n + 1);
      g << f, plane;
      if (!detail::solve_newton(jac, g, step)) {
        why = "the continuation's Newton matrix is singular";
        return false;
      }
      z += step;
    }
  }

  // dF/d(p / p_scale) at z by central differences, into last_fp_; one-sided from the
  // residual f at z where the key is not allowed on one side (a range ending on its bound).
  bool param_derivative(const ode::Vector& z, const ode::Vector& f, std::string& why) {
    const Eigen::Index n = z.size() - 1;
    const double p = param(z), h = kParamStep * p_scale_;
    ode::Vector fp, fm;
    std::string outside;
    const auto plus = family_at(p + h, outside), minus = family_at(p - h, outside);
    if (!plus && !minus) {
      why = outside;
      return false;
    }
    if (plus && !plus->shooting().residual(z.head(n), fp, nullptr, nullptr, why)) return false;
    if (minus && !minus->shooting().residual(z.head(n), fm, nullptr, nullptr, why)) return false;
    if (plus && minus)
      last_fp_ = (fp - fm) * (p_scale_ / (2 * h));
    else
      last_fp_ = (plus ? fp - f : f - fm) * (p_scale_ / h);
    return true;
  }

  // A period-doubled branch (its orbits of period 2N on an even number of segments) ends where
  // it meets a period-N orbit again (of the branch it left or of another family): there the
  // state after half the period is the start. Past that orbit the branch runs on as its own
  // orbits shifted by half a period, so the difference of the two states changes sign there.
  void mark_doubled() { doubled_ = segments_ % 2 == 0; }
  ode::Vector half_period_difference(const ode::Vector& z) const {
    const Eigen::Index d = scale_.size();
    return z.segment(0, d) - z.segment(d * (segments_ / 2), d);
  }
  double half_period_gap(const ode::Vector& z) const {
    return half_period_difference(z).lpNorm<Eigen::Infinity>();
  }
  // Where the branch from a to b (arclength ds apart) steps across a period-N orbit. Near one
  // the half-period difference is d ~ (s - s*) v: it turns to its opposite between a and b
  // (one that merely rotates is no crossing). The crossing is the point of least gap among a,
  // b and a bisection in arclength (a period doubling is a turning point of its doubled branch
  // in p, so p cannot bound the bracket); the corrector may fail next to the crossing (two
  // branches meet there) or stray from the bracket, and then the bisection stops.
  std::optional<Point> period_n_crossing(const Point& a, const Point& b, double ds) {
    const ode::Vector da = half_period_difference(a.z), db = half_period_difference(b.z);
    if (!(db.dot(da) < -kOppositeCosine * da.norm() * db.norm())) return std::nullopt;
    double lo = 0, hi = ds;
    Point at = half_period_gap(a.z) < half_period_gap(b.z) ? a : b;
    for (int i = 0; i < kMaxBisections && half_period_gap(at.z) >= kDistinctOrbit; ++i) {
      const double mid = 0.5 * (lo + hi);
      Point m;
      if (!point_at(a, mid, m) || (m.z - a.z).norm() > 2 * ds) break;
      (half_period_difference(m.z).dot(da) > 0 ? lo : hi) = mid;
      if (half_period_gap(m.z) < half_period_gap(at.z)) at = std::move(m);
    }
    return at;
  }

  // The period doubling of the period-N orbit that the doubled branch meets at m: where that
  // orbit's multiplier nearest -1 passes through -1, to kLocateWidth p_scale in p. The orbit
  // is shot with period N from m's first half (its segments at the same times) and followed in
  // p alone, which a period doubling leaves regular; the crossing is bracketed by steps of
  // kSwitchStep p_scale either side (doubled kMeetingBracketSteps times at most) and closed by
  // the Illinois variant of regula falsi. nullopt when a shooting fails before the bracket is
  // closed or no bracket is found (the branch then ends on m as it is).
  std::optional<Bifurcation> meeting_doubling(const Point& m) {
    const int periods = o_.orbit.periods / 2, segments = segments_ / 2;
    OrbitOptions oo = o_.orbit;
    oo.periods = periods;
    oo.segments = segments;
    struct Sample {
      double p = 0, g = 0;
      ode::Vector x;
      BranchOrbit orbit;
      std::string json;
    };
    // Re(mu) + 1 of the multiplier nearest -1 of the period-N orbit at p, shot from x.
    const auto shoot = [&](double p, const ode::Vector& x, Sample& out) {
      std::string why;
      std::unique_ptr<Family> f;
      try {
        f = family(case_at(p), periods, segments, scale_, engine_tolerance_,
                   stiffness_ ? &*stiffness_ : nullptr, mesh_);
      } catch (const InputError&) {
        return false;
      }
      out.p = p;
      out.x = x;
      const detail::NewtonOutcome n = detail::solve_periodic(f->shooting(), out.x, oo);
      if (!n.converged || !f->read(out.x, n.jacobians, out.orbit, &out.json, why) ||
          out.orbit.multipliers.empty())
        return false;
      std::complex<double> nearest = out.orbit.multipliers[0];
      for (const auto& mu : out.orbit.multipliers)
        if (std::abs(mu + 1.0) < std::abs(nearest + 1.0)) nearest = mu;
      out.g = nearest.real() + 1;
      return true;
    };
    Sample a, b;
    if (!shoot(param(m.z), m.z.head(scale_.size() * segments), a)) return std::nullopt;
    bool bracketed = false;
    for (int i = 0; i < kMeetingBracketSteps && !bracketed; ++i) {
      const double step = kSwitchStep * p_scale_ * std::ldexp(1.0, i);
      for (const double side : {1.0, -1.0}) {
        if (shoot(a.p + side * step, a.x, b) && a.g * b.g <= 0) {
          bracketed = true;
          break;
        }
      }
    }
    if (!bracketed) return std::nullopt;
    // Illinois: regula falsi that halves the value kept at a stuck end.
    double ga = a.g, gb = b.g;
    for (int i = 0; i < kMaxBisections && std::abs(b.p - a.p) > kLocateWidth * p_scale_ &&
                    a.g != 0 && b.g != 0;
         ++i) {
      const double p = (a.p * gb - b.p * ga) / (gb - ga);
      Sample c;
      if (!shoot(p, std::abs(p - a.p) < std::abs(p - b.p) ? a.x : b.x, c)) break;
      if (c.g * b.g < 0) {
        a = std::move(b);
        ga = gb;
      } else {
        ga *= 0.5;
      }
      b = std::move(c);
      gb = b.g;
    }
    // A shooting that failed inside the bracket leaves it wide: not located, not reported.
    if (!(std::abs(b.p - a.p) <= kLocateWidth * p_scale_ || a.g == 0 || b.g == 0))
      return std::nullopt;
    const Sample& at = std::abs(a.g) < std::abs(b.g) ? a : b;
    return Bifurcation{BifurcationType::kPeriodDoubling,
                       at.p,
                       0,
                       at.orbit,
                       at.json,
                       fmt::format("a multiplier through -1 of the period-{} orbit the "
                                   "period-doubled branch meets, where that branch ends",
                                   periods)};
  }

  // The orbit of point pt as `geardyn orbit --json` prints it ("" when it cannot be read).
  std::string orbit_json_at(const Point& pt) const {
    const Eigen::Index n = pt.z.size() - 1;
    std::string why, json;
    const auto s = family_at(param(pt.z), why);
    ode::Vector f;
    std::vector<ode::Matrix> seg;
    BranchOrbit o;
    if (!s || !s->shooting().residual(pt.z.head(n), f, nullptr, &seg, why) ||
        !s->read(pt.z.head(n), seg, o, &json, why))
      return {};
    return json;
  }

  // The unit tangent at pt (from the last correction's Jacobians), oriented along `previous`.
  bool tangent(Point& pt, const ode::Vector& previous, std::string& why) {
    const Eigen::Index n = pt.z.size() - 1;
    ode::Matrix jac(n + 1, n + 1);
    jac.topLeftCorner(n, n) = last_jx_;
    jac.topRightCorner(n, 1) = last_fp_;
    jac.bottomRows(1) = previous.transpose();
    ode::Vector rhs = ode::Vector::Zero(n + 1);
    rhs[n] = 1;
    ode::Vector t;
    if (!detail::solve_newton(jac, -rhs, t)) {
      why = "the tangent's system is singular (a branch point)";
      return false;
    }
    pt.tangent = t.normalized();
    return true;
  }

  // The point at arclength sigma from a along a's tangent (corrected); false when it fails.
  bool point_at(const Point& a, double sigma, Point& out) {
    std::string why;
    return correct(a.z + sigma * a.tangent, a.tangent, out, why);
  }

  // Locates where `same_as_a` turns false between a (arclength 0) and b (arclength ds) by
  // bisection, re-correcting at every trial, to kLocateWidth p_scale in p: the point on b's
  // side of the change.
  template <class Same>
  Point locate(const Point& a, const Point& b, double ds, Same same_as_a) {
    double lo = 0, hi = ds, p_lo = param(a.z), p_hi = param(b.z);
    Point at_hi = b;
    for (int i = 0; i < kMaxBisections && std::abs(p_hi - p_lo) > kLocateWidth * p_scale_; ++i) {
      const double mid = 0.5 * (lo + hi);
      Point m;
      if (!point_at(a, mid, m)) break;  // the bracket so far is the answer
      if (same_as_a(m)) {
        lo = mid;
        p_lo = param(m.z);
      } else {
        hi = mid;
        p_hi = param(m.z);
        at_hi = std::move(m);
      }
    }
    return at_hi;
  }

  // The bifurcations between two consecutive points a and b (arclength ds apart).
  void detect(const Point& a, const Point& b, double ds, std::vector<Bifurcation>& out) {
    const auto& sig_a = a.orbit.signature;
    if (sig_a != b.orbit.signature) {
      const Point g = locate(a, b, ds, [&](const Point& m) { return m.orbit.signature == sig_a; });
      out.push_back({BifurcationType::kGrazing, param(g.z), 0, g.orbit, orbit_json_at(g),
                     contact_change(a.orbit, b.orbit)});
      return;  // the multipliers jump at a grazing: their tests would read that jump
    }
    auto sign_test = [&](BifurcationType type, auto test, const std::string& detail) {
      const double ta = test(a.orbit), tb = test(b.orbit);
      if (!(ta * tb < 0)) return;
      const Point m = locate(a, b, ds, [&](const Point& q) { return test(q.orbit) * ta > 0; });
      out.push_back({type, param(m.z), 0, m.orbit, orbit_json_at(m), detail});
    };
    const double turn = a.tangent[a.tangent.size() - 1] * b.tangent[b.tangent.size() - 1];
    sign_test(
        turn < 0 ? BifurcationType::kFold : BifurcationType::kBranchPoint,
        [](const BranchOrbit& o) { return shifted_determinant(o, 1.0); },
        "a multiplier through +1");
    sign_test(
        BifurcationType::kPeriodDoubling,
        [](const BranchOrbit& o) { return shifted_determinant(o, -1.0); },
        "a multiplier through -1");
    const auto na = complex_pair_test(a.orbit), nb = complex_pair_test(b.orbit);
    if (na && nb)
      sign_test(
          BifurcationType::kNeimarkSacker,
          [](const BranchOrbit& o) { return complex_pair_test(o).value_or(0.0); },
          "a complex pair through the unit circle");
  }

  ContinuationResult run() {
    ContinuationResult res;
    const auto wall_start = std::chrono::steady_clock::now();
    auto done = [&](std::string msg) {
      res.message = std::move(msg);
      res.wall_time_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
      return res;
    };
    Point cur;
    std::string why;
    if (!start(cur, why)) return done(why);
    res.points.push_back({param(cur.z), 0, o_.orbit.periods, cur.orbit});
    double ds = o_.initial_step;
    const Eigen::Index np = cur.z.size() - 1;  // the key's entry in z
    while (static_cast<int>(res.points.size()) < o_.max_points) {
      // A step whose prediction passes an end of the range is shortened to land on it: the key
      // may not be allowed beyond (a damping ratio below 0).
      double step = ds;
      const double p_pred = param(cur.z + ds * cur.tangent);
      if (p_pred > hi_ || p_pred < lo_) {
        const double end = p_pred > hi_ ? hi_ : lo_;
        step = (end / p_scale_ - cur.z[np]) / cur.tangent[np];
      }
      Point next;
      bool ok = correct(cur.z + step * cur.tangent, cur.tangent, next, why) &&
                tangent(next, cur.tangent, why);
      if (ok && next.tangent.dot(cur.tangent) < kMinTangentCosine && ds > o_.min_step) {
        ok = false;
        why = "the branch turns too sharply for the step";
      }
      // Two folds inside one step: the key moves one way along the branch at both points and
      // the other way between them, so the branch turned twice in the step (where det(M - I)
      // changes sign twice and shows nothing). A shorter step separates them; at the shortest
      // the step is kept (folds closer than that are not resolved).
      const double dp = ok ? next.z[np] - cur.z[np] : 0.0;
      if (ok && cur.tangent[np] * next.tangent[np] > 0 && dp * cur.tangent[np] < 0 &&
          std::abs(dp) > o_.orbit.tolerance && 0.5 * ds >= o_.min_step) {
        ok = false;
        why = "two folds inside one step";
      }
      if (!ok) {
        ds *= 0.5;
        if (ds < o_.min_step)
          return done(fmt::format("lost the branch at {} = {:.12g}: {} (step {:.3g})", o_.key,
                                  param(cur.z), why, ds));
        continue;
      }
      {
        // Only what lies in the range: a step past an end may hold a bifurcation beyond it.
        std::vector<Bifurcation> found;
        detect(cur, next, step, found);
        for (Bifurcation& b : found)
          if (b.param >= lo_ && b.param <= hi_) res.bifurcations.push_back(std::move(b));
      }
      const double p = param(next.z);
      const bool landed = step != ds;  // aimed at an end, the corrector a hair either side
      if (p > hi_ || p < lo_ || landed) {
        // At an end: the last point on it, at p fixed.
        const double end = p > hi_ || (landed && p_pred > hi_) ? hi_ : lo_;
        const bool past_to = end == o_.to;
        ode::Vector along = ode::Vector::Zero(next.z.size());
        along[np] = 1;
        ode::Vector z = next.z;
        if (std::abs(p - param(cur.z)) > 0)
          z = cur.z + (end - param(cur.z)) / (p - param(cur.z)) * (next.z - cur.z);
        z[np] = end / p_scale_;
        Point last;
        std::string end_note;
        if (correct(z, along, last, why))
          res.points.push_back({end, 0, o_.orbit.periods, last.orbit});
        else
          end_note = fmt::format(" (no orbit corrected at the end: {})", why);
        if (past_to) {
          res.completed = true;
          return done(fmt::format("reached {} = {:.12g}{}", o_.key, o_.to, end_note));
        }
        return done(fmt::format("the branch turned back to {} = {:.12g}{}", o_.key, end, end_note));
      }
      if (doubled_ && half_period_gap(next.z) < kDistinctOrbit) {
        res.points.push_back({p, 0, o_.orbit.periods, next.orbit});
        return done(
            fmt::format("the period-doubled branch returned to the period doubling at "
                        "{} = {:.12g}",
                        o_.key, p));
      }
      if (doubled_) {
        // Stepped across a period-N orbit: beyond it lie the same orbits shifted by half a
        // period, which the branch would retrace. It ends on the crossing.
        if (const std::optional<Point> m = period_n_crossing(cur, next, step)) {
          res.points.push_back({param(m->z), 0, o_.orbit.periods, m->orbit});
          std::optional<Bifurcation> pd = meeting_doubling(*m);
          if (pd && !(pd->param >= lo_ && pd->param <= hi_)) pd.reset();
          const std::string met = fmt::format("the period-doubled branch met a period-{} orbit at",
                                              o_.orbit.periods / 2);
          const std::string beyond =
              "beyond, the branch is the same orbits shifted by half a period";
          if (pd) {
            const std::string msg = fmt::format(
                "{} {} = {:.12g}, where that orbit's multiplier passes through -1 (the branch's "
                "last point, at {:.12g}, returns after half its period to {:.1e}; {})",
                met, o_.key, pd->param, param(m->z), half_period_gap(m->z), beyond);
            res.bifurcations.push_back(std::move(*pd));
            return done(msg);
          }
          return done(fmt::format(
              "{} {} = {:.12g} (its orbits return after half their period there to {:.1e}; {})",
              met, o_.key, param(m->z), half_period_gap(m->z), beyond));
        }
      }
      res.points.push_back({p, 0, o_.orbit.periods, next.orbit});
      if (o_.progress && !o_.progress(p, res.points.size())) {
        res.cancelled = true;
        return done(fmt::format("cancelled at {} = {:.12g}", o_.key, p));
      }
      if (next.iterations <= kEasyCorrection) ds = std::min(o_.max_step, ds * kStepGrowth);
      cur = std::move(next);
    }
    return done(fmt::format("stopped after {} points (--max-points) at {} = {:.12g}", o_.max_points,
                            o_.key, param(cur.z)));
  }

 private:
  const Case& base_;
  const ContinuationOptions& o_;
  std::optional<MeshStiffness> stiffness_;  // shared_stiffness: when the key leaves it alone
  double p_scale_, lo_, hi_;
  std::size_t mesh_;  // a train's mesh read (ContinuationOptions::mesh)
  int segments_ = 1;
  bool doubled_ = false;
  double engine_tolerance_ = 1e-14;
  ode::Vector scale_;
  ode::Matrix last_jx_;  // dF/dx and dF/d(p / p_scale) at the last corrected point
  ode::Vector last_fp_;
};

}  // namespace

const char* to_string(BifurcationType t) {
  switch (t) {
    case BifurcationType::kFold:
      return "fold";
    case BifurcationType::kBranchPoint:
      return "branch_point";
    case BifurcationType::kPeriodDoubling:
      return "period_doubling";
    case BifurcationType::kNeimarkSacker:
      return "neimark_sacker";
    case BifurcationType::kGrazing:
      return "grazing";
  }
  return "?";
}

std::string ContinuationOptions::validate() const {
  if (key.empty()) return "--param: a numeric case key is required, e.g. model.omega";
  if (std::string why = check_sweepable(key); !why.empty()) return "--param " + why;
  if (!std::isfinite(from) || !std::isfinite(to) || from == to)
    return fmt::format("--from = {}, --to = {}: must be finite and differ", from, to);
  if (!(initial_step > 0 && initial_step <= max_step))
    return fmt::format("--step = {}: must be in (0, max_step = {}]", initial_step, max_step);
  if (!(min_step > 0 && min_step < initial_step))
    return fmt::format("min_step = {}: must be in (0, the initial step {})", min_step,
                       initial_step);
  if (max_points < 2 || max_points > 1000000)
    return fmt::format("--max-points = {}: must be an integer in [2, 1000000]", max_points);
  return orbit.validate();
}

namespace {

// The period-doubled orbit next to a period doubling `pd` of a branch of N-periodic orbits:
// Newton on 2N periods, just beyond pd.param on either side, from pd's state displaced along
// the eigenvector of the multiplier nearest -1. nullopt when no such orbit is found.
struct Switch {
  double param;
  BranchOrbit orbit;
  double toward;  // the end of the range the new branch heads for
};
std::optional<Switch> switch_branch(const Case& base, const ContinuationOptions& o,
                                    const Bifurcation& pd) {
  // On the balanced monodromy D^-1 M D (orbit.hpp's balance), whose eigenvector w is M's D w.
  ode::Matrix balanced = pd.orbit.monodromy;
  const ode::Vector d = balance(balanced);
  const Eigen::EigenSolver<ode::Matrix> eig(balanced);
  Eigen::Index k = 0;
  for (Eigen::Index i = 1; i < eig.eigenvalues().size(); ++i)
    if (std::abs(eig.eigenvalues()[i] + 1.0) < std::abs(eig.eigenvalues()[k] + 1.0)) k = i;
  const ode::Vector v = d.cwiseProduct(eig.eigenvectors().col(k).real());
  const double lo = std::min(o.from, o.to), hi = std::max(o.from, o.to);
  const double step = kSwitchStep * (hi - lo);
  for (const double side : {1.0, -1.0}) {
    const double p = pd.param + side * step;
    if (p <= lo || p >= hi) continue;
    Case c = base;
    set_case_value(c, {o.key, fmt::format("{:.17g}", p)});
    // One period N, one segment: the test that an orbit found is not the period-N one again.
    const std::size_t mesh = mesh_to_read(c, o.mesh);
    const auto single =
        family(c, o.orbit.periods, 1, ode::Vector{}, c.solver.tolerance, nullptr, mesh);
    const ode::Vector& scale = single->shooting().scale();
    const ode::Vector dir = v.cwiseQuotient(scale).normalized();  // in scaled units
    OrbitOptions oo = o.orbit;
    oo.periods = 2 * o.orbit.periods;
    oo.segments = 2 * (o.orbit.segments > 0 ? o.orbit.segments : o.orbit.periods);
    for (const double amount : kSwitchDisplacements)
      for (const double sign : {1.0, -1.0}) {
        const ode::Vector y = pd.orbit.unknowns + sign * amount * dir.cwiseProduct(scale);
        const std::optional<BranchOrbit> orbit = orbit_from(c, oo, y, scale, mesh);
        if (!orbit) continue;
        ode::Vector f;
        std::string why;
        if (!single->shooting().residual(single->shooting().scaled(orbit->unknowns), f, nullptr,
                                         nullptr, why))
          continue;
        if (f.lpNorm<Eigen::Infinity>() > kDistinctOrbit)
          return Switch{p, *orbit, side > 0 ? hi : lo};
      }
  }
  return std::nullopt;
}

}  // namespace

ContinuationResult continuation(const Case& c, const ContinuationOptions& options) {
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  // Both ends must be values the key allows (the start is checked where the branch begins).
  Case at_to = c;
  set_case_value(at_to,
                 {options.key, fmt::format("{}", options.to), fmt::format("--to {}", options.to)});
  if (const std::string why =
          unread_study_key(c, {{{options.key, fmt::format("{:.17g}", options.from),
                                 fmt::format("--from {}", options.from)}},
                               {{options.key, fmt::format("{:.17g}", options.to),
                                 fmt::format("--to {}", options.to)}}});
      !why.empty())
    throw InputError(
        fmt::format("--param {}: the continuation would vary a key this case does not read: {}",
                    options.key, why));
  const double lo = std::min(options.from, options.to), hi = std::max(options.from, options.to);
  const auto wall_start = std::chrono::steady_clock::now();
  Continuer k(c, options, lo, hi);
  ContinuationResult res = k.run();
  res.state_names = state_names(c);
  if (!one_degree(c))
    res.mesh = assembled_train(c).train().meshes[mesh_to_read(c, options.mesh)].name;
  const auto finish = [&]() -> ContinuationResult& {
    res.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    return res;
  };
  if (!options.follow_period_doubling || res.cancelled) return finish();
  int switches = 0;
  const std::vector<Bifurcation> found = res.bifurcations;
  for (const Bifurcation& b : found) {
    if (b.type != BifurcationType::kPeriodDoubling || switches >= kMaxBranchSwitches) continue;
    const std::optional<Switch> sw = switch_branch(c, options, b);
    if (!sw) {
      res.message +=
          fmt::format("; no period-doubled orbit found next to {} = {:.12g}", options.key, b.param);
      continue;
    }
    ++switches;
    ContinuationOptions sub = options;
    sub.follow_period_doubling = false;
    sub.from = sw->param;
    sub.to = sw->toward;
    sub.orbit.periods = 2 * options.orbit.periods;
    sub.orbit.segments =
        2 * (options.orbit.segments > 0 ? options.orbit.segments : options.orbit.periods);
    sub.start = sw->orbit.state;
    Continuer ks(c, sub, lo, hi);
    ks.mark_doubled();
    ContinuationResult r2 = ks.run();
    for (BranchPoint& p : r2.points) {
      p.branch = switches;
      res.points.push_back(std::move(p));
    }
    for (Bifurcation& x : r2.bifurcations) {
      x.branch = switches;
      res.bifurcations.push_back(std::move(x));
    }
    res.message += fmt::format("; period-doubled branch {} from {} = {:.12g}: {}", switches,
                               options.key, b.param, r2.message);
    res.cancelled = r2.cancelled;
    if (res.cancelled) break;
  }
  return finish();
}

}  // namespace geardyn
