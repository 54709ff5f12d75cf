#include "geardyn/newmark_flow.hpp"

#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/guard_crossing.hpp"

namespace geardyn::ode {
namespace {

// One region's acceleration a = B(t) (q, v) + s(t), B = [P R] the last N rows of A_r(t), s
// those of u_r(t), each as its Fourier series over the system's frequencies.
class RegionAcceleration {
 public:
  RegionAcceleration(const LinearSwitchedSystem& sys, int region)
      : r_(sys.region(region)), w_(sys.frequencies_rad_s) {
    if (std::string e = second_order_form_error(sys, region); !e.empty())
      throw std::invalid_argument(e);
    n_ = sys.dimension / 2;
    b0_ = r_.a.constant.bottomRows(n_);
    s0_ = r_.u.constant.tail(n_);
    for (std::size_t f = 0; f < r_.a.cos.size(); ++f) {
      bc_.push_back(r_.a.cos[f].bottomRows(n_));
      bs_.push_back(r_.a.sin[f].bottomRows(n_));
    }
    for (std::size_t f = 0; f < r_.u.cos.size(); ++f) {
      sc_.push_back(r_.u.cos[f].tail(n_));
      ss_.push_back(r_.u.sin[f].tail(n_));
    }
    for (std::size_t f = 0; f < bc_.size(); ++f)
      if (bc_[f].any() || bs_[f].any()) b_used_.push_back(f);
    for (std::size_t f = 0; f < sc_.size(); ++f)
      if (sc_[f].any() || ss_[f].any()) s_used_.push_back(f);
  }
  bool varies() const { return !b_used_.empty(); }
  // B and s at t into b (N x 2N, column-major) and s (N), summed over the frequencies whose
  // terms are not zero, entry by entry (a train's matrices are small: Eigen's expressions cost
  // more than the sums).
  void at(double t_s, double* b, double* s) const {
    const Eigen::Index b_size = b0_.size();
    std::copy(b0_.data(), b0_.data() + b_size, b);
    std::copy(s0_.data(), s0_.data() + n_, s);
    if (b_used_.empty() && s_used_.empty()) return;
    const Phases& phases = phases_at(w_, t_s);
    const std::vector<double>&cos_wt = phases.cos_wt, &sin_wt = phases.sin_wt;
    for (const std::size_t f : b_used_) {
      const double c = cos_wt[f], z = sin_wt[f];
      const double *mc = bc_[f].data(), *ms = bs_[f].data();
      for (Eigen::Index i = 0; i < b_size; ++i) b[i] += c * mc[i] + z * ms[i];
    }
    for (const std::size_t f : s_used_) {
      const double c = cos_wt[f], z = sin_wt[f];
      for (Eigen::Index i = 0; i < n_; ++i) s[i] += c * sc_[f](i) + z * ss_[f](i);
    }
  }
  Eigen::Index half() const { return n_; }

 private:
  const LinearRegion& r_;
  const std::vector<double>& w_;
  Eigen::Index n_ = 0;
  Matrix b0_;
  Vector s0_;
  std::vector<Matrix> bc_, bs_;
  std::vector<Vector> sc_, ss_;
  std::vector<std::size_t> b_used_, s_used_;  // the frequencies whose terms are not zero
};

// The step's vectors and matrices for N degrees of freedom: of fixed size for a small system
// (up to 6: Eigen's fixed-size products and factors, no allocation; a two-stage reducer's six
// bodies), dynamic (Eigen::Dynamic) above.
template <int N>
struct Sized {
  using Vec = Eigen::Matrix<double, N, 1>;
  using Mat = Eigen::Matrix<double, N, N>;
  using Rows = Eigen::Matrix<double, N, N == Eigen::Dynamic ? Eigen::Dynamic : 2 * N>;  // [P R]
};

// (q, v, a) at t, in a region.
template <int N>
struct Point {
  double t = 0;
  typename Sized<N>::Vec q, v, a;
  int region = 0;
};

// Cubic Hermite interpolation on [0, h] from end values and slopes, at s (integrator.hpp's).
template <class V>
V hermite(const V& y0, const V& dy0, const V& y1, const V& dy1, double h, double s) {
  V out(y0.size());
  for (Eigen::Index i = 0; i < y0.size(); ++i)
    out(i) = detail::hermite(y0(i), dy0(i), y1(i), dy1(i), h, s);
  return out;
}

// The flow itself (newmark_flow's contract), its steps in N degrees of freedom (n at run time,
// equal to N where N is fixed), n_steps of dt from t0.
template <int N>
FlowResult newmark_steps(const LinearSwitchedSystem& system, double t0, const Vector& y0,
                         int region, double t1, std::int64_t n_steps, double dt,
                         const OutputGrid& output, FlowObserver& observer, const NewmarkOptions& o);

}  // namespace

std::string second_order_form_error(const LinearSwitchedSystem& s, int region) {
  if (s.dimension % 2 != 0)
    return fmt::format("the Newmark method needs a second-order system, y = (q, v): dimension {}",
                       s.dimension);
  const Eigen::Index n = s.dimension / 2;
  const LinearRegion& r = s.region(region);
  const auto top_zero = [n](const auto& terms) {
    return std::all_of(terms.begin(), terms.end(),
                       [n](const auto& m) { return m.topRows(n).isZero(0.0); });
  };
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < s.dimension; ++j)
      if (r.a.constant(i, j) != (j == n + i ? 1.0 : 0.0))
        return fmt::format(
            "the Newmark method needs a second-order system: row {} of region {}'s A is not "
            "q'_{} = v_{}",
            i, region, i, i);
  if (!top_zero(r.a.cos) || !top_zero(r.a.sin) || !r.u.constant.head(n).isZero(0.0) ||
      !top_zero(r.u.cos) || !top_zero(r.u.sin))
    return fmt::format(
        "the Newmark method needs a second-order system: region {}'s rates q' vary or are forced",
        region);
  return {};
}

FlowResult newmark_flow(const LinearSwitchedSystem& system, double t0, const Vector& y0, int region,
                        double t1, double time_step_s, const OutputGrid& output,
                        FlowObserver& observer, const NewmarkOptions& o) {
  assert(system.validate().empty());
  if (std::string e = check_flow_arguments(system, t0, y0, region, t1); !e.empty())
    throw std::invalid_argument(e);
  if (!(time_step_s > 0) || !std::isfinite(time_step_s))
    throw std::invalid_argument(fmt::format(
        "newmark_flow: the time step must be positive and finite, not {}", time_step_s));
  const std::int64_t n_steps = std::max<std::int64_t>(
      1, static_cast<std::int64_t>(std::ceil((t1 - t0) / time_step_s - 1e-9)));
  const double dt = (t1 - t0) / static_cast<double>(n_steps);
  // The step of the system's degrees of freedom where a fixed size is compiled, else dynamic.
  using Steps =
      FlowResult (*)(const LinearSwitchedSystem&, double, const Vector&, int, double, std::int64_t,
                     double, const OutputGrid&, FlowObserver&, const NewmarkOptions&);
  static constexpr std::array<Steps, 7> kFixedSize = {
      nullptr,           &newmark_steps<1>, &newmark_steps<2>, &newmark_steps<3>,
      &newmark_steps<4>, &newmark_steps<5>, &newmark_steps<6>};
  const auto n = static_cast<std::size_t>(system.dimension / 2);
  const Steps steps =
      n >= 1 && n < kFixedSize.size() ? kFixedSize[n] : &newmark_steps<Eigen::Dynamic>;
  return steps(system, t0, y0, region, t1, n_steps, dt, output, observer, o);
}

namespace {

template <int N>
FlowResult newmark_steps(const LinearSwitchedSystem& system, double t0, const Vector& y0,
                         int region, double t1, std::int64_t n_steps, double dt,
                         const OutputGrid& output, FlowObserver& observer,
                         const NewmarkOptions& o) {
  using Vec = typename Sized<N>::Vec;
  using Mat = typename Sized<N>::Mat;
  using Rows = typename Sized<N>::Rows;
  using Point = geardyn::ode::Point<N>;
  // Each region's acceleration and guards, made when the flow first enters it; the whole
  // step's matrix of a region with constant coefficients, factorised once.
  PerRegion<RegionAcceleration> acceleration_of(system);
  PerRegion<RegionGuards> guards_of(system);
  std::vector<std::optional<Eigen::PartialPivLU<Mat>>> whole_step(
      static_cast<std::size_t>(system.region_count()));
  const Eigen::Index n = system.dimension / 2;

  Rows b = Rows::Zero(n, 2 * n);  // the sizes are checked against N where it is fixed
  Vec s = Vec::Zero(n);
  Vector y(2 * n);
  const auto state = [&y, n](const Point& p) -> const Vector& {
    y.head(n) = p.q;
    y.tail(n) = p.v;
    return y;
  };
  const auto p_of = [n](const Rows& m) { return m.template leftCols<N>(n); };
  const auto r_of = [n](const Rows& m) { return m.template rightCols<N>(n); };
  // a from the equation at (t, q, v) in p's region.
  const auto accelerate = [&](Point& p) {
    acceleration_of(p.region).at(p.t, b.data(), s.data());
    p.a = p_of(b) * p.q + r_of(b) * p.v + s;
  };
  // The step's predictors, right-hand side, matrix and its factors, kept across steps so that a
  // step allocates nothing.
  Vec qp = Vec::Zero(n), vp = qp, rhs = qp, rate_part = qp;
  Mat step_matrix = Mat::Zero(n, n);
  Eigen::PartialPivLU<Mat> factors(n);
  // The step of length h from p in p's region, to the time t_out (p.t + h, or the grid's time
  // that it rounds to); false where its matrix is singular.
  const auto step = [&](const Point& p, double h, double t_out, Point& out) {
    const RegionAcceleration& acc = acceleration_of(p.region);
    const double bh2 = o.beta * h * h, gh = o.gamma * h;
    qp = p.q + h * p.v + (0.5 - o.beta) * h * h * p.a;
    vp = p.v + (1.0 - o.gamma) * h * p.a;
    out.t = t_out;
    out.region = p.region;
    acc.at(out.t, b.data(), s.data());
    // P qp + R vp + s, summed in that order.
    rhs.noalias() = p_of(b) * qp;
    rate_part.noalias() = r_of(b) * vp;
    rhs += rate_part;
    rhs += s;
    // I - beta h^2 P - gamma h R.
    const auto matrix = [&]() -> const Mat& {
      step_matrix.setIdentity();
      step_matrix -= bh2 * p_of(b);
      step_matrix -= gh * r_of(b);
      return step_matrix;
    };
    auto& cached = whole_step[static_cast<std::size_t>(p.region)];
    if (h == dt && !acc.varies()) {
      if (!cached) cached.emplace(matrix());
      out.a = cached->solve(rhs);
    } else {
      factors.compute(matrix());
      out.a = factors.solve(rhs);
    }
    out.q = qp + bh2 * out.a;
    out.v = vp + gh * out.a;
    return out.a.allFinite();
  };

  FlowResult result;
  Point p{t0, y0.head(n), y0.tail(n), qp, region};
  accelerate(p);
  const auto finish = [&](Termination why, std::string message) {
    result.termination = why;
    result.message = std::move(message);
    result.end_time_s = p.t;
    result.state = state(p);
    result.region = p.region;
    return result;
  };
  std::int64_t next = 0;
  // The grid's samples in (from.t, to.t] (and at from.t itself when `inclusive`), interpolated
  // over the stretch from -> to of one region.
  const auto sample = [&](const Point& from, const Point& to, bool inclusive) {
    const double h = to.t - from.t;
    while (next < output.count) {
      const double ts = output.time(next);
      if (ts > to.t) break;
      if (ts >= from.t && (inclusive || ts > from.t || h == 0)) {
        if (ts == to.t || !(h > 0)) {
          observer.on_sample(ts, state(to), to.region);
        } else {
          const double at = ts - from.t;
          Point i;
          i.q = hermite(from.q, from.v, to.q, to.v, h, at);
          i.v = hermite(from.v, from.a, to.v, to.a, h, at);
          observer.on_sample(ts, state(i), to.region);
        }
      }
      ++next;
    }
  };
  // Skip the grid's times before the flow (a piece of a longer grid).
  while (next < output.count && output.time(next) < t0) ++next;
  sample(p, p, true);

  std::vector<double> values;
  Point trial, sub;
  // The phases at the grid's times, by rotation: the step's acceleration, its guards and the
  // observer's look at its end read them (phases_at hands them out while `given` lives).
  PhaseGrid phases(system.frequencies_rad_s, t0, dt);
  GivenPhases given;
  for (std::int64_t k = 1; k <= n_steps; ++k) {
    const double t_end = k == n_steps ? t1 : t0 + static_cast<double>(k) * dt;
    phases.advance(k);
    if (k < n_steps) given.give(system.frequencies_rad_s, t_end, phases.phases());
    int transitions = 0;
    for (;;) {
      const double h = transitions == 0 ? dt : t_end - p.t;
      // The step ends at the grid's t_end: its acceleration, guards and end are read there.
      if (!step(p, h, t_end, trial) || !trial.q.allFinite() || !trial.v.allFinite())
        return finish(Termination::kDiverged,
                      fmt::format("the state became non-finite after t = {:.6g} s", p.t));
      const RegionGuards& guards = guards_of(p.region);
      guards(t_end, state(trial), values);
      const std::vector<LinearGuard>& gs = guards.functionals();
      bool crossed = false;
      for (std::size_t i = 0; i < gs.size(); ++i) crossed |= values[i] < crossed_below(gs[i]);
      if (!crossed) break;
      if (transitions >= o.max_transitions_per_step) {
        ++result.unsplit_steps;
        break;
      }
      // The earliest crossing among the guards that ended the step below their slack.
      const GuardCrossing c = earliest_crossing(
          system, gs, values, 0.0, h,
          [&](double hh, Vector& y_at) {
            if (hh > 0) {
              step(p, hh, p.t + hh, sub);
            } else {
              sub = p;
            }
            y_at = state(sub);
            return p.t + hh;
          },
          kTransitionBits, kTransitionMaxIterations);
      const int first = c.guard;
      const double at_h = c.at;
      Point at = p;
      if (at_h > 0) {
        step(p, at_h, p.t + at_h, at);
        ++result.cells;
        sample(p, at, false);
        observer.on_step(at.t, state(at), at.region);
      }
      const int to = gs[static_cast<std::size_t>(first)].target;
      observer.on_event(at.t, state(at), p.region, to);
      ++result.events;
      ++transitions;
      p = at;
      p.region = to;
      accelerate(p);
    }
    ++result.cells;
    sample(p, trial, false);
    p = trial;
    observer.on_step(p.t, state(p), p.region);
    if (k % o.progress_interval_steps == 0 && !observer.on_progress(p.t))
      return finish(Termination::kCancelled, fmt::format("cancelled at t = {:.6g} s", p.t));
  }
  return finish(Termination::kCompleted, "");
}

}  // namespace

}  // namespace geardyn::ode
