// geardyn: the case, i.e. everything a run needs, as written in a case file.
//
// Pipeline stage 1 of 6: case file -> geometry -> mesh stiffness -> model -> integrator ->
// analysis. A case is read from TOML (see docs/case-files.md for every key) and may be amended
// by `--set key=value` overrides. Members carry the units of the case file in their names; the
// later stages convert to SI once.
//
// Every member has a default: Table 1 of Park (2010) and the conditions of its Fig. 4(c)
// (f_1 = 1 kHz, xi = 0.02, F_a/F_m = 0.25, b = 100 um), so `Case{}` is the paper's gear.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "geardyn/input_error.hpp"

namespace geardyn {

// [gear]: Table 1 of the paper. Index 0 is the driving gear (pinion), 1 the driven gear.
struct GearData {
  double normal_module_mm = 2.5;
  double normal_pressure_angle_deg = 20.0;
  double helix_angle_deg = 20.0;
  double center_distance_mm = 150.0;
  std::array<int, 2> teeth = {56, 56};
  double face_width_mm = 20.0;
  std::array<double, 2> outside_diameter_mm = {154.98, 154.98};
  std::array<double, 2> profile_shift = {0.2075, 0.2075};
  double density_kg_m3 = 7850.0;
  // Bore diameter of each blank; 0 = solid. The inner radius of the energy method's fillet
  // foundation (a solid blank: a hub of a third of the root radius) in every case, and of the
  // blank's inertia when inertia_kg_m2 is not given.
  std::array<double, 2> bore_diameter_mm = {0.0, 0.0};
  // Polar moments of inertia; when absent they follow from density, face width, reference
  // diameter and bore (docs/model.md, "Geometry").
  std::optional<std::array<double, 2>> inertia_kg_m2;
  // Material and blank, for the mesh stiffness (ISO 6336-1 and the energy method).
  std::array<double, 2> youngs_modulus_gpa = {206.0, 206.0};  // ISO 6336's steel, E_st
  std::array<double, 2> poisson_ratio = {0.3, 0.3};
  std::array<double, 2> basic_rack_dedendum = {1.25, 1.25};  // h_fP / m_n (ISO 53 profile A)
  std::array<double, 2> rim_thickness_mm = {0.0, 0.0};       // s_R; 0: solid blank
  std::array<double, 2> web_thickness_mm = {0.0, 0.0};       // b_s; 0: no web (solid blank)
};

enum class DampingForm {
  kContact,  // c acts only in contact (the paper, eqs. 3a-3c)
  kAlways,   // c acts on delta' at all times (Kahraman and Singh 1990)
};
enum class TensionRule {
  kAllow,  // F_G as eqs. 3a/3c, may turn negative in contact (the paper)
  kClip,   // F_G >= 0 on the drive side and <= 0 on the back side
};

// One term k_ai cos(i z1 omega_1 t + phi_i) of eq. 11, as a ratio to the mean stiffness.
struct StiffnessHarmonic {
  double ratio = 0.0;      // k_ai / k_m, >= 0
  double phase_deg = 0.0;  // phi_i
};

// One term a_i cos(i omega_mesh t + phi_i) of the static transmission error e(t), the i-th at i
// times the mesh frequency: amplitude in um (the gear pair) or in units of b (the
// non-dimensional form).
struct ErrorHarmonic {
  double amplitude = 0.0;  // a_i >= 0
  double phase_deg = 0.0;  // phi_i
};

enum class StiffnessSource {
  kEnergy,     // the potential-energy slice method from the gear data (stiffness.hpp)
  kHarmonics,  // mean_stiffness_n_per_m and stiffness_harmonics as given
  kTable,      // a CSV of k over one mesh cycle (stiffness_table)
  kIso6336,    // k_m = c_gamma_alpha b of ISO 6336-1 Method B, stiffness_harmonics as given
};

// [mesh]
struct MeshData {
  double backlash_um = 100.0;  // b, the half of the total normal backlash 2b
  StiffnessSource stiffness_source = StiffnessSource::kEnergy;
  // The mean k_m; with "energy" or "table" the curve is scaled to it (0: the computed mean).
  double mean_stiffness_n_per_m = 2.34e8;
  std::vector<StiffnessHarmonic> stiffness_harmonics;  // with "harmonics"; empty: constant k_m
  std::string stiffness_table;      // with "table": CSV `position,stiffness_n_per_m`, position in
                                    // [0, 1) of a mesh cycle; relative to the case file
  int harmonics_kept = 2;           // with "energy" or "table": harmonics kept (the paper: 2)
  int stiffness_positions = 256;    // mesh positions per cycle of the energy method
  int stiffness_slices = 64;        // face-width slices of the energy method
  double application_factor = 1.0;  // K_A, for ISO 6336-1's load correction of c'
  double damping_ratio = 0.02;
  DampingForm damping = DampingForm::kContact;
  TensionRule tension = TensionRule::kAllow;
  // The static transmission error e(t) in the mesh deflection, F_G = k(t) (delta - e - b) +
  // c (delta' - e'): harmonics of the mesh frequency (um), or a CSV table over one mesh cycle
  // (`position,transmission_error_um`, as a loaded tooth contact program writes it) of which
  // transmission_error_kept harmonics are kept. Neither: no transmission error.
  std::vector<ErrorHarmonic> transmission_error_um;
  std::string transmission_error_table;
  int transmission_error_kept = 4;
};

// [load]
struct LoadData {
  double torque_nm = 49.5;          // mean driving torque T1
  double fluctuation_ratio = 0.25;  // amplitude of T1's fluctuation over its mean (= F_a/F_m)
  double fluctuation_order = 1.0;   // torque frequency over shaft frequency
  double fluctuation_phase_deg = 0.0;
  // Independent load torque T2 of eq. 6; absent: matched load T2 = R_b2 T1(t) / R_b1 (eq. 7).
  std::optional<double> load_torque_nm;
  // The fluctuation of an independent T2: amplitude (N m), order over the shaft frequency and
  // phase, T2(t) = T2 + amplitude cos(order 2 pi f_1 t + phase). Needs load_torque_nm.
  double load_fluctuation_nm = 0.0;
  double load_fluctuation_order = 1.0;
  double load_fluctuation_phase_deg = 0.0;
};

// [speed]
struct SpeedData {
  double shaft_frequency_hz = 1000.0;  // f_1, rotation frequency of the driving gear
};

enum class Method {
  kExact,    // the exact engine: closed-form cells and located events (engine.hpp)
  kNewmark,  // Newmark-beta with located transitions (the paper's method)
  kDopri5,   // Dormand-Prince 5(4) with events (the independent check)
};
const char* to_string(Method m);

enum class InitialCondition {
  kCenter,  // delta = 0, delta' = 0: the middle of the backlash (eq. 15, the paper)
  kStatic,  // delta' = 0 at the static contact deflection under F_m (for operating points)
};

// [solver]
struct SolverData {
  Method method = Method::kExact;
  double duration_s = 0.05;
  double time_step_s = 0.0;        // 0: automatic (docs/numerics.md)
  double tolerance = 1e-10;        // accuracy: dopri5's relative and absolute tolerance; the exact
                                   // engine's truncation of its series
  double output_interval_s = 0.0;  // 0: automatic, duration / 5000
  double final_fraction = 0.1;     // final part of the window in which separation is "sustained"
  InitialCondition initial = InitialCondition::kCenter;
};

enum class ModelForm {
  kGearPair,        // the gear pair of [gear], [mesh], [load], [speed] (docs/model.md)
  kNondimensional,  // x'' + 2 zeta x' + k(tau) f(x) = F_m + F_a cos(Omega tau), b = 1
  kCoupled,         // the gears as rigid bodies on [bearings] (coupled_model.hpp)
  kTrain,           // bodies, meshes, shafts, torques, drags and speeds of [train] (train_case.hpp)
};
const char* to_string(ModelForm f);  // its name in a case file

// [model]: the form of the equation. The non-dimensional form of the literature (Kahraman and
// Singh 1990) has b = 1, damping acting at all times, and
// k(tau) = 1 + sum_i kappa_i cos(i Omega tau + phi_i); [gear], [mesh], [load] and [speed] are
// then not used, and times (solver.duration_s, ...) are in units of tau.
struct ModelData {
  ModelForm form = ModelForm::kGearPair;
  double zeta = 0.05;              // damping ratio
  double force_mean = 0.1;         // F_m
  double force_alternating = 0.1;  // F_a
  double omega = 1.0;              // Omega, excitation frequency over the natural one
  std::vector<StiffnessHarmonic> stiffness_harmonics;  // kappa_i, phi_i at i Omega
  std::vector<ErrorHarmonic> transmission_error;       // e(tau): a_i (units of b), phi_i at i Omega
  // With form "coupled": the gears' degrees of freedom kept (coupled_model.hpp): 3 (the
  // rotations and the translations along the line of action), 6 (and the axial ones) or 12.
  int dof = 12;
};

// [bearings]: each gear's supports in the coupled model, per gear (index 0 the pinion); the
// stiffnesses act on the gear body's translations and tilts. The defaults are those of the
// default gear (Park 2010 Table 1 at 49.5 N m) on two 6206 deep-groove ball bearings 80 mm
// apart, one of them locating, linearised at the static load (docs/model.md, "Bearing values";
// geardyn.bearings computes them): give your bearings' for another gear or load.
struct BearingData {
  std::array<double, 2> radial_stiffness_n_per_m = {1.7e8, 1.7e8};  // both radial directions
  std::array<double, 2> axial_stiffness_n_per_m = {1.6e7, 1.6e7};
  std::array<double, 2> tilt_stiffness_n_m_per_rad = {2.8e5, 2.8e5};  // both tilts
  // Damping ratio of every bearing direction against the gear's mass or tilt inertia.
  double damping_ratio = 0.02;
  // Radial clearance along the line of action, a dead zone +-c (Kahraman and Singh 1991); 0: none.
  std::array<double, 2> radial_clearance_um = {0.0, 0.0};
};

// [shafts] (model.form = "coupled"): a torsional shaft from the pinion to a motor and from the
// wheel to a load, each an inertia at the shaft's far end (T1 acts on the motor, T2 on the load).
// An end inertia of 0 leaves that shaft out: its torque acts on the gear itself.
struct ShaftData {
  std::array<double, 2> end_inertia_kg_m2 = {0.0, 0.0};  // [motor, load]
  // Torsional stiffness of each shaft; the default is the order of a solid steel shaft 35 mm
  // across and 0.2 m long (G pi d^4 / (32 L)), not a particular shaft: give yours.
  std::array<double, 2> stiffness_n_m_per_rad = {5e4, 5e4};
  // Damping ratio of each shaft against the reduced inertia of the two bodies it joins.
  double damping_ratio = 0.02;
};

struct TrainCase;  // train_case.hpp

struct Case {
  ModelData model;
  GearData gear;
  MeshData mesh;
  LoadData load;
  SpeedData speed;
  BearingData bearings;
  ShaftData shafts;
  SolverData solver;
  // [train] (model.form = "train"): its elements as the case file gives them; null otherwise.
  std::shared_ptr<const TrainCase> train;
  std::string name = "default";     // the case file's stem, or "default"
  std::filesystem::path directory;  // the case file's directory: relative paths start there
  std::string description;          // free text from the case file's top-level `description`
  // Where each key that was given came from: "file:line:column" or "--set key=value" (keys
  // left at their defaults are absent). Errors found later, in the derived geometry or
  // stiffness, name the origins of the keys they mention (with_origins).
  std::map<std::string, std::string> origins;
};

// `message` with where each case key it names came from: its origin (file:line:column or the
// --set) or "default value", appended unless the message says it already, e.g. "...: the tooth
// comes to a point (gear.outside_diameter_mm from c.toml:5:1)". When every key it names is at
// its default, the keys given in their sections are what made the message true, and it starts
// with them: "with gear.normal_module_mm = 1e-09 (--set gear.normal_module_mm=1e-9): ...".
std::string with_origins(const Case& c, const std::string& message);
// The same with the origins given apart from the case (while it is being read).
std::string annotate_origins(const Case& c, const std::map<std::string, std::string>& origins,
                             const std::string& message);

// One `--set key=value` override: key is dotted (`speed.shaft_frequency_hz`), value is in TOML
// value syntax (`100`, `"clip"`, `[[0.05, 0], [0.02, 0]]`).
struct Override {
  std::string key;
  std::string value;
  // How the user gave it, for messages: empty for "--set key=value"; a study that sets a key
  // names its own option ("--to -5").
  std::string origin = {};

  std::string label() const;  // origin, or "--set key=value"
};

// Parses "key=value" as given on the command line. Throws InputError if there is no '='.
Override parse_override(const std::string& assignment);

// `text` without the UTF-8 byte-order mark some editors put at its start (none is no change).
std::string_view without_byte_order_mark(std::string_view text);

// The largest input file read (a case file, a stiffness table): far above any real one, far
// below what exhausts memory.
constexpr std::uintmax_t kMaxInputFileBytes = 16u << 20;

// The text of an input file, without a UTF-8 byte-order mark. Throws InputError naming `what`
// and the path unless it is a regular file (not a directory, a device or a pipe) of at most
// kMaxInputFileBytes.
std::string read_input_file(const std::filesystem::path& path, const std::string& what);

// Reads a case file (or the defaults when `path` is empty) and applies the overrides in order.
// Throws InputError naming file, line, key, value and what is allowed on any bad input.
Case load_case(const std::optional<std::filesystem::path>& path,
               const std::vector<Override>& overrides = {});

// Sources named in messages without a line and column: an override (`--set k=v`) and a case
// built in Python (`Case(...)`), whose text the user never sees.
inline constexpr std::array<const char*, 2> kPositionlessSources = {"--set", "Case("};

// The same from TOML text; `source_name` is used in messages in place of a file name (with the
// line and column, unless it starts as one of kPositionlessSources).
Case parse_case(const std::string& toml_text, const std::string& source_name,
                const std::vector<Override>& overrides = {});

// Applies one override to a case already loaded (used by sweeps). Throws InputError.
void set_case_value(Case& c, const Override& o);

// Checks the ranges of every value (the same checks load_case applies). Returns an empty
// string when valid, or the message of the first broken bound.
std::string validate(const Case& c);

// The case written back as TOML, with every key, in the units of the case file.
std::string to_toml(const Case& c);

}  // namespace geardyn
