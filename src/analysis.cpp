#include "geardyn/analysis.hpp"

#include <algorithm>
#include <boost/math/tools/minima.hpp>
#include <cmath>
#include <limits>

namespace geardyn {

const char* to_string(Regime r) {
  switch (r) {
    case Regime::kNone:
      return "none";
    case Regime::kTransient:
      return "transient";
    case Regime::kSustained:
      return "sustained";
  }
  return "?";
}

const char* to_string(EventKind k) {
  switch (k) {
    case EventKind::kImpact:
      return "impact";
    case EventKind::kBacksideImpact:
      return "backside_impact";
    case EventKind::kSeparation:
      return "separation";
  }
  return "?";
}

RunReader::RunReader(const GearPairModel& model, double t0_s, double t1_s, double final_fraction,
                     bool keep_events, bool keep_samples, std::function<bool(double)> progress)
    : model_(model),
      t0_(t0_s),
      t1_(t1_s),
      final_start_(t1_s - final_fraction * (t1_s - t0_s)),
      keep_events_(keep_events),
      keep_samples_(keep_samples),
      progress_(std::move(progress)),
      b_(model.parameters().backlash_m),
      force_scale_(model.parameters().backlash_m * model.parameters().mean_stiffness_n_per_m()),
      last_t_(t0_s),
      max_force_(-std::numeric_limits<double>::infinity()),
      min_force_(std::numeric_limits<double>::infinity()),
      max_delta_(-std::numeric_limits<double>::infinity()),
      min_delta_(std::numeric_limits<double>::infinity()) {}

void RunReader::on_transition(const ode::State& s, int from_region) {
  const int from = contact_state(from_region);
  const int to = contact_state(s.region);
  if (to == -1) back_contact_ = true;
  if (from == to) return;  // clipping inside contact does not change the contact state
  EventKind kind;
  if (from == 0) {
    ++impacts_;
    kind = EventKind::kImpact;
    if (to == -1) {
      ++backside_impacts_;
      kind = EventKind::kBacksideImpact;
    }
    max_impact_velocity_ = std::max(max_impact_velocity_, std::abs(s.v));
  } else {
    ++separations_;
    last_separation_ = s.t;
    kind = EventKind::kSeparation;
    if (s.t > final_start_) separated_in_final_ = true;
  }
  if (keep_events_) events_.push_back({s.t, kind, s.v});
}

void RunReader::on_sample(const ode::State& s) {
  const GearPairModel::Drive d = model_.drive(s.t);
  const double f = model_.mesh_force(d, s.q, s.v, s.region);
  const double fb = f / force_scale_;
  const double db = s.q / b_;
  sum_force_ += fb;
  sum_force2_ += fb * fb;
  sum_delta_ += db;
  sum_delta2_ += db * db;
  ++n_samples_;
  max_force_ = std::max(max_force_, f);
  min_force_ = std::min(min_force_, f);
  max_delta_ = std::max(max_delta_, s.q);
  min_delta_ = std::min(min_delta_, s.q);
  const int cs = contact_state(s.region);
  if (cs == -1) back_contact_ = true;
  if (keep_samples_) {
    samples_.t_s.push_back(s.t);
    samples_.delta_bar.push_back(db);
    samples_.velocity_m_s.push_back(s.v);
    samples_.force_bar.push_back(fb);
    samples_.contact.push_back(cs);
  }
}

RunReading RunReader::reading() const {
  RunReading r;
  r.impacts = impacts_;
  r.backside_impacts = backside_impacts_;
  r.separations = separations_;
  r.last_separation_s = last_separation_;
  r.double_sided = back_contact_;
  r.separated_fraction = separated_time_ / (t1_ - t0_);
  r.max_impact_velocity_m_s = max_impact_velocity_;
  if (separated_in_final_) {
    r.regime = Regime::kSustained;
  } else if (separated_time_ > 0) {
    r.regime = Regime::kTransient;
  } else {
    r.regime = Regime::kNone;
  }
  r.max_force_bar = max_force_ / force_scale_;
  r.min_force_bar = min_force_ / force_scale_;
  r.max_delta_bar = max_delta_ / b_;
  r.min_delta_bar = min_delta_ / b_;
  if (n_samples_ > 0) {
    const double n = static_cast<double>(n_samples_);
    r.mean_force_bar = sum_force_ / n;
    r.rms_force_bar = std::sqrt(sum_force2_ / n);
    r.mean_delta_bar = sum_delta_ / n;
    r.rms_delta_bar = std::sqrt(sum_delta2_ / n);
  }
  const double static_force = model_.parameters().static_mesh_force_n();
  if (static_force > 0) r.dynamic_factor = max_force_ / static_force;
  return r;
}

}  // namespace geardyn

namespace geardyn {
namespace {
// Samples of a cell searched for an extreme before the best one is polished by Brent's method,
// and the bits of time to which it is polished (the extreme's value is then exact to ~1e-15).
constexpr int kExtremeSamples = 8;
constexpr int kExtremeBits = 26;
}  // namespace

RunFlowObserver::RunFlowObserver(const GearPairModel& model, RunReader& reader)
    : model_(model), reader_(reader) {
  const HarmonicSeries& k = model.parameters().stiffness_n_per_m;
  double swing = 0;
  for (const Harmonic& h : k.terms) swing += std::abs(h.amplitude);
  k_min_ = k.offset - swing;
  k_max_ = k.offset + swing;
}

void RunFlowObserver::on_cell(const ode::CellView& cell) {
  if (!(cell.t_end_s > cell.t_begin_s)) return;
  const int region = cell.region + GearPairModel::kFirstRegion;
  const double dlo = (*cell.lower)[0], dhi = (*cell.upper)[0];
  const double vlo = (*cell.lower)[1], vhi = (*cell.upper)[1];
  // Bounds of F_G over the cell from those of the state.
  const GearPairParameters& p = model_.parameters();
  const double b = p.backlash_m;
  double flo = 0, fhi = 0;
  if (region == kDriveContact || region == kBackContact) {
    const double edge = region == kDriveContact ? b : -b;
    const double c = p.damping_n_s_per_m;
    const double e[4] = {k_min_ * (dlo - edge), k_min_ * (dhi - edge), k_max_ * (dlo - edge),
                         k_max_ * (dhi - edge)};
    flo = *std::min_element(e, e + 4) + std::min(c * vlo, c * vhi);
    fhi = *std::max_element(e, e + 4) + std::max(c * vlo, c * vhi);
  } else if (region == kSeparated && p.damping == DampingForm::kAlways) {
    const double c = p.damping_n_s_per_m;
    flo = std::min(c * vlo, c * vhi);
    fhi = std::max(c * vlo, c * vhi);
  }
  const bool want[4] = {dhi > reader_.max_delta_m(),
                        dlo<reader_.min_delta_m(), fhi> reader_.max_force_n(),
                        flo < reader_.min_force_n()};
  if (!(want[0] || want[1] || want[2] || want[3])) return;
  // value(q, t): the quantity to minimise, negated for a maximum.
  ode::Vector y(2);
  auto point = [&](double t) {
    cell.state_at(t, y);
    return ode::State{t, y[0], y[1], 0.0, region};
  };
  auto value = [&](int q, double t) {
    const ode::State s = point(t);
    const double x = q < 2 ? s.q : model_.mesh_force(model_.drive(t), s.q, s.v, region);
    return (q % 2 == 0) ? -x : x;
  };
  const double t0 = cell.t_begin_s, t1 = cell.t_end_s;
  const double dt = (t1 - t0) / kExtremeSamples;
  for (int q = 0; q < 4; ++q) {
    if (!want[q]) continue;
    int best = 0;
    double best_v = value(q, t0);
    for (int i = 1; i <= kExtremeSamples; ++i) {
      const double v = value(q, t0 + i * dt);
      if (v < best_v) {
        best_v = v;
        best = i;
      }
    }
    const double a = t0 + std::max(0, best - 1) * dt,
                 c = t0 + std::min(kExtremeSamples, best + 1) * dt;
    std::uintmax_t it = 60;
    const auto r = boost::math::tools::brent_find_minima([&](double t) { return value(q, t); }, a,
                                                         c, kExtremeBits, it);
    const double t = r.second < best_v ? r.first : t0 + best * dt;
    reader_.on_point(point(t), model_.drive(t));
  }
}

}  // namespace geardyn
