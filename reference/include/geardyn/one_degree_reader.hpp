// geardyn: the one-degree model's reader (one_degree_reader.cpp), a reference implementation in
// the geardyn_reference library (reference/). RunReader is the integrators' observer for the
// gear model: it records the located transitions (impacts and separations), the time spent
// separated, the extremes of the response at every step, and the uniform output samples, as
// the readings of analysis.hpp.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "geardyn/analysis.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/model.hpp"

namespace geardyn {

class RunReader {
 public:
  // `keep_events` and `keep_samples` may be turned off when only the statistics are wanted.
  // `progress` (may be empty) is called with the fraction done; returning false cancels.
  RunReader(const GearPairModel& model, double t0_s, double t1_s, double final_fraction,
            bool keep_events = true, bool keep_samples = true,
            std::function<bool(double)> progress = {});

  // From t_s on (a time the integration stopped at, between two calls), the reader also reads
  // the rest of the run on its own: part_reading(), as a reader of [t_s, t1] with final
  // fraction 1 would (neither events nor samples kept). A later mark starts the part afresh.
  // The whole is read as before; the run's steady part is read so in the same pass.
  void mark(double t_s);
  bool marked() const { return part_.has_value(); }

  // Observer interface (integrator.hpp).
  void on_step(const ode::State& s, const GearPairModel::Drive& d) {
    on_time(s.t, s.region);
    on_point(s, d);
  }
  // The time accounting of a step alone: it ended at t_s in `region`.
  void on_time(double t_s, int region) {
    if (contact_state(region) == 0) {
      whole_.separated_for(t_s - last_t_, t_s);
      if (part_) part_->separated_for(t_s - last_t_, t_s);
    }
    last_t_ = t_s;
  }
  // A point inside a step: only the extremes look at it.
  void on_point(const ode::State& s, const GearPairModel::Drive& d) {
    const double f = model_.mesh_force(d, s.q, s.v, s.region);
    whole_.extremes(f, s.q);
    if (part_) part_->extremes(f, s.q);
  }
  void on_transition(const ode::State& s, int from_region);
  void on_sample(const ode::State& s) { on_sample(s, model_.drive(s.t)); }
  // The same with the inputs at s.t given (a caller that has them on a grid).
  void on_sample(const ode::State& s, const GearPairModel::Drive& d);
  bool on_progress(double t_s) { return !progress_ || progress_((t_s - t0_) / (t1_ - t0_)); }

  RunReading reading() const { return read(whole_); }
  // The reading of [mark, t1]; only when marked().
  RunReading part_reading() const { return read(*part_); }
  // The extremes so far, SI (N, m), of the part when marked (those an extreme inside a step
  // must beat to change either reading), else of the whole.
  double max_force_n() const { return latest().max_force; }
  double min_force_n() const { return latest().min_force; }
  double max_delta_m() const { return latest().max_delta; }
  double min_delta_m() const { return latest().min_delta; }
  const std::vector<ContactEvent>& events() const { return events_; }
  Timeseries& samples() { return samples_; }
  // Room for n samples, so that keeping them does not reallocate.
  void reserve_samples(std::size_t n);

 private:
  // What is read of one stretch of the run, [start_s, t1].
  struct Tally {
    Tally(double start_s, double final_start_s);
    void separated_for(double dt_s, double t_s) {
      separated_time += dt_s;
      if (t_s > final_start) separated_in_final = true;
    }
    void extremes(double force_n, double delta_m) {
      max_force = std::max(max_force, force_n);
      min_force = std::min(min_force, force_n);
      max_delta = std::max(max_delta, delta_m);
      min_delta = std::min(min_delta, delta_m);
    }
    double start, final_start;
    double separated_time = 0;
    bool separated_in_final = false;
    bool back_contact = false;
    double max_force, min_force, max_delta, min_delta;
    SampleMoments force_bar, delta_bar;
    std::int64_t impacts = 0, backside_impacts = 0, separations = 0;
    std::optional<double> last_separation;
    double max_impact_velocity = 0;
  };
  const Tally& latest() const { return part_ ? *part_ : whole_; }
  RunReading read(const Tally& t) const;

  const GearPairModel& model_;
  double t0_, t1_;
  bool keep_events_, keep_samples_;
  std::function<bool(double)> progress_;
  double b_, force_scale_;
  double last_t_;
  Tally whole_;
  std::optional<Tally> part_;
  std::vector<ContactEvent> events_;
  Timeseries samples_;
};

// The extremes of delta and F_G inside the exact engine's cells for a RunReader, found exactly
// (a search on the cell's polynomial) so that the readings do not depend on the engine's cell
// length, and deferred: a stretch whose bounds leave room for an extreme beyond those seen is
// kept (ode::KeptStretches) with its bounds (CellView::range), and finish() searches the kept
// stretches in the order of their bounds, each only while its bound still reaches the best
// value found. A response
// whose crests each beat the last (a steady part that still drifts) is then searched at a few
// crests, not at every one.
class CellExtremes {
 public:
  CellExtremes(const GearPairModel& model, RunReader& reader, const ode::ExactEngine& engine);
  // Looks at a stretch inside the engine's on_cell: kept if it may hold a new extreme.
  void look(const ode::CellView& cell);
  // Whether bounds of the state over a span leave room for an extreme beyond those seen.
  bool room(const ode::CellView& span) const;
  // Searches the kept stretches, so that the reader holds every extreme of the flows looked
  // at: to be called before the reader is marked or read.
  void finish();

 private:
  // The extremes in the order max delta, min delta, max F, min F.
  using Four = std::array<double, 4>;
  // Bounds of the four over a stretch in `engine_region` from those of delta and delta'.
  Four bounds_from_state(int engine_region, double dlo, double dhi, double vlo, double vhi) const;
  Four seen() const;  // the reader's extremes so far
  static bool beyond(int q, double bound, double seen) {
    return q % 2 == 0 ? bound > seen : bound < seen;
  }
  static bool room(const Four& bound, const Four& seen);

  const GearPairModel& model_;
  RunReader& reader_;
  const ode::ExactEngine& engine_;
  double k_min_, k_max_;                      // bounds of k(t)
  ode::Vector point_ = ode::Vector::Zero(2);  // a state inside a cell
  ode::KeptStretches kept_;
  std::vector<Four> kept_bounds_;   // of each kept stretch
  std::vector<std::size_t> order_;  // finish's scratch: the stretches to search
};

// The exact engine's observer for a run of the gear model: passes its steps, events and samples
// to a RunReader and its cells to a CellExtremes.
class RunFlowObserver final : public ode::FlowObserver {
 public:
  // `grid` is the output grid of the flow: the inputs at its times are rotated, not evaluated.
  RunFlowObserver(const GearPairModel& model, RunReader& reader, const ode::OutputGrid& grid,
                  CellExtremes& extremes);
  void on_cell(const ode::CellView& cell) override { extremes_.look(cell); }
  // A span needs detail when its bounds leave room for a new extreme.
  bool needs_detail(const ode::CellView& span) override { return extremes_.room(span); }
  // The extremes at a step's end were looked at by on_cell.
  void on_step(double t_s, const ode::Vector& /*y*/, int region) override {
    reader_.on_time(t_s, region + GearPairModel::kFirstRegion);
  }
  void on_event(double t_s, const ode::Vector& y, int from, int to) override {
    reader_.on_transition(state(t_s, y, to), from + GearPairModel::kFirstRegion);
  }
  void on_sample(double t_s, const ode::Vector& y, int region) override {
    reader_.on_sample(state(t_s, y, region), sample_drive_.next());
  }
  bool on_progress(double t_s) override { return reader_.on_progress(t_s); }

 private:
  static ode::State state(double t_s, const ode::Vector& y, int region) {
    return {t_s, y[0], y[1], 0.0, region + GearPairModel::kFirstRegion};
  }
  RunReader& reader_;
  CellExtremes& extremes_;
  GearPairModel::DriveGrid sample_drive_;
};

}  // namespace geardyn
