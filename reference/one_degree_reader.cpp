// The one-degree model's reader (one_degree_reader.hpp): its contact states, extremes, samples
// and the extremes inside the exact engine's cells.
#include "geardyn/one_degree_reader.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace geardyn {

RunReader::Tally::Tally(double start_s, double final_start_s)
    : start(start_s),
      final_start(final_start_s),
      max_force(-std::numeric_limits<double>::infinity()),
      min_force(std::numeric_limits<double>::infinity()),
      max_delta(-std::numeric_limits<double>::infinity()),
      min_delta(std::numeric_limits<double>::infinity()) {}

RunReader::RunReader(const GearPairModel& model, double t0_s, double t1_s, double final_fraction,
                     bool keep_events, bool keep_samples, std::function<bool(double)> progress)
    : model_(model),
      t0_(t0_s),
      t1_(t1_s),
      keep_events_(keep_events),
      keep_samples_(keep_samples),
      progress_(std::move(progress)),
      b_(model.parameters().backlash_m),
      force_scale_(model.parameters().backlash_m * model.parameters().mean_stiffness_n_per_m()),
      last_t_(t0_s),
      whole_(t0_s, t1_s - final_fraction * (t1_s - t0_s)) {}

void RunReader::mark(double t_s) { part_.emplace(t_s, t_s); }

void RunReader::on_transition(const ode::State& s, int from_region) {
  const int from = contact_state(from_region);
  const int to = contact_state(s.region);
  const auto count = [&](Tally& x) {
    if (to == -1) x.back_contact = true;
    if (from == to) return;  // clipping inside contact does not change the contact state
    if (from == 0) {
      ++x.impacts;
      if (to == -1) ++x.backside_impacts;
      x.max_impact_velocity = std::max(x.max_impact_velocity, std::abs(s.v));
    } else {
      ++x.separations;
      x.last_separation = s.t;
      if (s.t > x.final_start) x.separated_in_final = true;
    }
  };
  count(whole_);
  if (part_) count(*part_);
  if (from == to || !keep_events_) return;
  const EventKind kind = from != 0  ? EventKind::kSeparation
                         : to == -1 ? EventKind::kBacksideImpact
                                    : EventKind::kImpact;
  events_.push_back({s.t, kind, s.v});
}

void RunReader::on_sample(const ode::State& s, const GearPairModel::Drive& d) {
  const double f = model_.mesh_force(d, s.q, s.v, s.region);
  const double fb = f / force_scale_;
  const double db = s.q / b_;
  const int cs = contact_state(s.region);
  const auto add = [&](Tally& x) {
    x.force_bar.add(fb);
    x.delta_bar.add(db);
    x.extremes(f, s.q);
    if (cs == -1) x.back_contact = true;
  };
  add(whole_);
  if (part_) add(*part_);
  if (keep_samples_) {
    samples_.t_s.push_back(s.t);
    samples_.delta_bar.push_back(db);
    samples_.velocity_m_s.push_back(s.v);
    samples_.force_bar.push_back(fb);
    samples_.contact.push_back(cs);
  }
}

void RunReader::reserve_samples(std::size_t n) {
  if (!keep_samples_) return;
  samples_.t_s.reserve(n);
  samples_.delta_bar.reserve(n);
  samples_.velocity_m_s.reserve(n);
  samples_.force_bar.reserve(n);
  samples_.contact.reserve(n);
}

RunReading RunReader::read(const Tally& x) const {
  RunReading r;
  r.impacts = x.impacts;
  r.backside_impacts = x.backside_impacts;
  r.separations = x.separations;
  r.last_separation_s = x.last_separation;
  r.double_sided = x.back_contact;
  r.separated_fraction = x.separated_time / (t1_ - x.start);
  r.max_impact_velocity_m_s = x.max_impact_velocity;
  r.regime = regime_of(x.separated_in_final, x.separated_time);
  r.max_force_bar = x.max_force / force_scale_;
  r.min_force_bar = x.min_force / force_scale_;
  r.max_delta_bar = x.max_delta / b_;
  r.min_delta_bar = x.min_delta / b_;
  r.mean_force_bar = x.force_bar.mean();
  r.rms_force_bar = x.force_bar.rms();
  r.mean_delta_bar = x.delta_bar.mean();
  r.rms_delta_bar = x.delta_bar.rms();
  const double static_force = model_.parameters().static_mesh_force_n();
  if (static_force > 0) r.dynamic_factor = x.max_force / static_force;
  return r;
}

namespace {
// Stretches kept before CellExtremes searches them in the middle of a flow: keeping is a few
// numbers a stretch, and a long drifting run keeps one or two a crest.
constexpr std::size_t kMaxKeptStretches = 2048;
}  // namespace

CellExtremes::CellExtremes(const GearPairModel& model, RunReader& reader,
                           const ode::ExactEngine& engine)
    : model_(model), reader_(reader), engine_(engine) {
  const HarmonicSeries& k = model.parameters().stiffness_n_per_m;
  double swing = 0;
  for (const Harmonic& h : k.terms) swing += std::abs(h.amplitude);
  k_min_ = k.offset - swing;
  k_max_ = k.offset + swing;
}

CellExtremes::Four CellExtremes::bounds_from_state(int engine_region, double dlo, double dhi,
                                                   double vlo, double vhi) const {
  const int region = engine_region + GearPairModel::kFirstRegion;
  const GearPairParameters& p = model_.parameters();
  const double b = p.backlash_m, c = p.damping_n_s_per_m;
  double flo = 0, fhi = 0;
  if (region == kDriveContact || region == kBackContact) {
    // delta - edge keeps the sign of the contact in its region.
    const double edge = region == kDriveContact ? b : -b;
    const double lo = region == kDriveContact ? std::max(0.0, dlo - edge) : dlo - edge;
    const double hi = region == kDriveContact ? dhi - edge : std::min(0.0, dhi - edge);
    const std::array<double, 4> e{k_min_ * lo, k_min_ * hi, k_max_ * lo, k_max_ * hi};
    flo = *std::min_element(e.begin(), e.end()) + std::min(c * vlo, c * vhi);
    fhi = *std::max_element(e.begin(), e.end()) + std::max(c * vlo, c * vhi);
  } else if (region == kSeparated && p.damping == DampingForm::kAlways) {
    flo = std::min(c * vlo, c * vhi);
    fhi = std::max(c * vlo, c * vhi);
  }
  return {dhi, dlo, fhi, flo};
}

CellExtremes::Four CellExtremes::seen() const {
  return {reader_.max_delta_m(), reader_.min_delta_m(), reader_.max_force_n(),
          reader_.min_force_n()};
}

bool CellExtremes::room(const Four& bound, const Four& seen) {
  for (int q = 0; q < 4; ++q)
    if (beyond(q, bound[q], seen[q])) return true;
  return false;
}

bool CellExtremes::room(const ode::CellView& span) const {
  return room(bounds_from_state(span.region, (*span.lower)[0], (*span.upper)[0], (*span.lower)[1],
                                (*span.upper)[1]),
              seen());
}

void CellExtremes::look(const ode::CellView& cell) {
  if (!(cell.t_end_s > cell.t_begin_s)) return;
  // The state's bounds first, then the observables' own where the cell gives them.
  Four bound = bounds_from_state(cell.region, (*cell.lower)[0], (*cell.upper)[0], (*cell.lower)[1],
                                 (*cell.upper)[1]);
  const Four s = seen();
  if (!room(bound, s)) return;
  double low = 0, high = 0;
  if ((beyond(0, bound[0], s[0]) || beyond(1, bound[1], s[1])) &&
      cell.range(GearPairModel::kObservableDelta, low, high)) {
    bound[0] = std::min(bound[0], high);
    bound[1] = std::max(bound[1], low);
  }
  if ((beyond(2, bound[2], s[2]) || beyond(3, bound[3], s[3])) &&
      cell.range(GearPairModel::kObservableForce, low, high)) {
    bound[2] = std::min(bound[2], high);
    bound[3] = std::max(bound[3], low);
  }
  if (!room(bound, s)) return;
  cell.keep(kept_);
  kept_bounds_.push_back(bound);
  if (kept_.size() >= kMaxKeptStretches) finish();
}

void CellExtremes::finish() {
  if (kept_.size() == 0) return;
  ode::Vector& y = point_;
  // The four extremes' searches look through one scratch flow (a session of revisits).
  engine_.revisit(kept_, [&](const ode::ExactEngine::Visit& visit) {
    for (int q = 0; q < 4; ++q) {
      const bool maximum = q % 2 == 0;
      const int observable =
          q < 2 ? GearPairModel::kObservableDelta : GearPairModel::kObservableForce;
      // Searches the stretches of order_ while their bound beats the extreme seen.
      const auto search = [&] {
        visit(order_, [&](std::size_t i, const ode::CellView& cell) {
          const double best = seen()[q];
          if (!beyond(q, kept_bounds_[i][q], best)) return false;
          double value = 0, t = 0;
          if (cell.extreme(observable, maximum, best, value, t)) {
            cell.state_at(t, y);
            reader_.on_point({t, y[0], y[1], 0.0, cell.region + GearPairModel::kFirstRegion},
                             model_.drive(t));
          }
          return true;
        });
      };
      // The stretch of the widest bound first: its extreme is the one most others must beat.
      std::size_t top = kept_.size();
      for (std::size_t i = 0; i < kept_.size(); ++i)
        if (beyond(q, kept_bounds_[i][q], seen()[q]) &&
            (top == kept_.size() || beyond(q, kept_bounds_[i][q], kept_bounds_[top][q])))
          top = i;
      if (top == kept_.size()) continue;
      order_.assign(1, top);
      search();
      // Then those whose bound still beats it, widest first.
      order_.clear();
      for (std::size_t i = 0; i < kept_.size(); ++i)
        if (i != top && beyond(q, kept_bounds_[i][q], seen()[q])) order_.push_back(i);
      std::sort(order_.begin(), order_.end(), [&](std::size_t a, std::size_t b) {
        return beyond(q, kept_bounds_[a][q], kept_bounds_[b][q]);
      });
      search();
    }
  });
  kept_.clear();
  kept_bounds_.clear();
}

RunFlowObserver::RunFlowObserver(const GearPairModel& model, RunReader& reader,
                                 const ode::OutputGrid& grid, CellExtremes& extremes)
    : reader_(reader),
      extremes_(extremes),
      sample_drive_(model.drive_grid(grid.time(-1), grid.interval_s)) {
  reader.reserve_samples(static_cast<std::size_t>(std::max<std::int64_t>(0, grid.count)));
}

}  // namespace geardyn
