#include "geardyn/train_steadiness.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string_view>

namespace geardyn {

ExcitationRange excitation_range(const train::Assembled& a) {
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  const auto add = [&](double w) {
    lo = std::min(lo, w);
    hi = std::max(hi, w);
  };
  const auto series = [&](const HarmonicSeries& s) {
    for (const Harmonic& h : s.terms)
      if (h.amplitude != 0 && h.angular_frequency_rad_s > 0) add(h.angular_frequency_rad_s);
  };
  const train::Train& t = a.train();
  for (int m = 0; m < static_cast<int>(t.meshes.size()); ++m) {
    series(a.stiffness_series(m));
    series(a.error_series(m));
  }
  for (int q = 0; q < static_cast<int>(t.torques.size()); ++q) series(a.torque_series(q));
  for (const train::Speed& v : t.speeds)
    for (const train::SpeedHarmonic& h : v.harmonics)
      if (h.amplitude_rad != 0) add(h.order * 2 * std::numbers::pi * a.turning_hz(a.index(v.body)));
  return std::isfinite(lo) ? ExcitationRange{lo, hi} : ExcitationRange{};
}

double statistics_window_s(const train::Assembled& a) {
  const std::optional<double> t0 = a.system_period_s();
  const ExcitationRange w = excitation_range(a);
  if (!(w.slowest_rad_s > 0)) return 0;
  const double slowest = 2 * std::numbers::pi / w.slowest_rad_s;
  if (t0 && *t0 <= kMaxSectionPeriods * slowest) return 0;
  return slowest * std::ceil(kLeastFastCycles * w.slowest_rad_s / w.fastest_rad_s);
}

namespace {

// The mean and the standard deviation of column j of rows [first, end), over its scale.
struct Moments {
  double mean = 0, rms = 0;
  double deviation() const { return std::sqrt(std::max(rms * rms - mean * mean, 0.0)); }
};
template <class Rows>
Moments column_moments(const Rows& rows, std::size_t j, std::size_t first, std::size_t end) {
  double sum = 0, sum2 = 0;
  for (std::size_t i = first; i < end; ++i) {
    const double x = rows[i][static_cast<Eigen::Index>(j)];
    sum += x;
    sum2 += x * x;
  }
  const auto n = static_cast<double>(end - first);
  return {sum / n, std::sqrt(sum2 / n)};
}

void push_moments(const Moments& m, double scale, std::vector<WindowStatistic>& out) {
  out.push_back({m.mean, scale, kStatisticsTolerance});
  const double sd = m.deviation();
  out.push_back({sd, std::max(sd, kStatisticsTolerance * scale), kDynamicTolerance});
}

}  // namespace

std::vector<WindowStatistic> window_statistics(const TrainRunResult& r, std::size_t first,
                                               std::size_t end) {
  std::vector<WindowStatistic> out;
  const TrainSamples& s = r.samples;
  end = std::min(end, s.force_n.size());
  if (first >= end) return out;
  for (std::size_t m = 0; m < r.meshes.size(); ++m) {
    const TrainMeshReading& x = r.meshes[m];
    const double scale =
        std::max(std::abs(x.static_force_n.value_or(0.0)), x.backlash_m * x.mean_stiffness_n_per_m);
    push_moments(column_moments(s.force_n, m, first, end), scale, out);
  }
  if (s.parts.size() < end) return out;
  const std::vector<TrainPartQuantity> q = part_quantities(r);
  std::vector<Moments> moments(q.size());
  for (std::size_t j = 0; j < q.size(); ++j) moments[j] = column_moments(s.parts, j, first, end);
  // A quantity in N m (a shaft's torque, a moment) or in N.
  const auto torque = [&](std::size_t i) { return std::string_view(q[i].what).ends_with("_nm"); };
  std::array<double, 2> largest{0, 0};
  for (std::size_t i = 0; i < q.size(); ++i)
    largest[torque(i)] = std::max(largest[torque(i)], moments[i].rms);
  for (std::size_t j = 0; j < q.size(); ++j) {
    double scale = kNegligibleShare * largest[torque(j)];
    for (std::size_t i = 0; i < q.size(); ++i)
      if (q[i].part == q[j].part) scale = std::max(scale, moments[i].rms);
    push_moments(moments[j], scale, out);
  }
  return out;
}

double statistics_change(const std::vector<WindowStatistic>& now,
                         const std::vector<WindowStatistic>& before) {
  if (now.size() != before.size() || now.empty()) return std::numeric_limits<double>::infinity();
  double change = 0;
  for (std::size_t i = 0; i < now.size(); ++i)
    if (const double s = std::max(now[i].scale, before[i].scale); s > 0)
      change = std::max(change, std::abs(now[i].value - before[i].value) / (now[i].tolerance * s) *
                                    kStatisticsTolerance);
  return change;
}

SteadyVerdict statistics_verdict(const std::vector<double>& changes) {
  SteadyVerdict v;
  const std::size_t n = changes.size(), m = kJudgedChanges;
  if (n == 0) return v;
  const double c = changes[n - 1];
  v.error = c;
  if (n < m) return v;
  const auto last = changes.end() - static_cast<std::ptrdiff_t>(m);
  // Stationary: the changes no longer fall (the largest of the last m at least
  // kStationaryShare of the largest of the m before): what moves them is the windows' own
  // variation, and the last change within the tolerance is the verdict, as two windows agree.
  if (n >= 2 * m + 1 &&
      *std::max_element(last, changes.end()) >=
          kStationaryShare * *std::max_element(last - static_cast<std::ptrdiff_t>(m), last)) {
    if (c <= kStatisticsTolerance) v.period_multiple = 1;
    return v;
  }
  // Still falling: each of the last m within the tolerance, and so the change to come while
  // the last three fall one after the other (the rest of their geometric series).
  const double before = changes[n - 2];
  const bool decaying = changes[n - 3] > before && before > c;
  const double rate = decaying ? c / before : 1.0;
  v.error = decaying ? c * rate / (1 - rate) : c;
  const bool each =
      std::all_of(last, changes.end(), [](double x) { return x <= kStatisticsTolerance; });
  if (each && v.error <= kStatisticsTolerance) v.period_multiple = 1;
  return v;
}

}  // namespace geardyn
