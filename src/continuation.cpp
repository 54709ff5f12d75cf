#include "geardyn/continuation.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "geardyn/case_keys.hpp"
#include "geardyn/figures.hpp"
#include "geardyn/output.hpp"
#include "shooting.hpp"

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

// The contact sequence of one period, the grazing test's signature: cyclic, so the least of
// its rotations (an event that moves across the section time changes nothing).
std::vector<EventKind> signature(const Orbit& o) {
  std::vector<EventKind> s;
  for (const ContactEvent& e : o.sequence) s.push_back(e.kind);
  std::vector<EventKind> best = s;
  for (std::size_t i = 1; i < s.size(); ++i) {
    std::rotate(s.begin(), s.begin() + 1, s.end());
    best = std::min(best, s);
  }
  return best;
}

// det(M - sign I), real.
double shifted_determinant(const Orbit& o, double sign) {
  const auto n = o.monodromy.rows();
  return (o.monodromy - sign * ode::Matrix::Identity(n, n)).determinant();
}

// |mu|^2 - 1 of the complex pair (Neimark-Sacker test); nullopt without one.
std::optional<double> complex_pair_test(const Orbit& o) {
  for (const auto& m : o.multipliers)
    if (std::abs(m.imag()) > 1e-12 * std::max(1.0, std::abs(m))) return std::norm(m) - 1;
  return std::nullopt;
}

// A converged point of the branch: its unknowns, tangent and orbit.
struct Point {
  ode::Vector z;        // (x, p / p_scale)
  ode::Vector tangent;  // unit, pointing onward
  Orbit orbit;
  int iterations = 0;
};

class Continuer {
 public:
  // The branch stays within [lo, hi] (from and to, or wider for a switched branch that may
  // run back past its start to the period doubling it came from).
  Continuer(const Case& base, const ContinuationOptions& o, double lo, double hi)
      : base_(base), o_(o), p_scale_(hi - lo), lo_(lo), hi_(hi) {
    segments_ = o.orbit.segments > 0 ? o.orbit.segments : o.orbit.periods;
    engine_tolerance_ =
        std::min(base.solver.tolerance, o.orbit.tolerance * detail::kEngineToleranceFraction);
  }

  double param(const ode::Vector& z) const { return z[z.size() - 1] * p_scale_; }

  Case case_at(double p) const {
    Case c = base_;
    try {
      set_case_value(c, {o_.key, fmt::format("{:.17g}", p)});
    } catch (const InputError& e) {
      throw InputError(fmt::format("--param {} at {}: {}", o_.key, p, e.what()));
    }
    return c;
  }

  std::unique_ptr<detail::Shooting> shooting(double p) const {
    return std::make_unique<detail::Shooting>(case_at(p), o_.orbit.periods, segments_, scale_,
                                              engine_tolerance_);
  }

  // The first point: find_orbit at `from`, then one correction at fixed p.
  bool start(Point& pt, std::string& why) {
    const Case c0 = case_at(o_.from);
    OrbitOptions oo = o_.orbit;
    oo.segments = segments_;
    const Orbit first = find_orbit(c0, oo, o_.start);
    if (!first.converged) {
      why = fmt::format("no orbit at {} = {:.17g}: {}", o_.key, o_.from, first.message);
      return false;
    }
    {
      const GearPairModel m0 = build_model(c0);
      scale_ = detail::orbit_scale(m0);
    }
    const auto s = shooting(o_.from);
    ode::Vector y0(2), x;
    y0 << first.state.q, first.state.v;
    if (!s->guess(y0, x, why)) return false;
    const Eigen::Index n = x.size();
    ode::Vector z(n + 1);
    z << x, o_.from / p_scale_;
    ode::Vector along = ode::Vector::Zero(n + 1);
    along[n] = o_.to > o_.from ? 1.0 : -1.0;
    if (!correct(z, along, pt, why)) return false;
    return tangent(pt, along, why);
  }

  // Newton on F(z) = 0, t . (z - z_pred) = 0 from z_pred. Fills pt.z, pt.orbit (read) and
  // pt.iterations, and leaves dF/dx and dF/dp at pt.z for its tangent; false with `why`.
  bool correct(const ode::Vector& z_pred, const ode::Vector& t, Point& pt, std::string& why) {
    ode::Vector z = z_pred, f, step;
    const Eigen::Index n = z.size() - 1;
    ode::Matrix jac(n + 1, n + 1);
    std::vector<ode::Matrix> seg;
    for (int it = 0;; ++it) {
      const auto s = shooting(param(z));
      if (!s->residual(z.head(n), f, &last_jx_, &seg, why) || !param_derivative(z, why))
        return false;
      const double norm = f.lpNorm<Eigen::Infinity>();
      const double plane = t.dot(z - z_pred);
      if (norm <= o_.orbit.tolerance && std::abs(plane) <= o_.orbit.tolerance) {
        pt.z = z;
        pt.iterations = it;
        return s->read(z.head(n), seg, pt.orbit, why);
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

  // dF/d(p / p_scale) at z by central differences, into last_fp_.
  bool param_derivative(const ode::Vector& z, std::string& why) {
    const Eigen::Index n = z.size() - 1;
    const double p = param(z), h = kParamStep * p_scale_;
    ode::Vector fp, fm;
    if (!shooting(p + h)->residual(z.head(n), fp, nullptr, nullptr, why) ||
        !shooting(p - h)->residual(z.head(n), fm, nullptr, nullptr, why))
      return false;
    last_fp_ = (fp - fm) * (p_scale_ / (2 * h));
    return true;
  }

  // A period-doubled branch (its orbits of period 2N on an even number of segments) ends where
  // it meets the period-N branch again: there the state after half the period is the start.
  void mark_doubled() { doubled_ = segments_ % 2 == 0; }
  double half_period_gap(const ode::Vector& z) const {
    return (z.segment(0, 2) - z.segment(Eigen::Index{2} * (segments_ / 2), 2))
        .lpNorm<Eigen::Infinity>();
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
    const auto sig_a = signature(a.orbit), sig_b = signature(b.orbit);
    if (sig_a != sig_b) {
      const Point g = locate(a, b, ds, [&](const Point& m) { return signature(m.orbit) == sig_a; });
      out.push_back({BifurcationType::kGrazing, param(g.z), 0, g.orbit,
                     fmt::format("impacts per period {} -> {}, separations {} -> {}",
                                 a.orbit.reading.impacts, b.orbit.reading.impacts,
                                 a.orbit.reading.separations, b.orbit.reading.separations)});
      return;  // the multipliers jump at a grazing: their tests would read that jump
    }
    auto sign_test = [&](BifurcationType type, auto test, const std::string& detail) {
      const double ta = test(a.orbit), tb = test(b.orbit);
      if (!(ta * tb < 0)) return;
      const Point m = locate(a, b, ds, [&](const Point& q) { return test(q.orbit) * ta > 0; });
      out.push_back({type, param(m.z), 0, m.orbit, detail});
    };
    const double turn = a.tangent[a.tangent.size() - 1] * b.tangent[b.tangent.size() - 1];
    sign_test(
        turn < 0 ? BifurcationType::kFold : BifurcationType::kBranchPoint,
        [](const Orbit& o) { return shifted_determinant(o, 1.0); }, "a multiplier through +1");
    sign_test(
        BifurcationType::kPeriodDoubling,
        [](const Orbit& o) { return shifted_determinant(o, -1.0); }, "a multiplier through -1");
    const auto na = complex_pair_test(a.orbit), nb = complex_pair_test(b.orbit);
    if (na && nb)
      sign_test(
          BifurcationType::kNeimarkSacker,
          [](const Orbit& o) { return complex_pair_test(o).value_or(0.0); },
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
    while (static_cast<int>(res.points.size()) < o_.max_points) {
      Point next;
      bool ok = correct(cur.z + ds * cur.tangent, cur.tangent, next, why) &&
                tangent(next, cur.tangent, why);
      if (ok && next.tangent.dot(cur.tangent) < kMinTangentCosine && ds > o_.min_step) {
        ok = false;
        why = "the branch turns too sharply for the step";
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
        detect(cur, next, ds, found);
        for (Bifurcation& b : found)
          if (b.param >= lo_ && b.param <= hi_) res.bifurcations.push_back(std::move(b));
      }
      const double p = param(next.z);
      if (p > hi_ || p < lo_) {
        // Past an end: the last point on it, at p fixed.
        const double end = p > hi_ ? hi_ : lo_;
        const bool past_to = end == o_.to;
        const double frac = (end - param(cur.z)) / (p - param(cur.z));
        ode::Vector along = ode::Vector::Zero(next.z.size());
        along[along.size() - 1] = 1;
        ode::Vector z = cur.z + frac * (next.z - cur.z);
        z[z.size() - 1] = end / p_scale_;
        Point last;
        if (correct(z, along, last, why))
          res.points.push_back({end, 0, o_.orbit.periods, last.orbit});
        if (past_to) {
          res.completed = true;
          return done(fmt::format("reached {} = {:.12g}", o_.key, o_.to));
        }
        return done(fmt::format("the branch turned back to {} = {:.12g}", o_.key, end));
      }
      res.points.push_back({p, 0, o_.orbit.periods, next.orbit});
      if (doubled_ && half_period_gap(next.z) < kDistinctOrbit)
        return done(
            fmt::format("the period-doubled branch returned to the period doubling at "
                        "{} = {:.12g}",
                        o_.key, p));
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
  double p_scale_, lo_, hi_;
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

std::string branch_csv(const ContinuationResult& r) {
  std::string s =
      "param,stable,x_a,min_delta_bar,max_delta_bar,max_force_bar,impacts_per_period,"
      "max_multiplier,min_force_bar,backside_impacts_per_period,separations_per_period,delta_m,"
      "velocity_m_s,mu1_re,mu1_im,mu2_re,mu2_im,branch,periods\n";
  for (const BranchPoint& p : r.points) {
    const Orbit& o = p.orbit;
    const RunReading& x = o.reading;
    fmt::format_to(std::back_inserter(s), "{:.17g},{},{:.17g},{:.17g},{:.17g},{:.17g},{},{:.17g},",
                   p.param, o.stable ? 1 : 0, p.amplitude(), x.min_delta_bar, x.max_delta_bar,
                   x.max_force_bar, x.impacts, o.max_multiplier());
    fmt::format_to(std::back_inserter(s), "{:.17g},{},{},{:.17g},{:.17g}", x.min_force_bar,
                   x.backside_impacts, x.separations, o.state.q, o.state.v);
    for (std::size_t i = 0; i < 2; ++i) {
      const std::complex<double> m = i < o.multipliers.size() ? o.multipliers[i] : 0.0;
      fmt::format_to(std::back_inserter(s), ",{:.17g},{:.17g}", m.real(), m.imag());
    }
    fmt::format_to(std::back_inserter(s), ",{},{}\n", p.branch, p.periods);
  }
  return s;
}

std::string bifurcations_json(const ContinuationResult& r) {
  nlohmann::json a = nlohmann::json::array();
  for (const Bifurcation& b : r.bifurcations) {
    nlohmann::json mu = nlohmann::json::array();
    for (const auto& m : b.orbit.multipliers) mu.push_back({m.real(), m.imag()});
    a.push_back({{"type", to_string(b.type)},
                 {"param", b.param},
                 {"branch", b.branch},
                 {"detail", b.detail},
                 {"x_a", 0.5 * (b.orbit.reading.max_delta_bar - b.orbit.reading.min_delta_bar)},
                 {"impacts_per_period", b.orbit.reading.impacts},
                 {"state", {b.orbit.state.q, b.orbit.state.v}},
                 {"floquet_multipliers", mu}});
  }
  return a.dump(2) + "\n";
}

namespace {

// overlay.csv (direction,value,x_a) from a sweep.csv's direction, value and pp_delta_bar.
std::string sweep_overlay(const std::string& sweep_csv) {
  std::istringstream in(sweep_csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  {
    std::istringstream h(line);
    for (std::string cell; std::getline(h, cell, ',');) header.push_back(cell);
  }
  const auto column = [&](const char* name) {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end())
      throw InputError(fmt::format(
          "--overlay-sweep: the sweep file has no column {} (is it a geardyn sweep.csv?)", name));
    return static_cast<std::size_t>(it - header.begin());
  };
  const std::size_t cd = column("direction"), cv = column("value"), cp = column("pp_delta_bar");
  std::string out = "direction,value,x_a\n";
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    if (cells.size() <= std::max({cd, cv, cp})) continue;
    fmt::format_to(std::back_inserter(out), "{},{},{:.10g}\n", cells[cd], cells[cv],
                   0.5 * std::strtod(cells[cp].c_str(), nullptr));
  }
  return out;
}

}  // namespace

void write_continuation(const std::filesystem::path& dir, const ContinuationResult& r,
                        const std::string& key, bool figures, const std::string& sweep_csv) {
  const std::string overlay = sweep_csv.empty() ? std::string{} : sweep_overlay(sweep_csv);
  std::string marks = "param,x_a,type\n";
  for (const Bifurcation& b : r.bifurcations)
    fmt::format_to(std::back_inserter(marks), "{:.17g},{:.17g},{}\n", b.param,
                   0.5 * (b.orbit.reading.max_delta_bar - b.orbit.reading.min_delta_bar),
                   to_string(b.type));
  std::vector<std::pair<std::string, std::string>> files{
      {"branch.csv", branch_csv(r)},
      {"bifurcations.json", bifurcations_json(r)},
      {"bifurcations.csv", marks}};
  if (!overlay.empty()) files.emplace_back("overlay.csv", overlay);
  write_files_atomically(dir, files);
  if (!figures || r.points.empty()) return;
  // Only what happened: a curve per branch and stability found, a mark per type found.
  std::vector<std::string> plots;
  int branches = 0;
  for (const BranchPoint& p : r.points) branches = std::max(branches, p.branch + 1);
  // One curve per branch and stability (a period-doubled branch in another colour), titled
  // once.
  bool titled_stable = false, titled_unstable = false;
  for (int b = 0; b < branches; ++b) {
    const char* colour = b == 0 ? "#1f3b73" : "#4a8f3c";
    for (const int stable : {1, 0}) {
      const bool present = std::any_of(r.points.begin(), r.points.end(), [&](const BranchPoint& p) {
        return p.branch == b && p.orbit.stable == (stable == 1);
      });
      if (!present) continue;
      bool& titled = stable ? titled_stable : titled_unstable;
      const std::string title =
          titled ? "notitle" : (stable ? "title 'stable'" : "title 'unstable'");
      titled = true;
      plots.push_back(fmt::format(
          "'branch.csv' every ::1 using 1:($18 == {0} && $2 == {1} ? $3 : NaN) with lines lw 2 "
          "{2}lc rgb '{3}' {4}",
          b, stable, stable ? "" : "dt 2 ", colour, title));
    }
  }
  const std::pair<BifurcationType, const char*> styles[] = {
      {BifurcationType::kFold, "pt 5 ps 1.3 lc rgb 'black'"},
      {BifurcationType::kBranchPoint, "pt 4 ps 1.3 lc rgb 'black'"},
      {BifurcationType::kPeriodDoubling, "pt 9 ps 1.5 lc rgb '#7a1f7a'"},
      {BifurcationType::kNeimarkSacker, "pt 11 ps 1.5 lc rgb '#1f7a3b'"},
      {BifurcationType::kGrazing, "pt 7 ps 1.1 lc rgb '#c08a00'"}};
  for (const auto& style : styles) {
    const BifurcationType type = style.first;
    const bool found = std::any_of(r.bifurcations.begin(), r.bifurcations.end(),
                                   [type](const Bifurcation& b) { return b.type == type; });
    if (found)
      plots.push_back(fmt::format(
          "'bifurcations.csv' every ::1 using 1:(strcol(3) eq '{0}' ? $2 : NaN) with points {1} "
          "title '{0}'",
          to_string(type), style.second));
  }
  for (const char* direction : {"up", "down"}) {
    if (overlay.find(std::string("\n") + direction + ",") == std::string::npos) continue;
    plots.push_back(fmt::format(
        "'overlay.csv' every ::1 using 2:(strcol(1) eq '{0}' ? $3 : NaN) with points pt {1} ps "
        "0.9 lc rgb '{2}' title 'sweep {0}'",
        direction, std::string(direction) == "up" ? 6 : 8,
        std::string(direction) == "up" ? "#555555" : "#b5532b"));
  }
  std::string body =
      "reset\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key top left font ',9'\n";
  fmt::format_to(std::back_inserter(body),
                 "set title 'periodic orbits: amplitude along {0}'\nset xlabel '{0}'\n"
                 "set ylabel 'x_a = (max - min)/2 of delta / b'\nplot ",
                 key);
  for (std::size_t i = 0; i < plots.size(); ++i) body += (i ? ", \\\n     " : "") + plots[i];
  body += "\n";
  render_figure(dir, "branch", body, 1000, 600);
}

namespace {

// The period-doubled orbit next to a period doubling `pd` of a branch of N-periodic orbits:
// Newton on 2N periods, just beyond pd.param on either side, from pd's state displaced along
// the eigenvector of the multiplier nearest -1. nullopt when no such orbit is found.
struct Switch {
  double param;
  Orbit orbit;
  double toward;  // the end of the range the new branch heads for
};
std::optional<Switch> switch_branch(const Case& base, const ContinuationOptions& o,
                                    const Bifurcation& pd) {
  const Eigen::EigenSolver<ode::Matrix> eig(pd.orbit.monodromy);
  Eigen::Index k = 0;
  for (Eigen::Index i = 1; i < eig.eigenvalues().size(); ++i)
    if (std::abs(eig.eigenvalues()[i] + 1.0) < std::abs(eig.eigenvalues()[k] + 1.0)) k = i;
  const ode::Vector v = eig.eigenvectors().col(k).real();
  const ode::Vector scale = detail::orbit_scale(build_model(base));
  const ode::Vector dir = v.cwiseQuotient(scale).normalized();  // in scaled units
  const double lo = std::min(o.from, o.to), hi = std::max(o.from, o.to);
  const double step = kSwitchStep * (hi - lo);
  for (const double side : {1.0, -1.0}) {
    const double p = pd.param + side * step;
    if (p <= lo || p >= hi) continue;
    Case c = base;
    set_case_value(c, {o.key, fmt::format("{:.17g}", p)});
    OrbitOptions oo = o.orbit;
    oo.periods = 2 * o.orbit.periods;
    oo.segments = 2 * (o.orbit.segments > 0 ? o.orbit.segments : o.orbit.periods);
    for (const double amount : kSwitchDisplacements)
      for (const double sign : {1.0, -1.0}) {
        const ode::Vector y = (ode::Vector(2) << pd.orbit.state.q, pd.orbit.state.v).finished() +
                              sign * amount * dir.cwiseProduct(scale);
        const Orbit orbit = find_orbit(c, oo, ode::State{0.0, y[0], y[1], 0.0, 0});
        if (!orbit.converged) continue;
        // A period-doubled orbit, not the period-N one again: one period N does not return.
        const detail::Shooting single(c, o.orbit.periods, 1, scale, c.solver.tolerance);
        ode::Vector f;
        std::string why;
        ode::Vector x = single.scaled((ode::Vector(2) << orbit.state.q, orbit.state.v).finished());
        if (!single.residual(x, f, nullptr, nullptr, why)) continue;
        if (f.lpNorm<Eigen::Infinity>() > kDistinctOrbit)
          return Switch{p, orbit, side > 0 ? hi : lo};
      }
  }
  return std::nullopt;
}

}  // namespace

ContinuationResult continuation(const Case& c, const ContinuationOptions& options) {
  if (const std::string e = options.validate(); !e.empty()) throw InputError(e);
  const double lo = std::min(options.from, options.to), hi = std::max(options.from, options.to);
  const auto wall_start = std::chrono::steady_clock::now();
  Continuer k(c, options, lo, hi);
  ContinuationResult res = k.run();
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
