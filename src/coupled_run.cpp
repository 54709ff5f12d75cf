#include "geardyn/coupled_run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <ostream>
#include <utility>
#include <vector>

#include "contact_tracker.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/csv.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/model.hpp"
#include "geardyn/run.hpp"

namespace geardyn {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The coupled model's cells are twice the one-degree model's in h times the fastest rate
// (EngineOptions::cell_rate_product 1.5): with 6 to 26 states a cell's cost (its series'
// products, the Jacobian's product by its map, its bounds) grows more slowly with its order
// than the number of cells falls. Measured (docs/performance.md): dof 12 runs, continuations
// and sweeps 14 to 25 % faster, a dof 3 continuation 13 %, at the same accuracy (1e-9 at the
// loosest tolerance).
constexpr double kCoupledCellRateProduct = 3.0;

// Looks at the engine's flow: samples, state changes per nonlinearity, exact extremes.
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
        mesh_(t0, t1, final_from, contact_state(coupled_state(region).mesh)),
        bearings_{ContactTracker(t0, t1, final_from, coupled_state(region).bearing[0]),
                  ContactTracker(t0, t1, final_from, coupled_state(region).bearing[1])} {
    out_.max_force_n = out_.max_deflection_m = -kInf;
    out_.min_force_n = out_.min_deflection_m = kInf;
    ranges_.resize(sys.regions.size());
    for (std::size_t r = 0; r < sys.regions.size(); ++r) {
      for (const ode::LinearGuard& g : sys.regions[r].observables) ranges_[r].emplace_back(g);
      readers_.emplace_back(sys, sys.regions[r].observables);
    }
  }

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
    extreme(cell, CoupledModel::kObservableForce, true, out_.max_force_n);
    extreme(cell, CoupledModel::kObservableForce, false, out_.min_force_n);
    extreme(cell, CoupledModel::kObservableDeflection, true, out_.max_deflection_m);
    extreme(cell, CoupledModel::kObservableDeflection, false, out_.min_deflection_m);
    for (int i = 0; i < 2; ++i) {
      absolute(cell, CoupledModel::kObservableBearing + i, out_.max_bearing_force_n[i]);
      absolute(cell, CoupledModel::kObservableAxial + i, out_.max_axial_force_n[i]);
      absolute(cell, CoupledModel::kObservableShaft + i, out_.max_shaft_torque_nm[i]);
    }
  }

  void on_event(double t, const ode::Vector&, int from, int to) override {
    const CoupledState a = coupled_state(from), b = coupled_state(to);
    if (contact_state(a.mesh) != contact_state(b.mesh)) mesh_.change(t, contact_state(b.mesh));
    for (int i = 0; i < 2; ++i)
      if (a.bearing[i] != b.bearing[i]) bearings_[i].change(t, b.bearing[i]);
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
    out_.mesh = mesh_.reading();
    const CoupledParameters& p = model_.parameters();
    for (int i = 0; i < 2; ++i) {
      out_.bearing[i] = bearings_[i].reading();
      out_.bearing[i].present = p.clearance_m[i] > 0;
    }
  }

 private:
  // Every observable's bounds over a cell or span (of its region), into low_ and high_.
  void bound_all(const ode::CellView& cell) {
    for (int k = 0; k < CoupledModel::kObservableCount; ++k)
      ranges_[cell.region][k].bounds(*cell.lower, *cell.upper, low_[k], high_[k]);
  }
  // Whether the bounds of the last bound_all leave room for a new extreme of any observable
  // read.
  bool any_room() const {
    if (high_[CoupledModel::kObservableForce] > out_.max_force_n ||
        low_[CoupledModel::kObservableForce] < out_.min_force_n)
      return true;
    if (high_[CoupledModel::kObservableDeflection] > out_.max_deflection_m ||
        low_[CoupledModel::kObservableDeflection] < out_.min_deflection_m)
      return true;
    for (int i = 0; i < 2; ++i)
      for (const auto& [k, largest] :
           {std::pair{CoupledModel::kObservableBearing + i, out_.max_bearing_force_n[i]},
            std::pair{CoupledModel::kObservableAxial + i, out_.max_axial_force_n[i]},
            std::pair{CoupledModel::kObservableShaft + i, out_.max_shaft_torque_nm[i]}})
        if (high_[k] > largest || -low_[k] > largest) return true;
    return false;
  }
  // The cell's extreme of observable k beyond `seen` (its maximum or minimum), when the cell's
  // bounds (bound_all) leave room for one: then found exactly on the cell's polynomial.
  void extreme(const ode::CellView& cell, int k, bool maximum, double& seen) const {
    double v = 0, t = 0;
    if (maximum ? !(high_[k] > seen) : !(low_[k] < seen)) return;
    if (cell.extreme(k, maximum, seen, v, t)) seen = v;
  }
  void absolute(const ode::CellView& cell, int k, double& largest) const {
    double v = 0, t = 0;
    if (high_[k] > largest && cell.extreme(k, true, largest, v, t)) largest = std::max(largest, v);
    if (-low_[k] > largest && cell.extreme(k, false, -largest, v, t))
      largest = std::max(largest, -v);
  }

  const CoupledModel& model_;
  const ode::LinearSwitchedSystem& sys_;
  CoupledRunResult& out_;
  const std::function<bool(double)>& progress_;
  double t0_, t1_;
  ContactTracker mesh_;
  std::array<ContactTracker, 2> bearings_;
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
  if (initial == InitialCondition::kCenter)
    return ode::Vector::Zero(2 * model_->parameters().size());
  try {
    return model_->static_state();
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

CoupledRunResult CoupledSolver::read(double t0, const ode::Vector& y0, double t1,
                                     const ode::OutputGrid& grid, double final_from,
                                     const std::function<bool(double)>& progress,
                                     ode::Vector* end_state) const {
  CoupledRunResult result;
  result.input = case_;
  result.parameters = model_->parameters();
  const CoupledParameters& p = result.parameters;
  const int region = model_->classify(t0, y0);
  CoupledObserver observer(*model_, engine_->system(), result, t0, t1, final_from, region,
                           progress);
  const ode::FlowResult flow = engine_->flow(t0, y0, region, t1, grid, observer);
  observer.finish();
  if (end_state) *end_state = flow.state;
  result.termination = flow.termination;
  result.message = flow.message;
  result.cells = flow.cells;
  result.events = flow.events;
  const double fs = p.static_mesh_force_n();
  result.dynamic_mesh_factor = result.max_force_n / fs;
  for (int i = 0; i < 2; ++i) {
    result.bearing_factor[i] = result.max_bearing_force_n[i] / (p.cos_base_helix * fs);
    result.axial_factor[i] = p.sin_base_helix > 0
                                 ? result.max_axial_force_n[i] / (p.sin_base_helix * fs)
                                 : std::numeric_limits<double>::quiet_NaN();
    result.shaft_factor[i] = p.shaft[i] >= 0
                                 ? result.max_shaft_torque_nm[i] / p.static_shaft_torque_nm(i)
                                 : std::numeric_limits<double>::quiet_NaN();
  }
  if (result.ok() && !(std::isfinite(result.max_force_n) && std::isfinite(result.min_force_n))) {
    result.termination = ode::Termination::kNoProgress;
    result.message = "non-finite readings (an overflow)";
  }
  return result;
}

double checked_output_interval_s(const Case& c, double fastest_period_s, const char* what) {
  const double t1 = c.solver.duration_s;
  const double interval =
      c.solver.output_interval_s > 0
          ? c.solver.output_interval_s
          : std::max(t1 / kMaxAutomaticSamples,
                     std::min(t1 / kAutomaticSamples, fastest_period_s / kSamplesPerFastestPeriod));
  const double samples = t1 / interval + 1;
  if (!(samples <= kMaxSamples))
    throw InputError(
        with_origins(c, fmt::format("solver.output_interval_s = {:.6g}: {:.3g} samples over "
                                    "solver.duration_s = {:.6g}; at most {:.0e}",
                                    interval, samples, t1, kMaxSamples)));
  if (!(t1 / fastest_period_s <= kMaxFastestPeriods))
    throw InputError(with_origins(
        c, fmt::format("solver.duration_s = {:.6g}: {:.3g} periods of the {}'s fastest time "
                       "scale ({:.3g} s); at most {:.0e}",
                       t1, t1 / fastest_period_s, what, fastest_period_s, kMaxFastestPeriods)));
  return interval;
}

CoupledRunResult run_coupled(const Case& c, const CoupledRunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  const CoupledSolver solver(c);
  const double t0 = 0, t1 = c.solver.duration_s;
  const double interval = checked_output_interval_s(c, fastest_period_s(solver.model()), "model");
  CoupledRunResult result = solver.read(t0, solver.initial_state(c.solver.initial), t1,
                                        ode::make_output_grid(t0, t1, interval),
                                        t1 * (1 - c.solver.final_fraction), options.progress);
  result.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

namespace {

nlohmann::json contact_json(const ContactReading& r) {
  nlohmann::json j = {
      {"regime", to_string(r.regime)}, {"double_sided", r.double_sided},
      {"impacts", r.impacts},          {"backside_impacts", r.backside_impacts},
      {"separations", r.separations},  {"separated_fraction", r.separated_fraction}};
  j["last_separation_s"] =
      r.last_separation_s ? nlohmann::json(*r.last_separation_s) : nlohmann::json(nullptr);
  return j;
}

nlohmann::json finite_or_null(double x) {
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

}  // namespace

std::string coupled_summary_json(const CoupledRunResult& r, int indent) {
  const CoupledParameters& p = r.parameters;
  nlohmann::json j;
  j["case"] = r.input.name;
  j["model"] = "coupled";
  j["dof"] = p.dof;
  j["completed"] = r.ok();
  j["termination"] = ode::to_string(r.termination);
  j["message"] = r.message;
  nlohmann::json coords = nlohmann::json::array();
  for (Coordinate x : p.coordinates) coords.push_back(to_string(x));
  j["coordinates"] = coords;
  j["mesh"] = contact_json(r.mesh);
  j["mesh"]["max_force_n"] = r.max_force_n;
  j["mesh"]["min_force_n"] = r.min_force_n;
  j["mesh"]["max_deflection_bar"] = r.max_deflection_m / p.backlash_m;
  j["mesh"]["min_deflection_bar"] = r.min_deflection_m / p.backlash_m;
  j["mesh"]["static_force_n"] = p.static_mesh_force_n();
  j["mesh"]["dynamic_factor"] = r.dynamic_mesh_factor;
  nlohmann::json bearings = nlohmann::json::array();
  for (int i = 0; i < 2; ++i) {
    nlohmann::json b = {{"gear", i + 1},
                        {"max_line_force_n", r.max_bearing_force_n[i]},
                        {"line_force_factor", r.bearing_factor[i]},
                        {"max_axial_force_n", r.max_axial_force_n[i]},
                        {"axial_force_factor", finite_or_null(r.axial_factor[i])},
                        {"clearance_um", p.clearance_m[i] * 1e6}};
    b["clearance"] = r.bearing[i].present ? contact_json(r.bearing[i]) : nlohmann::json(nullptr);
    bearings.push_back(b);
  }
  j["bearings"] = bearings;
  nlohmann::json shafts = nlohmann::json::array();
  for (int i = 0; i < 2; ++i)
    if (p.shaft[i] >= 0)
      shafts.push_back({{"shaft", i + 1},
                        {"end", i == 0 ? "motor" : "load"},
                        {"end_inertia_kg_m2", r.input.shafts.end_inertia_kg_m2[i]},
                        {"static_torque_nm", p.static_shaft_torque_nm(i)},
                        {"max_torque_nm", r.max_shaft_torque_nm[i]},
                        {"torque_factor", finite_or_null(r.shaft_factor[i])}});
  j["shafts"] = shafts;
  j["cells"] = r.cells;
  j["events"] = r.events;
  j["duration_s"] = r.input.solver.duration_s;
  j["wall_time_s"] = r.wall_time_s;
  j["unused_settings"] = unused_settings(r.input);
  return j.dump(indent);
}

void write_coupled_timeseries_csv(std::ostream& out, const CoupledRunResult& r) {
  const CoupledParameters& p = r.parameters;
  std::string header = "t_s";
  for (Coordinate x : p.coordinates) header += fmt::format(",{}", to_string(x));
  for (Coordinate x : p.coordinates) {
    std::string rate = to_string(x);  // "y1_m" -> "y1_m_s", "ty1_rad" -> "ty1_rad_s"
    header += fmt::format(",{}_s", rate);
  }
  header +=
      ",deflection_bar,force_bar,mesh_contact,bearing1_force_n,bearing2_force_n,axial1_force_n,"
      "axial2_force_n";
  for (int i = 0; i < 2; ++i)
    if (p.shaft[i] >= 0) header += fmt::format(",shaft{}_torque_nm", i + 1);
  out << header << '\n';
  const CoupledSamples& s = r.samples;
  CsvWriter csv(out);
  for (std::size_t k = 0; k < s.t_s.size(); ++k) {
    csv.number(s.t_s[k]);
    for (Eigen::Index i = 0; i < s.state[k].size(); ++i) csv.number(s.state[k][i]);
    csv.number(s.deflection_bar[k]).number(s.force_bar[k]).integer(s.mesh_contact[k]);
    csv.number(s.bearing_force_n[k][0]).number(s.bearing_force_n[k][1]);
    csv.number(s.axial_force_n[k][0]).number(s.axial_force_n[k][1]);
    for (int i = 0; i < 2; ++i)
      if (p.shaft[i] >= 0) csv.number(s.shaft_torque_nm[k][i]);
    csv.end_row();
  }
  csv.finish();
}

std::string modes_json(const ModeSet& m, int indent) {
  nlohmann::json j;
  nlohmann::json coords = nlohmann::json::array();
  for (Coordinate x : m.coordinates) coords.push_back(to_string(x));
  j["coordinates"] = coords;
  nlohmann::json list = nlohmann::json::array();
  for (const Mode& x : m.modes) {
    std::vector<double> shape(x.shape.data(), x.shape.data() + x.shape.size());
    list.push_back({{"frequency_hz", x.frequency_hz},
                    {"damping_ratio", x.damping_ratio},
                    {"shape", shape},
                    {"energy",
                     {{"mesh", x.mesh_energy},
                      {"line_bearings", {x.line_energy[0], x.line_energy[1]}},
                      {"axial_bearings", {x.axial_energy[0], x.axial_energy[1]}},
                      {"tilt_bearings", {x.tilt_energy[0], x.tilt_energy[1]}},
                      {"cross_bearings", {x.cross_energy[0], x.cross_energy[1]}},
                      {"shafts", {x.shaft_energy[0], x.shaft_energy[1]}}}}});
  }
  j["modes"] = list;
  nlohmann::json damped = nlohmann::json::array();
  for (const auto& [f, z] : m.damped) damped.push_back({{"frequency_hz", f}, {"damping_ratio", z}});
  j["damped_eigenvalues"] = damped;
  return j.dump(indent);
}

std::string modes_table(const ModeSet& m) {
  std::string out =
      fmt::format("{:>4} {:>12} {:>8}   strain energy: {:>6} {:>13} {:>13} {:>13} {:>13} {:>13}\n",
                  "mode", "f (Hz)", "zeta", "mesh", "line bearing", "axial bearing", "tilt bearing",
                  "cross bearing", "shaft");
  const auto pair = [](const std::array<double, 2>& e) {
    return fmt::format("{:5.1f} {:5.1f}", 100 * e[0], 100 * e[1]);
  };
  for (std::size_t r = 0; r < m.modes.size(); ++r) {
    const Mode& x = m.modes[r];
    out += fmt::format(
        "{:>4} {:>12.6g} {:>8.4f}   (%)            {:>6.1f} {:>13} {:>13} {:>13} {:>13} {:>13}\n",
        r + 1, x.frequency_hz, x.damping_ratio, 100 * x.mesh_energy, pair(x.line_energy),
        pair(x.axial_energy), pair(x.tilt_energy), pair(x.cross_energy), pair(x.shaft_energy));
  }
  return out;
}

}  // namespace geardyn
