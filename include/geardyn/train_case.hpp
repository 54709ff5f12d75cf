// geardyn: a gear train as a case file writes it (model.form = "train"), pipeline stage 1 beside
// case.hpp, and its assembly into the elements of train.hpp (stage 4).
//
// The case file names its bodies and joins them by name, one array of tables per kind of
// element (docs/case-files.md, "Gear trains"):
//
//   [model]
//   form = "train"
//   [train]
//   reference = "input"          # the body whose speed is given (default: the first body)
//   reference_speed_hz = 50
//   [[train.body]]               # name, and inertia_kg_m2 or the gear data it follows from
//   [[train.mesh]]               # driving, driven, backlash_um, mean_stiffness_n_per_m, ...
//   [[train.shaft]]  [[train.bearing]]  [[train.torque]]  [[train.drag]]  [[train.speed]]
//
// Every key of an element is declared once in the tables of train_keys() (its unit, bounds,
// whether it must be given, its meaning): they drive the reader, its messages and the key
// tables of the docs. Values keep the case file's units here; train_of converts to SI.
#pragma once

#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/damper.hpp"
#include "geardyn/drag.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/planetary_preset.hpp"
#include "geardyn/train.hpp"

namespace geardyn {
struct MeshStiffness;  // stiffness.hpp
}

namespace geardyn {

// One term a cos(order Omega t + phase) at an order of a body's own rotation frequency.
struct OrderHarmonic {
  double amplitude = 0;  // in the key's unit
  double order = 1;      // > 0
  double phase_deg = 0;
};

// [[train.body]]: a rigid body turning about its axis. A gear gives its teeth and module (its
// base radius follows, and its inertia when inertia_kg_m2 is absent: a solid or bored cylinder
// of the reference diameter, as the gear pair's); a plain inertia (motor, load) gives
// inertia_kg_m2 alone. dof = "planar" lets the body's centre move in the plane on its bearings
// (its mass from the same cylinder when mass_kg is absent).
// The degrees of freedom a body keeps (dof = "torsion", "planar", "axial", "spatial", "line",
// "line_axial": the key's words, in this order), read once by the case reader.
enum class BodyDof { kTorsion, kPlanar, kAxial, kSpatial, kLine, kLineAxial };
// Two external gears, or a pinion in a ring gear (kind = "external", "internal").
enum class MeshKind { kExternal, kInternal };
// The word a case file writes for each.
std::string_view to_string(BodyDof dof);
std::string_view to_string(MeshKind kind);

struct TrainBodyData {
  std::string name;
  BodyDof dof = BodyDof::kTorsion;
  std::optional<double> inertia_kg_m2;
  std::optional<double> mass_kg;
  std::optional<double> tilt_inertia_kg_m2;  // about a diameter, of a spatial body
  int teeth = 0;                             // 0: not a gear
  double normal_module_mm = 0;
  double normal_pressure_angle_deg = 20;
  double helix_angle_deg = 0;
  double face_width_mm = 0;
  double bore_diameter_mm = 0;
  double density_kg_m3 = 7850;
  double eccentricity_um = 0;  // runout of its teeth and pins (train::Body)
  double eccentricity_angle_deg = 0;
  // Its flanks and material, read by a mesh whose stiffness_source is "energy" (the gear
  // pair's [gear] keys of this gear): the tip diameter (absent: d + 2 m_n (1 + x)).
  double profile_shift = 0;
  std::optional<double> outside_diameter_mm;
  double youngs_modulus_gpa = 206;
  double poisson_ratio = 0.3;
  double basic_rack_dedendum = 1.25;
};

// [[train.mesh]]: a mesh between two gears, the driving one (whose drive flank pushes) first;
// kind "internal" for a pinion and a ring gear (the one with more teeth, whose inertia is
// given: its blank is no solid cylinder).
struct TrainMeshData {
  std::string name, driving, driven;
  MeshKind kind = MeshKind::kExternal;
  double backlash_um = 100;  // b, half the total normal backlash
  // "harmonics": k_m and its harmonics as given; "energy": the gear pair's energy method on
  // the two gears' data (pair_mesh_stiffness); "table": stiffness_table's curve
  // (table_mesh_stiffness); "iso6336": ISO 6336-1's c_gamma_alpha b of the two gears under the
  // mesh's static load (iso_mesh_stiffness), its harmonics as given. With a curve, k_m scales
  // it when given.
  std::string stiffness_source = "harmonics";
  std::optional<double> mean_stiffness_n_per_m;
  std::vector<StiffnessHarmonic> stiffness_harmonics;  // of the mesh frequency
  std::string stiffness_table;  // with "table": CSV `position,stiffness_n_per_m`, one mesh cycle
  int harmonics_kept = 2;       // with "energy" or "table": harmonics kept of the curve
  std::optional<double> center_distance_mm;          // with "energy" (absent: the shifts' own)
  std::vector<ErrorHarmonic> transmission_error_um;  // of the mesh frequency
  // e(t)'s constant part: a constant offset of where the teeth touch (a table's mean).
  double transmission_error_mean_um = 0;
  // Instead of the two above: CSV `position,transmission_error_um` over one mesh cycle, its mean
  // and transmission_error_kept harmonics (table_mesh_error).
  std::string transmission_error_table;
  int transmission_error_kept = 4;
  double damping_ratio = 0.02;      // of the mesh's own contact oscillator
  std::string damping = "contact";  // where it acts: "contact", or "always"
  std::string tension = "allow";    // the contact force may pull, or "clip": held at 0
  // Where the driven gear's centre lies seen from the driving gear's, counterclockwise from x:
  // the direction of the line of action, read when a body of the mesh is planar.
  double position_angle_deg = 0;
  // "+z" or "-z": where the drive flank pushes the driven gear along the axes, read with a
  // spatial gear of a helical mesh.
  std::string thrust = "+z";
};

// [[train.shaft]]: a torsional spring and damper between two bodies, or from a body to the
// ground (to = "ground": a torsional support, such as a ring gear's in its housing).
struct TrainShaftData {
  std::string name, from, to;
  double stiffness_n_m_per_rad = 0;
  // Its damping, one of three ways (at most one given): a ratio against the reduced inertia of
  // its two bodies (the shaft and its bodies on their own); a ratio of the train's mode whose
  // strain energy it holds most of, the ratio it alone gives that mode (a drivetrain's first
  // mode damped as written, whatever the inertias); or the coefficient itself.
  double damping_ratio = 0.02;
  std::optional<double> mode_damping_ratio;
  std::optional<double> damping_n_m_s_per_rad;
};

// [[train.bearing]]: a bearing carrying a planar body's centre, the same stiffness in x and y:
// on the ground, or on a pin of another body (`on`, a planet's carrier) at pin_radius_mm from
// its centre in the direction pin_angle_deg.
struct TrainBearingData {
  std::string name, body;
  double stiffness_n_per_m = 0;
  double damping_ratio = 0.02;  // against the body's mass
  std::string on;               // "": the ground
  double pin_radius_mm = 0;
  double pin_angle_deg = 0;
  double pin_error_radial_um = 0, pin_error_tangential_um = 0;  // the seat's position error
  double clearance_um = 0;  // a radial clearance (train.hpp's Bearing::clearance_m)
  // A spatial body's: along its axis and about each diameter (damped by damping_ratio against
  // its mass and its tilt inertia).
  double axial_stiffness_n_per_m = 0, tilt_stiffness_n_m_per_rad = 0;
};

// [[train.torque]]: a torque on a body, positive along its rotation (a drive), negative against
// it (a load); harmonics in N m at orders of the body's speed.
struct TrainTorqueData {
  std::string name, body;
  double mean_nm = 0;
  std::vector<OrderHarmonic> harmonics;
  // Its mean is the reaction that balances every other mean torque and drag at the train's
  // speeds (train_of computes it; mean_nm is then not read).
  bool balances = false;
  // Instead of mean_nm: the mean power it delivers (kW, > 0 a drive, < 0 a load), its mean
  // torque P / (2 pi |n|) at its body's absolute speed n (train_of computes it).
  std::optional<double> power_kw;
};

// [[train.speed]]: a prescribed speed: the body turns at its nominal speed with a fluctuation
// whose angular acceleration is sum a_i cos(order_i Omega t + phase_i), a_i in rad/s^2 (an
// engine's firing orders), whatever the train does to it.
struct TrainSpeedData {
  std::string name, body;
  std::vector<OrderHarmonic> acceleration_harmonics;
};

struct TrainCase {
  std::string reference;  // empty: the first body
  double reference_speed_hz = 0;
  // "given": each mesh's harmonic phases about t = 0 as written; "layout": about a tooth pair
  // passing its pitch point, each mesh delayed by where the layout puts its teeth (train.hpp).
  std::string mesh_phase = "given";
  // The frame's rotation terms (train.hpp, Train::frame_terms).
  bool frame_terms = false;
  // A planetary set's planets from one (expand_planets): the body written once as `planet`,
  // and every element that names it, stand for `planets` copies at the carrier angles
  // planet_angles_deg (equally spaced when empty).
  std::string planet;  // empty: no copies
  int planets = 0;
  std::vector<double> planet_angles_deg;
  // Each copy's pin errors [radial, tangential] (um), added to its bearings' (empty: none).
  std::vector<std::array<double, 2>> planet_pin_errors_um;
  std::vector<TrainBodyData> bodies;
  std::vector<TrainMeshData> meshes;
  std::vector<TrainShaftData> shafts;
  std::vector<TrainBearingData> bearings;
  std::vector<TrainTorqueData> torques;
  std::vector<TrainDragData> drags;
  std::vector<TrainSpeedData> speeds;
  std::vector<TrainDamperData> dampers;
  // A planetary set written as a preset (add_planetary_elements), and the labels ("body 'sun'")
  // of the elements it wrote into the vectors above: written back as the preset alone, never
  // set by their index.
  std::vector<TrainPlanetaryData> planetaries;
  std::set<std::string> generated;
  // Where each element was written, "file:line:column" of its table (or the --set), by its
  // label "mesh 'stage1'" ("the train" for [train], "the train: reference" for its reference
  // key), and each of its keys by "mesh 'stage1': backlash_um": the assembler's messages name
  // the element (and the key), the reader adds where.
  std::map<std::string, std::string> origins;
};

// The train with its planets copied (a planetary set's preset; the train as written when it
// names no planet): the body `planet` becomes planet1 ... planetN, each element that names it
// (meshes, shafts, bearings, torques, drags, speeds) one copy per planet named <name>1 ...
// <name>N, turned about the set's axis by the planet's angle psi_n: its meshes' position angles
// and its bearings' pin angles plus psi_n (the template is written for a planet at 0 deg, on +x
// from the carrier's centre), and the bearings of planet n given its planet_pin_errors_um. Each
// copy keeps its template's origin for messages. Throws InputError naming the key for a planet that
// is no body, a count without a planet (or the reverse), and angles that are not one per planet.
TrainCase expand_planets(const TrainCase& t);

// The centre distance (mm) and working transverse pressure angle at which mesh m's gears a and b
// (its driving and driven) mesh without backlash, from their teeth, module, angles and profile
// shifts (shifted_center_distance: of an internal mesh the ring is the gear of more teeth, its
// shift in ISO 21771's sign). The line of action of a mesh lies at that angle. Throws InputError
// as shifted_center_distance does.
ShiftedCenterDistance mesh_center_distance_from_gears(const TrainMeshData& m,
                                                      const TrainBodyData& a,
                                                      const TrainBodyData& b);

// The radius at which bearing b's pin holds its body for its teeth to mesh: the centre distance
// (mesh_center_distance_from_gears) of the body's first mesh with a gear on no pin (a planet's
// with its sun or its ring); none for a bearing on the ground or where the gear data do not give
// it. A pin written without pin_radius_mm sits there (train_of).
std::optional<double> pin_radius_from_gears_mm(const TrainCase& t, const TrainBearingData& b);

// A pin radius this far from the gears' centre distance, relative, is more than a drawing's
// rounding: a pin that does not hold its planet where the teeth mesh (train_plausibility says
// so). Within it, the planet's lines of action lie at the pin's radius (train_of).
constexpr double kPinRadiusTolerance = 1e-3;

// The train of a case with model.form = "train", in SI: base radii and inertias from the gear
// data, each mesh's damping from its ratio. Throws InputError naming the element, its key and
// where it was written (file:line), for an arrangement the assembler refuses (an unknown body,
// a body named twice, no mesh, a train that cannot turn) and for a case of another form.
train::Train train_of(const Case& c);
// The same, assembled, its joints settled at the static state (settle_joints); a case of the
// gear pair's forms as its train form (train_form_of, with `stiffness` as there).
train::Assembled assembled_train(const Case& c, const MeshStiffness* stiffness = nullptr);

// Every key of [train] and of its elements, described from the tables the reader uses: for
// the key tables of docs/case-files.md (as case_keys_markdown writes those of the sections),
// `geardyn keys` and `geardyn keys --json`.
struct TrainKeyInfo {
  std::string kind;  // "body", "mesh", ...; "" for a key of [train] itself
  std::string leaf, unit, default_text, allowed, meaning;
  std::string dotted() const;  // "train.mesh[].backlash_um", "train.reference_speed_hz"
};
const std::vector<TrainKeyInfo>& train_key_list();
std::string train_keys_markdown();
std::string train_keys_listing();

// Empty when `dotted` is a real number of [train] or of one of its elements, which a study
// may vary ("train.reference_speed_hz", "train.mesh[0].damping_ratio"); else why not. Whether
// the element exists is the case's to say when the value is set.
std::string train_key_not_sweepable(std::string_view dotted);

// The index of the mesh a study reads (its `--mesh NAME`, `mesh=` in Python): the named mesh
// of a train, the first when `name` is empty; 0 for a case of another form with no name.
// Throws InputError "--mesh = "NAME": ..." for a name the train does not have (listing its
// meshes) and for a name given to a case of another form (which has one mesh).
std::size_t mesh_to_read(const Case& c, const std::string& name);

// The train's settings that nothing reads, "train.mesh[0].position_angle_deg = 30 (where): not
// used: why" (a mesh's layout when neither of its gears is planar), for unused_settings.
std::vector<std::string> train_unused_settings(const TrainCase& t);

// The [train] section written back as TOML (case.toml of a run).
std::string train_toml(const TrainCase& t);

// Sets a number of the train in place, as reading the case with the override would: the
// reference speed, a key of an element whose value is one number ("train.mesh[0].backlash_um";
// not a whole number such as teeth), or an entry of an element's harmonics that is there
// ("train.speed[0].acceleration_harmonics[0][0]"), within its key's bounds, the key's and its
// element's origins the override's. False, and t unchanged, for any other key or value (the
// caller reads the case again with it, which says what is wrong).
bool set_train_number_in_place(TrainCase& t, const Override& o);

}  // namespace geardyn
