// geardyn: a case's geometry, mesh stiffness and one-degree model (case_model.cpp), model
// layer: what the runs, the studies and the pair forms' trains build from a case.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/model.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {

// compute_geometry of a case's gear data, its errors naming where the keys they mention came
// from (file:line or the --set; Case::origins).
Geometry case_geometry(const Case& c);

// The mesh stiffness of a case of the dimensional forms (its geometry's, tabulated or given;
// mesh_stiffness), its errors naming where the keys came from. Throws InputError.
MeshStiffness case_stiffness(const Case& c);

// The mesh stiffness a study that varies only `keys` of `base` computes once for all its values:
// empty for the nondimensional form (it has none), for ISO 6336-1's stiffness (a closed form of
// the load: the torque and the application factor move it) or when a key changes the stiffness
// curve (changes_stiffness; each value then computes its own). Throws InputError.
std::optional<MeshStiffness> shared_stiffness(const Case& base,
                                              const std::vector<std::string>& keys);

// The model of a case (geometry and stiffness included). `stiffness`, when given, is used in
// place of computing the case's mesh stiffness (shared_stiffness). Throws InputError.
GearPairModel build_model(const Case& c, Geometry* geometry_out = nullptr,
                          const MeshStiffness* stiffness = nullptr);

}  // namespace geardyn
