#include "geardyn/steady.hpp"

#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numeric>
#include <utility>

namespace geardyn {
namespace {

// The smallest residual floor: rounding of delta / b ~ 1 over a period's arithmetic.
constexpr double kResidualFloor = 1e-12;

// The prediction is an estimate (a fitted rate), so a response is steady when it is under
// this fraction of the tolerance.
constexpr double kPredictionSafety = 0.5;

// A response steady as period q is of period d (a divisor of q) when its section states d
// periods apart differ by at most this many tolerances (two distances to the same fixed point
// and their error).
constexpr double kDivisorSlack = 3.0;

// Residuals whose directions are this close to parallel (the sine of their angle) are one
// real mode: the rate is then their length ratio.
constexpr double kParallelResiduals = 1e-6;

}  // namespace

SectionSeries::SectionSeries(double backlash_m, double omega_n_rad_s, double integration_tolerance)
    : b_(backlash_m),
      bw_(backlash_m * omega_n_rad_s),
      floor_(std::max(kResidualFloor, integration_tolerance)) {}

void SectionSeries::add(const ode::State& s) { x_.push_back({s.q / b_, s.v / bw_}); }

double SectionSeries::predicted_error(int q) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto norm = [](const Point& a) {
    return std::max(std::abs(a.delta), std::abs(a.velocity));
  };
  const auto n = static_cast<std::ptrdiff_t>(x_.size());
  const auto p = static_cast<std::ptrdiff_t>(q);
  if (n < 3 * p + 1) return kInf;
  const auto residual = [&](std::ptrdiff_t back) {  // x_(n-1-back) - x_(n-1-back-q)
    const Point& u = x_[static_cast<std::size_t>(n - 1 - back)];
    const Point& v = x_[static_cast<std::size_t>(n - 1 - back - p)];
    return Point{u.delta - v.delta, u.velocity - v.velocity};
  };
  const Point dc = residual(0), db = residual(p), da = residual(2 * p);
  if (norm(dc) <= floor_) return norm(dc);
  // A = [da db], B = [db dc], M = B A^-1.
  const double det = da.delta * db.velocity - db.delta * da.velocity;
  const double la = std::hypot(da.delta, da.velocity), lb = std::hypot(db.delta, db.velocity);
  if (!(la > 0 && lb > 0)) return kInf;
  if (std::abs(det) <= kParallelResiduals * la * lb) {
    const double rho = std::max(norm(dc) / norm(db), norm(db) / norm(da));
    return rho < 1 ? norm(dc) * rho / (1 - rho) : kInf;
  }
  const double m11 = (db.delta * db.velocity - dc.delta * da.velocity) / det;
  const double m12 = (dc.delta * da.delta - db.delta * db.delta) / det;
  const double m21 = (db.velocity * db.velocity - dc.velocity * da.velocity) / det;
  const double m22 = (dc.velocity * da.delta - db.velocity * db.delta) / det;
  // The spectral radius of the 2x2 M from its trace and determinant.
  const double tr = m11 + m22, dm = m11 * m22 - m12 * m21, disc = tr * tr / 4 - dm;
  const double rho = disc >= 0 ? std::abs(tr / 2) + std::sqrt(disc) : std::sqrt(std::max(dm, 0.0));
  if (!(rho < 1)) return kInf;
  // e = M (M - I)^-1 dc.
  const double a11 = m11 - 1, a22 = m22 - 1, d = a11 * a22 - m12 * m21;
  const double y1 = (a22 * dc.delta - m12 * dc.velocity) / d;
  const double y2 = (a11 * dc.velocity - m21 * dc.delta) / d;
  return std::max(norm({m11 * y1 + m12 * y2, m21 * y1 + m22 * y2}), floor_);
}

SteadyVerdict SectionSeries::judge(double tolerance) const {
  SteadyVerdict best;
  for (int q = 1; q <= kMaxSettledMultiple; ++q) {
    const double e = predicted_error(q);
    if (e <= kPredictionSafety * tolerance) {
      const Point& last = x_.back();
      for (int d = 1; d < q; ++d) {
        const Point& back = x_[x_.size() - 1 - static_cast<std::size_t>(d)];
        if (q % d == 0 &&
            std::max(std::abs(last.delta - back.delta), std::abs(last.velocity - back.velocity)) <=
                kDivisorSlack * tolerance)
          return {d, e};
      }
      return {q, e};
    }
    best.error = std::min(best.error, e);
  }
  return best;
}

SteadyVerdict judge_together(const std::vector<SectionSeries>& series, double tolerance) {
  SteadyVerdict all{1, 0.0};
  bool steady = true;
  for (const SectionSeries& s : series) {
    const SteadyVerdict v = s.judge(tolerance);
    all.error = std::max(all.error, v.error);
    if (!v.settled()) {
      steady = false;
    } else if (steady) {
      all.period_multiple = std::lcm(all.period_multiple, v.period_multiple);
    }
  }
  if (!steady || all.period_multiple > kMaxSettledMultiple) all.period_multiple = 0;
  return all;
}

double scaled_norm(const ode::Vector& v, const ode::Vector& scale) {
  return v.cwiseQuotient(scale).cwiseAbs().maxCoeff();
}

std::optional<AffineResponse> affine_response(const ode::Matrix& monodromy, const ode::Vector& y,
                                              const ode::Vector& image, const ode::Vector& scale) {
  const Eigen::Index n = y.size();
  // In scaled components: A = S^-1 (I - M) S.
  const ode::Matrix a = scale.cwiseInverse().asDiagonal() *
                        (ode::Matrix::Identity(n, n) - monodromy) * scale.asDiagonal();
  const Eigen::FullPivLU<ode::Matrix> lu(a);
  if (!lu.isInvertible()) return std::nullopt;
  const ode::Matrix inverse = lu.inverse();
  AffineResponse r;
  r.amplification = inverse.cwiseAbs().rowwise().sum().maxCoeff();
  if (!std::isfinite(r.amplification)) return std::nullopt;
  r.state = y + scale.asDiagonal() * (inverse * (image - y).cwiseQuotient(scale));
  return r;
}

const char* to_string(SteadyBasis b) {
  switch (b) {
    case SteadyBasis::kSettled:
      return "settled";
    case SteadyBasis::kNotSettled:
      return "not_settled";
    case SteadyBasis::kAperiodic:
      return "aperiodic";
    case SteadyBasis::kStatistics:
      return "statistics";
  }
  return "?";
}

SteadyStart integrate_watching(double t0, double t1, double period_s,
                               const std::function<SteadyVerdict()>& judge,
                               const std::function<bool(double)>& advance,
                               const std::function<void(double)>& mark) {
  SteadyStart out;
  out.error = std::numeric_limits<double>::infinity();
  const double t_half = t1 - kSteadyFraction * (t1 - t0);
  bool judging = period_s > 0;
  if (!judging) out.basis = SteadyBasis::kAperiodic;
  bool at_section = judging;       // the run stands at a section time
  double t = t0;                   // where the run has reached
  std::int64_t sections_done = 0;  // section times passed
  const auto mark_at = [&](double when) {
    out.from_s = when;
    out.marked = true;
    mark(when);
  };
  for (;;) {
    if (judging && at_section) {
      const SteadyVerdict v = judge();
      out.error = v.error;
      if (v.settled()) {
        out.basis = SteadyBasis::kSettled;
        out.period_multiple = v.period_multiple;
        mark_at(t);
        judging = false;
      } else if (t + 2 * period_s > t1) {
        judging = false;  // a steady part holds at least one period
      }
    }
    if (!out.marked && t >= t_half) mark_at(t);
    // The next stop: the next section time while judging, the final half's start, the end.
    const double next_section =
        judging ? t0 + static_cast<double>(sections_done + 1) * period_s : t1;
    double stop = std::min(next_section, t1);
    if (!out.marked && t_half < stop) stop = t_half;
    if (!advance(stop) || stop >= t1) break;
    t = stop;
    at_section = judging && stop == next_section;
    if (at_section) ++sections_done;
  }
  if (!out.marked) out.from_s = t_half;
  return out;
}

FlowPieces::FlowPieces(double t0, const ode::Vector& y0, int region, double t1,
                       const ode::OutputGrid& grid, Flow flow, std::function<bool(double)> progress)
    : t0_(t0),
      t_(t0),
      t1_(t1),
      grid_(grid),
      flow_(std::move(flow)),
      progress_(std::move(progress)) {
  total_.state = y0;
  total_.region = region;
  total_.end_time_s = t0;
}

bool FlowPieces::operator()(double stop) {
  const std::int64_t until = stop < t1_ ? grid_.count_until(stop) : grid_.count;
  const ode::OutputGrid piece = grid_.stretch(sampled_, std::max(until, sampled_));
  sampled_ = std::max(until, sampled_);
  ode::FlowResult f = flow_(t_, total_.state, total_.region, stop, piece);
  total_.termination = f.termination;
  total_.message = std::move(f.message);
  total_.cells += f.cells;
  total_.periods += f.periods;
  total_.events += f.events;
  total_.unsplit_steps += f.unsplit_steps;
  if (!f.ok()) return false;
  total_.state = std::move(f.state);
  total_.region = f.region;
  total_.end_time_s = f.end_time_s;
  t_ = stop;
  // A piece may be shorter than the engine's interval between progress calls.
  if (stop < t1_ && progress_ && !progress_((stop - t0_) / (t1_ - t0_))) {
    total_.termination = ode::Termination::kCancelled;
    total_.message = fmt::format("cancelled at t = {:.9g} s", stop);
    return false;
  }
  return true;
}

}  // namespace geardyn
