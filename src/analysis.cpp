#include "geardyn/analysis.hpp"

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
