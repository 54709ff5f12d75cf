#include "geardyn/coupled_run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <ostream>
#include <utility>
#include <vector>

#include "geardyn/case_keys.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/model.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_statics.hpp"
#include "studies/contact_tracker.hpp"

namespace geardyn {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The coupled model's cells are twice the one-degree model's in h times the fastest rate
// (EngineOptions::cell_rate_product 1.5): with 6 to 26 states a cell's cost (its series'
// products, the Jacobian's product by its map, its bounds) grows more slowly with its order
// than the number of cells falls. Measured in commit ee3725e: dof 12 runs, continuations
// and sweeps 14 to 25 % faster, a dof 3 continuation 13 %, at the same accuracy (1e-9 at the
// loosest tolerance).
constexpr double kCoupledCellRateProduct = 3.0;

// Looks at the engine's flow: samples, state changes per nonlinearity, exact extremes, over
// the whole window and, from a mark on, over the steady part beside it.
class CoupledObserver : public ode::FlowObserver {
 public:
  CoupledObserver(const CoupledModel& model, const ode::LinearSwitchedSystem& sys,
                  CoupledRunResult& out, double t0, double t1, double final_from, int region,
                  const std::function<bool(double)>& progress)
      : model_(model),
        sys_(sys),
        out_(out),
        progress_(progress),
        t0_(t0),
        t1_(t1),
        state_(coupled_state(region)),
        whole_(t0, t1, final_from, state_) {
    ranges_.resize(sys.regions.size());
    for (std::size_t r = 0; r < sys.regions.size(); ++r) {
      for (const ode::LinearGuard& g : sys.regions[r].observables) ranges_[r].emplace_back(g);
      readers_.emplace_back(sys, sys.regions[r].observables);
    }
  }

  // From t on (a time a flow ended at), the steady part is read beside the whole, its extremes
  // found against its own (a later mark starts it afresh).
  void mark(double t) { part_.emplace(t, t1_, t, state_); }

  // A whole coefficient period may be jumped when the span's state bounds leave no room for a
  // new extreme of any observable.
  bool needs_detail(const ode::CellView& span) override {
    bound_all(span);
    return any_room();
  }

  void on_cell(const ode::CellView& cell) override {
    if (!(cell.t_end_s > cell.t_begin_s)) return;
    bound_all(cell);
    if (!any_room()) return;
    extreme(cell, CoupledModel::kObservableForce, true);
    extreme(cell, CoupledModel::kObservableForce, false);
    extreme(cell, CoupledModel::kObservableDeflection, true);
    extreme(cell, CoupledModel::kObservableDeflection, false);
    for (int i = 0; i < 2; ++i) {
      absolute(cell, CoupledModel::kObservableBearing + i);
      absolute(cell, CoupledModel::kObservableAxial + i);
      absolute(cell, CoupledModel::kObservableShaft + i);
    }
  }

  void on_event(double t, const ode::Vector&, int from, int to) override {
    const CoupledState b = coupled_state(to);
    whole_.change(t, state_, b);
    if (part_) part_->change(t, state_, b);
    state_ = b;
  }

  void on_sample(double t, const ode::Vector& y, int region) override {
    CoupledSamples& s = out_.samples;
    readers_[static_cast<std::size_t>(region)](t, y, values_);
    const auto value = [&](int k) { return values_[k]; };
    const CoupledParameters& p = model_.parameters();
    s.t_s.push_back(t);
    s.state.push_back(y);
    s.deflection_bar.push_back(value(CoupledModel::kObservableDeflection) / p.backlash_m);
    s.force_bar.push_back(value(CoupledModel::kObservableForce) /
                          (p.backlash_m * p.stiffness_n_per_m.offset));
    s.mesh_contact.push_back(contact_state(coupled_state(region).mesh));
    s.bearing_force_n.push_back(
        {value(CoupledModel::kObservableBearing), value(CoupledModel::kObservableBearing + 1)});
    s.axial_force_n.push_back(
        {value(CoupledModel::kObservableAxial), value(CoupledModel::kObservableAxial + 1)});
    s.shaft_torque_nm.push_back(
        {value(CoupledModel::kObservableShaft), value(CoupledModel::kObservableShaft + 1)});
  }

  bool on_progress(double t) override { return !progress_ || progress_((t - t0_) / (t1_ - t0_)); }

  void finish() {
    const CoupledParameters& p = model_.parameters();
    static_cast<CoupledPart&>(out_) = whole_.reading(p);
    if (part_) out_.steady_part = part_->reading(p);
  }

 private:
  // What is read of one stretch: the contact histories and the extremes (indexed by
  // observable: the largest and smallest value, or for the forces read as magnitudes, the
  // largest |value| in `largest`).
  struct Tally {
    Tally(double t0, double t1, double final_from, const CoupledState& s)
        : mesh(t0, t1, final_from, contact_state(s.mesh)),
          bearings{ContactTracker(t0, t1, final_from, s.bearing[0]),
                   ContactTracker(t0, t1, final_from, s.bearing[1])} {
      high.fill(-kInf);
      low.fill(kInf);
    }
    void change(double t, const CoupledState& a, const CoupledState& b) {
      if (contact_state(a.mesh) != contact_state(b.mesh)) mesh.change(t, contact_state(b.mesh));
      for (int i = 0; i < 2; ++i)
        if (a.bearing[i] != b.bearing[i]) bearings[i].change(t, b.bearing[i]);
    }
    CoupledPart reading(const CoupledParameters& p) {
      CoupledPart r;
      r.mesh = mesh.reading();
      for (int i = 0; i < 2; ++i) {
        r.bearing[i] = bearings[i].reading();
        r.bearing[i].present = p.clearance_m[i] > 0;
        r.max_bearing_force_n[i] = largest[CoupledModel::kObservableBearing + i];
        r.max_axial_force_n[i] = largest[CoupledModel::kObservableAxial + i];
        r.max_shaft_torque_nm[i] = largest[CoupledModel::kObservableShaft + i];
      }
      r.max_force_n = high[CoupledModel::kObservableForce];
      r.min_force_n = low[CoupledModel::kObservableForce];
      r.max_deflection_m = high[CoupledModel::kObservableDeflection];
      r.min_deflection_m = low[CoupledModel::kObservableDeflection];
      return r;
    }
    ContactTracker mesh;
    std::array<ContactTracker, 2> bearings;
    std::array<double, CoupledModel::kObservableCount> high{}, low{}, largest{};
  };

  // The tally whose extremes a new value must beat to change a reading: the part's once
  // marked (within the whole's), else the whole's.
  const Tally& latest() const { return part_ ? *part_ : whole_; }
  void note(int k, bool maximum, double v) {
    for (Tally* x : {&whole_, part_ ? &*part_ : nullptr}) {
      if (!x) continue;
      if (maximum)
        x->high[k] = std::max(x->high[k], v);
      else
        x->low[k] = std::min(x->low[k], v);
    }
  }
  void note_magnitude(int k, double v) {
    whole_.largest[k] = std::max(whole_.largest[k], v);
    if (part_) part_->largest[k] = std::max(part_->largest[k], v);
  }
  // Every observable's bounds over a cell or span (of its region), into low_ and high_.
  void bound_all(const ode::CellView& cell) {
    for (int k = 0; k < CoupledModel::kObservableCount; ++k)
      ranges_[cell.region][k].bounds(*cell.lower, *cell.upper, low_[k], high_[k]);
  }
  // Whether the bounds of the last bound_all leave room for a new extreme of any observable
  // read.
  bool any_room() const {
    const Tally& x = latest();
    for (const int k : {CoupledModel::kObservableForce, CoupledModel::kObservableDeflection})
      if (high_[k] > x.high[k] || low_[k] < x.low[k]) return true;
    for (int i = 0; i < 2; ++i)
      for (const int k : {CoupledModel::kObservableBearing + i, CoupledModel::kObservableAxial + i,
                          CoupledModel::kObservableShaft + i})
        if (high_[k] > x.largest[k] || -low_[k] > x.largest[k]) return true;
    return false;
  }
  // The cell's extreme of observable k beyond the latest one (its maximum or minimum), when
  // the cell's bounds (bound_all) leave room for one: then found exactly on the cell's
  // polynomial.
  void extreme(const ode::CellView& cell, int k, bool maximum) {
    const double seen = maximum ? latest().high[k] : latest().low[k];
    double v = 0, t = 0;
    if (maximum ? !(high_[k] > seen) : !(low_[k] < seen)) return;
    if (cell.extreme(k, maximum, seen, v, t)) note(k, maximum, v);
  }
  void absolute(const ode::CellView& cell, int k) {
    const double largest = latest().largest[k];
    double v = 0, t = 0;
    if (high_[k] > largest && cell.extreme(k, true, largest, v, t)) note_magnitude(k, v);
    if (-low_[k] > largest && cell.extreme(k, false, -largest, v, t)) note_magnitude(k, -v);
  }

  const CoupledModel& model_;
  const ode::LinearSwitchedSystem& sys_;
  CoupledRunResult& out_;
  const std::function<bool(double)>& progress_;
  double t0_, t1_;
  CoupledState state_;  // the nonlinearities' states now
  Tally whole_;
  std::optional<Tally> part_;
  std::vector<std::vector<ode::FunctionalBounds>> ranges_;             // per region, per observable
  std::array<double, CoupledModel::kObservableCount> low_{}, high_{};  // the last bound_all's
  std::vector<ode::FunctionalValues> readers_;  // per region, of its observables
  std::vector<double> values_;                  // a sample's observables
};

// The shortest time scale: the fastest natural period in contact or excitation period.
double fastest_period_s(const CoupledModel& m) {
  double w = 0;
  for (const Mode& x : modes(m).modes) w = std::max(w, 2 * std::numbers::pi * x.frequency_hz);
  const CoupledParameters& p = m.parameters();
  w = std::max({w, p.stiffness_n_per_m.max_angular_frequency_rad_s(),
                p.drive_torque_nm.max_angular_frequency_rad_s(),
                p.load_torque_nm.max_angular_frequency_rad_s(),
                p.transmission_error_m.max_angular_frequency_rad_s()});
  return 2 * std::numbers::pi / w;
}

}  // namespace

CoupledSolver::CoupledSolver(const Case& c, const MeshStiffness* stiffness) : case_(c) {
  if (const std::string err = validate(c); !err.empty()) throw InputError(err);
  if (c.solver.method != Method::kExact)
    throw InputError(fmt::format(
        "solver.method = \"{}\": the coupled model runs with the exact engine (\"exact\")",
        to_string(c.solver.method)));
  model_ = std::make_unique<CoupledModel>(coupled_parameters(c, stiffness));
  ode::EngineOptions eo;
  eo.tolerance = std::max(ode::kRoundingLimit, c.solver.tolerance * kExactToleranceFraction);
  eo.cell_rate_product = kCoupledCellRateProduct;
  try {
    engine_ = std::make_unique<ode::ExactEngine>(model_->linear_system(), eo);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("the coupled model's exact engine: ") + e.what());
  }
}

CoupledSolver::~CoupledSolver() = default;

ode::Vector CoupledSolver::initial_state(InitialCondition initial) const {
  if (initial == InitialCondition::kCenter) return model_->rest_state();
  try {
    return model_->static_state(true);
  } catch (const std::runtime_error& e) {
    throw InputError(std::string("solver.initial = \"static\": ") + e.what());
  }
}

ode::FlowResult CoupledSolver::advance(double t0, const ode::Vector& y0, double t1) const {
  ode::FlowObserver nothing;
  return engine_->flow(t0, y0, model_->classify(t0, y0), t1, ode::OutputGrid{}, nothing);
}

ode::FlowResult CoupledSolver::advance_with_jacobian(double t0, const ode::Vector& y0,
                                                     double t1) const {
  ode::FlowObserver nothing;
  return engine_->flow(t0, y0, model_->classify(t0, y0), t1, ode::OutputGrid{}, nothing, true);
}

namespace {
// The dynamic factors of a coupled result, over its steady part when one was marked, else over
// the window read (CoupledRunResult).
void factors(CoupledRunResult& result) {
  const CoupledParameters& p = result.parameters;
  const double fs = p.static_mesh_force_n();
  const CoupledPart& x = result.steady.marked ? result.steady_part : result;
  result.dynamic_mesh_factor = x.max_force_n / fs;
  result.dynamic_mesh_factor_with_startup = result.max_force_n / fs;
  for (int i = 0; i < 2; ++i) {
    result.bearing_factor[i] = x.max_bearing_force_n[i] / (p.cos_base_helix * fs);
    result.axial_factor[i] = p.sin_base_helix > 0 ? x.max_axial_force_n[i] / (p.sin_base_helix * fs)
                                                  : std::numeric_limits<double>::quiet_NaN();
    result.shaft_factor[i] = p.shaft[i] >= 0
                                 ? x.max_shaft_torque_nm[i] / p.static_shaft_torque_nm(i)
                                 : std::numeric_limits<double>::quiet_NaN();
  }
  if (result.ok() && !(std::isfinite(result.max_force_n) && std::isfinite(result.min_force_n))) {
    result.termination = ode::Termination::kNoProgress;
    result.message = "non-finite readings (an overflow)";
  }
}
}  // namespace

CoupledRunResult CoupledSolver::read(double t0, const ode::Vector& y0, double t1,
                                     const ode::OutputGrid& grid, double final_from,
                                     const std::function<bool(double)>& progress,
                                     ode::Vector* end_state) const {
  return read_pieces(t0, y0, t1, grid, final_from, std::nullopt, progress, end_state);
}

CoupledRunResult CoupledSolver::read_watching(double t0, const ode::Vector& y0, double t1,
                                              const ode::OutputGrid& grid, double final_from,
                                              double period_s,
                                              const std::function<bool(double)>& progress) const {
  return read_pieces(t0, y0, t1, grid, final_from, period_s, progress, nullptr);
}

CoupledRunResult CoupledSolver::read_pieces(double t0, const ode::Vector& y0, double t1,
                                            const ode::OutputGrid& grid, double final_from,
                                            std::optional<double> period_s,
                                            const std::function<bool(double)>& progress,
                                            ode::Vector* end_state) const {
  CoupledRunResult result;
  result.input = case_;
  result.parameters = model_->parameters();
  const int region = model_->classify(t0, y0);
  CoupledObserver observer(*model_, engine_->system(), result, t0, t1, final_from, region,
                           progress);
  CoupledSections sections(model_->parameters(), case_.solver.tolerance);
  FlowPieces pieces(
      t0, y0, region, t1, grid,
      [&](double from, const ode::Vector& y, int r, double to, const ode::OutputGrid& piece) {
        return engine_->flow(from, y, r, to, piece, observer);
      },
      progress);
  const auto judge = [&] {
    sections.add(pieces.t_s(), pieces.state());
    return sections.judge(kSteadyTolerance);
  };
  if (period_s)
    result.steady = integrate_watching(t0, t1, *period_s, judge, std::ref(pieces),
                                       [&](double at) { observer.mark(at); });
  else
    pieces(t1);
  if (end_state) *end_state = pieces.state();
  result.termination = pieces.total().termination;
  result.message = pieces.total().message;
  result.cells = pieces.total().cells;
  result.events = pieces.total().events;
  observer.finish();
  factors(result);
  return result;
}

CoupledSections::CoupledSections(const CoupledParameters& p, double integration_tolerance) : p_(p) {
  for (std::size_t i = 0; i < p.coordinates.size(); ++i)
    if (std::ranges::count(std::array{Coordinate::kLine1, Coordinate::kLine2, Coordinate::kAxial1,
                                      Coordinate::kAxial2},
                           p.coordinates[i]) > 0)
      bearing_coordinates_.push_back(static_cast<Eigen::Index>(i));
  const double w_n = std::sqrt(p.cos_base_helix * p.cos_base_helix * p.stiffness_n_per_m.offset /
                               p.equivalent_mass_kg);
  series_.assign(1 + bearing_coordinates_.size(),
                 SectionSeries(p.backlash_m, w_n, integration_tolerance));
}

ode::State CoupledSections::mesh(double t_s, const ode::Vector& y) const {
  const Eigen::Index n = p_.size();
  const HarmonicSeries& e = p_.transmission_error_m;
  return {t_s, p_.mesh_vector.dot(y.head(n)) - e(t_s), p_.mesh_vector.dot(y.tail(n)) - e.rate(t_s),
          0.0, 0};
}

void CoupledSections::add(double t_s, const ode::Vector& y) {
  series_[0].add(mesh(t_s, y));
  for (std::size_t j = 0; j < bearing_coordinates_.size(); ++j) {
    const Eigen::Index i = bearing_coordinates_[j];
    series_[j + 1].add(ode::State{t_s, y(i), y(p_.size() + i), 0.0, 0});
  }
}

double coupled_section_period_s(const Case& c, const MeshStiffness* stiffness) {
  try {
    return section_period_s(build_model(gear_pair_of(c), nullptr, stiffness).parameters());
  } catch (const InputError&) {
    return 0;  // no common period
  }
}

CoupledRunResult run_coupled(const Case& c, const CoupledRunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  const CoupledSolver solver(c);
  const double t0 = 0, t1 = c.solver.duration_s;
  const double interval = checked_output_interval_s(c, fastest_period_s(solver.model()), "model");
  CoupledRunResult result = solver.read_watching(
      t0, solver.initial_state(c.solver.initial), t1, ode::make_output_grid(t0, t1, interval),
      t1 * (1 - c.solver.final_fraction), coupled_section_period_s(c), options.progress);
  result.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace geardyn
