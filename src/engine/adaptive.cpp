#include "geardyn/adaptive.hpp"

#include <fmt/format.h>

#include <Eigen/QR>
#include <algorithm>
#include <boost/numeric/odeint.hpp>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/guard_crossing.hpp"

namespace geardyn::ode {
namespace {

using Values = std::vector<double>;  // the stepper's state type
// A contact change is located in time to this many bits, in at most so many evaluations of the
// dense output (guard_crossing.hpp).
constexpr int kCrossingBits = 50;
constexpr std::uintmax_t kCrossingMaxIterations = 100;

}  // namespace

RegionDerivative::RegionDerivative(const LinearSwitchedSystem& s, int region)
    : r_(s.region(region)), n_(s.dimension) {
  const std::size_t nf = s.frequencies_rad_s.size();
  const Matrix& a0 = r_.a.constant;
  // The frequencies with a matrix term, the rows they touch and their non-zero entries.
  std::vector<std::size_t> varying;
  std::vector<bool> row_varies(static_cast<std::size_t>(n_), false);
  double entries = 0;
  for (std::size_t f = 0; f < r_.a.cos.size(); ++f) {
    bool any = false;
    for (Eigen::Index i = 0; i < n_; ++i)
      for (Eigen::Index j = 0; j < n_; ++j)
        if (r_.a.cos[f](i, j) != 0 || r_.a.sin[f](i, j) != 0) {
          any = true;
          row_varies[static_cast<std::size_t>(i)] = true;
          ++entries;
        }
    if (any) varying.push_back(f);
  }
  for (Eigen::Index i = 0; i < n_; ++i) {
    if (!row_varies[static_cast<std::size_t>(i)]) {
      Eigen::Index nonzero = 0, j = 0;
      for (Eigen::Index k = 0; k < n_; ++k)
        if (a0(i, k) != 0) {
          ++nonzero;
          j = k;
        }
      if (nonzero == 1 && a0(i, j) == 1.0) {
        copies_.emplace_back(i, j);
        continue;
      }
    }
    rows_.push_back(i);
  }
  a0_rows_ = a0(rows_, Eigen::all);
  const auto m = static_cast<Eigen::Index>(rows_.size());

  // The varying matrices' shared row space: the column space of their transposes side by side.
  if (!varying.empty()) {
    const auto nv = static_cast<Eigen::Index>(varying.size());
    Matrix w(n_, 2 * nv * n_);
    for (Eigen::Index k = 0; k < nv; ++k) {
      const std::size_t f = varying[static_cast<std::size_t>(k)];
      w.middleCols(2 * k * n_, n_) = r_.a.cos[f].transpose();
      w.middleCols((2 * k + 1) * n_, n_) = r_.a.sin[f].transpose();
    }
    const Eigen::ColPivHouseholderQR<Matrix> qr(w);
    const Eigen::Index r = qr.rank();
    const double dense = static_cast<double>(n_ * r + m * 2 * nv * r);
    if (r < n_ && dense < kSparseEntryCost * entries) {
      const Matrix q = qr.householderQ() * Matrix::Identity(n_, r);
      Matrix b(m, 2 * nv * r);
      double miss = 0, size = 0;
      for (Eigen::Index k = 0; k < nv; ++k) {
        const std::size_t f = varying[static_cast<std::size_t>(k)];
        for (int part = 0; part < 2; ++part) {
          const Matrix& a = part == 0 ? r_.a.cos[f] : r_.a.sin[f];
          const Matrix aq = a * q;
          miss = std::max(miss, (a - aq * q.transpose()).cwiseAbs().maxCoeff());
          size = std::max(size, a.cwiseAbs().maxCoeff());
          b.middleCols((2 * k + part) * r, r) = aq(rows_, Eigen::all);
        }
      }
      if (miss <= kLowRankTolerance * size) {
        q_ = q;
        b_rows_ = std::move(b);
        low_rank_f_ = varying;
      }
    }
  }
  for (std::size_t f = 0; f < nf; ++f) {
    Terms t{f, {}, {}};
    if (!low_rank() && f < r_.a.cos.size())
      for (Eigen::Index i = 0; i < n_; ++i)
        for (Eigen::Index j = 0; j < n_; ++j)
          if (r_.a.cos[f](i, j) != 0 || r_.a.sin[f](i, j) != 0)
            t.matrix.push_back({i, j, r_.a.cos[f](i, j), r_.a.sin[f](i, j)});
    if (f < r_.u.cos.size())
      for (Eigen::Index i = 0; i < n_; ++i)
        if (r_.u.cos[f](i) != 0 || r_.u.sin[f](i) != 0)
          t.forcing.push_back({i, 0, r_.u.cos[f](i), r_.u.sin[f](i)});
    if (!t.matrix.empty() || !t.forcing.empty()) terms_.push_back(std::move(t));
  }
  for (const std::size_t f : low_rank_f_) used_.push_back(f);
  for (const Terms& t : terms_)
    if (std::find(used_.begin(), used_.end(), t.f) == used_.end()) used_.push_back(t.f);
  w_ = s.frequencies_rad_s;
  cos_.assign(nf, 0.0);
  sin_.assign(nf, 0.0);
  qy_.resize(q_.cols());
  phases_.resize(b_rows_.cols());
  product_.resize(m);
}

void RegionDerivative::operator()(const double* y, double* dy, double t_s) const {
  const Eigen::Map<const Vector> x(y, n_);
  Eigen::Map<Vector> out(dy, n_);
  for (const std::size_t f : used_) {
    cos_[f] = std::cos(w_[f] * t_s);
    sin_[f] = std::sin(w_[f] * t_s);
  }
  product_.noalias() = a0_rows_ * x;
  if (low_rank()) {
    qy_.noalias() = q_.transpose() * x;
    const Eigen::Index r = q_.cols();
    for (std::size_t k = 0; k < low_rank_f_.size(); ++k) {
      const auto at = static_cast<Eigen::Index>(2 * k) * r;
      phases_.segment(at, r) = cos_[low_rank_f_[k]] * qy_;
      phases_.segment(at + r, r) = sin_[low_rank_f_[k]] * qy_;
    }
    product_.noalias() += b_rows_ * phases_;
  }
  for (const auto& [i, j] : copies_) out(i) = x(j);
  for (std::size_t k = 0; k < rows_.size(); ++k)
    out(rows_[k]) = product_(static_cast<Eigen::Index>(k));
  out += r_.u.constant;
  for (const Terms& f : terms_) {
    const double c = cos_[f.f], sn = sin_[f.f];
    for (const Entry& e : f.matrix) out(e.i) += (c * e.c + sn * e.s) * x(e.j);
    for (const Entry& e : f.forcing) out(e.i) += c * e.c + sn * e.s;
  }
}

FlowResult adaptive_flow(const LinearSwitchedSystem& system, double t0, const Vector& y0,
                         int region, double t1, const OutputGrid& output, FlowObserver& observer,
                         const AdaptiveOptions& options) {
  namespace odeint = boost::numeric::odeint;
  assert(system.validate().empty());
  if (std::string e = check_flow_arguments(system, t0, y0, region, t1); !e.empty())
    throw std::invalid_argument(e);
  const Eigen::Index n = system.dimension;
  // Each region's right-hand side and guards, made when the flow first enters it.
  PerRegion<RegionDerivative> rhs_of(system);
  PerRegion<RegionGuards> guards_of(system);
  FlowResult result;
  Values x(y0.data(), y0.data() + n), xe(x), xs(x);
  Vector y(n);
  const auto as_vector = [&](const Values& s) -> const Vector& {
    y = Eigen::Map<const Vector>(s.data(), n);
    return y;
  };
  std::vector<double> values;
  const auto guard_values = [&](double t, const Values& s) {
    guards_of(region)(t, as_vector(s), values);
  };
  auto stepper = odeint::make_dense_output(options.tolerance, options.tolerance,
                                           odeint::runge_kutta_dopri5<Values>());
  double t = t0;
  int stalled = 0;
  std::int64_t steps = 0;
  stepper.initialize(x, t, 1e-6 * std::max(t1 - t0, 1e-300));
  std::int64_t next = 0;
  const auto sample_until = [&](double te, bool inclusive) {
    while (next < output.count) {
      const double ts = output.time(next);
      if (ts > te || (!inclusive && ts == te)) break;
      if (ts >= t0) {
        if (ts == t) {
          observer.on_sample(ts, as_vector(x), region);
        } else {
          stepper.calc_state(ts, xs);
          observer.on_sample(ts, as_vector(xs), region);
        }
      }
      ++next;
    }
  };
  const auto finish = [&](Termination why, std::string message) {
    result.termination = why;
    result.message = std::move(message);
    result.end_time_s = t;
    result.state = Eigen::Map<const Vector>(x.data(), n);
    result.region = region;
    result.cells = steps;
    return result;
  };
  // The dense output's points inside (t, te), for the observer's extremes, in time order with
  // the samples among them.
  const auto points_until = [&](double te) {
    const int count = std::max(0, options.points_per_step);
    for (int k = 1; k <= count; ++k) {
      const double tp = t + (te - t) * k / (count + 1);
      if (!(tp > t && tp < te)) continue;
      sample_until(tp, false);
      stepper.calc_state(tp, xs);
      observer.on_point(tp, as_vector(xs), region);
    }
  };
  sample_until(t0, true);
  while (t < t1) {
    if (++steps % options.progress_interval_steps == 0 && !observer.on_progress(t))
      return finish(Termination::kCancelled, fmt::format("cancelled at t = {:.6g} s", t));
    if (steps > options.max_steps)
      return finish(Termination::kStepUnderflow,
                    fmt::format("more than {} steps by t = {:.6g} s", options.max_steps, t));
    const RegionDerivative& f = rhs_of(region);
    stepper.do_step([&f, n](const Values& s, Values& ds, double tt) {
      ds.resize(static_cast<std::size_t>(n));
      f(s.data(), ds.data(), tt);
    });
    double te = std::min(stepper.current_time(), t1);
    stepper.calc_state(te, xe);
    if (!std::all_of(xe.begin(), xe.end(), [](double v) { return std::isfinite(v); }))
      return finish(Termination::kDiverged,
                    fmt::format("the state became non-finite after t = {:.6g} s", t));
    if (!(te > t) && te < t1)
      return finish(Termination::kStepUnderflow,
                    fmt::format("the step fell below what t = {:.6g} s can resolve", t));
    guard_values(te, xe);
    const std::vector<LinearGuard>& gs = system.region(region).guards;
    // The earliest crossing among the guards that ended the step below their slack.
    const GuardCrossing c = earliest_crossing(
        system, gs, values, std::max(t, stepper.previous_time()), te,
        [&](double tt, Vector& at) {
          stepper.calc_state(tt, xs);
          at = Eigen::Map<const Vector>(xs.data(), n);
          return tt;
        },
        kCrossingBits, kCrossingMaxIterations);
    const int crossed = c.guard;
    const double tc = c.at;
    if (crossed >= 0) {
      points_until(tc);
      stepper.calc_state(tc, xe);
      sample_until(tc, false);
      observer.on_step(tc, as_vector(xe), region);
      const int to = gs[static_cast<std::size_t>(crossed)].target;
      observer.on_event(tc, as_vector(xe), region, to);
      stalled = tc - t < 1e-12 * (t1 - t0) ? stalled + 1 : 0;
      ++result.events;
      x = xe;
      t = tc;
      region = to;
      if (stalled > options.max_stalled_events)
        return finish(Termination::kNoProgress,
                      fmt::format("{} contact changes in a row at t = {:.9g} s without time "
                                  "advancing (a chattering contact)",
                                  stalled, t));
      stepper.initialize(x, t, stepper.current_time_step());
      sample_until(t, true);
      continue;
    }
    points_until(te);
    sample_until(te, true);
    x = xe;
    t = te;
    observer.on_step(t, as_vector(x), region);
  }
  return finish(Termination::kCompleted, "");
}

}  // namespace geardyn::ode
