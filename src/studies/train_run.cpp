#include "geardyn/train_run.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cassert>
#include <chrono>
#include <cmath>
#include <functional>
#include <initializer_list>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <ostream>
#include <stdexcept>

#include "geardyn/adaptive.hpp"
#include "geardyn/csv.hpp"
#include "geardyn/newmark_flow.hpp"
#include "geardyn/output_folder.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_statics.hpp"
#include "geardyn/train_steadiness.hpp"
#include "studies/contact_tracker.hpp"

namespace geardyn {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// A train's cells are twice the one-degree model's in h times the fastest rate, as the coupled
// model's (coupled_run.cpp, kCoupledCellRateProduct): a coupled case, which runs as its train,
// then steps the coupled model's cells (12982 for the shipped case over 0.05 s, against 23119
// with the one-degree model's 1.5; the same cells and events, TrainCase test), about 10 %
// faster in one process; the shipped trains' runs measured the same either way within the
// machine's noise (commit b6d87d8).
constexpr double kTrainCellRateProduct = 3.0;

// Stretches a run's observer keeps before it searches them in the middle of a flow (as
// CellExtremes' kMaxKeptStretches): a few numbers a stretch and its observables' bounds.
constexpr std::size_t kMaxKeptStretches = 2048;

// Looks at the engine's flow: samples, each mesh's contact changes and its exact extremes, over
// the whole window and, from a mark on, over the steady part beside it.
class TrainObserver : public ode::FlowObserver {
 public:
  // `engine` is the exact engine whose flows it looks at (their cells' extremes are searched
  // deferred, as CellExtremes does for the one-degree run); null for the other methods, whose
  // flows have no cells.
  // `grid` is the flows' output grid: under the exact engine, the observables at its times
  // read phases advanced by rotation (give_sample_phases).
  TrainObserver(const train::Assembled& a, const ode::LinearSwitchedSystem& sys,
                const ode::ExactEngine* engine, const ode::OutputGrid& grid, TrainRunResult& out,
                double t0, double t1, double final_from, int region,
                const std::function<bool(double)>& progress)
      : a_(a),
        out_(out),
        progress_(progress),
        t0_(t0),
        t1_(t1),
        states_(a.states(region)),
        whole_(states_.size()),
        first_part_(2 * states_.size()),
        whole_parts_(sys.region(0).observables.size() - first_part_, kNoExtremes),
        sys_(sys),
        engine_(engine),
        grid_(grid) {
    for (const int state : states_) trackers_.emplace_back(t0, t1, final_from, state);
    // The rows whose product with q' is each nonlinearity's rate: a mesh's V (less its error's
    // rate), a joint's row.
    const Eigen::Index n = a.size();
    rate_rows_.resize(static_cast<Eigen::Index>(states_.size() + a.joints().size()), n);
    for (std::size_t m = 0; m < states_.size(); ++m) {
      rate_rows_.row(static_cast<Eigen::Index>(m)) = a.mesh_vector(static_cast<int>(m));
      errors_.push_back(a.error_series(static_cast<int>(m)));
    }
    for (std::size_t j = 0; j < a.joints().size(); ++j)
      rate_rows_.row(static_cast<Eigen::Index>(states_.size() + j)) = a.joints()[j].row;
    joint_states_ = a.joint_states(region);
    for (const int state : joint_states_) gaps_.emplace_back(t0, t1, final_from, state);
    // Each region's readers, made when the flow first enters it (region()).
    ranges_.resize(static_cast<std::size_t>(sys.region_count()));
    readers_.resize(ranges_.size());
    mesh_readers_.resize(ranges_.size());
    low_.resize(sys.region(0).observables.size());
    high_.resize(low_.size());
    seen_low_.resize(low_.size());
    seen_high_.resize(low_.size());
  }

  // From t on (a time a flow ended at), each mesh's steady part is read beside the whole: its
  // contact history and its extremes, found against the part's own (a later mark starts it
  // afresh).
  void mark(double t) {
    search_kept();  // the stretches kept so far are the whole's alone
    part_trackers_.clear();
    for (const int state : states_) part_trackers_.emplace_back(t, t1_, t, state);
    part_gaps_.clear();
    for (const int state : joint_states_) part_gaps_.emplace_back(t, t1_, t, state);
    part_.assign(states_.size(), Tally{});
    part_parts_.assign(whole_parts_.size(), kNoExtremes);
  }

  // Judged against every extreme of the flow so far: the kept stretches are searched first when
  // the span's bounds leave room beyond the extremes seen.
  bool needs_detail(const ode::CellView& span) override {
    bound_all(span);
    if (!any_room() || kept_.size() == 0) return any_room();
    search_kept();
    take_seen();  // the search may have found new extremes
    return any_room();
  }

  // A cell whose bounds leave room for a new extreme is kept, to be searched later (search_kept)
  // only while its bounds still reach beyond the extremes found: of a run's many crests, only
  // the few that may hold the largest are searched.
  void on_cell(const ode::CellView& cell) override {
    looks_at_cells_ = true;
    if (!(cell.t_end_s > cell.t_begin_s)) return;
    bound_all(cell);
    if (!any_room()) return;
    // The cell's own bounds of the observables with room, tighter than the state's.
    double low = 0, high = 0;
    for (std::size_t i = 0; i < low_.size(); ++i)
      if (room(i) && cell.range(static_cast<int>(i), low, high)) {
        low_[i] = std::max(low_[i], low);
        high_[i] = std::min(high_[i], high);
      }
    if (!any_room()) return;
    assert(engine_ != nullptr);  // cells are the exact engine's
    cell.keep(kept_);
    kept_bounds_.insert(kept_bounds_.end(), low_.begin(), low_.end());
    kept_bounds_.insert(kept_bounds_.end(), high_.begin(), high_.end());
    if (kept_.size() >= kMaxKeptStretches) search_kept();
  }

  // A step's end is a point of the window: Newmark's only one besides events and samples, the
  // adaptive integrator's besides those and the points inside its steps (on_point). The exact
  // engine's cells end at its steps, and on_cell has looked at each (or its bounds left no room
  // for a new extreme there).
  void on_step(double t, const ode::Vector& y, int region) override {
    if (looks_at_cells_) return;
    reader(region)(t, y, values_);
    for (std::size_t m = 0; m < states_.size(); ++m) point(m, values_[2 * m], values_[2 * m + 1]);
    for (std::size_t k = 0; k < whole_parts_.size(); ++k) point_part(k, values_[first_part_ + k]);
  }
  // A point inside an adaptive step (its dense output): the meshes' deflections and forces, whose
  // crests between step ends are the readings that matter most (the dynamic factors). The
  // shafts' and bearings' are read at step ends, events and samples alone: on a planetary set
  // they are two thirds of the observables, whose reading at every point cost a sixth of its run.
  void on_point(double t, const ode::Vector& y, int region) override {
    mesh_reader(region)(t, y, point_values_);
    for (std::size_t m = 0; m < states_.size(); ++m)
      point(m, point_values_[2 * m], point_values_[2 * m + 1]);
  }

  void on_event(double t, const ode::Vector& y, int from, int to) override {
    const std::vector<int> a = a_.states(from), b = a_.states(to);
    for (std::size_t m = 0; m < a.size(); ++m) {
      if (a[m] == b[m]) continue;
      trackers_[m].change(t, b[m]);
      if (!part_trackers_.empty()) part_trackers_[m].change(t, b[m]);
      if ((a[m] == 0) == (b[m] == 0)) continue;  // clipping inside contact
      const double v = rate(m, y) - errors_[m].rate(t);
      add_event(t, m, a[m], b[m], v);
      if (a[m] != 0) continue;
      for (Tally* x : {&whole_[m], part_.empty() ? nullptr : &part_[m]})
        if (x) x->max_impact_velocity = std::max(x->max_impact_velocity, std::abs(v));
    }
    states_ = b;
    const std::vector<int> c = a_.joint_states(to);
    for (std::size_t j = 0; j < c.size(); ++j) {
      if (c[j] == joint_states_[j]) continue;
      gaps_[j].change(t, c[j]);
      if (!part_gaps_.empty()) part_gaps_[j].change(t, c[j]);
      // A change between stages beyond the rest is no contact change.
      if ((joint_states_[j] == 0) != (c[j] == 0)) {
        const std::size_t k = states_.size() + j;
        add_event(t, k, joint_states_[j], c[j], rate(k, y));
      }
    }
    joint_states_ = c;
  }

  void on_sample(double t, const ode::Vector& y, int region) override {
    TrainSamples& s = out_.samples;
    give_sample_phases(t);
    reader(region)(t, y, values_);
    s.t_s.push_back(t);
    const std::size_t meshes = states_.size();
    double* f = s.force_n.append(meshes);
    for (std::size_t m = 0; m < meshes; ++m) {
      f[m] = values_[2 * m + 1];
      point(m, values_[2 * m], f[m]);  // a sample is a point of the window too
      whole_[m].add_sample(values_[2 * m], f[m]);
      if (!part_.empty()) part_[m].add_sample(values_[2 * m], f[m]);
    }
    for (std::size_t k = 0; k < whole_parts_.size(); ++k) point_part(k, values_[first_part_ + k]);
    double* parts = s.parts.append(whole_parts_.size());
    for (std::size_t k = 0; k < whole_parts_.size(); ++k) parts[k] = values_[first_part_ + k];
    // A study's sample: its time, forces (for load sharing) and loads (for its steadiness).
    if (!keep_samples_) return;
    if (keep_states_ && lifted_from_)
      lift_.lift_into(t, y, s.state.append(2 * static_cast<std::size_t>(a_.size())));
    else if (keep_states_)
      s.state.push_back(y);
    double* d = s.deflection_bar.append(meshes);
    for (std::size_t m = 0; m < meshes; ++m) d[m] = values_[2 * m] / out_.meshes[m].backlash_m;
    double* rates = s.deflection_rate_m_s.append(meshes);
    for (std::size_t m = 0; m < meshes; ++m) rates[m] = rate(m, y) - errors_[m].rate(t);
    s.contact.push_back(region_states(region));
  }

  // The flow it looks at next steps the complement of a free rotation (its states are
  // split->reduced()'s, the observer's system), from t0 with the rotation's (phi, phi') = rigid0:
  // its samples are kept as the whole train's states.
  void lift_from(const ode::RigidSplit& split, double t0, const Eigen::Vector2d& rigid0) {
    lift_ = ode::RigidSplit::Motion(split, t0, rigid0);
    if (!lifted_from_) reduced_rate_rows_ = rate_rows_ * split.complement();
    lifted_from_ = true;
  }

  // Room in the result for `count` output samples, all their rows kept, all but the states
  // (keep_states false), or (keep false) only their times, mesh forces and parts' loads.
  void reserve(std::int64_t count, bool keep, bool keep_states) {
    keep_samples_ = keep;
    keep_states_ = keep_states;
    const auto rows = static_cast<std::size_t>(std::max<std::int64_t>(count, 0));
    TrainSamples& s = out_.samples;
    s.t_s.reserve(rows);
    s.force_n.reserve(rows, states_.size());
    s.parts.reserve(rows, whole_parts_.size());
    if (!keep) return;
    if (keep_states) s.state.reserve(rows, 2 * static_cast<std::size_t>(a_.size()));
    s.deflection_bar.reserve(rows, states_.size());
    s.deflection_rate_m_s.reserve(rows, states_.size());
    s.contact.reserve(rows, states_.size());
  }

  // a_.states(region), kept for the region last asked of (samples come many to a region).
  const std::vector<int>& region_states(int region) {
    if (region != sample_region_) {
      sample_states_ = a_.states(region);
      sample_region_ = region;
    }
    return sample_states_;
  }

  bool on_progress(double t) override { return !progress_ || progress_((t - t0_) / (t1_ - t0_)); }

  // The readings into the result: the whole window, and the steady part when it was marked.
  void finish() {
    search_kept();
    for (std::size_t m = 0; m < trackers_.size(); ++m) {
      TrainMeshReading& r = out_.meshes[m];
      static_cast<TrainMeshPart&>(r) = reading(trackers_[m], whole_[m]);
      if (!part_trackers_.empty()) r.steady = reading(part_trackers_[m], part_[m]);
    }
    for (std::size_t j = 0; j < gaps_.size(); ++j) {
      TrainJointReading& r = out_.joints[j];
      r.contact = gaps_[j].reading();
      if (!part_gaps_.empty()) r.steady_contact = part_gaps_[j].reading();
    }
    // A clearance direction's, as its bearing's (the first joints, in clearances()' order).
    for (std::size_t j = 0; j < a_.clearances().size(); ++j) {
      const auto [bearing, axis] = a_.clearances()[j];
      TrainBearingReading& r = out_.bearings[static_cast<std::size_t>(bearing)];
      (axis == 0 ? r.clearance_x : r.clearance_y) = out_.joints[j].contact;
      if (!part_gaps_.empty())
        (axis == 0 ? r.steady_clearance_x : r.steady_clearance_y) = out_.joints[j].steady_contact;
    }
    // The parts' extremes, each quantity's in turn in the order of their observables
    // (part_quantities').
    const bool steady = !part_parts_.empty();
    std::size_t k = 0;
    const auto next = [&](TrainExtremes& whole, TrainExtremes& part) {
      whole = TrainExtremes{whole_parts_[k][0], whole_parts_[k][1]};
      if (steady) part = TrainExtremes{part_parts_[k][0], part_parts_[k][1]};
      ++k;
    };
    for (TrainShaftReading& r : out_.shafts) next(r.torque_nm, r.steady_torque_nm);
    for (TrainBearingReading& r : out_.bearings) {
      next(r.force_x_n, r.steady_force_x_n);
      next(r.force_y_n, r.steady_force_y_n);
      if (!r.spatial) continue;
      next(r.axial_force_n, r.steady_axial_force_n);
      if (!r.tilts) continue;
      next(r.moment_x_nm, r.steady_moment_x_nm);
      next(r.moment_y_nm, r.steady_moment_y_nm);
    }
    for (TrainJointReading& r : out_.joints) {
      if (!r.read) continue;
      next(r.force, r.steady_force);
      next(r.deformation, r.steady_deformation);
    }
  }

 private:
  // What is read of one mesh over a stretch beside its contact history: the extremes of F (N)
  // and d - e (m), at indices 2 m + 1 and 2 m of the observables; the largest impact velocity;
  // the sums over the output samples.
  struct Tally {
    double max_force = -kInf, min_force = kInf, max_deflection = -kInf, min_deflection = kInf;
    double max_impact_velocity = 0;
    SampleMoments force, deflection;
    double& at(int k, bool maximum) {
      if (k % 2 == 1) return maximum ? max_force : min_force;
      return maximum ? max_deflection : min_deflection;
    }
    double at(int k, bool maximum) const {
      if (k % 2 == 1) return maximum ? max_force : min_force;
      return maximum ? max_deflection : min_deflection;
    }
    void add_sample(double d, double f) {
      deflection.add(d);
      force.add(f);
    }
  };
  static TrainMeshPart reading(ContactTracker& tracker, const Tally& x) {
    TrainMeshPart r;
    static_cast<ContactReading&>(r) = tracker.reading();
    r.max_force_n = x.max_force;
    r.min_force_n = x.min_force;
    r.max_deflection_m = x.max_deflection;
    r.min_deflection_m = x.min_deflection;
    r.max_impact_velocity_m_s = x.max_impact_velocity;
    r.mean_force_n = x.force.mean();
    r.rms_force_n = x.force.rms();
    r.mean_deflection_m = x.deflection.mean();
    r.rms_deflection_m = x.deflection.rms();
    return r;
  }
  // Nonlinearity k's rate (rate_rows_' row k times q') at a state y the flow stepped. When a
  // free rotation is split off, y is the complement's (p, p'): no mesh or clearance moves with
  // the rotation, so its rate is its row times L (reduced_rate_rows_) times p', without the lift.
  double rate(std::size_t k, const ode::Vector& y) const {
    const auto i = static_cast<Eigen::Index>(k);
    if (!lifted_from_) return rate_rows_.row(i).dot(y.tail(a_.size()));
    return reduced_rate_rows_.row(i).dot(y.tail(reduced_rate_rows_.cols()));
  }
  // Records a contact change of nonlinearity k from state `from` to `to` (1, 0, -1; 2 and -2
  // clipped) with its rate v.
  void add_event(double t, std::size_t k, int from, int to, double v) {
    const EventKind kind = from != 0 ? EventKind::kSeparation
                           : to < 0  ? EventKind::kBacksideImpact
                                     : EventKind::kImpact;
    out_.contact_events.push_back({t, static_cast<int>(k), kind, v});
  }
  // The extremes a new value must beat to change a reading: the part's once marked (within the
  // whole's), else the whole's.
  Tally& latest(std::size_t m) { return part_.empty() ? whole_[m] : part_[m]; }
  const Tally& latest(std::size_t m) const { return part_.empty() ? whole_[m] : part_[m]; }
  void note(std::size_t m, int k, bool maximum, double v) {
    double& w = whole_[m].at(k, maximum);
    w = maximum ? std::max(w, v) : std::min(w, v);
    if (part_.empty()) return;
    double& p = part_[m].at(k, maximum);
    p = maximum ? std::max(p, v) : std::min(p, v);
  }
  void point(std::size_t m, double deflection, double force) {
    const int d = static_cast<int>(2 * m);
    note(m, d, true, deflection);
    note(m, d, false, deflection);
    note(m, d + 1, true, force);
    note(m, d + 1, false, force);
  }
  // Each observable's bounds over the cell, and its extremes seen now (take_seen).
  void bound_all(const ode::CellView& cell) {
    const std::vector<ode::FunctionalBounds>& of_region = ranges(cell.region);
    for (std::size_t k = 0; k < low_.size(); ++k)
      of_region[k].bounds(*cell.lower, *cell.upper, low_[k], high_[k]);
    take_seen();
  }
  // Each observable's extremes seen, taken once for room and any_room: they change only when
  // an extreme is noted (a sample, an event, search_kept), after which they are taken again.
  void take_seen() {
    for (std::size_t k = 0; k < low_.size(); ++k) {
      seen_low_[k] = seen(k, false);
      seen_high_[k] = seen(k, true);
    }
  }
  // Whether the last bound_all's bounds of observable i reach beyond its extremes seen.
  bool room(std::size_t i) const { return high_[i] > seen_high_[i] || low_[i] < seen_low_[i]; }
  bool any_room() const {
    for (std::size_t i = 0; i < low_.size(); ++i)
      if (room(i)) return true;
    return false;
  }
  // The extreme of observable i a new value must beat: a mesh's (i < first_part_: 2 m for
  // d - e, 2 m + 1 for F) or a shaft's or bearing's, the steady part's once marked.
  double seen(std::size_t i, bool maximum) const {
    if (i < first_part_) return latest(i / 2).at(static_cast<int>(i), maximum);
    const std::vector<std::array<double, 2>>& parts =
        part_parts_.empty() ? whole_parts_ : part_parts_;
    return parts[i - first_part_][maximum ? 0 : 1];
  }
  void note_any(std::size_t i, bool maximum, double v) {
    if (i < first_part_) {
      note(i / 2, static_cast<int>(i), maximum, v);
    } else {
      note_part(i - first_part_, maximum, v);
    }
  }
  static bool beyond(bool maximum, double bound, double seen) {
    return maximum ? bound > seen : bound < seen;
  }
  // Searches the kept stretches for every observable's extremes: for each, the stretch of the
  // widest bound first (its extreme is the one most others must beat), then those whose bound
  // still beats the extreme found, widest first. A stretch searched for the maximum is searched
  // for the minimum in the same visit where its bound leaves room (the engine reads both from
  // one series), and not again. Their bounds were taken against the extremes then seen; a
  // search finds the same extreme whenever it is made.
  void search_kept() {
    if (kept_.size() == 0) return;
    const std::size_t q = low_.size();
    // Stretch s's bound of observable i: its lows, then its highs (on_cell).
    const auto bound = [&](std::size_t s, std::size_t i, bool maximum) {
      return kept_bounds_[2 * q * s + (maximum ? q : 0) + i];
    };
    const auto has_room = [&](std::size_t s, std::size_t i, bool maximum) {
      return beyond(maximum, bound(s, i, maximum), seen(i, maximum));
    };
    // Every observable's searches look through one scratch flow (a session of revisits).
    engine_->revisit(kept_, [&](const ode::ExactEngine::Visit& visit) {
      for (std::size_t i = 0; i < q; ++i) {
        minimum_searched_.assign(kept_.size(), 0);
        for (const bool maximum : {true, false}) {
          const auto look = [&](std::size_t s, const ode::CellView& cell) {
            if (!has_room(s, i, maximum)) return false;
            if (maximum) {
              search(cell, i, true);
              if (has_room(s, i, false)) {
                search(cell, i, false);
                minimum_searched_[s] = 1;
              }
            } else if (minimum_searched_[s] == 0) {
              search(cell, i, false);
            }
            return true;
          };
          std::size_t top = kept_.size();
          for (std::size_t s = 0; s < kept_.size(); ++s)
            if (has_room(s, i, maximum) &&
                (top == kept_.size() ||
                 beyond(maximum, bound(s, i, maximum), bound(top, i, maximum))))
              top = s;
          if (top == kept_.size()) continue;
          order_.assign(1, top);
          visit(order_, look);
          order_.clear();
          for (std::size_t s = 0; s < kept_.size(); ++s)
            if (s != top && has_room(s, i, maximum)) order_.push_back(s);
          std::sort(order_.begin(), order_.end(), [&](std::size_t a, std::size_t b) {
            return beyond(maximum, bound(a, i, maximum), bound(b, i, maximum));
          });
          visit(order_, look);
        }
      }
    });
    kept_.clear();
    kept_bounds_.clear();
  }
  // A shaft's or bearing's observable k (after the meshes'): its extremes {max, min}.
  void note_part(std::size_t k, bool maximum, double v) {
    for (std::vector<std::array<double, 2>>* x : {&whole_parts_, &part_parts_}) {
      if (x->empty()) continue;
      double& w = (*x)[k][maximum ? 0 : 1];
      w = maximum ? std::max(w, v) : std::min(w, v);
    }
  }
  void point_part(std::size_t k, double v) {
    note_part(k, true, v);
    note_part(k, false, v);
  }
  // Under the exact engine, whose flows give no phases of their own, gives the phases of the
  // system's frequencies at output grid time t to the observables' reader: advanced from the
  // last sample's by rotation (ode::PhaseGrid, within about 1e-13 of the direct values) when t
  // is the grid's next time, computed afresh otherwise.
  void give_sample_phases(double t) {
    if (!engine_ || !(grid_.interval_s > 0) || sys_.frequencies_rad_s.empty()) return;
    // The grid's next time first, as the engine computes it, without rounding a quotient.
    std::int64_t k = sample_index_ + 1;
    if (!sample_phases_ || grid_.t0_s + static_cast<double>(k) * grid_.interval_s != t) {
      k = static_cast<std::int64_t>(std::llround((t - grid_.t0_s) / grid_.interval_s));
      if (grid_.t0_s + static_cast<double>(k) * grid_.interval_s != t) return;  // not a grid time
    }
    if (sample_phases_ && k == sample_index_ + 1) {
      sample_phases_->advance(k - sample_base_);
    } else {
      sample_phases_.emplace(sys_.frequencies_rad_s, t, grid_.interval_s);
      sample_base_ = k;
    }
    sample_index_ = k;
    given_.give(sys_.frequencies_rad_s, t, sample_phases_->phases());
  }

  // Searches the stretch for an extreme of observable i beyond those seen.
  void search(const ode::CellView& cell, std::size_t i, bool maximum) {
    double v = 0, t = 0;
    if (cell.extreme(static_cast<int>(i), maximum, seen(i, maximum), v, t)) note_any(i, maximum, v);
  }

  const train::Assembled& a_;
  TrainRunResult& out_;
  const std::function<bool(double)>& progress_;
  double t0_, t1_;
  std::vector<int> states_;         // each mesh's contact state now
  std::vector<int> sample_states_;  // region_states'
  int sample_region_ = -1;
  std::vector<ContactTracker> trackers_, part_trackers_;
  // Each joint's (train::Assembled::joints()) state now and its trackers.
  std::vector<int> joint_states_;
  std::vector<ContactTracker> gaps_, part_gaps_;
  std::vector<Tally> whole_, part_;     // part_ empty until marked
  Eigen::MatrixXd rate_rows_;           // each mesh's V, then each joint's row
  Eigen::MatrixXd reduced_rate_rows_;   // rate_rows_ L, on a split rotation's complement
  std::vector<HarmonicSeries> errors_;  // each mesh's e(t)
  // The shafts' and bearings' observables, from first_part_ on: {max, min} of each.
  static constexpr std::array<double, 2> kNoExtremes = {-kInf, kInf};
  std::size_t first_part_;
  std::vector<std::array<double, 2>> whole_parts_, part_parts_;
  const ode::LinearSwitchedSystem& sys_;
  // The deferred search (on_cell, search_kept): the stretches kept, each one's bounds of every
  // observable (lows, then highs), and search_kept's order.
  const ode::ExactEngine* engine_;
  ode::KeptStretches kept_;
  std::vector<double> kept_bounds_;
  std::vector<std::size_t> order_;
  std::vector<char> minimum_searched_;  // per kept stretch, in search_kept
  // give_sample_phases': the grid, the phases at its last sample (index sample_index_, advanced
  // from sample_base_'s), and what gives them.
  ode::OutputGrid grid_;
  std::optional<ode::PhaseGrid> sample_phases_;
  std::int64_t sample_index_ = 0, sample_base_ = 0;
  ode::GivenPhases given_;
  // Region r's readers of its observables, made on first use.
  const ode::FunctionalValues& reader(int r) {
    auto& x = readers_[static_cast<std::size_t>(r)];
    if (!x) x = std::make_unique<ode::FunctionalValues>(sys_, sys_.region(r).observables);
    return *x;
  }
  // Region r's reader of its meshes' observables alone (the first first_part_), for on_point.
  const ode::FunctionalValues& mesh_reader(int r) {
    auto& x = mesh_readers_[static_cast<std::size_t>(r)];
    if (!x.reader) {
      const std::vector<ode::LinearGuard>& all = sys_.region(r).observables;
      x.observables = std::make_unique<std::vector<ode::LinearGuard>>(
          all.begin(), all.begin() + static_cast<std::ptrdiff_t>(first_part_));
      x.reader = std::make_unique<ode::FunctionalValues>(sys_, *x.observables);
    }
    return *x.reader;
  }
  const std::vector<ode::FunctionalBounds>& ranges(int r) {
    auto& x = ranges_[static_cast<std::size_t>(r)];
    if (!x) {
      x.emplace();
      for (const ode::LinearGuard& g : sys_.region(r).observables) x->emplace_back(g);
    }
    return *x;
  }

  std::vector<std::optional<std::vector<ode::FunctionalBounds>>> ranges_;  // per region
  std::vector<double> low_, high_;                                         // the last bound_all's
  std::vector<double> seen_low_, seen_high_;                               // take_seen's
  std::vector<std::unique_ptr<ode::FunctionalValues>> readers_;            // per region
  struct MeshReader {  // the list a reader reads must outlive it: both kept
    std::unique_ptr<std::vector<ode::LinearGuard>> observables;
    std::unique_ptr<ode::FunctionalValues> reader;
  };
  std::vector<MeshReader> mesh_readers_;  // per region, on_point's
  std::vector<double> point_values_;      // on_point's readings
  std::vector<double> values_;
  ode::RigidSplit::Motion lift_;  // lift_from's, when lifted_from_
  bool looks_at_cells_ = false;   // on_cell was called: the flow is the exact engine's
  bool lifted_from_ = false;
  bool keep_samples_ = true;  // reserve's: every row of a sample, or its time and forces alone
  bool keep_states_ = true;   // reserve's: the whole train's state among the rows kept
};

// The shortest time scale of the train: its fastest mode in contact (top_mode_rad_s, the
// highest natural frequency of train::modes) or excitation.
double shortest_time_scale_s(const train::Assembled& a, double top_mode_rad_s) {
  double w = top_mode_rad_s;
  const train::Train& t = a.train();
  for (std::size_t m = 0; m < t.meshes.size(); ++m) {
    const int i = static_cast<int>(m);
    w = std::max({w, a.stiffness_series(i).max_angular_frequency_rad_s(),
                  a.error_series(i).max_angular_frequency_rad_s()});
  }
  for (std::size_t q = 0; q < t.torques.size(); ++q)
    w = std::max(w, a.torque_series(static_cast<int>(q)).max_angular_frequency_rad_s());
  for (const train::Speed& v : t.speeds) {
    const double omega = kTwoPi * a.turning_hz(a.index(v.body));
    for (const train::SpeedHarmonic& h : v.harmonics) w = std::max(w, h.order * omega);
  }
  return kTwoPi / w;
}

// The load-sharing groups of a train (TrainLoadSharing) read from a run's meshes and samples.
std::vector<TrainLoadSharing> read_load_sharing(const train::Assembled& a,
                                                const TrainRunResult& r) {
  std::vector<TrainLoadSharing> out;
  for (const LoadSharingGroup& group : load_sharing_groups(a)) {
    TrainLoadSharing x;
    x.gear = group.gear;
    x.label = group.label;
    std::vector<double> at_rest;
    for (const std::size_t m : group.meshes) {
      const TrainMeshReading& mesh = r.meshes[m];
      x.meshes.push_back(mesh.name);
      if (mesh.static_force_n) {
        at_rest.push_back(*mesh.static_force_n);
        if (!(*mesh.static_force_n > 0)) x.unloaded_at_rest.push_back(mesh.name);
      }
      if (left_drive_flank(r.steady.marked ? mesh.steady : mesh))
        x.lost_contact.push_back(mesh.name);
    }
    if (at_rest.size() == group.meshes.size()) x.static_factor = load_sharing_factor(at_rest);
    std::vector<double> forces(group.meshes.size());
    for (std::size_t i = 0; i < r.samples.t_s.size(); ++i) {
      for (std::size_t k = 0; k < group.meshes.size(); ++k)
        forces[k] = r.samples.force_n[i][group.meshes[k]];
      const std::optional<double> f = load_sharing_factor(forces);
      if (!f) continue;
      x.factor_with_startup = std::max(x.factor_with_startup.value_or(0.0), *f);
      if (r.steady.marked && r.samples.t_s[i] >= r.steady.from_s)
        x.factor = std::max(x.factor.value_or(0.0), *f);
    }
    out.push_back(std::move(x));
  }
  return out;
}

}  // namespace

std::vector<LoadSharingGroup> load_sharing_groups(const train::Assembled& a) {
  const train::Train& t = a.train();
  std::vector<LoadSharingGroup> out;
  for (int g = 0; g < a.body_count(); ++g) {
    const std::size_t first = out.size();
    for (const bool driving : {true, false}) {
      LoadSharingGroup group;
      for (std::size_t m = 0; m < t.meshes.size(); ++m)
        if (a.index(driving ? t.meshes[m].driving : t.meshes[m].driven) == g)
          group.meshes.push_back(m);
      if (group.meshes.size() < 2) continue;
      group.gear = group.label = t.bodies[static_cast<std::size_t>(g)].name;
      out.push_back(std::move(group));
    }
    if (out.size() - first == 2) {
      out[first].label += "_driving";
      out[first + 1].label += "_driven";
    }
  }
  return out;
}

bool left_drive_flank(const TrainMeshPart& part) {
  return part.separations > 0 || part.separated_fraction > 0 || part.min_force_n < 0;
}

std::optional<double> load_sharing_factor(const std::vector<double>& forces_n) {
  double sum = 0, most = -kInf;
  for (const double f : forces_n) {
    sum += f;
    most = std::max(most, f);
  }
  if (!(sum > 0)) return std::nullopt;
  return static_cast<double>(forces_n.size()) * most / sum;
}

TrainSolver::TrainSolver(const Case& c, const MeshStiffness* stiffness) : case_(c) {
  if (const std::string err = validate(c); !err.empty()) throw InputError(err);
  // A pair's form as its train of elements (assembled_train): the same system, read per element.
  a_ = std::make_unique<train::Assembled>(assembled_train(c, stiffness));
  // The highest natural frequency in contact, 0 when no mode moves.
  for (const train::TrainMode& m : train::modes(*a_))
    top_frequency_rad_s_ = std::max(top_frequency_rad_s_, kTwoPi * m.frequency_hz);
  fastest_period_s_ = shortest_time_scale_s(*a_, top_frequency_rad_s_);
  // The method (method()): the exact engine's cells a contact region, one coefficient period
  // cut into cells of kTrainCellRateProduct over the fastest rate.
  method_ = c.solver.method;
  const bool asked = c.origins.count("solver.method") > 0;
  const double coefficient_period_s = a_->coefficient_period_s();
  const double cells = coefficient_period_s *
                       std::max(top_frequency_rad_s_, kTwoPi / fastest_period_s_) /
                       kTrainCellRateProduct;
  if (method_ == Method::kExact && cells > kMaxDefaultExactCells) {
    if (asked && cells > kMaxExactCells)
      throw InputError(with_origins(
          c, fmt::format("solver.method = \"exact\": the exact engine would cut the meshes' "
                         "common period of {:.4g} s into some {:.3g} cells a contact region, "
                         "more than the {:g} it can hold; use solver.method = \"dopri5\" (or "
                         "leave solver.method out to have it chosen)",
                         coefficient_period_s, cells, kMaxExactCells)));
    if (!asked) {
      method_ = Method::kDopri5;
      method_note_ = fmt::format(
          "chosen by the default: the exact engine would cut the meshes' common period of {:.4g} "
          "s into some {:.3g} cells a contact region (more than {:g}); dopri5's memory does not "
          "grow with the period (solver.method chooses)",
          coefficient_period_s, cells, kMaxDefaultExactCells);
    }
  }
  // The exact engine and Newmark step a train that turns freely on the complement of its
  // rotation (rigid_split.hpp), whose quadrature is exact. dopri5 steps the whole train: the
  // complement's matrices are dense where the train's are sparse, and an adaptive step evaluates
  // them six times (the shipped reducer took 1.7 times as long a step on its complement).
  ode::LinearSwitchedSystem full = a_->linear_system();
  const train::Train& t = a_->train();
  if (method_ != Method::kDopri5 && t.speeds.empty() && !t.frame_terms &&
      !a_->damps_rigid_motions()) {
    const Eigen::MatrixXd rigid = a_->rigid_motions();
    if (rigid.cols() == 1) {
      try {
        split_ = std::make_unique<ode::RigidSplit>(full, rigid.col(0), a_->mass());
      } catch (const std::invalid_argument&) {
        split_.reset();  // an element acts on the rotation after all: the whole train is stepped
      }
    }
  }
  if (method_ == Method::kExact) {
    ode::EngineOptions eo;
    eo.tolerance = std::max(ode::kRoundingLimit, c.solver.tolerance * kExactToleranceFraction);
    eo.cell_rate_product = kTrainCellRateProduct;
    try {
      engine_ = split_ ? std::make_unique<ode::ExactEngine>(split_->reduced(), eo)
                       : std::make_unique<ode::ExactEngine>(std::move(full), eo);
    } catch (const std::invalid_argument& e) {
      if (asked)
        throw InputError(std::string("the train's exact engine: ") + e.what() +
                         "; solver.method = \"dopri5\" integrates any train (or leave "
                         "solver.method out to have it chosen)");
      // The default changes its mind: dopri5 steps the whole train.
      method_ = Method::kDopri5;
      method_note_ = fmt::format(
          "chosen by the default: the exact engine cannot take this train ({}); dopri5 steps it "
          "(solver.method chooses)",
          e.what());
      split_.reset();
      whole_ = a_->linear_system();
    }
  } else if (!split_) {
    whole_ = std::move(full);
  }
  if (method_ == Method::kNewmark) {
    // Every region of a train is (theta, theta') with theta' = the rates, and so is its
    // complement's: the first says so.
    if (const std::string e = ode::second_order_form_error(stepped(), 0); !e.empty())
      throw std::logic_error("the train's system: " + e);
    // The one-degree run's rule (run.cpp): a given step must resolve the fastest time scale,
    // the automatic one takes kStepsPerFastestPeriod a period; either divides the system
    // period, so that a run watched period by period steps on one grid.
    const double largest = fastest_period_s_ / kMinStepsPerFastestPeriod;
    if (c.solver.time_step_s > largest)
      throw InputError(with_origins(
          c, fmt::format("solver.time_step_s = {:.6g}: does not resolve the train's fastest time "
                         "scale ({:.3g} s); at most {:.3g} s ({:g} steps a period), or 0 for the "
                         "automatic step",
                         c.solver.time_step_s, fastest_period_s_, largest,
                         kMinStepsPerFastestPeriod)));
    const double wanted = c.solver.time_step_s > 0 ? c.solver.time_step_s
                                                   : fastest_period_s_ / kStepsPerFastestPeriod;
    const double period = a_->system_period_s().value_or(0);
    newmark_step_s_ =
        period > 0 ? period / std::max(1.0, std::ceil(period / wanted - 1e-9)) : wanted;
  }
  if (!(top_frequency_rad_s_ > 0)) top_frequency_rad_s_ = kTwoPi / fastest_period_s_;
}

TrainSolver::~TrainSolver() = default;

int TrainSolver::stepped_states() const {
  return split_ ? split_->reduced().dimension : 2 * a_->size();
}

ode::Vector TrainSolver::initial_state(InitialCondition initial, double t0_s) const {
  if (initial != InitialCondition::kStatic) return rest_state(*a_, t0_s);
  std::string why;
  const std::optional<Eigen::VectorXd> rest = static_state(*a_, &why, t0_s);
  if (!rest) throw InputError(with_origins(case_, "solver.initial = \"static\": " + why));
  return *rest;
}

ode::FlowResult TrainSolver::flow(double t0_s, const ode::Vector& y0, int region, double t1_s,
                                  const ode::OutputGrid& grid, ode::FlowObserver& observer,
                                  bool jacobian) const {
  if (engine_ && !split_) return engine_->flow(t0_s, y0, region, t1_s, grid, observer, jacobian);
  if (engine_) {
    // The complement stepped, the rotation's quadrature added back at the end.
    ode::FlowResult f =
        engine_->flow(t0_s, split_->reduce(y0), region, t1_s, grid, observer, jacobian);
    f.state = split_->lift(t0_s, split_->rigid(y0), f.end_time_s, f.state);
    if (f.jacobian) f.jacobian = split_->lift_jacobian(t0_s, f.end_time_s, *f.jacobian);
    return f;
  }
  // Newmark on the complement, as the exact engine, when a rotation is split off; dopri5.
  const ode::Vector y = split_ ? split_->reduce(y0) : y0;
  ode::FlowResult f;
  if (newmark_step_s_ > 0) {
    f = ode::newmark_flow(stepped(), t0_s, y, region, t1_s, newmark_step_s_, grid, observer);
  } else {
    ode::AdaptiveOptions ao;
    ao.tolerance = case_.solver.tolerance;
    f = ode::adaptive_flow(stepped(), t0_s, y, region, t1_s, grid, observer, ao);
  }
  if (split_) f.state = split_->lift(t0_s, split_->rigid(y0), f.end_time_s, f.state);
  return f;
}

ode::FlowResult TrainSolver::advance(double t0_s, const ode::Vector& y0, double t1_s) const {
  ode::FlowObserver nothing;
  return flow(t0_s, y0, a_->classify(t0_s, y0), t1_s, ode::OutputGrid{}, nothing);
}

ode::FlowResult TrainSolver::advance_with_jacobian(double t0_s, const ode::Vector& y0,
                                                   double t1_s) const {
  if (!engine_) throw std::logic_error("TrainSolver: a Jacobian needs the exact engine");
  ode::FlowObserver nothing;
  return flow(t0_s, y0, a_->classify(t0_s, y0), t1_s, ode::OutputGrid{}, nothing, true);
}

void add_parts(const train::Assembled& a, const std::optional<Eigen::VectorXd>& rest,
               TrainRunResult& result) {
  const train::Train& t = a.train();
  for (std::size_t k = 0; k < t.shafts.size(); ++k) {
    TrainShaftReading r;
    r.name = t.shafts[k].name;
    if (rest)
      r.static_torque_nm = t.shafts[k].stiffness_n_m_per_rad *
                           a.shaft_vector(static_cast<int>(k)).dot(rest->head(a.size()));
    result.shafts.push_back(r);
  }
  for (std::size_t k = 0; k < t.bearings.size(); ++k) {
    TrainBearingReading r;
    r.name = t.bearings[k].name;
    const Eigen::MatrixXd support = a.support_matrix(static_cast<int>(k));
    r.spatial = support.rows() > 0;
    r.tilts = support.rows() > 1;
    if (rest) {
      const Eigen::Vector2d w = a.bearing_matrix(static_cast<int>(k)) * rest->head(a.size()) -
                                a.bearing_offset(static_cast<int>(k));
      r.static_force_x_n = t.bearings[k].stiffness_n_per_m * w(0);
      r.static_force_y_n = t.bearings[k].stiffness_n_per_m * w(1);
      if (r.spatial) {
        const Eigen::VectorXd s = support * rest->head(a.size());
        r.static_axial_force_n = t.bearings[k].axial_stiffness_n_per_m * s(0);
        if (r.tilts) {
          r.static_moment_x_nm = t.bearings[k].tilt_stiffness_n_m_per_rad * s(1);
          r.static_moment_y_nm = t.bearings[k].tilt_stiffness_n_m_per_rad * s(2);
        }
      }
    }
    result.bearings.push_back(r);
  }
  for (std::size_t j = 0; j < a.joints().size(); ++j) {
    const train::Joint& x = a.joints()[j];
    TrainJointReading r;
    r.name = x.name;
    r.read = x.read;
    r.force_what = x.force_what;
    r.deformation_what = x.deformation_what;
    if (rest && x.read) {
      const double d = x.row.dot(rest->head(a.size())) - x.offset;
      r.static_deformation = d;
      r.static_force = x.force(x.stage_at(d), d, 0.0);
    }
    result.joints.push_back(r);
  }
}

std::vector<TrainPartQuantity> part_quantities(const TrainRunResult& r) {
  std::vector<TrainPartQuantity> out;
  for (const TrainShaftReading& m : r.shafts)
    out.push_back({m.name, "torque_nm", &m.torque_nm, &m.steady_torque_nm, &m.static_torque_nm});
  for (const TrainBearingReading& m : r.bearings) {
    const std::array<TrainPartQuantity, 5> all = {
        TrainPartQuantity{m.name, "force_x_n", &m.force_x_n, &m.steady_force_x_n,
                          &m.static_force_x_n},
        TrainPartQuantity{m.name, "force_y_n", &m.force_y_n, &m.steady_force_y_n,
                          &m.static_force_y_n},
        TrainPartQuantity{m.name, "axial_force_n", &m.axial_force_n, &m.steady_axial_force_n,
                          &m.static_axial_force_n},
        TrainPartQuantity{m.name, "moment_x_nm", &m.moment_x_nm, &m.steady_moment_x_nm,
                          &m.static_moment_x_nm},
        TrainPartQuantity{m.name, "moment_y_nm", &m.moment_y_nm, &m.steady_moment_y_nm,
                          &m.static_moment_y_nm}};
    out.insert(out.end(), all.begin(), all.begin() + m.part_count());
  }
  for (const TrainJointReading& m : r.joints) {
    if (!m.read) continue;
    out.push_back({m.name, m.force_what.c_str(), &m.force, &m.steady_force, &m.static_force});
    out.push_back({m.name, m.deformation_what.c_str(), &m.deformation, &m.steady_deformation,
                   &m.static_deformation});
  }
  return out;
}

TrainRunResult TrainSolver::read(double t0_s, const ode::Vector& y0, double t1_s,
                                 const ode::OutputGrid& grid, double final_from_s,
                                 std::optional<SteadyWatch> watch,
                                 const std::function<bool(double)>& progress,
                                 ode::Vector* end_state, bool keep_samples,
                                 bool keep_states) const {
  const train::Assembled& a = *a_;
  const train::Train& t = a.train();
  TrainRunResult result;
  result.input = case_;
  result.method = method_;
  result.method_note = method_note_;
  for (int i = 0; i < a.body_count(); ++i) {
    result.bodies.push_back(t.bodies[static_cast<std::size_t>(i)].name);
    result.body_speed_hz.push_back(a.body_speed_hz(i));
    result.body_inertia_kg_m2.push_back(t.bodies[static_cast<std::size_t>(i)].inertia_kg_m2);
    result.body_mass_kg.push_back(t.bodies[static_cast<std::size_t>(i)].planar
                                      ? t.bodies[static_cast<std::size_t>(i)].mass_kg
                                      : 0.0);
  }
  for (const train::Torque& q : t.torques) {
    result.torques.push_back(q.name);
    result.torque_mean_nm.push_back(q.mean_nm);
  }
  result.coordinates = a.coordinate_names();
  result.system_period_s = a.system_period_s(&result.system_period_note);
  const std::optional<Eigen::VectorXd> rest = static_state(a, &result.static_note);
  const std::vector<double> static_forces =
      rest ? static_mesh_forces_n(a, *rest) : std::vector<double>{};
  for (std::size_t m = 0; m < t.meshes.size(); ++m) {
    TrainMeshReading r;
    r.name = t.meshes[m].name;
    r.mesh_frequency_hz = a.mesh_frequency_hz(static_cast<int>(m));
    r.backlash_m = t.meshes[m].backlash_m;
    r.mean_stiffness_n_per_m = t.meshes[m].mean_stiffness_n_per_m;
    if (t.mesh_phase_from_layout) r.layout_phase = a.mesh_phases()[m];
    if (rest) r.static_force_n = static_forces[m];
    result.meshes.push_back(r);
    result.contact_parts.push_back(r.name);
  }
  add_parts(a, rest, result);
  for (const TrainJointReading& j : result.joints) result.contact_parts.push_back(j.name);

  const int region = a.classify(t0_s, y0);
  const ode::LinearSwitchedSystem& sys = engine_ ? engine_->system() : stepped();
  TrainObserver observer(a, sys, engine_.get(), grid, result, t0_s, t1_s, final_from_s, region,
                         progress);
  observer.reserve(grid.count, keep_samples, keep_states);
  FlowPieces pieces(
      t0_s, y0, region, t1_s, grid,
      [&](double from, const ode::Vector& y, int r, double to, const ode::OutputGrid& piece) {
        if (split_) observer.lift_from(*split_, from, split_->rigid(y));
        return flow(from, y, r, to, piece, observer);
      },
      progress);
  const auto mark = [&](double at) { observer.mark(at); };
  if (watch && watch->by_statistics) {
    // Each window's statistics against the window before's (train_steadiness.hpp), from the
    // samples taken since the last section.
    std::vector<WindowStatistic> before;
    std::size_t from_row = 0;
    bool started = false;
    std::vector<double> changes;
    const auto judge = [&] {
      SteadyVerdict v;
      const std::size_t rows = result.samples.force_n.size();
      if (started && rows > from_row) {
        std::vector<WindowStatistic> now = window_statistics(result, from_row, rows);
        const double change = statistics_change(now, before);
        changes.push_back(change);
        v = statistics_verdict(changes);
        before = std::move(now);
      }
      started = true;
      from_row = rows;
      return v;
    };
    result.steady = integrate_watching(t0_s, t1_s, watch->period_s, judge, std::ref(pieces), mark);
    if (result.steady.basis == SteadyBasis::kSettled)
      result.steady.basis = SteadyBasis::kStatistics;
    result.steady.window_s = watch->period_s;
  } else if (watch) {
    TrainSections sections(a, top_frequency_rad_s_, case_.solver.tolerance);
    const auto judge = [&] {
      sections.add(pieces.t_s(), pieces.state());
      return sections.judge(kSteadyTolerance);
    };
    result.steady = integrate_watching(t0_s, t1_s, watch->period_s, judge, std::ref(pieces), mark);
  } else {
    pieces(t1_s);
  }
  result.termination = pieces.total().termination;
  result.message = pieces.total().message;
  result.cells = pieces.total().cells;
  result.events = pieces.total().events;
  result.unsplit_steps = pieces.total().unsplit_steps;
  if (end_state) *end_state = pieces.state();
  observer.finish();
  for (TrainMeshReading& r : result.meshes) {
    if (r.static_force_n && *r.static_force_n > 0) {
      if (result.steady.marked) r.dynamic_factor = r.steady.max_force_n / *r.static_force_n;
      r.dynamic_factor_with_startup = r.max_force_n / *r.static_force_n;
    }
    if (result.ok() && !(std::isfinite(r.max_force_n) && std::isfinite(r.min_force_n))) {
      result.termination = ode::Termination::kNoProgress;
      result.message = fmt::format("mesh '{}': non-finite readings (an overflow)", r.name);
    }
  }
  result.load_sharing = read_load_sharing(a, result);
  return result;
}

ode::Vector train_state_scale(const train::Assembled& a, double rate_rad_s) {
  const train::Train& t = a.train();
  const Eigen::Index n = a.size();
  ode::Vector scale(2 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    double size = kInf;
    for (std::size_t m = 0; m < t.meshes.size(); ++m) {
      const double v = std::abs(a.mesh_vector(static_cast<int>(m))(i));
      if (v > 0) size = std::min(size, t.meshes[m].backlash_m / v);
    }
    if (!std::isfinite(size)) {
      size = 1e-3;
      if (i >= a.body_count())
        for (const train::Mesh& x : t.meshes) size = std::min(size, x.backlash_m);
    }
    scale(i) = size;
    scale(n + i) = size * rate_rad_s;
  }
  return scale;
}

TrainSections::TrainSections(const train::Assembled& a, double top_frequency_rad_s,
                             double integration_tolerance)
    : a_(a), rate_rad_s_(top_frequency_rad_s) {
  const train::Train& t = a.train();
  const Eigen::Index n = a.size();
  double angle_scale = kInf;   // the smallest b / (cos beta_b R) of the meshes, rad
  double length_scale = kInf;  // the smallest b, m
  for (const train::Mesh& x : t.meshes) {
    for (const double r : {x.base_radius_driving_m, x.base_radius_driven_m})
      angle_scale = std::min(angle_scale, x.backlash_m / (std::cos(x.base_helix_angle_rad) * r));
    length_scale = std::min(length_scale, x.backlash_m);
  }
  const auto count =
      static_cast<Eigen::Index>(t.meshes.size() + t.shafts.size()) + (n - a.body_count());
  rows_ = Eigen::MatrixXd::Zero(count, n);
  sizes_.resize(count);
  Eigen::Index j = 0;
  for (std::size_t m = 0; m < t.meshes.size(); ++m, ++j) {
    errors_.push_back(a.error_series(static_cast<int>(m)));
    rows_.row(j) = a.mesh_vector(static_cast<int>(m));
    sizes_(j) = t.meshes[m].backlash_m;
  }
  for (std::size_t k = 0; k < t.shafts.size(); ++k, ++j) {
    rows_.row(j) = a.shaft_vector(static_cast<int>(k));
    sizes_(j) = angle_scale;
  }
  // Each planar body's centre.
  for (Eigen::Index k = a.body_count(); k < n; ++k, ++j) {
    rows_(j, k) = 1;
    sizes_(j) = length_scale;
  }
  for (j = 0; j < count; ++j)
    series_.emplace_back(sizes_(j), top_frequency_rad_s, integration_tolerance);
}

double TrainSections::distance(const ode::Vector& dy) const {
  const Eigen::Index n = a_.size();
  const Eigen::VectorXd q = (rows_ * dy.head(n)).cwiseQuotient(sizes_);
  const Eigen::VectorXd v = (rows_ * dy.tail(n)).cwiseQuotient(sizes_) / rate_rad_s_;
  return std::max(q.lpNorm<Eigen::Infinity>(), v.lpNorm<Eigen::Infinity>());
}

double TrainSections::gain(const ode::Vector& scale) const {
  const Eigen::Index n = a_.size();
  const Eigen::MatrixXd w = rows_.cwiseAbs();
  const Eigen::VectorXd q = (w * scale.head(n)).cwiseQuotient(sizes_);
  const Eigen::VectorXd v = (w * scale.tail(n)).cwiseQuotient(sizes_) / rate_rad_s_;
  return std::max(q.lpNorm<Eigen::Infinity>(), v.lpNorm<Eigen::Infinity>());
}

ode::State TrainSections::mesh(int m, double t_s, const ode::Vector& y) const {
  const Eigen::Index n = a_.size();
  const Eigen::RowVectorXd v = a_.mesh_vector(m);
  const HarmonicSeries& e = errors_[static_cast<std::size_t>(m)];
  return {t_s, v.dot(y.head(n)) - e(t_s), v.dot(y.tail(n)) - e.rate(t_s), 0.0, 0};
}

void TrainSections::add(double t_s, const ode::Vector& y) {
  const Eigen::Index n = a_.size();
  const Eigen::VectorXd q = rows_ * y.head(n), v = rows_ * y.tail(n);
  for (std::size_t j = 0; j < series_.size(); ++j) {
    const auto k = static_cast<Eigen::Index>(j);
    // A mesh's deflection less its error: d - e.
    const double e = j < errors_.size() ? errors_[j](t_s) : 0.0;
    const double de = j < errors_.size() ? errors_[j].rate(t_s) : 0.0;
    series_[j].add({t_s, q(k) - e, v(k) - de, 0.0, 0});
  }
}

bool runs_as_train(const Case& c) {
  return c.model.form == ModelForm::kTrain || c.model.form == ModelForm::kCoupled;
}

TrainRunResult run_train(const Case& c, const TrainRunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  const TrainSolver solver(c, options.stiffness);
  const double t0 = 0, t1 = c.solver.duration_s;
  const double interval = checked_output_interval_s(c, solver.fastest_period_s(), "train");
  if (const double step = solver.newmark_step_s();
      step > 0 && !((t1 - t0) / step <= kMaxNewmarkSteps))
    throw InputError(with_origins(
        c, fmt::format("solver.time_step_s = {:.6g}: {:.3g} Newmark steps over solver.duration_s = "
                       "{:.6g}; at most {:.0e}",
                       step, (t1 - t0) / step, t1 - t0, kMaxNewmarkSteps)));
  const ode::Vector y0 = solver.initial_state(c.solver.initial, t0);
  const double final_from = t1 - c.solver.final_fraction * (t1 - t0);
  // A train whose common period is long is judged by its statistics (train_steadiness.hpp).
  const double window = statistics_window_s(solver.assembled());
  const SteadyWatch watch = window > 0
                                ? SteadyWatch{window, true}
                                : SteadyWatch{solver.assembled().system_period_s().value_or(0)};
  TrainRunResult result =
      solver.read(t0, y0, t1, ode::make_output_grid(t0, t1, interval), final_from, watch,
                  options.progress, nullptr, options.keep_samples, options.keep_states);
  // The default does not fail where dopri5 would not: a contact region the exact engine cannot
  // build on the way (its cell series do not converge) hands the whole run to dopri5, which
  // says why. A method asked for fails as asked.
  if (!result.ok() && result.termination != ode::Termination::kCancelled &&
      solver.method() == Method::kExact && c.origins.count("solver.method") == 0) {
    Case adaptive = c;
    adaptive.solver.method = Method::kDopri5;
    const TrainSolver fallback(adaptive, options.stiffness);
    const std::string why =
        fmt::format("{}: {}", ode::to_string(result.termination), result.message);
    result = fallback.read(t0, fallback.initial_state(c.solver.initial, t0), t1,
                           ode::make_output_grid(t0, t1, interval), final_from, watch,
                           options.progress, nullptr, options.keep_samples, options.keep_states);
    result.input = c;
    result.method_note = fmt::format(
        "chosen by the default: the exact engine failed on the way ({}); dopri5 ran the train "
        "from the start (solver.method chooses)",
        why);
  }
  result.output_interval_s = interval;
  result.time_step_s = solver.newmark_step_s();
  if (options.keep_samples && options.read_peaks) {
    for (std::size_t m = 0; m < result.meshes.size(); ++m) {
      const MeshSpectra s = mesh_spectra(result, m);
      result.meshes[m].force_peaks = dominant_peaks(s.force_n, kReportedPeaks);
      result.meshes[m].deflection_peaks = dominant_peaks(s.deflection_bar, kReportedPeaks);
    }
  }
  result.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

MeshSpectra mesh_spectra(const TrainRunResult& r, std::size_t m) {
  const TrainSamples& s = r.samples;
  std::vector<double> force, deflection;
  for (std::size_t i = 0; i < s.t_s.size(); ++i) {
    if (s.t_s[i] < r.steady.from_s) continue;
    force.push_back(s.force_n[i][m]);
    deflection.push_back(s.deflection_bar[i][m]);
  }
  if (!(r.output_interval_s > 0)) return {};
  return {amplitude_spectrum(force, r.output_interval_s),
          amplitude_spectrum(deflection, r.output_interval_s)};
}

namespace {
nlohmann::ordered_json optional_json(const std::optional<double>& x) {
  return x ? nlohmann::ordered_json(*x) : nlohmann::ordered_json(nullptr);
}
nlohmann::ordered_json finite_json(double x) {
  return std::isfinite(x) ? nlohmann::ordered_json(x) : nlohmann::ordered_json(nullptr);
}
// A mesh's contact reading and extremes over a stretch (summary.json, docs/outputs.md).
void part_json(nlohmann::ordered_json& x, const TrainMeshPart& m, double backlash_m) {
  x["regime"] = to_string(m.regime);
  x["double_sided"] = m.double_sided;
  x["impacts"] = m.impacts;
  x["backside_impacts"] = m.backside_impacts;
  x["separations"] = m.separations;
  x["separated_fraction"] = m.separated_fraction;
  x["last_separation_s"] = optional_json(m.last_separation_s);
  x["max_force_n"] = m.max_force_n;
  x["min_force_n"] = m.min_force_n;
  x["max_deflection_bar"] = m.max_deflection_m / backlash_m;
  x["min_deflection_bar"] = m.min_deflection_m / backlash_m;
  x["max_impact_velocity_m_s"] = m.max_impact_velocity_m_s;
  x["mean_force_n"] = m.mean_force_n;
  x["rms_force_n"] = m.rms_force_n;
  x["mean_deflection_bar"] = m.mean_deflection_m / backlash_m;
  x["rms_deflection_bar"] = m.rms_deflection_m / backlash_m;
}
// Spectral peaks as the one-degree summary's: [{frequency_hz, amplitude}], largest first.
nlohmann::ordered_json peaks_json(const std::vector<SpectralPeak>& peaks) {
  nlohmann::ordered_json a = nlohmann::ordered_json::array();
  for (const SpectralPeak& p : peaks)
    a.push_back({{"frequency_hz", p.frequency_hz}, {"amplitude", p.amplitude}});
  return a;
}
// A joint's contact history (summary.json's bearings' "clearance_x", "_y", a joint's "contact").
nlohmann::ordered_json clearance_json(const ContactReading& whole, const ContactReading& steady) {
  const auto one = [](const ContactReading& c) {
    nlohmann::ordered_json x;
    x["impacts"] = c.impacts;
    x["separations"] = c.separations;
    x["inside_fraction"] = c.separated_fraction;
    return x;
  };
  nlohmann::ordered_json x = one(whole);
  if (steady.present) x["steady"] = one(steady);
  return x;
}
// A shaft's or bearing's reading (summary.json, docs/outputs.md): its name, each quantity's
// max_ and min_, the same over the steady part, then each one's static_, then its dynamic
// factor (part_dynamic_factor) by quantity.
nlohmann::ordered_json part_reading_json(const TrainRunResult& r, const std::string& name,
                                         const std::vector<TrainPartQuantity>& quantities) {
  nlohmann::ordered_json x, steady, factors;
  x["name"] = name;
  for (const TrainPartQuantity& q : quantities) {
    x[fmt::format("max_{}", q.what)] = finite_json(q.whole->max);
    x[fmt::format("min_{}", q.what)] = finite_json(q.whole->min);
    steady[fmt::format("max_{}", q.what)] = finite_json(q.steady->max);
    steady[fmt::format("min_{}", q.what)] = finite_json(q.steady->min);
  }
  x["steady"] = steady;
  for (const TrainPartQuantity& q : quantities) {
    x[fmt::format("static_{}", q.what)] = optional_json(*q.at_rest);
    factors[q.what] = optional_json(part_dynamic_factor(r, *q.steady, *q.at_rest));
  }
  x["dynamic_factor"] = factors;
  return x;
}
}  // namespace

std::optional<double> part_dynamic_factor(const TrainRunResult& r, const TrainExtremes& steady,
                                          const std::optional<double>& at_rest) {
  double scale = 0;  // the largest static mesh force
  for (const TrainMeshReading& m : r.meshes)
    if (m.static_force_n) scale = std::max(scale, std::abs(*m.static_force_n));
  if (!at_rest || !(std::abs(*at_rest) > kNegligibleStaticFraction * scale)) return std::nullopt;
  return std::max(std::abs(steady.max), std::abs(steady.min)) / std::abs(*at_rest);
}

std::string train_summary_json(const TrainRunResult& r, const std::vector<std::string>& unused,
                               int indent) {
  nlohmann::ordered_json j;
  const Case& c = r.input;
  j["case"] = c.name;
  j["description"] = c.description;
  // A pair's form run as its train (TrainSolver) keeps its name: "coupled".
  j["form"] = to_string(c.model.form);
  if (c.model.form == ModelForm::kCoupled) j["dof"] = c.model.dof;
  j["method"] = to_string(r.method);
  if (!r.method_note.empty()) j["method_note"] = r.method_note;
  j["termination"] = ode::to_string(r.termination);
  j["message"] = r.message;
  j["duration_s"] = c.solver.duration_s;
  j["system_period_s"] = optional_json(r.system_period_s);
  if (!r.system_period_note.empty()) j["system_period_note"] = r.system_period_note;
  if (!r.static_note.empty()) j["static_note"] = r.static_note;
  j["cells"] = r.cells;
  j["events"] = r.events;
  if (r.unsplit_steps > 0) j["unsplit_steps"] = r.unsplit_steps;
  j["steady"] = {{"basis", to_string(r.steady.basis)},
                 {"from_s", r.steady.from_s},
                 {"period_multiple", r.steady.period_multiple},
                 {"steady_error", finite_json(r.steady.error)}};
  if (r.steady.window_s > 0) j["steady"]["window_s"] = r.steady.window_s;
  nlohmann::ordered_json bodies = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < r.bodies.size(); ++i)
    bodies.push_back({{"name", r.bodies[i]},
                      {"speed_hz", r.body_speed_hz[i]},
                      {"inertia_kg_m2", r.body_inertia_kg_m2[i]},
                      {"mass_kg", r.body_mass_kg[i]}});
  j["bodies"] = bodies;
  nlohmann::ordered_json torques = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < r.torques.size(); ++k)
    torques.push_back({{"name", r.torques[k]}, {"mean_nm", r.torque_mean_nm[k]}});
  j["torques"] = torques;
  j["coordinates"] = r.coordinates;
  nlohmann::ordered_json meshes = nlohmann::ordered_json::array();
  for (const TrainMeshReading& m : r.meshes) {
    nlohmann::ordered_json x;
    x["name"] = m.name;
    x["mesh_frequency_hz"] = m.mesh_frequency_hz;
    x["mean_stiffness_n_per_m"] = m.mean_stiffness_n_per_m;
    x["backlash_m"] = m.backlash_m;
    if (m.layout_phase) x["layout_phase"] = *m.layout_phase;
    part_json(x, m, m.backlash_m);
    nlohmann::ordered_json steady;
    part_json(steady, m.steady, m.backlash_m);
    x["steady"] = steady;
    x["static_force_n"] = optional_json(m.static_force_n);
    x["dynamic_factor"] = optional_json(m.dynamic_factor);
    x["dynamic_factor_with_startup"] = optional_json(m.dynamic_factor_with_startup);
    x["spectrum"] = {{"force_n", peaks_json(m.force_peaks)},
                     {"deflection_bar", peaks_json(m.deflection_peaks)}};
    meshes.push_back(x);
  }
  j["meshes"] = meshes;
  // Each part's quantities, in part_quantities' order: a shaft's one, then a bearing's, then a
  // joint's.
  const std::vector<TrainPartQuantity> quantities = part_quantities(r);
  auto next = quantities.begin();
  const auto take = [&](const std::string& name, int count) {
    const std::vector<TrainPartQuantity> own(next, next + count);
    next += count;
    return part_reading_json(r, name, own);
  };
  nlohmann::ordered_json shafts = nlohmann::ordered_json::array();
  for (const TrainShaftReading& m : r.shafts) shafts.push_back(take(m.name, 1));
  j["shafts"] = shafts;
  nlohmann::ordered_json bearings = nlohmann::ordered_json::array();
  for (const TrainBearingReading& m : r.bearings) {
    nlohmann::ordered_json x = take(m.name, m.part_count());
    if (m.clearance_x.present) {
      x["clearance_x"] = clearance_json(m.clearance_x, m.steady_clearance_x);
      x["clearance_y"] = clearance_json(m.clearance_y, m.steady_clearance_y);
    }
    bearings.push_back(x);
  }
  j["bearings"] = bearings;
  // Each joint read as a part (an element's: a clutch damper): its force and x, its contact
  // history (a clearance direction's is its bearing's above).
  nlohmann::ordered_json joints = nlohmann::ordered_json::array();
  for (const TrainJointReading& m : r.joints) {
    if (!m.read) continue;
    nlohmann::ordered_json x = take(m.name, 2);
    x["contact"] = clearance_json(m.contact, m.steady_contact);
    joints.push_back(x);
  }
  j["joints"] = joints;
  nlohmann::ordered_json sharing = nlohmann::ordered_json::array();
  const auto optional = [](const std::optional<double>& x) {
    return x ? nlohmann::ordered_json(*x) : nlohmann::ordered_json();
  };
  for (const TrainLoadSharing& x : r.load_sharing) {
    nlohmann::ordered_json g;
    g["gear"] = x.gear;
    g["label"] = x.label;
    g["meshes"] = x.meshes;
    g["static_factor"] = optional(x.static_factor);
    g["unloaded_at_rest"] = x.unloaded_at_rest;
    g["factor"] = optional(x.factor);
    g["factor_with_startup"] = optional(x.factor_with_startup);
    g["lost_contact"] = x.lost_contact;
    sharing.push_back(g);
  }
  j["load_sharing"] = sharing;
  j["unused_settings"] = unused;
  j["wall_time_s"] = r.wall_time_s;
  return j.dump(indent);
}

void write_train_timeseries_csv(std::ostream& out, const TrainRunResult& r) {
  if (r.samples.deflection_rate_m_s.size() != r.samples.t_s.size())
    throw std::invalid_argument(
        "write_train_timeseries_csv: the samples' mesh rates are not "
        "filled (run_train fills them)");
  out << "t_s";
  for (const std::string& q : r.coordinates) out << ',' << q;
  for (const std::string& q : r.coordinates) out << ',' << q << "_s";
  for (const TrainMeshReading& m : r.meshes)
    out << ',' << m.name << "_deflection_bar," << m.name << "_force_n," << m.name << "_contact";
  for (const TrainPartQuantity& q : part_quantities(r)) out << ',' << q.part << '_' << q.what;
  for (const TrainMeshReading& m : r.meshes) out << ',' << m.name << "_deflection_rate_m_s";
  out << '\n';
  const TrainSamples& s = r.samples;
  write_csv_rows(out, s.t_s.size(), [&s, &r](CsvWriter& csv, std::size_t i) {
    csv.number(s.t_s[i]);
    for (Eigen::Index k = 0; k < s.state[i].size(); ++k) csv.number(s.state[i](k));
    for (std::size_t m = 0; m < r.meshes.size(); ++m)
      csv.number(s.deflection_bar[i][m]).number(s.force_n[i][m]).integer(s.contact[i][m]);
    for (const double x : s.parts[i]) csv.number(x);
    for (std::size_t m = 0; m < r.meshes.size(); ++m) csv.number(s.deflection_rate_m_s[i][m]);
    csv.end_row();
  });
}

void write_train_events_csv(std::ostream& out, const TrainRunResult& r) {
  out << "t_s,part,kind,velocity_m_s\n";
  for (const TrainContactEvent& e : r.contact_events)
    out << fmt::format("{:.15g},{},{},{:.10g}\n", e.t_s,
                       r.contact_parts[static_cast<std::size_t>(e.part)], to_string(e.kind),
                       e.velocity_m_s);
}

void write_train_run(const std::filesystem::path& dir, const TrainRunResult& r,
                     const std::vector<std::string>& unused) {
  write_files_atomically(
      dir, {{"summary.json", [&](std::ostream& o) { o << train_summary_json(r, unused) << "\n"; }},
            {"timeseries.csv", [&](std::ostream& o) { write_train_timeseries_csv(o, r); }},
            {"events.csv", [&](std::ostream& o) { write_train_events_csv(o, r); }},
            {"case.toml", [&](std::ostream& o) { o << to_toml(r.input); }}});
}

std::string train_modes_json(const train::Assembled& a, const std::vector<train::TrainMode>& m,
                             int indent) {
  nlohmann::ordered_json j = nlohmann::ordered_json::array();
  const train::Train& t = a.train();
  for (const train::TrainMode& x : m) {
    nlohmann::ordered_json mode;
    mode["frequency_hz"] = x.frequency_hz;
    mode["multiplicity"] = x.multiplicity;
    mode["damping_ratio"] = x.damping_ratio;
    if (!x.type.empty()) mode["type"] = x.type;
    nlohmann::ordered_json shape, shape_imag, mesh, shaft, bearing, parts, joint;
    // A rotation by its body's name (rad), a centre's displacement by "<body>_x", "<body>_y",
    // a spatial body's "<body>_z", "<body>_tx", "<body>_ty": the coordinate's name less its
    // unit.
    for (int i = 0; i < a.size(); ++i) {
      const std::string& q = a.coordinate_names()[static_cast<std::size_t>(i)];
      const std::string name = i < a.body_count() ? t.bodies[static_cast<std::size_t>(i)].name
                                                  : q.substr(0, q.rfind('_'));
      shape[name] = x.shape(i);
      if (x.shape_imag.size() > 0) shape_imag[name] = x.shape_imag(i);
    }
    for (std::size_t k = 0; k < t.meshes.size(); ++k) mesh[t.meshes[k].name] = x.mesh_energy[k];
    for (std::size_t k = 0; k < t.shafts.size(); ++k) shaft[t.shafts[k].name] = x.shaft_energy[k];
    for (std::size_t k = 0; k < t.bearings.size(); ++k) {
      bearing[t.bearings[k].name] = x.bearing_energy[k];
      // By direction: x and y, then the axial and tilt parts the bearing has.
      const Eigen::Index support = a.support_matrix(static_cast<int>(k)).rows();
      const std::array<double, 5>& e = x.bearing_parts[k];
      nlohmann::ordered_json p{{"x", e[0]}, {"y", e[1]}};
      if (support > 0) p["axial"] = e[2];
      if (support > 1) {
        p["tilt_x"] = e[3];
        p["tilt_y"] = e[4];
      }
      parts[t.bearings[k].name] = p;
    }
    for (std::size_t k = 0, read = 0; k < a.joints().size(); ++k)
      if (a.joints()[k].read) joint[a.joints()[k].name] = x.joint_energy[read++];
    mode["shape"] = shape;
    if (!shape_imag.is_null()) mode["shape_imag"] = shape_imag;  // a whirl (frame terms)
    mode["mesh_energy"] = mesh.is_null() ? nlohmann::ordered_json::object() : mesh;
    mode["shaft_energy"] = shaft.is_null() ? nlohmann::ordered_json::object() : shaft;
    mode["bearing_energy"] = bearing.is_null() ? nlohmann::ordered_json::object() : bearing;
    mode["bearing_energy_parts"] = parts.is_null() ? nlohmann::ordered_json::object() : parts;
    mode["joint_energy"] = joint.is_null() ? nlohmann::ordered_json::object() : joint;
    j.push_back(mode);
  }
  nlohmann::ordered_json damped = nlohmann::ordered_json::array();
  for (const auto& [f, z] : train::damped_eigenvalues(a))
    damped.push_back({{"frequency_hz", f}, {"damping_ratio", z}});
  nlohmann::ordered_json out;
  out["form"] = "train";
  out["modes"] = j;
  out["damped_eigenvalues"] = damped;
  return out.dump(indent);
}

std::string train_modes_table(const train::Assembled& a, const std::vector<train::TrainMode>& m) {
  const train::Train& t = a.train();
  // A planetary set's modes with their type (train::TrainMode::type).
  const bool typed = !m.empty() && !m.front().type.empty();
  std::string out =
      fmt::format("{:>4}  {:>14}  {:>4}  {:>7}", "mode", "frequency_hz", "mult", "zeta");
  if (typed) out += fmt::format("  {:<13}", "type");
  for (const train::Mesh& x : t.meshes) out += fmt::format("  {:>12}", x.name);
  for (const train::Shaft& x : t.shafts) out += fmt::format("  {:>12}", x.name);
  for (const train::Bearing& x : t.bearings) out += fmt::format("  {:>12}", x.name);
  for (const train::Joint& x : a.joints())
    if (x.read) out += fmt::format("  {:>12}", x.name);
  out += "   (strain energy, %)\n";
  for (std::size_t i = 0; i < m.size(); ++i) {
    out += fmt::format("{:>4}  {:>14.6g}  {:>4}  {:>7.4f}", i + 1, m[i].frequency_hz,
                       m[i].multiplicity, m[i].damping_ratio);
    if (typed) out += fmt::format("  {:<13}", m[i].type);
    for (double e : m[i].mesh_energy) out += fmt::format("  {:>12.2f}", 100 * e);
    for (double e : m[i].shaft_energy) out += fmt::format("  {:>12.2f}", 100 * e);
    for (double e : m[i].bearing_energy) out += fmt::format("  {:>12.2f}", 100 * e);
    for (double e : m[i].joint_energy) out += fmt::format("  {:>12.2f}", 100 * e);
    out += "\n";
  }
  return out;
}

}  // namespace geardyn
