// geardyn: a planetary set written in a screenful, [[train.planetary]], expanded into the
// train's elements when the case is read.
//
// The preset writes what a planetary stage's elements would say (docs/case-files.md, "A
// planetary set in a screenful"): the bodies sun, ring, carrier and planet (the planet written
// once, copied train.planets times by expand_planets), the meshes between the sun and the planet
// and between the planet and the ring, with the member that drives pushing on its drive flank,
// the pin that seats the planet on the carrier at the centre distance its teeth give, the
// bearings on the ground for the sun, the ring and the carrier (the four members planar: a pin
// carries a planar body), and the shaft that holds one member in the housing. Elements written
// beside it join its bodies by their names (a rotor on the carrier, a load on the sun). Every
// generated element keeps the preset's table as where it was written, so that a message about it
// names the preset's line.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "geardyn/case.hpp"

namespace geardyn {

struct TrainCase;  // train_case.hpp

// [[train.planetary]]: one planetary set (train_case.cpp's planetary_keys() gives each key's
// unit, bounds and meaning).
struct TrainPlanetaryData {
  std::string name;  // the set's, for messages
  int sun_teeth = 0, planet_teeth = 0;
  int ring_teeth = 0;  // 0: sun_teeth + 2 planet_teeth
  double normal_module_mm = 0;
  double normal_pressure_angle_deg = 20;
  double helix_angle_deg = 0;
  double face_width_mm = 0;
  // The profile shifts of the three gears (the ring's in ISO 21771's sign).
  double sun_profile_shift = 0, planet_profile_shift = 0, ring_profile_shift = 0;
  std::string input = "sun";  // the member that drives: "sun", "carrier" or "ring"
  std::string held = "ring";  // the member held in the housing: "ring", "carrier", "sun", "none"
  double support_n_m_per_rad = 0;  // the held member's torsional support
  // Each member's inertia and (planar) mass; a gear's absent: its blank's (TrainBodyData).
  std::optional<double> sun_inertia_kg_m2, sun_mass_kg, planet_inertia_kg_m2, planet_mass_kg,
      ring_inertia_kg_m2, ring_mass_kg, carrier_inertia_kg_m2, carrier_mass_kg;
  // The meshes' k_m and harmonics; absent k_m: ISO 6336-1's from the gears (stiffness_source =
  // "iso6336", harmonics as given).
  std::optional<double> mesh_stiffness_n_per_m;
  std::vector<StiffnessHarmonic> mesh_stiffness_harmonics;
  std::optional<double> backlash_um, mesh_damping_ratio;  // absent: a mesh's defaults
  double bearing_stiffness_n_per_m = 0;         // the sun's, the ring's and the carrier's bearings
  std::optional<double> pin_stiffness_n_per_m;  // absent: bearing_stiffness_n_per_m
};

// The elements of t's planetary set (at most one), appended to those written (whose indices
// train.body[i] and the like keep), each named in t.generated and given the preset's origin;
// t.planet becomes "planet". Throws InputError naming the preset's key and where it was written
// for a second set, a train.planet of another name, a name the preset writes that an element
// written beside it has too, and a held member without support_n_m_per_rad (or the reverse).
void add_planetary_elements(TrainCase& t);

}  // namespace geardyn
