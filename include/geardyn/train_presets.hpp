// geardyn: the gear-pair presets of a train (train_presets.cpp). A train's mesh read as the gear
// pair of its two gears (its stiffness by the energy method, ISO 6336-1 or a table, its
// transmission error table, its geometry's warnings, the pair `geardyn geometry` and `geardyn
// stiffness` read), and the other way, a case of the gear pair's forms written as its train.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/train_case.hpp"

namespace geardyn {

struct MeshStiffness;  // stiffness.hpp

// Gear b of t as an internal mesh reads it, its pinion: b itself when it gives its tip diameter
// or meshes with no external gear; else with the tip its first external mesh gives it, the
// standard basic rack's less that mesh's tip shortening (ISO 21771), so that a planet meshes
// with its ring at the tip its sun mesh shortens.
TrainBodyData pinion_as_meshed(const TrainCase& t, const TrainBodyData& b);

// The mean stiffness (N/m) and the harmonics of the mesh frequency (ratios to it, phases in
// degrees) of a mesh whose stiffness_source is "energy": the external gear pair of its two gears
// (driving first) by the gear pair's energy method (stiffness.hpp), as the one-degree model
// takes its own curve, its [gear] keys from the bodies' (the face width the narrower of the
// two), its centre distance the mesh's or, absent, the one the profile shifts imply, k_m
// scaling the curve when the mesh gives one; an internal mesh's by the internal pair's energy
// method (internal_energy_method_cycle: the pinion first, the ring second, its centre distance
// the mesh's or the standard r_2 - r_1). Throws InputError naming the mesh's or a body's key.
struct PairMeshStiffness {
  double mean_n_per_m = 0;
  std::vector<StiffnessHarmonic> harmonics;
};
PairMeshStiffness pair_mesh_stiffness(const TrainMeshData& m, const TrainBodyData& driving,
                                      const TrainBodyData& driven);
// The same of a mesh whose stiffness_source is "iso6336": ISO 6336-1 Method B's c_gamma_alpha b
// (stiffness.hpp's iso6336_stiffness) of that gear pair under `driving_torque_nm` on its driving
// gear (absent: a line load of twice ISO's 100 N/mm, so its load factor is 1), the mesh's
// stiffness_harmonics as given. Throws InputError as pair_mesh_stiffness.
PairMeshStiffness iso_mesh_stiffness(const TrainMeshData& m, const TrainBodyData& driving,
                                     const TrainBodyData& driven,
                                     std::optional<double> driving_torque_nm = std::nullopt);
// The same of a mesh whose stiffness_source is "table": its stiffness_table (relative to
// `directory`, the case file's) read, resampled and reduced to harmonics_kept harmonics as the
// gear pair reads mesh.stiffness_table (stiffness.hpp's table_cycle), k_m scaling it when the
// mesh gives one. Throws InputError naming the mesh's key, the file and the line.
PairMeshStiffness table_mesh_stiffness(const TrainMeshData& m,
                                       const std::filesystem::path& directory);
// The mean (um) and the harmonics (um, phases in degrees) of a mesh's transmission_error_table,
// as the gear pair reads mesh.transmission_error_table (transmission_error.hpp). Throws
// InputError naming the mesh's key, the file and the line.
struct TableMeshError {
  double mean_um = 0;
  std::vector<ErrorHarmonic> harmonics;
};
TableMeshError table_mesh_error(const TrainMeshData& m, const std::filesystem::path& directory);
// What that gear pair's geometry says of the data and goes on (a centre distance that the
// shifts do not imply), in the train's keys; nothing where the pair is refused (the assembly
// says why).
std::vector<std::string> pair_mesh_warnings(const TrainMeshData& m, const TrainBodyData& driving,
                                            const TrainBodyData& driven);

// The train form (model.form = "train") of a case of the gear pair's forms: the preset the
// forms "gear_pair", "coupled" and "nondimensional" are of the elements
// (src/model/train_presets.cpp); a train case is returned as it is.
// - Bodies "pinion" and "wheel": the case's gears with their inertias as computed; with form
//   "coupled" held to the line of action as the coupled model holds them ("line" with dof 3,
//   "line_axial" with dof 6) or spatial (dof 12) on bearings "pinion_bearing"
//   and "wheel_bearing" (the [bearings] values and clearances), the mesh's position angle the
//   transverse pressure angle, so that its line of action is the train's y as the coupled
//   pair's; its [shafts] as bodies "motor" and "load" with shafts "drive_shaft" and
//   "load_shaft".
// - Mesh "mesh": the case's backlash, damping ratio, damping form and tension rule, and its
//   stiffness k(t) and transmission error e(t) (whatever their source: ISO 6336, the energy
//   method, a table) as the harmonics of the mesh frequency the pair's model keeps.
// - Torques: T1(t) on the pinion (the motor), "drive"; on the wheel (the load) "load", the
//   matched load -R_b2 T1(t) / R_b1 or the given -T2(t), each harmonic at its order of its
//   body's speed. The reference is the pinion at the case's shaft frequency; the solver is the
//   case's.
// - The non-dimensional form: the same names in units where the train is the oscillator (b =
//   1 m, k_m = 1 N/m, m_eq = 1 kg, the mesh frequency Omega / 2 pi, damping at all times, F(tau)
//   as matched torques on base circles of 1 m): its seconds are tau.
// Its run is the case's run: d - e, impacts and forces (tests/train_case_test.cpp). Throws
// InputError naming the key and where it was given for a harmonic at no whole multiple of the
// mesh frequency. `stiffness`: the mesh's curve when a study has computed it already
// (build_model's; shared_stiffness), else computed from the case.
Case train_form_of(const Case& c, const MeshStiffness* stiffness = nullptr);

// The gear pair of a train's mesh (mesh_to_read's; an external one), for `geardyn geometry` and
// `geardyn stiffness`: its [gear] keys from the two gears' as pair_mesh_stiffness writes them,
// its [mesh] stiffness source, k_m, harmonics or table as the train mesh runs with them, its
// driving gear's speed, and as load.torque_nm the torque F cos(beta_b) r_b of the mesh's force
// at the train's static state (0 without one), which ISO 6336-1's load factor reads. Named
// "<case>, mesh '<name>'". Throws InputError naming the mesh and where it was written.
Case train_mesh_pair(const Case& c, const std::string& mesh);
// What that gear pair's geometry says of the data (pair_mesh_warnings), in the train's keys.
std::vector<std::string> train_mesh_pair_warnings(const Case& c, const std::string& mesh);
// The gear pair that `geardyn geometry` and `geardyn stiffness` (and Python's geometry() and
// stiffness()) read: a train's mesh's (train_mesh_pair, its warnings in the train's keys), or the
// case itself with its geometry's warnings (a mesh named for it refused, mesh_to_read). An
// internal mesh's (with `internal_too`; else refused, internal_pair_has_no_geometry) is
// `internal`: its pinion first, its ring second, at the mesh's center_distance_mm or 0 (the
// standard r_2 - r_1), the rest as train_mesh_pair has it; no external pair's geometry describes
// it (mesh_stiffness_report reads it).
struct GearPairToRead {
  Case pair;
  std::vector<std::string> warnings;
  bool internal = false;
};
GearPairToRead gear_pair_to_read(const Case& c, const std::string& mesh, bool internal_too = false);
// The refusal of internal mesh `mesh`'s geometry (`geardyn geometry --mesh`, Python's
// geometry()).
std::string internal_pair_has_no_geometry(const std::string& mesh);

}  // namespace geardyn
