#include "geardyn/mesh_stiffness_report.hpp"

#include <cmath>
#include <numbers>

#include "geardyn/run.hpp"  // case_geometry
#include "geardyn/train_case.hpp"

namespace geardyn {

MeshStiffnessReport mesh_stiffness_report(const Case& c, const std::string& mesh) {
  GearPairToRead read = gear_pair_to_read(c, mesh, /*internal_too=*/true);
  MeshStiffnessReport r;
  r.pair = std::move(read.pair);
  r.internal = read.internal;
  r.warnings = std::move(read.warnings);
  const Case& pair = r.pair;
  if (!r.internal) {
    r.geometry = case_geometry(pair);
    r.iso = iso6336_stiffness(pair, r.geometry);
    r.cycle = energy_method_cycle(pair, r.geometry);
    r.used = mesh_stiffness(pair, r.geometry).fourier;
  } else {
    // ISO 6336-1 reads the pinion's data and the pair's contact ratio: the external pair of the
    // same teeth at its reference centre distance gives the rest of its geometry.
    const GearData& gd = pair.gear;
    const double beta = gd.helix_angle_deg * std::numbers::pi / 180;
    Case outer = pair;
    outer.gear.center_distance_mm =
        0.5 * (gd.teeth[0] + gd.teeth[1]) * gd.normal_module_mm / std::cos(beta);
    outer.gear.outside_diameter_mm[1] =
        gd.teeth[1] * gd.normal_module_mm / std::cos(beta) + 2 * gd.normal_module_mm;
    r.geometry = case_geometry(outer);
    r.geometry.transverse_contact_ratio =
        internal_contact_ratio(gd.teeth[0], gd.teeth[1], 1e-3 * gd.normal_module_mm,
                               gd.normal_pressure_angle_deg * std::numbers::pi / 180, beta);
    r.iso = iso6336_internal_stiffness(outer, r.geometry, r.geometry.transverse_contact_ratio);
    r.cycle = internal_energy_method_cycle(pair);
    switch (pair.mesh.stiffness_source) {
      case StiffnessSource::kEnergy:
        r.used = internal_mesh_stiffness(pair).fourier;
        break;
      case StiffnessSource::kIso6336:  // the train's k_m at its static load, harmonics as given
        r.used.mean_n_per_m = pair.mesh.mean_stiffness_n_per_m;
        r.used.harmonics = pair.mesh.stiffness_harmonics;
        break;
      case StiffnessSource::kHarmonics:
      case StiffnessSource::kTable:
        r.used = mesh_stiffness(pair, Geometry{}).fourier;
    }
  }
  r.kept = fourier_harmonics(r.cycle, pair.mesh.harmonics_kept);
  return r;
}

}  // namespace geardyn
