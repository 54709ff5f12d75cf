#include "geardyn/mesh_stiffness_report.hpp"

#include <cmath>
#include <numbers>

#include "geardyn/run.hpp"  // case_geometry
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"

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
    // The internal pair's geometry in the report's terms: its contact and overlap ratios, its
    // base helix angle and pitch.
    const InternalGeometry g = internal_geometry(pair.gear);
    r.geometry.transverse_contact_ratio = g.transverse_contact_ratio();
    r.geometry.overlap_ratio = 1e-3 * pair.gear.face_width_mm *
                               std::sin(pair.gear.helix_angle_deg * std::numbers::pi / 180) /
                               (std::numbers::pi * 1e-3 * pair.gear.normal_module_mm);
    r.geometry.base_helix_angle_rad = g.base_helix_angle_rad;
    r.geometry.transverse_base_pitch_m = g.pbt;
    r.iso = iso6336_internal_stiffness(pair, g);
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
