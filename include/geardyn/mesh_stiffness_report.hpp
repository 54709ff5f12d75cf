// geardyn: what `geardyn stiffness` and Python's stiffness() report of a mesh's gear pair.
//
// One report for every pair a case names (gear_pair_to_read): the case's own gear pair, a
// train's external mesh or an internal one (a pinion in its ring). Each gives ISO 6336-1 Method
// B, the energy method's curve over a mesh cycle with the harmonics the case keeps, the
// stiffness a run of the case uses, and the geometry they read.
#pragma once

#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {

struct MeshStiffnessReport {
  Case pair;              // the gear pair read (gear_pair_to_read): an internal one's pinion first
  bool internal = false;  // a pinion in its ring
  // The geometry the report reads; an internal pair's is its pinion's and the external pair's
  // of the same teeth but for its contact ratio, the internal pair's (ISO 21771).
  Geometry geometry;
  Iso6336Stiffness iso;   // iso6336_stiffness, or an internal pair's iso6336_internal_stiffness
  StiffnessCycle cycle;   // energy_method_cycle, or internal_energy_method_cycle
  StiffnessFourier kept;  // the cycle's mesh.harmonics_kept harmonics
  StiffnessFourier used;  // the stiffness a run of the case uses (its source, scaling)
  std::vector<std::string> warnings;  // the pair's geometry's, in the case's keys
};

// The report of the mesh `mesh` of c ("" for its only one). Throws InputError as
// gear_pair_to_read, and for what the pair's methods refuse (involute interference, a ring's
// tip diameter of the other sign's shift), naming the key.
MeshStiffnessReport mesh_stiffness_report(const Case& c, const std::string& mesh);

}  // namespace geardyn
