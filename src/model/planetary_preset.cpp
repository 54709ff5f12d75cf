#include "geardyn/planetary_preset.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>

#include "geardyn/train_case.hpp"

namespace geardyn {
namespace {

// The preset's message, where it was written first: "file:line: train: planetary 'x': ...".
[[noreturn]] void refuse(const TrainCase& t, const TrainPlanetaryData& p, const std::string& what) {
  const auto o = t.origins.find(fmt::format("planetary '{}'", p.name));
  throw InputError(fmt::format("{}train: planetary '{}': {}",
                               o == t.origins.end() ? "" : o->second + ": ", p.name, what));
}

TrainBodyData gear(const TrainPlanetaryData& p, const char* name, int teeth, double shift,
                   std::optional<double> inertia_kg_m2, std::optional<double> mass_kg) {
  TrainBodyData b;
  b.name = name;
  b.dof = BodyDof::kPlanar;
  b.teeth = teeth;
  b.normal_module_mm = p.normal_module_mm;
  b.normal_pressure_angle_deg = p.normal_pressure_angle_deg;
  b.helix_angle_deg = p.helix_angle_deg;
  b.face_width_mm = p.face_width_mm;
  b.profile_shift = shift;
  b.inertia_kg_m2 = inertia_kg_m2;
  b.mass_kg = mass_kg;
  return b;
}

TrainMeshData mesh(const TrainPlanetaryData& p, const char* name, const char* driving,
                   const char* driven, bool internal, double position_angle_deg) {
  TrainMeshData m;
  m.name = name;
  m.driving = driving;
  m.driven = driven;
  if (internal) m.kind = MeshKind::kInternal;
  if (p.mesh_stiffness_n_per_m)
    m.mean_stiffness_n_per_m = p.mesh_stiffness_n_per_m;
  else
    m.stiffness_source = "iso6336";
  m.stiffness_harmonics = p.mesh_stiffness_harmonics;
  if (p.backlash_um) m.backlash_um = *p.backlash_um;
  if (p.mesh_damping_ratio) m.damping_ratio = *p.mesh_damping_ratio;
  m.position_angle_deg = position_angle_deg;
  return m;
}

TrainBearingData bearing(const char* name, const char* body, double stiffness_n_per_m) {
  TrainBearingData b;
  b.name = name;
  b.body = body;
  b.stiffness_n_per_m = stiffness_n_per_m;
  return b;
}

}  // namespace

void add_planetary_elements(TrainCase& t) {
  if (t.planetaries.empty()) return;
  const TrainPlanetaryData& p = t.planetaries.front();
  if (t.planetaries.size() > 1)
    refuse(t, t.planetaries[1],
           "a train has one planetary set written as a preset; write a second set's elements "
           "([[train.body]], [[train.mesh]], ...)");
  if (!t.planet.empty() && t.planet != "planet")
    refuse(t, p,
           fmt::format("train.planet = \"{}\": the preset's planet is body 'planet' (write "
                       "train.planets alone)",
                       t.planet));
  if ((p.held == "none") != (p.support_n_m_per_rad == 0))
    refuse(t, p,
           p.held == "none"
               ? fmt::format("support_n_m_per_rad = {}: nothing is held (held = \"none\")",
                             p.support_n_m_per_rad)
               : fmt::format("held = \"{}\": give support_n_m_per_rad, its torsional support in "
                             "the housing (N m/rad, > 0)",
                             p.held));
  const int ring_teeth = p.ring_teeth > 0 ? p.ring_teeth : p.sun_teeth + 2 * p.planet_teeth;

  std::vector<TrainBodyData> bodies = {
      gear(p, "sun", p.sun_teeth, p.sun_profile_shift, p.sun_inertia_kg_m2, p.sun_mass_kg),
      gear(p, "ring", ring_teeth, p.ring_profile_shift, p.ring_inertia_kg_m2, p.ring_mass_kg),
      {},
      gear(p, "planet", p.planet_teeth, p.planet_profile_shift, p.planet_inertia_kg_m2,
           p.planet_mass_kg)};
  bodies[2].name = "carrier";
  bodies[2].dof = BodyDof::kPlanar;
  bodies[2].inertia_kg_m2 = p.carrier_inertia_kg_m2;
  bodies[2].mass_kg = p.carrier_mass_kg;

  // The member that drives pushes on its drive flank: the sun pushes the planet, which pushes
  // the ring; driven through the carrier or the ring, the planet pushes the sun and the ring
  // pushes the planet. Each position angle is the driven centre seen from the driving one, the
  // planet's template at 0 deg on the carrier.
  const std::vector<TrainMeshData> meshes =
      p.input == "sun"
          ? std::vector<TrainMeshData>{mesh(p, "sun_planet", "sun", "planet", false, 0),
                                       mesh(p, "planet_ring", "planet", "ring", true, 180)}
          : std::vector<TrainMeshData>{mesh(p, "planet_sun", "planet", "sun", false, 180),
                                       mesh(p, "ring_planet", "ring", "planet", true, 0)};

  std::vector<TrainShaftData> shafts;
  if (p.held != "none") {
    TrainShaftData s;
    s.name = p.held + "_support";
    s.from = p.held;
    s.to = "ground";
    s.stiffness_n_m_per_rad = p.support_n_m_per_rad;
    shafts.push_back(s);
  }
  std::vector<TrainBearingData> bearings = {
      bearing("sun_bearing", "sun", p.bearing_stiffness_n_per_m),
      bearing("ring_bearing", "ring", p.bearing_stiffness_n_per_m),
      bearing("carrier_bearing", "carrier", p.bearing_stiffness_n_per_m),
      bearing("pin", "planet", p.pin_stiffness_n_per_m.value_or(p.bearing_stiffness_n_per_m))};
  bearings[3].on = "carrier";

  // No element written beside the preset may take a name it writes.
  const std::string origin = t.origins.at(fmt::format("planetary '{}'", p.name));
  const auto claim = [&](const auto& written, const auto& made, std::string_view kind) {
    for (const auto& e : made) {
      if (std::any_of(written.begin(), written.end(),
                      [&](const auto& x) { return x.name == e.name; }))
        refuse(t, p,
               fmt::format("writes {0} '{1}', and a [[train.{0}]] of that name is written too "
                           "({2}): name it otherwise",
                           kind, e.name, t.origins.at(fmt::format("{} '{}'", kind, e.name))));
      const std::string label = fmt::format("{} '{}'", kind, e.name);
      t.origins[label] = origin;
      t.generated.insert(label);
    }
  };
  claim(t.bodies, bodies, "body");
  claim(t.meshes, meshes, "mesh");
  claim(t.shafts, shafts, "shaft");
  claim(t.bearings, bearings, "bearing");
  t.bodies.insert(t.bodies.end(), bodies.begin(), bodies.end());
  t.meshes.insert(t.meshes.end(), meshes.begin(), meshes.end());
  t.shafts.insert(t.shafts.end(), shafts.begin(), shafts.end());
  t.bearings.insert(t.bearings.end(), bearings.begin(), bearings.end());
  t.planet = "planet";
}

}  // namespace geardyn
