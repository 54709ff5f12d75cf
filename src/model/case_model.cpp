// A case's geometry, mesh stiffness and one-degree model (case_model.hpp), the errors of each
// naming where the keys they mention came from.
#include "geardyn/case_model.hpp"

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "geardyn/case_keys.hpp"
#include "geardyn/transmission_error.hpp"

namespace geardyn {

Geometry case_geometry(const Case& c) {
  try {
    return compute_geometry(c.gear);
  } catch (const InputError& e) {
    throw InputError(with_origins(c, e.what()));
  }
}

MeshStiffness case_stiffness(const Case& c) {
  if (const std::string err = validate(c); !err.empty()) throw InputError(err);
  const Geometry g = case_geometry(c);
  try {
    return mesh_stiffness(c, g);
  } catch (const InputError& e) {
    throw InputError(with_origins(c, e.what()));
  }
}

std::optional<MeshStiffness> shared_stiffness(const Case& base,
                                              const std::vector<std::string>& keys) {
  // The non-dimensional form has no gears; a train's meshes carry their own stiffness.
  if (base.model.form == ModelForm::kNondimensional || base.model.form == ModelForm::kTrain)
    return std::nullopt;
  // ISO 6336-1's k_m follows the load (its c' below 100 N/mm), and costs a formula to compute.
  if (base.mesh.stiffness_source == StiffnessSource::kIso6336) return std::nullopt;
  for (const std::string& key : keys)
    if (changes_stiffness(key)) return std::nullopt;
  return case_stiffness(base);
}

GearPairModel build_model(const Case& c, Geometry* geometry_out, const MeshStiffness* stiffness) {
  if (const std::string err = validate(c); !err.empty()) throw InputError(err);
  if (c.model.form == ModelForm::kTrain)
    throw InputError(
        "model.form = \"train\": this takes the one-degree forms; a gear train runs with "
        "`geardyn run` (run_train, train_run.hpp)");
  if (c.model.form == ModelForm::kCoupled)
    throw InputError(
        "model.form = \"coupled\": this command takes the one-degree forms (\"gear_pair\", "
        "\"nondimensional\"); `geardyn run`, `sweep`, `orbit`, `continue`, `stability` and `modes` "
        "take the coupled model");
  HarmonicSeries e;
  try {
    e = transmission_error_series(c);
  } catch (const InputError& err) {
    throw InputError(with_origins(c, err.what()));
  }
  if (c.model.form == ModelForm::kNondimensional) {
    GearPairParameters p = nondimensional_parameters(c.model);
    add_transmission_error(p, e);
    return GearPairModel(std::move(p));
  }
  Geometry g = case_geometry(c);
  HarmonicSeries k;
  try {
    k = stiffness ? mesh_stiffness_series(c, *stiffness) : mesh_stiffness_series(c, g);
  } catch (const InputError& e) {
    throw InputError(with_origins(c, e.what()));  // where the keys it names came from
  }
  GearPairParameters p = gear_pair_parameters(c, g, k);
  add_transmission_error(p, e);
  GearPairModel model(std::move(p));
  if (geometry_out) *geometry_out = std::move(g);
  return model;
}

}  // namespace geardyn
