// The piecewise-linear system's description (linear_system.hpp): its regions built on demand
// and checked, the Fourier terms evaluated, the phases of a frequency table kept per thread,
// and the affine functionals (guards, observables) with their bounds over a box of states.
#include "geardyn/linear_system.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

namespace geardyn::ode {

bool harmonic_of(double w_rad_s, double period_s, double fraction) {
  const double cycles = w_rad_s * period_s / (2 * std::numbers::pi);
  return std::abs(cycles - std::round(cycles)) <= fraction * std::max(1.0, cycles);
}

namespace {

// A Fourier series at t.
template <class T>
T evaluate(const FourierTerms<T>& x, const std::vector<double>& w, double t) {
  T v = x.constant;
  for (std::size_t f = 0; f < x.cos.size(); ++f) {
    v += x.cos[f] * std::cos(w[f] * t);
    v += x.sin[f] * std::sin(w[f] * t);
  }
  return v;
}

// What is wrong with region r of a system of R regions (validate()), "" when nothing.
std::string check_region(const LinearSwitchedSystem& sys, int r, const LinearRegion& g,
                         const LinearRegion& first) {
  const int n = sys.dimension, R = sys.region_count();
  const auto F = sys.frequencies_rad_s.size();
  auto terms_ok = [&](const auto& x, auto rows, auto cols) {
    auto fits = [&](const auto& m) { return m.rows() == rows && m.cols() == cols; };
    if (!fits(x.constant)) return false;
    if (!x.cos.empty() && (x.cos.size() != F || x.sin.size() != F)) return false;
    for (const auto& m : x.cos)
      if (!fits(m)) return false;
    for (const auto& m : x.sin)
      if (!fits(m)) return false;
    return true;
  };
  const double period = sys.coefficient_period_s;
  if (!terms_ok(g.a, n, n)) return fmt::format("region {}: A is not {} x {} per term", r, n, n);
  if (!terms_ok(g.u, n, 1)) return fmt::format("region {}: u is not of size {} per term", r, n);
  if (g.a.varies() && !(period > 0))
    return fmt::format("region {}: A varies but coefficient_period_s = {}", r, period);
  if (g.observables.size() != first.observables.size())
    return fmt::format("region {}: {} observables, region 0 has {}", r, g.observables.size(),
                       first.observables.size());
  for (std::size_t i = 0; i < g.observables.size(); ++i) {
    const LinearGuard& q = g.observables[i];
    if (!terms_ok(q.row, 1, n) ||
        (!q.offset.cos.empty() && (q.offset.cos.size() != F || q.offset.sin.size() != F)))
      return fmt::format("region {} observable {}: terms do not fit 1 x {}", r, i, n);
    if (q.row.varies() && !(period > 0))
      return fmt::format("region {} observable {}: row varies but coefficient_period_s = {}", r, i,
                         period);
  }
  for (std::size_t i = 0; i < g.guards.size(); ++i) {
    const LinearGuard& q = g.guards[i];
    if (!terms_ok(q.row, 1, n))
      return fmt::format("region {} guard {}: row is not 1 x {}", r, i, n);
    if (!q.offset.cos.empty() && (q.offset.cos.size() != F || q.offset.sin.size() != F))
      return fmt::format("region {} guard {}: offset terms do not match the frequencies", r, i);
    if (q.row.varies() && !(period > 0))
      return fmt::format("region {} guard {}: row varies but coefficient_period_s = {}", r, i,
                         period);
    if (q.target < 0 || q.target >= R || q.target == r)
      return fmt::format("region {} guard {}: target {} is not another region in [0, {})", r, i,
                         q.target, R);
    if (!(q.scale > 0))
      return fmt::format("region {} guard {}: scale {} must be > 0", r, i, q.scale);
  }
  // Every frequency that enters a coefficient must fit the coefficient period.
  if (period > 0) {
    for (std::size_t f = 0; f < F; ++f) {
      bool used = g.a.varies() && (g.a.cos[f].any() || g.a.sin[f].any());
      for (const LinearGuard& q : g.guards)
        if (q.row.varies() && (q.row.cos[f].any() || q.row.sin[f].any())) used = true;
      if (used && !harmonic_of(sys.frequencies_rad_s[f], period, kHarmonicFit))
        return fmt::format("frequency {} rad/s is not a multiple of 2 pi / {} s",
                           sys.frequencies_rad_s[f], period);
    }
  }
  return {};
}

template <class T>
bool is_zero(const T& x) {
  if constexpr (std::is_arithmetic_v<T>) {
    return x == 0;
  } else {
    return !x.any();
  }
}

template <class T>
void drop_if_zero(FourierTerms<T>& s) {
  const auto zero = [](const std::vector<T>& terms) {
    return std::all_of(terms.begin(), terms.end(), [](const T& x) { return is_zero(x); });
  };
  if (zero(s.cos) && zero(s.sin)) {
    s.cos.clear();
    s.sin.clear();
  }
}

}  // namespace

void drop_zero_terms(LinearRegion& region) {
  drop_if_zero(region.a);
  drop_if_zero(region.u);
  for (auto* list : {&region.guards, &region.observables})
    for (LinearGuard& g : *list) {
      drop_if_zero(g.row);
      drop_if_zero(g.offset);
    }
}

struct LazyRegionStore {
  int count = 0;
  std::function<LinearRegion(int)> build;
  std::vector<std::unique_ptr<LinearRegion>> built;
  std::unique_ptr<std::once_flag[]> once;
};

void LinearSwitchedSystem::make_lazy(int count, std::function<LinearRegion(int)> build) {
  regions.clear();
  lazy_ = std::make_shared<LazyRegionStore>();
  lazy_->count = count;
  lazy_->build = std::move(build);
  lazy_->built.resize(static_cast<std::size_t>(count));
  lazy_->once = std::make_unique<std::once_flag[]>(static_cast<std::size_t>(count));
}

int LinearSwitchedSystem::region_count() const {
  return lazy_ ? lazy_->count : static_cast<int>(regions.size());
}

const LinearRegion& LinearSwitchedSystem::region(int r) const {
  if (!lazy_) return regions[static_cast<std::size_t>(r)];
  LazyRegionStore& store = *lazy_;
  std::call_once(store.once[static_cast<std::size_t>(r)], [&] {
    auto made = std::make_unique<LinearRegion>(store.build(r));
    // Region 0 sets the count of observables every region has (checked against itself first).
    const LinearRegion& first = r == 0 ? *made : region(0);
    if (const std::string e = check_region(*this, r, *made, first); !e.empty())
      throw std::logic_error("linear system, built on demand: " + e);
    store.built[static_cast<std::size_t>(r)] = std::move(made);
  });
  return *store.built[static_cast<std::size_t>(r)];
}

std::string LinearSwitchedSystem::validate() const {
  const int n = dimension;
  if (n <= 0) return fmt::format("dimension = {}: must be >= 1", n);
  if (region_count() == 0) return "no regions";
  for (double w : frequencies_rad_s)
    if (!(w > 0) || !std::isfinite(w))
      return fmt::format("frequency {} rad/s: must be finite and > 0", w);
  if (lazy_) {
    try {
      region(0);  // built and checked; the others as they are asked for
    } catch (const std::logic_error& e) {
      return e.what();
    }
    return {};
  }
  for (int r = 0; r < region_count(); ++r)
    if (std::string e = check_region(*this, r, regions[static_cast<std::size_t>(r)], regions[0]);
        !e.empty())
      return e;
  return {};
}

std::string check_flow_arguments(const LinearSwitchedSystem& s, double t0_s, const Vector& y0,
                                 int region, double t1_s) {
  if (region < 0 || region >= s.region_count())
    return fmt::format("flow: region {} is not one of the system's {}", region, s.region_count());
  if (y0.size() != s.dimension)
    return fmt::format("flow: the initial state has {} entries, the system's dimension is {}",
                       y0.size(), s.dimension);
  if (!std::isfinite(t0_s) || !std::isfinite(t1_s) || t1_s < t0_s)
    return fmt::format("flow: from {} s to {} s: the times must be finite and t1 >= t0", t0_s,
                       t1_s);
  return {};
}

Vector derivative(const LinearSwitchedSystem& s, int region, double t_s, const Vector& y) {
  assert(region >= 0 && region < s.region_count() && y.size() == s.dimension);
  const LinearRegion& g = s.region(region);
  return evaluate(g.a, s.frequencies_rad_s, t_s) * y + evaluate(g.u, s.frequencies_rad_s, t_s);
}

RowVector guard_row(const LinearSwitchedSystem& s, int region, int guard, double t_s) {
  assert(region >= 0 && region < s.region_count() && guard >= 0 &&
         guard < static_cast<int>(s.region(region).guards.size()));
  return evaluate(s.region(region).guards[guard].row, s.frequencies_rad_s, t_s);
}

double guard_value(const LinearSwitchedSystem& s, int region, int guard, double t_s,
                   const Vector& y) {
  return functional_value(s, s.region(region).guards[guard], t_s, y);
}

double functional_value(const LinearSwitchedSystem& s, const LinearGuard& g, double t_s,
                        const Vector& y) {
  return evaluate(g.row, s.frequencies_rad_s, t_s).dot(y) +
         evaluate(g.offset, s.frequencies_rad_s, t_s);
}

namespace {
// phases_at's and GivenPhases' last table and time, on this thread: the phases phases_at
// computed (`direct`, of the table `w`, kept by value), or those a GivenPhases gave (of the
// table at `given_w`, both by address, while it lives).
struct KeptPhases {
  std::vector<double> w;
  double t_s = std::numeric_limits<double>::quiet_NaN();  // equal to no time
  Phases phases;
  bool direct = false;
  const std::vector<double>* given_w = nullptr;
  const Phases* given = nullptr;
};
thread_local KeptPhases kept_phases;
}  // namespace

GivenPhases::~GivenPhases() {
  KeptPhases& kept = kept_phases;
  if (!kept.given) return;
  kept.given = nullptr;
  kept.given_w = nullptr;
  kept.t_s = std::numeric_limits<double>::quiet_NaN();
}

void GivenPhases::give(const std::vector<double>& w, double t_s, const Phases& phases) {
  assert(phases.cos_wt.size() == w.size() && phases.sin_wt.size() == w.size());
  KeptPhases& kept = kept_phases;
  kept.given_w = &w;
  kept.given = &phases;
  kept.t_s = t_s;
  kept.direct = false;
}

const Phases* kept_direct_phases(const std::vector<double>& w, double t_s) {
  const KeptPhases& kept = kept_phases;
  return kept.direct && kept.t_s == t_s && kept.w == w ? &kept.phases : nullptr;
}

PhaseGrid::PhaseGrid(const std::vector<double>& w, double t0_s, double dt_s)
    : w_(&w),
      t0_s_(t0_s),
      dt_s_(dt_s),
      rot_cos_(w.size()),
      rot_sin_(w.size()),
      now_{std::vector<double>(w.size()), std::vector<double>(w.size())} {
  for (std::size_t f = 0; f < w.size(); ++f) {
    rot_cos_[f] = std::cos(w[f] * dt_s);
    rot_sin_[f] = std::sin(w[f] * dt_s);
    now_.cos_wt[f] = std::cos(w[f] * t0_s);
    now_.sin_wt[f] = std::sin(w[f] * t0_s);
  }
}

void PhaseGrid::advance(std::int64_t k) {
  const std::vector<double>& w = *w_;
  double* cos_wt = now_.cos_wt.data();
  double* sin_wt = now_.sin_wt.data();
  if (k % kResyncSteps == 0) {
    const double t = t0_s_ + static_cast<double>(k) * dt_s_;
    for (std::size_t f = 0; f < w.size(); ++f) {
      cos_wt[f] = std::cos(w[f] * t);
      sin_wt[f] = std::sin(w[f] * t);
    }
    return;
  }
  for (std::size_t f = 0; f < w.size(); ++f) {
    const double c = cos_wt[f] * rot_cos_[f] - sin_wt[f] * rot_sin_[f];
    sin_wt[f] = sin_wt[f] * rot_cos_[f] + cos_wt[f] * rot_sin_[f];
    cos_wt[f] = c;
  }
}

const Phases& phases_at(const std::vector<double>& w, double t_s) {
  KeptPhases& kept = kept_phases;
  // Given phases are of the table at their address (or an equal one) while their giver lives.
  if (kept.given) {
    if (kept.t_s == t_s && (kept.given_w == &w || *kept.given_w == w)) return *kept.given;
    kept.given = nullptr;
    kept.given_w = nullptr;
    kept.t_s = std::numeric_limits<double>::quiet_NaN();
  }
  if (!(kept.t_s == t_s && kept.w == w)) {
    kept.w = w;
    kept.t_s = t_s;
    kept.phases.cos_wt.resize(w.size());
    kept.phases.sin_wt.resize(w.size());
    for (std::size_t f = 0; f < w.size(); ++f) {
      kept.phases.cos_wt[f] = std::cos(w[f] * t_s);
      kept.phases.sin_wt[f] = std::sin(w[f] * t_s);
    }
    kept.direct = true;
  }
  return kept.phases;
}

FunctionalValues::FunctionalValues(const LinearSwitchedSystem& s,
                                   const std::vector<LinearGuard>& gs)
    : s_(&s), gs_(&gs) {
  for (const LinearGuard& g : gs) {
    // The frequencies the functional holds, in the table's order.
    std::vector<std::size_t> used;
    RowVector spread = RowVector::Zero(s.dimension);
    for (std::size_t f = 0; f < s.frequencies_rad_s.size(); ++f) {
      const bool row = f < g.row.cos.size() && (g.row.cos[f].any() || g.row.sin[f].any());
      const bool offset = f < g.offset.cos.size() && (g.offset.cos[f] != 0 || g.offset.sin[f] != 0);
      if (row) spread += g.row.cos[f].cwiseAbs() + g.row.sin[f].cwiseAbs();
      if (row || offset) used.push_back(f);
    }
    any_ = any_ || !used.empty();
    Functional x{entries_.size(), 0, g.offset.constant, 0, 0};
    // Each entry where the row varies: the terms of every frequency held, as functional_value
    // adds them (a frequency whose row terms are zero at this entry adds 0 c + 0 s there).
    for (Eigen::Index j = 0; j < s.dimension; ++j) {
      if (spread(j) == 0) continue;
      Entry e{j, g.row.constant(j), terms_.size(), 0};
      for (const std::size_t f : used)
        if (f < g.row.cos.size()) terms_.push_back({g.row.cos[f](j), g.row.sin[f](j), f});
      e.end = terms_.size();
      entries_.push_back(e);
    }
    x.entry_end = entries_.size();
    x.term_begin = terms_.size();
    for (const std::size_t f : used)
      if (f < g.offset.cos.size()) terms_.push_back({g.offset.cos[f], g.offset.sin[f], f});
    x.term_end = terms_.size();
    functionals_.push_back(x);
    // Where the row does not vary it is its constant at every time (0 + 0 c + 0 s = 0 there).
    rows_.push_back(g.row.constant);
  }
}

void FunctionalValues::operator()(double t_s, const Vector& y, std::vector<double>& values) const {
  assert(y.size() == s_->dimension);
  static const Phases kNone;  // no functional reads a harmonic
  const Phases& phases = any_ ? phases_at(s_->frequencies_rad_s, t_s) : kNone;
  const double* cos_wt = phases.cos_wt.data();
  const double* sin_wt = phases.sin_wt.data();
  // The operations of evaluate(), in its order, for the harmonics that are not zero: entry by
  // entry those of `row = constant; row += cos c; row += sin s` per frequency, where they
  // change anything; then the offset's.
  const std::size_t count = functionals_.size();
  if (values.size() != count) values.resize(count);
  const Term* terms = terms_.data();
  for (std::size_t i = 0; i < count; ++i) {
    const Functional& x = functionals_[i];
    RowVector& row = rows_[i];
    for (std::size_t k = x.entry_begin; k < x.entry_end; ++k) {
      const Entry& e = entries_[k];
      double v = e.constant;
      for (std::size_t m = e.begin; m < e.end; ++m) {
        v += terms[m].c * cos_wt[terms[m].f];
        v += terms[m].s * sin_wt[terms[m].f];
      }
      row(e.j) = v;
    }
    double offset = x.offset;
    for (std::size_t m = x.term_begin; m < x.term_end; ++m) {
      offset += terms[m].c * cos_wt[terms[m].f];
      offset += terms[m].s * sin_wt[terms[m].f];
    }
    values[i] = row.dot(y) + offset;
  }
}

namespace {
// A functional's harmonic (row and offset, cosine or sine) is its pattern scaled when each of
// its entries is within this fraction of the scaled pattern's, and zero where the pattern is:
// the rounding of products k_f times a geometric factor, far below any other harmonic's
// departure from it (FunctionalBounds; what is left out is added to the bound).
constexpr double kPatternTolerance = 1e-12;
}  // namespace

FunctionalBounds::FunctionalBounds(const LinearGuard& g) : offset_(g.offset.constant) {
  const RowVector& mid = g.row.constant;
  RowVector spread = RowVector::Zero(mid.size());
  for (std::size_t f = 0; f < g.row.cos.size(); ++f)
    spread += (g.row.cos[f].array().square() + g.row.sin[f].array().square()).sqrt().matrix();
  for (Eigen::Index j = 0; j < mid.size(); ++j) {
    if (spread[j] != 0) {
      varying_.emplace_back(j, mid[j] - spread[j], mid[j] + spread[j]);
      if (mid[j] != 0) varying_constant_.emplace_back(j, mid[j]);
    } else if (mid[j] != 0) {
      fixed_.emplace_back(j, mid[j]);
    }
  }
  for (std::size_t f = 0; f < g.offset.cos.size(); ++f)
    offset_spread_ += std::hypot(g.offset.cos[f], g.offset.sin[f]);
  // Each frequency's cos and sin coefficients (row entries and offset) where any is not zero.
  const std::size_t frequencies = std::max(g.row.cos.size(), g.offset.cos.size());
  for (std::size_t f = 0; f < frequencies; ++f) {
    Harmonic h;
    h.first = harmonic_entries_.size();
    if (f < g.offset.cos.size()) {
      h.offset_cos = g.offset.cos[f];
      h.offset_sin = g.offset.sin[f];
    }
    if (f < g.row.cos.size())
      for (Eigen::Index j = 0; j < mid.size(); ++j)
        if (g.row.cos[f][j] != 0 || g.row.sin[f][j] != 0)
          harmonic_entries_.emplace_back(j, g.row.cos[f][j], g.row.sin[f][j]);
    h.last = harmonic_entries_.size();
    if (h.last > h.first || h.offset_cos != 0 || h.offset_sin != 0) harmonics_.push_back(h);
  }
  // The harmonics as vectors (row entries, then the offset), cosines and sines in turn; the
  // pattern is the first not zero, each is its multiple lambda to kPatternTolerance, and the
  // scale of frequency f is hypot(lambda_cos, lambda_sin).
  const Eigen::Index n = mid.size();
  std::vector<RowVector> parts;
  for (std::size_t f = 0; f < frequencies; ++f)
    for (const bool cosine : {true, false}) {
      RowVector v = RowVector::Zero(n + 1);
      if (f < g.row.cos.size()) v.head(n) = cosine ? g.row.cos[f] : g.row.sin[f];
      if (f < g.offset.cos.size()) v(n) = cosine ? g.offset.cos[f] : g.offset.sin[f];
      parts.push_back(std::move(v));
    }
  const auto pattern = std::find_if(parts.begin(), parts.end(),
                                    [](const RowVector& v) { return (v.array() != 0).any(); });
  if (pattern == parts.end()) return;
  const RowVector p = *pattern;
  Eigen::Index at = 0;
  p.cwiseAbs().maxCoeff(&at);
  RowVector left_out = RowVector::Zero(n + 1);
  double scale = 0;
  for (std::size_t f = 0; f < frequencies; ++f) {
    double lambda[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
      const RowVector& v = parts[2 * f + static_cast<std::size_t>(k)];
      lambda[k] = v(at) / p(at);
      for (Eigen::Index i = 0; i <= n; ++i) {
        const double d = std::abs(v(i) - lambda[k] * p(i));
        if ((p(i) == 0 && v(i) != 0) || !(d <= kPatternTolerance * std::abs(lambda[k] * p(i))))
          return;  // no common pattern: each harmonic is bounded on its own
        left_out(i) += d;
      }
    }
    scale += std::hypot(lambda[0], lambda[1]);
  }
  one_pattern_ = true;
  pattern_scale_ = scale;
  pattern_offset_ = p(n);
  pattern_offset_left_out_ = left_out(n);
  for (Eigen::Index j = 0; j < n; ++j)
    if (p(j) != 0) pattern_.emplace_back(j, p(j), left_out(j));
}

void FunctionalBounds::bounds(const Vector& lo, const Vector& hi, double& low, double& high) const {
  // The constant entries, which both bounds below share.
  double fixed_low = 0, fixed_high = 0;
  for (const auto& [j, c] : fixed_) {
    const double p = c * lo[j], q = c * hi[j];
    fixed_low += std::min(p, q);
    fixed_high += std::max(p, q);
  }
  // Entry by entry: each varying entry over its whole range of values.
  low = fixed_low + offset_ - offset_spread_;
  high = fixed_high + offset_ + offset_spread_;
  for (const auto& [j, a, b] : varying_) {
    const double p[4] = {a * lo[j], a * hi[j], b * lo[j], b * hi[j]};
    low += std::min({p[0], p[1], p[2], p[3]});
    high += std::max({p[0], p[1], p[2], p[3]});
  }
  if (harmonics_.empty()) return;
  // Harmonic by harmonic: the constant part over the box, plus each frequency's amplitude
  // hypot(max |A|, max |B|) of its coefficients A = c . y + c0, B = s . y + s0 over the box.
  // A row and an offset that vary together (a mesh force k(t) (d - b)) then bound as one, where
  // entry by entry they bound apart. Either bound holds; their intersection is kept.
  const auto add = [&](double c, Eigen::Index j, double& l, double& h) {
    const double p = c * lo[j], q = c * hi[j];
    l += std::min(p, q);
    h += std::max(p, q);
  };
  double constant_low = fixed_low + offset_, constant_high = fixed_high + offset_;
  for (const auto& [j, c] : varying_constant_) add(c, j, constant_low, constant_high);
  double amplitude = 0;
  if (one_pattern_) {
    // Every harmonic is the pattern scaled: one interval of p y + p0 serves them all.
    double pl = pattern_offset_, ph = pattern_offset_, left_out = pattern_offset_left_out_;
    for (const auto& [j, c, d] : pattern_) {
      add(c, j, pl, ph);
      left_out += d * std::max(std::abs(lo[j]), std::abs(hi[j]));
    }
    amplitude = pattern_scale_ * std::max(std::abs(pl), std::abs(ph)) + left_out;
  } else {
    for (const Harmonic& h : harmonics_) {
      double cl = h.offset_cos, ch = h.offset_cos, sl = h.offset_sin, sh = h.offset_sin;
      for (std::size_t e = h.first; e < h.last; ++e) {
        const auto& [j, c, s] = harmonic_entries_[e];
        add(c, j, cl, ch);
        add(s, j, sl, sh);
      }
      // hypot's value without its cost (a bound taken every cell): the larger times
      // sqrt(1 + r^2), r <= 1, which neither overflows nor underflows.
      const double a = std::max(std::abs(cl), std::abs(ch)),
                   b = std::max(std::abs(sl), std::abs(sh));
      const double large = std::max(a, b), small = std::min(a, b);
      if (large > 0) amplitude += large * std::sqrt(1.0 + (small / large) * (small / large));
    }
  }
  low = std::max(low, constant_low - amplitude);
  high = std::min(high, constant_high + amplitude);
}
}  // namespace geardyn::ode
