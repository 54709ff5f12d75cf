#include "geardyn/orbit.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "geardyn/run.hpp"
#include "studies/shooting.hpp"

namespace geardyn {
namespace {

// Halvings of a Newton step before the iteration is declared stalled.
constexpr int kMaxBacktracks = 12;

}  // namespace

std::string OrbitOptions::validate() const {
  if (periods < 1 || periods > kMaxPeriodRatio)
    return fmt::format("--periods = {}: must be an integer in [1, {}]", periods, kMaxPeriodRatio);
  if (segments < 0 || segments > kMaxPeriodRatio)
    return fmt::format("--segments = {}: must be 0 (one per period) or an integer in [1, {}]",
                       segments, kMaxPeriodRatio);
  if (settle_periods < 0 || settle_periods > 1000000)
    return fmt::format("--settle-periods = {}: must be an integer in [0, 1000000]", settle_periods);
  if (!(tolerance >= 1e-14 && tolerance <= 1e-2))
    return fmt::format("--tolerance = {}: must be in [1e-14, 1e-2]", tolerance);
  if (starts < 1 || starts > 1000)
    return fmt::format("--starts = {}: must be an integer in [1, 1000]", starts);
  if (max_iterations < 1 || max_iterations > 1000)
    return fmt::format("--max-iterations = {}: must be an integer in [1, 1000]", max_iterations);
  return {};
}

double PeriodicSolution::max_multiplier() const {
  double m = 0;
  for (const auto& mu : multipliers) m = std::max(m, std::abs(mu));
  return m;
}

ode::Vector balance(ode::Matrix& m) {
  // A sweep ends when no scaling changes a row and column's norm sum by 5 % (LAPACK's test);
  // each sweep scales by powers of 2 whose exponents are bounded by the entries' range, so the
  // loop ends; kMaxBalanceSweeps is its checker.
  constexpr int kMaxBalanceSweeps = 1000;
  constexpr double kBalanceGain = 0.95;
  const Eigen::Index n = m.rows();
  ode::Vector d = ode::Vector::Ones(n);
  bool changed = true;
  for (int sweep = 0; changed && sweep < kMaxBalanceSweeps; ++sweep) {
    changed = false;
    for (Eigen::Index i = 0; i < n; ++i) {
      double c = 0, r = 0;
      for (Eigen::Index j = 0; j < n; ++j)
        if (j != i) {
          c += std::abs(m(j, i));
          r += std::abs(m(i, j));
        }
      if (c == 0 || r == 0 || !std::isfinite(c + r)) continue;
      const double sum = c + r;
      double f = 1;
      while (c < r / 2) {
        c *= 4;
        r /= 4;
        f *= 2;
      }
      while (c >= 2 * r) {
        c /= 4;
        r *= 4;
        f /= 2;
      }
      if (c + r < kBalanceGain * sum) {
        changed = true;
        d[i] *= f;
        m.col(i) *= f;
        m.row(i) /= f;
      }
    }
  }
  return d;
}

std::vector<std::complex<double>> floquet_multipliers(const ode::Matrix& monodromy) {
  ode::Matrix b = monodromy;
  balance(b);
  const Eigen::EigenSolver<ode::Matrix> eig(b, false);
  std::vector<std::complex<double>> mu;
  for (Eigen::Index i = 0; i < eig.eigenvalues().size(); ++i) mu.push_back(eig.eigenvalues()[i]);
  std::sort(mu.begin(), mu.end(),
            [](const auto& a, const auto& b) { return std::abs(a) > std::abs(b); });
  return mu;
}

namespace detail {

Case exact_case(const Case& c, double engine_tolerance) {
  Case e = c;
  e.solver.method = Method::kExact;
  e.solver.tolerance = std::max(engine_tolerance, kFinestEngineCaseTolerance);
  return e;
}

ode::Vector Segments::state(const ode::Vector& x, int i) const {
  const Eigen::Index d = state_dimension();
  return x.segment(d * i, d).cwiseProduct(scale_);
}

bool Segments::guess(const ode::Vector& y0, ode::Vector& x, std::string& why) const {
  const Eigen::Index d = state_dimension();
  x.resize(dimension());
  ode::Vector y = y0;
  for (int i = 0; i < segments_; ++i) {
    x.segment(d * i, d) = scaled(y);
    if (i + 1 == segments_) break;
    const ode::FlowResult r = flow(i, y);
    if (!r.ok()) {
      why = fmt::format("the first guess's flow failed ({}): {}", ode::to_string(r.termination),
                        r.message);
      return false;
    }
    y = r.state;
  }
  return true;
}

bool Segments::residual(const ode::Vector& x, ode::Vector& f, ode::Matrix* jacobian,
                        std::vector<ode::Matrix>* segment_jacobians, std::string& why) const {
  const Eigen::Index n = dimension(), d = state_dimension();
  f.resize(n);
  if (jacobian) jacobian->setZero(n, n);
  if (segment_jacobians) segment_jacobians->clear();
  for (int i = 0; i < segments_; ++i) {
    const ode::FlowResult r = flow(i, state(x, i));
    if (!r.ok()) {
      why = fmt::format("the flow of shooting segment {} failed ({}): {}", i,
                        ode::to_string(r.termination), r.message);
      return false;
    }
    const Eigen::Index at = d * i;
    const Eigen::Index next = d * ((i + 1) % segments_);
    f.segment(at, d) = scaled(r.state) - x.segment(next, d);
    if (jacobian) {
      // d(scaled phi_i)/dx_i = S^-1 J_i S; d/dx_next = -I.
      jacobian->block(at, at, d, d) +=
          scale_.cwiseInverse().asDiagonal() * *r.jacobian * scale_.asDiagonal();
      jacobian->block(at, next, d, d) -= ode::Matrix::Identity(d, d);
    }
    if (segment_jacobians) segment_jacobians->push_back(*r.jacobian);
  }
  return true;
}

NewtonOutcome solve_periodic(const Segments& s, ode::Vector& x, const OrbitOptions& options) {
  NewtonOutcome out;
  ode::Vector f, f_try, x_try, step;
  ode::Matrix jac;
  std::string why;
  if (!s.residual(x, f, &jac, &out.jacobians, why)) {
    out.message = why;
    return out;
  }
  // Backtracking on the residual's largest entry.
  double norm = f.lpNorm<Eigen::Infinity>();
  for (;;) {
    out.residual = norm;
    if (norm <= options.tolerance) break;
    if (out.iterations >= options.max_iterations) {
      out.message =
          fmt::format("no convergence in {} Newton iterations (residual {:.3g}, tolerance {:.3g})",
                      out.iterations, norm, options.tolerance);
      return out;
    }
    if (!solve_newton(jac, f, step)) {
      out.message = fmt::format(
          "the Newton matrix is singular at residual {:.3g}: a Floquet multiplier is 1 (a "
          "fold)",
          norm);
      return out;
    }
    ++out.iterations;
    double lambda = 1;
    bool accepted = false;
    why.clear();
    for (int b = 0; b <= kMaxBacktracks && !accepted; ++b, lambda *= 0.5) {
      x_try = x + lambda * step;
      if (!s.residual(x_try, f_try, nullptr, nullptr, why)) continue;
      accepted = f_try.lpNorm<Eigen::Infinity>() < norm;
    }
    if (!accepted) {
      out.message = fmt::format(
          "Newton stalled at residual {:.3g}: no step along the Newton direction lowers it "
          "(the start may be far from an orbit, or the orbit grazes a contact){}",
          norm, why.empty() ? "" : "; last failure: " + why);
      return out;
    }
    x = x_try;
    if (!s.residual(x, f, &jac, &out.jacobians, why)) {
      out.message = why;
      return out;
    }
    norm = f.lpNorm<Eigen::Infinity>();
  }
  out.converged = true;
  out.message = fmt::format("converged in {} Newton iterations to a residual of {:.3g}",
                            out.iterations, norm);
  return out;
}

std::string settling_failed(ode::Termination termination, const std::string& message) {
  return fmt::format("the settling simulation failed ({}): {}", ode::to_string(termination),
                     message);
}

NewtonOutcome solve_periodic_from_settled(
    const Segments& s, ode::Vector& x, const OrbitOptions& options,
    const std::function<bool(ode::Vector& x, std::string& why)>& next) {
  NewtonOutcome out = solve_periodic(s, x, options);
  int start = 1;
  std::string why;
  for (; start < options.starts && !out.converged; ++start) {
    if (!next(x, why)) break;
    const int before = out.iterations;
    out = solve_periodic(s, x, options);
    out.iterations += before;
  }
  if (out.converged && start > 1)
    out.message += fmt::format(" (start {} of {}: the settled state {} orbit period{} on)", start,
                               options.starts, start - 1, start == 2 ? "" : "s");
  if (!out.converged && (start > 1 || !why.empty()))
    out.message += fmt::format(" (from {} settled state{} one orbit period apart{})", start,
                               start == 1 ? "" : "s", why.empty() ? "" : "; the next: " + why);
  return out;
}

void floquet(const std::vector<ode::Matrix>& segment_jacobians, ode::Matrix& monodromy,
             std::vector<std::complex<double>>& multipliers) {
  const Eigen::Index d = segment_jacobians.empty() ? 0 : segment_jacobians.front().rows();
  monodromy = ode::Matrix::Identity(d, d);
  for (const ode::Matrix& j : segment_jacobians) monodromy = j * monodromy;
  multipliers = floquet_multipliers(monodromy);
}

bool solve_newton(const ode::Matrix& jacobian, const ode::Vector& f, ode::Vector& step) {
  const Eigen::FullPivLU<ode::Matrix> lu(jacobian);
  if (!lu.isInvertible()) return false;
  step = lu.solve(-f);
  return step.allFinite();
}

}  // namespace detail

namespace detail {

nlohmann::json periodic_json(const PeriodicSolution& o) {
  nlohmann::json j;
  j["converged"] = o.converged;
  j["message"] = o.message;
  j["iterations"] = o.iterations;
  j["residual"] = o.residual;
  j["period_s"] = o.period_s;
  j["periods"] = o.periods;
  j["system_period_s"] = o.system_period_s;
  j["segments"] = o.segments;
  nlohmann::json mu = nlohmann::json::array();
  for (const auto& m : o.multipliers) mu.push_back({m.real(), m.imag()});
  j["floquet_multipliers"] = mu;
  j["max_multiplier"] = o.max_multiplier();
  j["stable"] = o.stable;
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index r = 0; r < o.monodromy.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index k = 0; k < o.monodromy.cols(); ++k) row.push_back(o.monodromy(r, k));
    rows.push_back(row);
  }
  j["monodromy"] = rows;
  return j;
}

}  // namespace detail

std::string orbit_json(const Orbit& o, int indent) {
  nlohmann::json j = detail::periodic_json(o);
  j["state"] = {o.state.q, o.state.v};
  const int contact = contact_state(o.state.region);
  j["state_region"] = contact > 0 ? "drive contact" : contact < 0 ? "back contact" : "separated";
  j["impacts_per_period"] = o.reading.impacts;
  j["backside_impacts_per_period"] = o.reading.backside_impacts;
  j["separations_per_period"] = o.reading.separations;
  j["min_delta_bar"] = o.reading.min_delta_bar;
  j["max_delta_bar"] = o.reading.max_delta_bar;
  j["min_force_bar"] = o.reading.min_force_bar;
  j["max_force_bar"] = o.reading.max_force_bar;
  nlohmann::json seq = nlohmann::json::array();
  for (const auto& e : o.sequence)
    seq.push_back({{"t_s", e.t_s}, {"event", to_string(e.kind)}, {"velocity_m_s", e.velocity_m_s}});
  j["sequence"] = seq;
  return j.dump(indent);
}

}  // namespace geardyn
