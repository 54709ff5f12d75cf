#include "geardyn/adaptive.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <boost/math/tools/toms748_solve.hpp>
#include <boost/numeric/odeint.hpp>
#include <cassert>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace geardyn::ode {
namespace {

using Values = std::vector<double>;  // the stepper's state type

// y' = A_r(t) y + u_r(t) of one region. The time-varying parts are sparse (a mesh's stiffness
// joins two bodies), so they are kept as their non-zero entries, each with its cos and sin
// coefficients, and the cosines and sines are computed once per call per frequency.
class Derivative {
 public:
  Derivative(const LinearSwitchedSystem& s, int region) : r_(s.region(region)), n_(s.dimension) {
    const std::size_t nf = s.frequencies_rad_s.size();
    for (std::size_t f = 0; f < nf; ++f) {
      Terms t{s.frequencies_rad_s[f], {}, {}};
      if (f < r_.a.cos.size())
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
  }
  void operator()(const Values& x, Values& dx, double t) const {
    const Eigen::Map<const Vector> y(x.data(), n_);
    dx.resize(x.size());
    Eigen::Map<Vector> out(dx.data(), n_);
    out.noalias() = r_.a.constant * y;
    out += r_.u.constant;
    for (const Terms& f : terms_) {
      const double c = std::cos(f.w * t), sn = std::sin(f.w * t);
      for (const Entry& e : f.matrix) out(e.i) += (c * e.c + sn * e.s) * y(e.j);
      for (const Entry& e : f.forcing) out(e.i) += c * e.c + sn * e.s;
    }
  }

 private:
  struct Entry {
    Eigen::Index i, j;
    double c, s;
  };
  struct Terms {
    double w;
    std::vector<Entry> matrix, forcing;
  };
  const LinearRegion& r_;
  Eigen::Index n_;
  std::vector<Terms> terms_;
};

// A guard counts as crossed below this fraction of its scale (the exact engine's slack).
double crossed_below(const LinearGuard& g) { return -kGuardSlack * g.scale; }

}  // namespace

FlowResult adaptive_flow(const LinearSwitchedSystem& system, double t0, const Vector& y0,
                         int region, double t1, const OutputGrid& output, FlowObserver& observer,
                         const AdaptiveOptions& options) {
  namespace odeint = boost::numeric::odeint;
  assert(system.validate().empty());
  if (std::string e = check_flow_arguments(system, t0, y0, region, t1); !e.empty())
    throw std::invalid_argument(e);
  const Eigen::Index n = system.dimension;
  // Each region's right-hand side and guards, made when the flow first enters it (a train's
  // 3^meshes regions are mostly never visited).
  const auto count = static_cast<std::size_t>(system.region_count());
  std::vector<std::unique_ptr<Derivative>> rhs(count);
  std::vector<std::unique_ptr<FunctionalValues>> guards(count);
  const auto rhs_of = [&](int r) -> const Derivative& {
    auto& d = rhs[static_cast<std::size_t>(r)];
    if (!d) d = std::make_unique<Derivative>(system, r);
    return *d;
  };
  const auto guards_of = [&](int r) -> const FunctionalValues& {
    auto& g = guards[static_cast<std::size_t>(r)];
    if (!g) g = std::make_unique<FunctionalValues>(system, system.region(r).guards);
    return *g;
  };
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
  sample_until(t0, true);
  while (t < t1) {
    if (++steps % options.progress_interval_steps == 0 && !observer.on_progress(t))
      return finish(Termination::kCancelled, fmt::format("cancelled at t = {:.6g} s", t));
    if (steps > options.max_steps)
      return finish(Termination::kStepUnderflow,
                    fmt::format("more than {} steps by t = {:.6g} s", options.max_steps, t));
    const Derivative& f = rhs_of(region);
    stepper.do_step([&f](const Values& s, Values& ds, double tt) { f(s, ds, tt); });
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
    int crossed = -1;
    double tc = te;
    for (std::size_t i = 0; i < gs.size(); ++i) {
      if (!(values[i] < crossed_below(gs[i]))) continue;
      const std::vector<LinearGuard> single = {gs[i]};
      const FunctionalValues one(system, single);
      std::vector<double> v;
      const auto g = [&](double tt) {
        stepper.calc_state(tt, xs);
        one(tt, as_vector(xs), v);
        return v[0] - crossed_below(gs[i]);
      };
      double at = te;
      const double ta = std::max(t, stepper.previous_time());
      if (g(ta) < 0) {
        at = ta;  // below at the step's start already: the region is left there
      } else {
        std::uintmax_t iterations = 100;
        at = boost::math::tools::toms748_solve(
                 g, ta, te, boost::math::tools::eps_tolerance<double>(50), iterations)
                 .second;
      }
      if (crossed < 0 || at < tc) {
        crossed = static_cast<int>(i);
        tc = at;
      }
    }
    if (crossed >= 0) {
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
    sample_until(te, true);
    x = xe;
    t = te;
    observer.on_step(t, as_vector(x), region);
  }
  return finish(Termination::kCompleted, "");
}

}  // namespace geardyn::ode
