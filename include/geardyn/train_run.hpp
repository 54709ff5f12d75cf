// geardyn: a run of a gear train (train_case.hpp) with the exact engine, read per mesh as the
// one-degree run reads its mesh, pipeline stages 5 and 6 beside run.hpp.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <iterator>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "geardyn/analysis.hpp"
#include "geardyn/case.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/rigid_split.hpp"
#include "geardyn/spectrum.hpp"
#include "geardyn/steady.hpp"
#include "geardyn/train.hpp"

namespace geardyn {

struct MeshStiffness;  // stiffness.hpp

// What one mesh did over a stretch of a train run: its contact history (impacts, separations,
// regime) and its extremes (with the exact engine exact, on the engine's polynomial in every
// cell; with dopri5 at step ends, events, samples and each step's midpoint; with Newmark at step
// ends, events and samples).
struct TrainMeshPart : ContactReading {
  double max_force_n = 0, min_force_n = 0;            // F (N)
  double max_deflection_m = 0, min_deflection_m = 0;  // d - e (m)
  // The largest |d' - e'| at an impact on either flank (m/s; 0 without one), as the one-degree
  // run's max_impact_velocity_m_s.
  double max_impact_velocity_m_s = 0;
  // The mean and the RMS over the stretch's output samples of F (N) and of d - e (m), as the
  // one-degree run's over its samples; 0 without a sample.
  double mean_force_n = 0, rms_force_n = 0, mean_deflection_m = 0, rms_deflection_m = 0;
};

// A located contact change of one of a train's nonlinearities (TrainRunResult::contact_parts):
// a mesh (kImpact onto its drive flank, kBacksideImpact onto its back flank, kSeparation into
// its backlash) or a bearing's clearance direction (kImpact against its +c side,
// kBacksideImpact against -c, kSeparation back inside). Clipping inside contact (a mesh that
// clips its tension) is no contact change and no event.
struct TrainContactEvent {
  double t_s = 0;
  int part = 0;  // its index in TrainRunResult::contact_parts
  EventKind kind = EventKind::kImpact;
  // The part's rate at the event: a mesh's d' - e' (its impact velocity), a clearance's w' (the
  // centre's velocity along its direction), m/s.
  double velocity_m_s = 0;
};

// One mesh of a train run: the whole window read, its steady part (TrainRunResult::steady)
// read, and its dynamic factors.
struct TrainMeshReading : TrainMeshPart {
  std::string name;
  double mesh_frequency_hz = 0;
  double backlash_m = 0;
  double mean_stiffness_n_per_m = 0;  // k_m: F / (b k_m) is the one-degree run's F_bar
  // Its phase from the layout (train.hpp), in cycles; absent with train.mesh_phase = "given".
  std::optional<double> layout_phase;
  TrainMeshPart steady;  // its regime: separated anywhere in the part or not
  // The mesh force in drive contact at the mean torques and drags, the prescribed bodies held
  // (static_mesh_forces_n); absent when there is none (the train's mean torques do not balance).
  std::optional<double> static_force_n;
  // The largest F over the static force, over the steady part (as the one-degree run's
  // dynamic_factor) and from the start; absent without a static force > 0.
  std::optional<double> dynamic_factor, dynamic_factor_with_startup;
  // The kReportedPeaks largest peaks of the amplitude spectra of F (N) and of (d - e) / b over
  // the steady part's output samples (mesh_spectra), as the one-degree run's force_peaks and
  // delta_peaks; filled by run_train, empty with fewer than 4 samples there.
  std::vector<SpectralPeak> force_peaks, deflection_peaks;
};

// The largest and smallest value of a shaft's torque or a bearing's force component over a
// stretch (exact as a mesh's extremes).
struct TrainExtremes {
  double max = 0, min = 0;
};

// A shaft of a train run: its torque k_s (theta_a - theta_b) + c_s (theta_a' - theta_b') (N m,
// positive when its first body leads), over the whole window and its steady part, and at the
// static state (absent without one).
struct TrainShaftReading {
  std::string name;
  TrainExtremes torque_nm, steady_torque_nm;
  std::optional<double> static_torque_nm;
};

// A bearing of a train run: its force on the ground k u + c u' in x and y (N), over the whole
// window and its steady part, and at the static state.
struct TrainBearingReading {
  std::string name;
  TrainExtremes force_x_n, force_y_n, steady_force_x_n, steady_force_y_n;
  std::optional<double> static_force_x_n, static_force_y_n;
  // With a clearance, each direction's contact history (impacts on either side, separations,
  // the time inside the clearance) over the window and its steady part; `present` false
  // without one.
  ContactReading clearance_x, clearance_y, steady_clearance_x, steady_clearance_y;
  // On a spatial body (train::Body::spatial): its axial force (N) and, when it tilts
  // (train::Body::tilts), its moments about x and y (N m) on the seat, as the forces; `spatial`
  // (`tilts`) false and these empty on any other body.
  bool spatial = false, tilts = false;
  // Its parts among a sample's (TrainSamples::parts): x and y, then the axial force and moments
  // it has.
  int part_count() const { return 2 + (spatial ? 1 : 0) + (tilts ? 2 : 0); }
  TrainExtremes axial_force_n, moment_x_nm, moment_y_nm;
  TrainExtremes steady_axial_force_n, steady_moment_x_nm, steady_moment_y_nm;
  std::optional<double> static_axial_force_n, static_moment_x_nm, static_moment_y_nm;
};

// A joint of a train run (train::Assembled::joints(): each bearing clearance direction, then
// each element's piecewise-linear spring): its contact history over the window and its steady
// part (an impact: leaving its rest stage, into +x or, a backside impact, into -x; a separation:
// back into its rest stage; stages changed beyond the rest are no contact change), and when it is
// read as a part (train::Joint::read) the extremes of its force and of its x, and their static
// values, as a shaft's torque (named force_what and deformation_what: "torque_nm", "twist_rad").
struct TrainJointReading {
  std::string name;
  ContactReading contact, steady_contact;
  bool read = false;
  std::string force_what, deformation_what;
  TrainExtremes force, steady_force, deformation, steady_deformation;
  std::optional<double> static_force, static_deformation;
};

// One quantity of a shaft or bearing of a train run: which (`what`), its extremes over the
// window and the steady part, and its static value (absent without a static state). The one list
// of them (part_quantities) is what summary.json, the terminal and a sweep's part columns read.
struct TrainPartQuantity {
  std::string part;  // the shaft's, bearing's or joint's name
  const char* what;  // "torque_nm", "force_x_n", "force_y_n", "axial_force_n", "moment_x_nm", ...
  const TrainExtremes* whole;
  const TrainExtremes* steady;
  const std::optional<double>* at_rest;
};

// A gear's load shared among the meshes it drives, or among those that drive it, when there
// are two or more (a sun's planets, a ring's, a split-torque drive): the load-sharing factor
// n max_i F_i / sum_i F_i over its n meshes (ISO 6336-1's K_gamma, AGMA 6123's mesh load
// factor), 1 when they share equally.
struct TrainLoadSharing {
  std::string gear, label;  // LoadSharingGroup's
  std::vector<std::string> meshes;
  // At the static state (absent without one); the meshes whose static force is <= 0 (a planet
  // that the linear static state unloads: the run then shows it separate).
  std::optional<double> static_factor;
  std::vector<std::string> unloaded_at_rest;
  // The largest factor over the output samples of the steady part (absent when it was not
  // reached) and of the whole window, at the samples where sum_i F_i > 0.
  std::optional<double> factor, factor_with_startup;
  // The meshes of the group that left their drive flank in the steady part (the whole window
  // when it was not reached): separated, or pushed onto the back flank (a negative force): a
  // planet losing its load, where the factor no longer describes it.
  std::vector<std::string> lost_contact;
};

// The load-sharing factor of one group's mesh forces, n max_i F_i / sum_i F_i; absent when they
// sum to <= 0.
std::optional<double> load_sharing_factor(const std::vector<double>& forces_n);

// A load-sharing group of a train: a gear and the two or more meshes (indices in the train's
// order) it drives, or that drive it, in the order TrainRunResult::load_sharing reads them.
// `label` names it in files: the gear's name, with "_driving" or "_driven" appended when the
// gear heads both kinds of group.
struct LoadSharingGroup {
  std::string gear, label;
  std::vector<std::size_t> meshes;
};
std::vector<LoadSharingGroup> load_sharing_groups(const train::Assembled& a);

// Whether a mesh left its drive flank over a stretch: separated, or pushed onto its back flank
// (a negative force): a planet losing its load, where the factor no longer describes it.
bool left_drive_flank(const TrainMeshPart& part);

// Rows of one width in one buffer: a run's values per output sample, so that a sample costs
// no allocation. Row i reads as an Eigen vector: rows[i][m], rows[i].size(), rows[i].head(k).
template <class T>
class SampleRows {
 public:
  using Row = Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 1>>;
  std::size_t size() const { return rows_; }
  bool empty() const { return rows_ == 0; }
  std::size_t width() const { return width_; }
  Row operator[](std::size_t i) const {
    return Row(values_.data() + i * width_, static_cast<Eigen::Index>(width_));
  }
  // The rows in order (for a range-for), each a Row.
  class ConstIterator {
   public:
    using iterator_category = std::forward_iterator_tag;
    using value_type = Row;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = Row;
    ConstIterator() = default;
    ConstIterator(const SampleRows* rows, std::size_t i) : rows_(rows), i_(i) {}
    Row operator*() const { return (*rows_)[i_]; }
    ConstIterator& operator++() {
      ++i_;
      return *this;
    }
    ConstIterator operator++(int) {
      ConstIterator before = *this;
      ++i_;
      return before;
    }
    bool operator==(const ConstIterator& o) const { return i_ == o.i_; }

   private:
    const SampleRows* rows_ = nullptr;
    std::size_t i_ = 0;
  };
  ConstIterator begin() const { return {this, 0}; }
  ConstIterator end() const { return {this, rows_}; }
  // Room for `rows` rows of `width` values (a run knows its output samples beforehand).
  void reserve(std::size_t rows, std::size_t width) { values_.reserve(rows * width); }
  // Appends a row of `width` values (every row the first one's width) and returns where they
  // go, to be written before the next append. The buffer takes all the room reserved at once,
  // then grows by doubling, so that an append within it only counts the row.
  T* append(std::size_t width) {
    if (rows_ == 0) width_ = width;
    if (width != width_) [[unlikely]]
      widths_differ();
    const std::size_t end = rows_ * width_;
    if (end + width_ > values_.size()) [[unlikely]]
      grow(end + width_);
    ++rows_;
    return values_.data() + end;
  }
  // Appends a copy of any contiguous range of T (an Eigen vector, a std::vector).
  template <class Range>
  void push_back(const Range& row) {
    T* to = append(static_cast<std::size_t>(row.size()));
    std::copy(row.data(), row.data() + row.size(), to);
  }
  // The values, row after row, moved out without a copy (rows of width 1: a column); the rows
  // are empty afterwards.
  std::vector<T> release() {
    values_.resize(rows_ * width_);
    std::vector<T> out = std::move(values_);
    values_.clear();
    rows_ = 0;
    return out;
  }

 private:
  // Room for at least `size` values: all the room reserved at once, else twice the buffer
  // (out of line: the append within room stays a few instructions, inlined).
  [[gnu::cold, gnu::noinline]] void grow(std::size_t size) {
    values_.resize(std::max({values_.capacity(), 2 * values_.size(), size}));
  }
  [[noreturn, gnu::cold, gnu::noinline]] static void widths_differ() {
    throw std::logic_error("SampleRows: rows of different widths");
  }
  std::vector<T> values_;
  std::size_t width_ = 0, rows_ = 0;
};

struct TrainSamples {
  std::vector<double> t_s;
  SampleRows<double> state;           // (q, q'): rad, m and their rates (unless keep_states false)
  SampleRows<double> deflection_bar;  // per sample, per mesh: (d - e) / b
  SampleRows<double> force_n;         // per sample, per mesh: F
  // Per sample, per mesh: d' - e' (m/s), V q' - e'(t) of the state's rates.
  SampleRows<double> deflection_rate_m_s;
  SampleRows<int> contact;  // per sample, per mesh: 1, 0, -1
  // Per sample: each part's quantities in part_quantities' order: each shaft's torque (N m),
  // then each bearing's force in x and y (N) and what else it carries, then each joint's read as
  // a part, its force and its x.
  SampleRows<double> parts;
};

struct TrainRunResult {
  Case input;
  std::vector<std::string> bodies;  // in the case's order
  // Each body's absolute speed, positive in the reference's direction of rotation, and its
  // inertia and mass as the run took them (given, or derived from its gear data; a body that
  // keeps torsion only has mass 0).
  std::vector<double> body_speed_hz, body_inertia_kg_m2, body_mass_kg;
  // Each torque's name and mean as the run applied it (a reaction's as computed: balances).
  std::vector<std::string> torques;
  std::vector<double> torque_mean_nm;
  // The coordinates with their units (train::Assembled::coordinate_names): the state's order.
  std::vector<std::string> coordinates;
  std::optional<double> system_period_s;  // absent: quasi-periodic (system_period_note says why)
  std::string system_period_note;
  std::string static_note;  // why there is no static force, when there is none
  // The method the run took (TrainSolver::method) and, when the default chose it, why.
  Method method = Method::kExact;
  std::string method_note;
  // Where the steady part starts, as the one-degree run's (steady.hpp): the train settled on
  // the section t = k T0 (judged on every mesh's d - e, every shaft's twist and every planar
  // body's x and y, with their rates), else the final half; the distance in each mesh's b (a
  // shaft's: in the smallest b / (cos beta_b R) of the meshes; a centre's: in the smallest b)
  // and b times the highest natural frequency in contact.
  SteadyStart steady;
  ode::Termination termination = ode::Termination::kCompleted;
  std::string message;
  std::int64_t cells = 0, events = 0;
  // "newmark": steps that met more contact changes than it locates in one (taken unsplit).
  std::int64_t unsplit_steps = 0;
  std::vector<TrainMeshReading> meshes;
  // The nonlinearities whose contact changes are events: each mesh's name, then each joint's
  // (train::Assembled::joints(): a clearance direction's, an element spring's); and every change
  // located, in time order.
  std::vector<std::string> contact_parts;
  std::vector<TrainContactEvent> contact_events;
  std::vector<TrainShaftReading> shafts;
  std::vector<TrainBearingReading> bearings;
  std::vector<TrainJointReading> joints;  // every joint, in train::Assembled::joints()' order
  std::vector<TrainLoadSharing> load_sharing;
  TrainSamples samples;
  double output_interval_s = 0;  // the samples' spacing (s); 0 when none were asked for
  double time_step_s = 0;        // the Newmark step taken (s); 0 for the other methods
  double wall_time_s = 0;
  bool ok() const { return termination == ode::Termination::kCompleted; }
};

// Mesh m's amplitude spectra (spectrum.hpp) over the output samples of r's steady part (t >=
// r.steady.from_s), as the one-degree run's (compute_spectra): of F (N) and of (d - e) / b.
struct MeshSpectra {
  Spectrum force_n, deflection_bar;
};
MeshSpectra mesh_spectra(const TrainRunResult& r, std::size_t m);

// Every quantity of r's shafts, bearings and joints, referring into r: each shaft's torque_nm,
// then each bearing's force_x_n and force_y_n, on a spatial body its axial_force_n, and when it
// tilts its moment_x_nm and moment_y_nm, then each joint read as a part its force and its x.
std::vector<TrainPartQuantity> part_quantities(const TrainRunResult& r);

// Appends a's shafts, bearings and joints to r.shafts, r.bearings and r.joints as a run reads
// them before its first sample: named, what each bearing carries (spatial, tilts), which joints
// are read, the static values at `rest` when given (static_state), the extremes yet to come.
void add_parts(const train::Assembled& a, const std::optional<Eigen::VectorXd>& rest,
               TrainRunResult& r);

// Whether a case runs as a gear train (run_train, TrainSolver): a train, or a coupled pair as its
// train form (train_form_of); the one-degree forms run on their own model (run.hpp).
bool runs_as_train(const Case& c);

struct TrainRunOptions {
  // Called now and then with the fraction of the window done; false cancels.
  std::function<bool(double)> progress;
  // False for a study's sample (study_sample.hpp), whose readings are the same either way: of
  // the output samples only the times, the mesh forces and the parts' loads are kept (the
  // load-sharing factors and the steadiness read them), no states, deflections, contact, rates
  // or spectra.
  bool keep_samples = true;
  // False for a run read per mesh (the one-degree forms' run, run.hpp): every row of the samples
  // kept but the whole train's states (TrainSamples::state empty), which a train that turns
  // freely would lift from its complement at every sample.
  bool keep_states = true;
  // False where the caller reads the samples' spectra itself (the one-degree forms' run, in the
  // pair's units): no mesh's force_peaks or deflection_peaks.
  bool read_peaks = true;
  // A pair form's mesh stiffness computed once for a study's samples (shared_stiffness; as
  // TrainSolver takes it); null: the case's own. A train's meshes carry their own.
  const MeshStiffness* stiffness = nullptr;
};

// A train case's integrator (the exact engine with solver.method = "exact", the adaptive one of
// adaptive.hpp with "dopri5", at solver.tolerance, the Newmark-beta one of newmark_flow.hpp with
// "newmark") and its readings over any stretch: a run's window, a sweep point's settling and
// measurement.
// The exact engine builds its cells once per coefficient period, each of some (2 n)^2 numbers
// for n coordinates and more per excitation frequency: past this many cells a contact region
// (about 1 GB for a train of 24 coordinates), the default takes dopri5 instead, whose memory
// does not grow with the period.
constexpr double kMaxDefaultExactCells = 8192;
// The engine's own bound on cells per period (engine.cpp): an exact engine asked for beyond it
// cannot resolve the period and is refused.
constexpr double kMaxExactCells = 65536;

// How a read seeks its steady part: on the section t0 + k period_s (period_s 0: the excitations
// have no common period, the final half is read), or by_statistics: windows of period_s whose
// statistics agree (train_steadiness.hpp).
struct SteadyWatch {
  double period_s = 0;
  bool by_statistics = false;
};

class TrainSolver {
 public:
  // A train case, or a pair's form as its train of elements (train_form_of; its readings are
  // the train's, its input the case as given). With the exact engine, a train that turns freely
  // (its rigid rotation free: no prescribed speed, support, pin or viscous drag on it) is stepped
  // on the complement of its rotation (rigid_split.hpp: the pair's two states, not four), the
  // rotation a closed-form quadrature; states, samples and Jacobians are the whole train's all
  // the same. Throws InputError for a given Newmark step
  // (solver.time_step_s) that does not resolve the train's fastest time scale, or a system the
  // exact engine cannot take. The Newmark step is the given one or the fastest time scale over
  // kStepsPerFastestPeriod (the one-degree run's rule), made to divide the system period.
  // `stiffness`, when given, is a pair form's mesh stiffness computed beforehand (a study whose
  // key leaves the curve alone shares it: shared_stiffness); a train's meshes carry their own.
  explicit TrainSolver(const Case& c, const MeshStiffness* stiffness = nullptr);
  ~TrainSolver();
  TrainSolver(const TrainSolver&) = delete;
  TrainSolver& operator=(const TrainSolver&) = delete;

  const train::Assembled& assembled() const { return *a_; }
  // The method it integrates with: solver.method as given; left to its default, the exact
  // engine unless its cells over the meshes' common period would pass kMaxDefaultExactCells in a
  // contact region (a hunting-tooth train's period of minutes), or the engine cannot take the
  // system, and then dopri5, with method_note saying why ("" when nothing was chosen for the
  // user). An exact engine asked for whose cells would pass the engine's own bound is refused
  // before any work (InputError), naming the period and the count.
  Method method() const { return method_; }
  const std::string& method_note() const { return method_note_; }
  // The train's shortest time scale (s): its fastest mode in contact or excitation.
  double fastest_period_s() const { return fastest_period_s_; }
  // The number of states the integrator steps: the whole train's 2 n, or 2 (n - 1) when its free
  // rotation is split off (the exact engine on a train that turns freely).
  int stepped_states() const;
  // The Newmark step (s) with solver.method = "newmark", 0 with the other methods.
  double newmark_step_s() const { return newmark_step_s_; }
  // The highest natural frequency in contact (rad/s; the fastest time scale's when no mode
  // moves): the rate scale of the section's judgement.
  double top_frequency_rad_s() const { return top_frequency_rad_s_; }
  // The state solver.initial gives at t0_s, the prescribed bodies as prescribed: "center" at
  // rest in the middle of every backlash relative to its error (rest_state), "static" the
  // static state there (static_state with at_s; InputError when there is none).
  ode::Vector initial_state(InitialCondition initial, double t0_s = 0) const;
  // From (t0, y0) to t1 with nothing read.
  ode::FlowResult advance(double t0_s, const ode::Vector& y0, double t1_s) const;
  // The same with dy(t1)/dy(t0) in the result's jacobian (saltation at every event); the exact
  // engine only (std::logic_error with "dopri5").
  ode::FlowResult advance_with_jacobian(double t0_s, const ode::Vector& y0, double t1_s) const;
  // From (t0, y0) to t1, sampled on `grid` and read per mesh (contact separated after
  // final_from is "sustained"); with a watch integrated once while the steady part is sought
  // (integrate_watching), read beside the whole and giving the dynamic factors. The end state
  // into *end_state when given; wall_time_s is left 0. With keep_samples false only the samples'
  // times, mesh forces and parts' loads are kept, with keep_states false all but the states
  // (TrainRunOptions').
  TrainRunResult read(double t0_s, const ode::Vector& y0, double t1_s, const ode::OutputGrid& grid,
                      double final_from_s, std::optional<SteadyWatch> watch,
                      const std::function<bool(double)>& progress = {},
                      ode::Vector* end_state = nullptr, bool keep_samples = true,
                      bool keep_states = true) const;

 private:
  ode::FlowResult flow(double t0_s, const ode::Vector& y0, int region, double t1_s,
                       const ode::OutputGrid& grid, ode::FlowObserver& observer,
                       bool jacobian = false) const;
  Case case_;
  Method method_ = Method::kExact;
  std::string method_note_;
  std::unique_ptr<train::Assembled> a_;
  std::unique_ptr<ode::ExactEngine> engine_;        // "exact"
  std::unique_ptr<ode::RigidSplit> split_;          // its free rotation split off, or none
  std::optional<ode::LinearSwitchedSystem> whole_;  // "dopri5", and "newmark" without split_
  // The system dopri5 and Newmark step: the split's complement, or the whole train.
  const ode::LinearSwitchedSystem& stepped() const { return split_ ? split_->reduced() : *whole_; }
  double newmark_step_s_ = 0;  // "newmark": the step (s), else 0
  double fastest_period_s_ = 0, top_frequency_rad_s_ = 0;
};

// Each coordinate of a train's state (q, q') by the size a periodic response is measured in: a
// coordinate by the smallest b / |v_i| of the meshes that move it (an angle's b / (cos beta_b R),
// v the mesh's row of V), one no mesh moves by a milliradian (a body joined by shafts alone) or
// the smallest b (a centre); each rate by its coordinate's times rate_rad_s (the train's highest
// natural frequency in contact). The orbits' unknowns (train_orbit.hpp) and a sweep point's
// periodic response in contact are measured in it.
ode::Vector train_state_scale(const train::Assembled& a, double rate_rad_s);

// A train's state as the section judges it (steady.hpp): every mesh's d - e and every shaft's
// twist, with their rates, in the mesh's b (a shaft's: in the smallest b / (cos beta_b R) of the
// meshes) and b times the highest natural frequency in contact.
class TrainSections {
 public:
  TrainSections(const train::Assembled& a, double top_frequency_rad_s,
                double integration_tolerance);
  // The state at the next section time.
  void add(double t_s, const ode::Vector& y);
  SteadyVerdict judge(double tolerance) const { return judge_together(series_, tolerance); }
  // Mesh m's d - e (m) and its rate (m/s) at (t, y).
  ode::State mesh(int m, double t_s, const ode::Vector& y) const;
  // The size of a state difference dy = (dq, dq') in the judgement's measure: the largest of
  // its projections (each mesh's d, each shaft's twist, each centre) over their size, and of
  // their rates over size times the top frequency. An exact distance to a periodic response
  // (a sweep point's region_response) is measured in it.
  double distance(const ode::Vector& dy) const;
  // The largest distance() of a difference whose components are at most scale_i.
  double gain(const ode::Vector& scale) const;

 private:
  const train::Assembled& a_;
  std::vector<HarmonicSeries> errors_;  // each mesh's e(t)
  // Each series' projection of q (a row of V, a shaft's row, a centre's unit row) and size.
  Eigen::MatrixXd rows_;
  Eigen::VectorXd sizes_;
  double rate_rad_s_;
  std::vector<SectionSeries> series_;
};

// Runs a train case over [0, solver.duration_s] with the exact engine (solver.method = "exact")
// or the adaptive integrator of adaptive.hpp ("dopri5", at solver.tolerance) from solver.initial
// ("center": at rest, every mesh in the middle of its backlash, the prescribed bodies as
// prescribed; "static": the static state), integrated once while its steady part is sought
// (integrate_watching). Throws InputError for a case that is no train,
// "newmark", a static start without a static state, or a window past the work bounds of run.hpp;
// a numerical failure is reported in the result.
TrainRunResult run_train(const Case& c, const TrainRunOptions& options = {});

// A shaft's or bearing's dynamic factor for one quantity (a torque, a force in x, y or along the
// axis, a moment): the largest magnitude over the steady part over the static value's (as the
// mesh's dynamic factor reads F), absent where the static value is not above
// kNegligibleStaticFraction of the largest static mesh force (times 1 m for a torque or moment)
// of the run: a direction the static load does not load, whose factor would be a ratio of
// roundings.
constexpr double kNegligibleStaticFraction = 1e-9;
std::optional<double> part_dynamic_factor(const TrainRunResult& r, const TrainExtremes& steady,
                                          const std::optional<double>& at_rest);

// summary.json of a train run (docs/outputs.md): the run, then one object per mesh.
std::string train_summary_json(const TrainRunResult& r, const std::vector<std::string>& unused,
                               int indent = 2);
// timeseries.csv: t_s, each body's theta and rate, then per mesh (d - e)/b, F and contact, the
// parts' readings, and last each mesh's d' - e' (m/s). r is run_train's (std::invalid_argument
// when its samples' rates are not filled).
void write_train_timeseries_csv(std::ostream& out, const TrainRunResult& r);
// events.csv: every contact change located (TrainRunResult::contact_events), t_s, the part's
// name, the kind (impact, backside_impact, separation) and the part's rate (m/s).
void write_train_events_csv(std::ostream& out, const TrainRunResult& r);
// The files of `geardyn run --out` of a train into dir, each atomically (output_folder.hpp):
// summary.json (with `unused`, the settings the case gives and the run does not read),
// timeseries.csv, events.csv and case.toml (the case run). The command line and Python's
// TrainRunResult.write call it inside their output set; the figures are apart
// (write_train_run_figures).
void write_train_run(const std::filesystem::path& dir, const TrainRunResult& r,
                     const std::vector<std::string>& unused);

// The modes of a train as JSON and as a table for the terminal: frequency, multiplicity, a
// planetary set's mode type, and the strain energy in each mesh, shaft and bearing (the JSON
// also by each bearing's direction, and the damped eigenvalues).
std::string train_modes_json(const train::Assembled& a, const std::vector<train::TrainMode>& m,
                             int indent = 2);
std::string train_modes_table(const train::Assembled& a, const std::vector<train::TrainMode>& m);

}  // namespace geardyn
