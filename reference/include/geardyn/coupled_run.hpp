// geardyn: a run of the coupled model (coupled_model.hpp) with the exact engine, read per
// nonlinearity (the mesh and each bearing clearance). No run, sweep or study goes through it: a
// coupled case runs as its train (train_presets.cpp, run_train); `geardyn validate` and the
// tests run it as the independent reference that train is checked against: a reference
// implementation, in the geardyn_reference library (reference/), which the library never calls.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/analysis.hpp"
#include "geardyn/case.hpp"
#include "geardyn/coupled_model.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/steady.hpp"

namespace geardyn {

struct CoupledSamples {
  std::vector<double> t_s;
  std::vector<Eigen::VectorXd> state;                  // (q, q'), SI
  std::vector<double> deflection_bar;                  // (d - e) / b
  std::vector<double> force_bar;                       // F_n / (b k_m)
  std::vector<int> mesh_contact;                       // 1 drive side, 0 separated, -1 back side
  std::vector<std::array<double, 2>> bearing_force_n;  // line-of-action bearing forces
  std::vector<std::array<double, 2>> axial_force_n;    // axial bearing forces
  std::vector<std::array<double, 2>> shaft_torque_nm;  // shaft torques (0 without the shaft)
};

// What the coupled model did over a stretch of a run: each nonlinearity's contact history and
// the extremes, exact (the engine's polynomial on every cell).
struct CoupledPart {
  ContactReading mesh;
  std::array<ContactReading, 2> bearing;
  double max_force_n = 0, min_force_n = 0;
  double max_deflection_m = 0, min_deflection_m = 0;                 // of d - e
  std::array<double, 2> max_bearing_force_n{}, max_axial_force_n{};  // largest |.|
  std::array<double, 2> max_shaft_torque_nm{};                       // largest |.|
};

// A coupled run: the readings of the window read (CoupledPart), and, for a run that sought
// its steady part (run_coupled), those of the steady part.
struct CoupledRunResult : CoupledPart {
  Case input;
  CoupledParameters parameters;
  ode::Termination termination = ode::Termination::kCompleted;
  std::string message;
  std::int64_t cells = 0, events = 0;
  // Where the steady part starts, as the one-degree run's (run_coupled; judged on the mesh's
  // d - e and every bearing displacement, CoupledSections), and its readings. A window read
  // without it (CoupledSolver::read: a sweep's block, an orbit's period) has basis
  // kNotSettled, marked false.
  SteadyStart steady;
  CoupledPart steady_part;
  // Dynamic factors: the largest over the static value (mesh: F_n; bearings: cos(beta_b) F_n;
  // axial: sin(beta_b) F_n; shafts: their static torque; NaN for an axial factor of a spur
  // pair and for a shaft that is not there), over the steady part when the run marked one,
  // else over the window read; the mesh's also from the start.
  double dynamic_mesh_factor = 0, dynamic_mesh_factor_with_startup = 0;
  std::array<double, 2> bearing_factor{}, axial_factor{}, shaft_factor{};
  CoupledSamples samples;
  double wall_time_s = 0;
  bool ok() const { return termination == ode::Termination::kCompleted; }
};

struct CoupledRunOptions {
  // Called now and then with the fraction of the window done; false cancels.
  std::function<bool(double)> progress;
};

// The coupled model of a case with its exact engine, built once: for runs and sweep points.
class CoupledSolver {
 public:
  // Throws InputError for a bad case or a method other than "exact". `stiffness` as for
  // coupled_parameters.
  explicit CoupledSolver(const Case& c, const MeshStiffness* stiffness = nullptr);
  ~CoupledSolver();
  const CoupledModel& model() const { return *model_; }
  // The state a run starts from, at t = 0: at rest in the middle of the backlash and the
  // clearances, or the static contact state (InputError when there is none), each relative to
  // the transmission error (CoupledModel::rest_state, static_state).
  ode::Vector initial_state(InitialCondition initial) const;
  // From (t0, y0) to t1 with nothing read.
  ode::FlowResult advance(double t0, const ode::Vector& y0, double t1) const;
  // The same with dy(t1)/dy(t0) in the result's jacobian (saltation at every event).
  ode::FlowResult advance_with_jacobian(double t0, const ode::Vector& y0, double t1) const;
  // From (t0, y0) to t1, sampled on `grid` and read (contact separated after final_from is
  // "sustained"); the end state into *end_state when given. wall_time_s is left 0.
  CoupledRunResult read(double t0, const ode::Vector& y0, double t1, const ode::OutputGrid& grid,
                        double final_from, const std::function<bool(double)>& progress = {},
                        ode::Vector* end_state = nullptr) const;
  // The same integrated once while the steady part is sought on the section t0 + k period_s
  // (integrate_watching; 0: no common period, the final half), read beside the whole.
  CoupledRunResult read_watching(double t0, const ode::Vector& y0, double t1,
                                 const ode::OutputGrid& grid, double final_from, double period_s,
                                 const std::function<bool(double)>& progress = {}) const;

 private:
  // Both: with a period, watching; without, the window as one flow.
  CoupledRunResult read_pieces(double t0, const ode::Vector& y0, double t1,
                               const ode::OutputGrid& grid, double final_from,
                               std::optional<double> period_s,
                               const std::function<bool(double)>& progress,
                               ode::Vector* end_state) const;
  Case case_;
  std::unique_ptr<CoupledModel> model_;
  std::unique_ptr<ode::ExactEngine> engine_;
};

// The coupled model's state as the section judges it (steady.hpp): the mesh's d - e and each
// bearing displacement the model has, each with its rate, in b and b w_n (w_n the one-degree
// pair's contact frequency): a transient that one projection barely sees shows in another.
class CoupledSections {
 public:
  CoupledSections(const CoupledParameters& p, double integration_tolerance);
  // The state at the next section time.
  void add(double t_s, const ode::Vector& y);
  SteadyVerdict judge(double tolerance) const { return judge_together(series_, tolerance); }
  // The mesh's (d - e, its rate) at (t, y).
  ode::State mesh(double t_s, const ode::Vector& y) const;

 private:
  const CoupledParameters& p_;
  std::vector<Eigen::Index> bearing_coordinates_;
  std::vector<SectionSeries> series_;
};

// The section period of a coupled case: its one-degree pair's (the same stiffness, torques and
// transmission error), 0 when the excitations have no common period.
double coupled_section_period_s(const Case& c, const MeshStiffness* stiffness = nullptr);

// Runs the case's coupled model over [0, solver.duration_s] with the exact engine from
// solver.initial ("center": at rest in the middle of the backlash and the clearances;
// "static": the static contact state). Throws InputError for a bad case, a method other than
// "exact", or a window past the work bounds of run.hpp; a numerical failure is reported in the
// result.
CoupledRunResult run_coupled(const Case& c, const CoupledRunOptions& options = {});

}  // namespace geardyn
