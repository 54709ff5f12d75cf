#include "geardyn/train_case.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <set>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <variant>

#include "geardyn/case_keys.hpp"
#include "geardyn/plausibility.hpp"
#include "geardyn/suggest.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_statics.hpp"
#include "model/element_keys.hpp"
#include "model/toml_source.hpp"

namespace geardyn {
namespace {

using namespace element_keys;

constexpr double kPi = std::numbers::pi;
constexpr double kMmToM = 1e-3;
constexpr double kUmToM = 1e-6;
constexpr double kDegToRad = kPi / 180.0;
// The passes of an ISO 6336 mesh's stiffness at its static load, and when they have settled
// (iso_meshes_at_their_load): relative change of k_m.
constexpr int kIsoLoadPasses = 50;
constexpr double kIsoLoadTolerance = 1e-12;

// The keys of each kind of element: the one table the reader, its messages and the docs use.
const std::vector<ElementKey<TrainBodyData>>& body_keys() {
  using B = TrainBodyData;
  static const std::vector<ElementKey<B>> keys = {
      {"name", &B::name, "", {}, true, "the body's name, by which meshes and shafts join it"},
      {"dof",
       &B::dof,
       "",
       {},
       false,
       "the degrees of freedom it keeps: its rotation (\"torsion\"), also its centre's "
       "displacement in the plane on its bearings (\"planar\"), or all six: also along its "
       "axis and its tilts about x and y (\"spatial\", a helical gear's axial force and "
       "moment; not in a planetary set), or along its axis without tilting (\"axial\", its "
       "tilts held: the coupled pair's dof 6); \"line\" and \"line_axial\" as \"planar\" and "
       "\"axial\" with the centre held to its one mesh's line of action (Kahraman and Singh's "
       "lumped pair: the coupled pair's dof 3 and 6)"},
      {"inertia_kg_m2", &B::inertia_kg_m2, "kg m^2", above(0), false,
       "polar moment of inertia; absent: a cylinder of the reference diameter and face width "
       "(a gear's)"},
      {"mass_kg", &B::mass_kg, "kg", above(0), false,
       "a planar or spatial body's mass; absent: the cylinder of inertia_kg_m2's rule"},
      {"tilt_inertia_kg_m2", &B::tilt_inertia_kg_m2, "kg m^2", above(0), false,
       "a spatial body's moment of inertia about a diameter; absent: the cylinder's, m (3 (r^2 "
       "+ r_i^2) + w^2) / 12"},
      {"teeth", &B::teeth, "", closed(0, 10000), false, "number of teeth; 0: not a gear"},
      {"normal_module_mm", &B::normal_module_mm, "mm", closed(0, 100), false,
       "normal module m_n (a gear's)"},
      {"normal_pressure_angle_deg", &B::normal_pressure_angle_deg, "deg", open(0, 45), false,
       "normal pressure angle alpha_n"},
      {"helix_angle_deg", &B::helix_angle_deg, "deg", closed_open(0, 60), false,
       "helix angle beta (0: spur); a mesh's two gears have the same"},
      {"face_width_mm", &B::face_width_mm, "mm", at_least(0), false,
       "face width, for the inertia when inertia_kg_m2 is absent"},
      {"bore_diameter_mm", &B::bore_diameter_mm, "mm", at_least(0), false,
       "bore of the blank, for the inertia (0: solid)"},
      {"density_kg_m3", &B::density_kg_m3, "kg/m^3", above(0), false, "for the inertia"},
      {"eccentricity_um", &B::eccentricity_um, "um", closed(0, 1e4), false,
       "runout: the centre of its teeth (and of a carrier's pins) lies this far from its axis "
       "and turns with it, its mass centred (a sun's or a carrier's eccentricity)"},
      {"eccentricity_angle_deg", &B::eccentricity_angle_deg, "deg", closed(-360, 360), false,
       "where that centre lies at t = 0, counterclockwise from x in the train's frame"},
      {"profile_shift", &B::profile_shift, "", closed(-1.5, 1.5), false,
       "profile shift coefficient x, a ring's in ISO 21771's sign (positive thickens its teeth): "
       "its meshes' centre distance, working pressure angle and stiffness from the gears"},
      {"outside_diameter_mm", &B::outside_diameter_mm, "mm", above(0), false,
       "tip diameter d_a (a ring's inner one), for a mesh's stiffness_source = \"energy\" or "
       "\"iso6336\"; absent: d + 2 m_n (1 + x - k), k the tip shortening its (first) external "
       "mesh's centre distance leaves (ISO 21771), in its internal mesh too; a ring's d - 2 m_n "
       "(1 + x)"},
      {"youngs_modulus_gpa", &B::youngs_modulus_gpa, "GPa", above(0), false,
       "Young's modulus, for a mesh's stiffness_source = \"energy\""},
      {"poisson_ratio", &B::poisson_ratio, "", open(0, 0.5), false,
       "Poisson's ratio, for a mesh's stiffness_source = \"energy\""},
      {"basic_rack_dedendum", &B::basic_rack_dedendum, "", closed(1, 1.6), false,
       "h_fP / m_n of the basic rack, for a mesh's stiffness_source = \"energy\""},
  };
  return keys;
}

const std::vector<ElementKey<TrainMeshData>>& mesh_keys() {
  using M = TrainMeshData;
  static const std::vector<ElementKey<M>> keys = {
      {"name", &M::name, "", {}, false, "the mesh's name in outputs"},
      {"driving", &M::driving, "", {}, true, "the gear whose drive flank pushes"},
      {"driven", &M::driven, "", {}, true, "the gear it drives"},
      {"kind",
       &M::kind,
       "",
       {},
       false,
       "\"external\", or \"internal\" for a pinion and a ring gear (the gear with more teeth, "
       "turning the same way)"},
      {"backlash_um", &M::backlash_um, "um", above(1e-3), false,
       "b, half the total normal backlash 2b"},
      {"stiffness_source",
       &M::stiffness_source,
       "",
       {},
       false,
       "where k(t) comes from: \"harmonics\", mean_stiffness_n_per_m and stiffness_harmonics "
       "as given; \"energy\", the gear pair's energy method on the two gears' teeth, module, "
       "angles, face widths, profile shifts, tip diameters and material (the narrower face "
       "width), as mesh.stiffness_source = \"energy\" (docs/stiffness.md); \"table\", the "
       "curve of stiffness_table; \"iso6336\", k_m = c_gamma_alpha b of ISO 6336-1 Method B "
       "from the same data under the mesh's load at the train's static state, "
       "stiffness_harmonics as given",
       "harmonics energy table iso6336"},
      {"mean_stiffness_n_per_m", &M::mean_stiffness_n_per_m, "N/m", above(0), false,
       "mean normal mesh stiffness k_m; required with stiffness_source = \"harmonics\", with "
       "\"energy\" or \"table\" the curve scaled to it (absent: its own mean)"},
      {"stiffness_harmonics", &M::stiffness_harmonics, "", closed_open(0, 1), false,
       "[[ratio k_i/k_m, phase_deg], ...] at i times the mesh frequency, with stiffness_source = "
       "\"harmonics\" or \"iso6336\""},
      {"stiffness_table",
       &M::stiffness_table,
       "",
       {},
       false,
       "with stiffness_source = \"table\": a CSV `position,stiffness_n_per_m` over one mesh "
       "cycle, position in [0, 1) (as mesh.stiffness_table), relative to the case file",
       "",
       true},
      {"harmonics_kept", &M::harmonics_kept, "", closed(0, 16), false,
       "with stiffness_source = \"energy\" or \"table\": the harmonics kept of the curve"},
      {"center_distance_mm", &M::center_distance_mm, "mm", above(0), false,
       "with stiffness_source = \"energy\" or \"iso6336\": the centre distance a; absent: the one "
       "the two "
       "profile shifts imply"},
      {"transmission_error_um", &M::transmission_error_um, "um", at_least(0), false,
       "[[amplitude, phase_deg], ...] of the static transmission error at i times the mesh "
       "frequency"},
      {"transmission_error_mean_um",
       &M::transmission_error_mean_um,
       "um",
       {},
       false,
       "the transmission error's constant part: where the teeth touch moves by it (the forces "
       "change only where the train's statics depend on its deflections: meshes in parallel, a "
       "body held twice)"},
      {"transmission_error_table",
       &M::transmission_error_table,
       "",
       {},
       false,
       "instead of the two above: a CSV `position,transmission_error_um` over one mesh cycle (as "
       "mesh.transmission_error_table), relative to the case file: its mean and "
       "transmission_error_kept harmonics",
       "",
       true},
      {"transmission_error_kept", &M::transmission_error_kept, "", closed(1, kMaxErrorHarmonics),
       false, "harmonics kept from transmission_error_table"},
      {"damping_ratio", &M::damping_ratio, "", closed_open(0, 1), false,
       "of the mesh's contact oscillator (its two gears on their own)"},
      {"damping",
       &M::damping,
       "",
       {},
       false,
       "where the mesh's damper acts: in contact only (the paper), or at all times (Kahraman "
       "and Singh), as mesh.damping",
       "contact always"},
      {"tension",
       &M::tension,
       "",
       {},
       false,
       "whether the contact force k (d - e -+ b) + c (d' - e') may pull (the paper), or is held "
       "at 0 where it would (\"clip\"), as mesh.tension; unused with damping = \"always\"",
       "allow clip"},
      {"position_angle_deg", &M::position_angle_deg, "deg", closed(-360, 360), false,
       "where the driven gear's centre lies seen from the driving gear's, counterclockwise "
       "from x (the reference turns counterclockwise): the line of action's direction, read "
       "when a gear of the mesh is planar or eccentric, and where its teeth meet with "
       "train.mesh_phase = \"layout\""},
      {"thrust",
       &M::thrust,
       "",
       {},
       false,
       "where the drive flank pushes the driven gear along the axes (the helix hands and "
       "senses of rotation set it), read when a gear of a helical mesh is spatial",
       "+z -z"},
  };
  return keys;
}

const std::vector<ElementKey<TrainShaftData>>& shaft_keys() {
  using S = TrainShaftData;
  static const std::vector<ElementKey<S>> keys = {
      {"name", &S::name, "", {}, false, "the shaft's name"},
      {"from", &S::from, "", {}, true, "one body it joins"},
      {"to",
       &S::to,
       "",
       {},
       true,
       "the other, or \"ground\": a torsional support holding the body at rest (a ring gear "
       "in its housing), about which it vibrates"},
      {"stiffness_n_m_per_rad", &S::stiffness_n_m_per_rad, "N m/rad", above(0), true,
       "torsional stiffness"},
      {"damping_ratio", &S::damping_ratio, "", closed_open(0, 1), false,
       "against the reduced inertia of the two bodies (the body's own, to the ground): the "
       "shaft and its two bodies on their own"},
      {"mode_damping_ratio", &S::mode_damping_ratio, "", closed_open(0, 1), false,
       "instead: the damping ratio the shaft alone gives the train's mode whose strain energy "
       "it holds most of (a drivetrain's first mode), at the mean mesh stiffnesses"},
      {"damping_n_m_s_per_rad", &S::damping_n_m_s_per_rad, "N m s/rad", at_least(0), false,
       "instead: the damping coefficient on the twist's rate"},
  };
  return keys;
}

const std::vector<ElementKey<TrainBearingData>>& bearing_keys() {
  using G = TrainBearingData;
  static const std::vector<ElementKey<G>> keys = {
      {"name", &G::name, "", {}, false, "the bearing's name"},
      {"body", &G::body, "", {}, true, "the planar body it carries"},
      {"stiffness_n_per_m", &G::stiffness_n_per_m, "N/m", above(0), true,
       "radial stiffness, the same in x and y"},
      {"damping_ratio", &G::damping_ratio, "", closed_open(0, 1), false, "against the body's mass"},
      {"on",
       &G::on,
       "",
       {},
       false,
       "the body whose pin carries it (a planet's carrier, whose frame its meshes turn in); "
       "absent: the ground"},
      {"pin_radius_mm", &G::pin_radius_mm, "mm", at_least(0), false,
       "where the pin is on that body: its distance from the body's centre; absent (or 0): the "
       "centre distance of the carried gear's mesh with its sun or ring, from their teeth, "
       "module and profile shifts (a radius more than 0.1 % off it is warned of)"},
      {"pin_angle_deg", &G::pin_angle_deg, "deg", closed(-360, 360), false,
       "and its direction, counterclockwise from x (on the ground: the direction its errors "
       "are read in)"},
      {"pin_error_radial_um",
       &G::pin_error_radial_um,
       "um",
       {},
       false,
       "the seat's position error along the pin's direction (a planet pin's radial error)"},
      {"pin_error_tangential_um",
       &G::pin_error_tangential_um,
       "um",
       {},
       false,
       "and across it, counterclockwise (a planet pin's tangential error)"},
      {"clearance_um", &G::clearance_um, "um", at_least(0), false,
       "radial clearance: the bearing acts in x and in y each as a dead zone, nothing within "
       "+-clearance, its damping in contact only (0: none)"},
      {"axial_stiffness_n_per_m", &G::axial_stiffness_n_per_m, "N/m", at_least(0), false,
       "along the axis, of an axial or spatial body's bearing (on the ground), damped by "
       "damping_ratio against the body's mass"},
      {"tilt_stiffness_n_m_per_rad", &G::tilt_stiffness_n_m_per_rad, "N m/rad", at_least(0), false,
       "about each diameter, of a spatial body's bearing, damped by damping_ratio against its "
       "tilt inertia"},
  };
  return keys;
}

const std::vector<ElementKey<TrainTorqueData>>& torque_keys() {
  using T = TrainTorqueData;
  static const std::vector<ElementKey<T>> keys = {
      {"name", &T::name, "", {}, false, "the torque's name"},
      {"body", &T::body, "", {}, true, "the body it acts on"},
      {"mean_nm",
       &T::mean_nm,
       "N m",
       {},
       false,
       "mean torque: > 0 along the body's rotation (a drive), < 0 against it (a load)"},
      {"balances",
       &T::balances,
       "",
       {},
       false,
       "true: its mean is the reaction that balances every other mean torque and drag at the "
       "train's speeds (computed and reported; mean_nm unread), as a generator's or a brake's"},
      {"power_kw",
       &T::power_kw,
       "kW",
       {},
       false,
       "instead of mean_nm: the mean power it delivers, > 0 a drive, < 0 a load; its mean torque "
       "is P / (2 pi n) at its body's absolute speed n (computed and reported)"},
      {"harmonics", &T::harmonics, "N m", at_least(0), false,
       "[[amplitude, order, phase_deg], ...] at orders of the body's own speed"},
  };
  return keys;
}

const std::vector<ElementKey<TrainSpeedData>>& speed_keys() {
  using V = TrainSpeedData;
  static const std::vector<ElementKey<V>> keys = {
      {"name", &V::name, "", {}, false, "the prescription's name"},
      {"body", &V::body, "", {}, true, "the body whose speed is prescribed"},
      {"acceleration_harmonics", &V::acceleration_harmonics, "rad/s^2", at_least(0), false,
       "[[amplitude, order, phase_deg], ...]: its angular acceleration about the nominal speed, "
       "at orders of its own speed (an engine's firing orders)"},
  };
  return keys;
}

const std::vector<ElementKey<TrainPlanetaryData>>& planetary_keys() {
  using P = TrainPlanetaryData;
  static const std::vector<ElementKey<P>> keys = {
      {"name", &P::name, "", {}, false, "the set's name in messages"},
      {"sun_teeth", &P::sun_teeth, "", closed(1, 10000), true, "the sun's teeth"},
      {"planet_teeth", &P::planet_teeth, "", closed(1, 10000), true, "each planet's teeth"},
      {"ring_teeth", &P::ring_teeth, "", closed(0, 10000), false,
       "the ring's teeth; absent (or 0): sun_teeth + 2 planet_teeth"},
      {"normal_module_mm", &P::normal_module_mm, "mm", closed(0, 100), true,
       "normal module m_n of the three gears"},
      {"normal_pressure_angle_deg", &P::normal_pressure_angle_deg, "deg", open(0, 45), false,
       "normal pressure angle alpha_n"},
      {"helix_angle_deg", &P::helix_angle_deg, "deg", closed_open(0, 60), false,
       "helix angle beta (0: spur)"},
      {"face_width_mm", &P::face_width_mm, "mm", at_least(0), false,
       "face width of the three gears: their blanks' inertias when not given, ISO 6336-1's "
       "stiffness"},
      {"sun_profile_shift", &P::sun_profile_shift, "", closed(-1.5, 1.5), false,
       "the sun's profile shift coefficient x"},
      {"planet_profile_shift", &P::planet_profile_shift, "", closed(-1.5, 1.5), false,
       "each planet's"},
      {"ring_profile_shift", &P::ring_profile_shift, "", closed(-1.5, 1.5), false,
       "the ring's, in ISO 21771's sign (positive thickens its teeth)"},
      {"input",
       &P::input,
       "",
       {},
       false,
       "the member that drives: \"sun\" (the sun pushes the planets, which push the ring), "
       "\"carrier\" or \"ring\" (the ring pushes the planets, which push the sun)",
       "sun carrier ring"},
      {"held",
       &P::held,
       "",
       {},
       false,
       "the member held in the housing by a shaft <held>_support to the ground, or \"none\"",
       "ring carrier sun none"},
      {"support_n_m_per_rad", &P::support_n_m_per_rad, "N m/rad", at_least(0), false,
       "that shaft's torsional stiffness (required unless held = \"none\")"},
      {"sun_inertia_kg_m2", &P::sun_inertia_kg_m2, "kg m^2", above(0), false,
       "absent: its blank's, a cylinder of the reference diameter and face width"},
      {"sun_mass_kg", &P::sun_mass_kg, "kg", above(0), false, "absent: its blank's"},
      {"planet_inertia_kg_m2", &P::planet_inertia_kg_m2, "kg m^2", above(0), false,
       "absent: its blank's"},
      {"planet_mass_kg", &P::planet_mass_kg, "kg", above(0), false, "absent: its blank's"},
      {"ring_inertia_kg_m2", &P::ring_inertia_kg_m2, "kg m^2", above(0), true,
       "the ring's (a ring's blank is no solid cylinder)"},
      {"ring_mass_kg", &P::ring_mass_kg, "kg", above(0), true, "the ring's"},
      {"carrier_inertia_kg_m2", &P::carrier_inertia_kg_m2, "kg m^2", above(0), true,
       "the carrier's, its pins and what turns with it"},
      {"carrier_mass_kg", &P::carrier_mass_kg, "kg", above(0), true, "the carrier's"},
      {"mesh_stiffness_n_per_m", &P::mesh_stiffness_n_per_m, "N/m", above(0), false,
       "both meshes' k_m; absent: ISO 6336-1's c_gamma_alpha b from the gears at the static "
       "load (stiffness_source = \"iso6336\")"},
      {"mesh_stiffness_harmonics", &P::mesh_stiffness_harmonics, "", closed_open(0, 1), false,
       "[[ratio k_i/k_m, phase_deg], ...] of both meshes at i times the mesh frequency"},
      {"backlash_um", &P::backlash_um, "um", above(1e-3), false,
       "both meshes' b; absent: a mesh's default"},
      {"mesh_damping_ratio", &P::mesh_damping_ratio, "", closed_open(0, 1), false,
       "both meshes' damping_ratio; absent: a mesh's default"},
      {"bearing_stiffness_n_per_m", &P::bearing_stiffness_n_per_m, "N/m", above(0), true,
       "the sun's, the ring's and the carrier's bearings on the ground, in x and y"},
      {"pin_stiffness_n_per_m", &P::pin_stiffness_n_per_m, "N/m", above(0), false,
       "each planet's bearing on its pin; absent: bearing_stiffness_n_per_m"},
  };
  return keys;
}

// One row per kind of element, in the case file's order: its name (train.<name>[]), its key
// table, its list in the train, whether a study sets its numbers by index (a planetary preset's
// are set through its text, read again), and the keys its TOML leaves out of an element (a key
// whose default another key of the element replaces). The reader, the writer, the key tables of
// the docs, --set and the sweepable keys iterate these rows (for_each_kind).
template <class E>
struct ElementKind {
  std::string_view name;
  const std::vector<ElementKey<E>>& (*keys)();
  std::vector<E> TrainCase::*list;
  bool set_by_index = true;
  bool (*left_out)(const E&, std::string_view leaf) = nullptr;
};

// A shaft damped by its mode's ratio or a coefficient has no damping_ratio (the reader refuses
// two ways of damping one shaft).
bool shaft_left_out(const TrainShaftData& s, std::string_view leaf) {
  return leaf == "damping_ratio" && (s.mode_damping_ratio || s.damping_n_m_s_per_rad);
}
// A torque whose mean is a power's or a reaction's has no mean_nm written.
bool torque_left_out(const TrainTorqueData& q, std::string_view leaf) {
  return leaf == "mean_nm" && (q.power_kw || q.balances);
}

const auto& element_kinds() {
  static const auto kinds = std::tuple{
      ElementKind<TrainBodyData>{"body", body_keys, &TrainCase::bodies},
      ElementKind<TrainMeshData>{"mesh", mesh_keys, &TrainCase::meshes},
      ElementKind<TrainShaftData>{"shaft", shaft_keys, &TrainCase::shafts, true, shaft_left_out},
      ElementKind<TrainBearingData>{"bearing", bearing_keys, &TrainCase::bearings},
      ElementKind<TrainTorqueData>{"torque", torque_keys, &TrainCase::torques, true,
                                   torque_left_out},
      ElementKind<TrainDragData>{"drag", drag_keys, &TrainCase::drags},
      ElementKind<TrainSpeedData>{"speed", speed_keys, &TrainCase::speeds},
      ElementKind<TrainDamperData>{"damper", damper_keys, &TrainCase::dampers},
      ElementKind<TrainPlanetaryData>{"planetary", planetary_keys, &TrainCase::planetaries, false}};
  return kinds;
}

// f(row) for every row of element_kinds(), in order.
template <class F>
void for_each_kind(F&& f) {
  std::apply([&](const auto&... kind) { (f(kind), ...); }, element_kinds());
}

// Each enumeration's words in the case file, in its order.
constexpr std::array<std::string_view, 6> kBodyDofWords = {"torsion", "planar", "axial",
                                                           "spatial", "line",   "line_axial"};
constexpr std::array<std::string_view, 2> kMeshKindWords = {"external", "internal"};
std::vector<std::string_view> words_of_enum(BodyDof /*tag*/) {
  return {kBodyDofWords.begin(), kBodyDofWords.end()};
}
std::vector<std::string_view> words_of_enum(MeshKind /*tag*/) {
  return {kMeshKindWords.begin(), kMeshKindWords.end()};
}

// The words of a key's choices, "torsion planar".
std::vector<std::string_view> words_of(std::string_view text) {
  std::vector<std::string_view> out;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t end = std::min(text.find(' ', at), text.size());
    out.push_back(text.substr(at, end - at));
    at = end + 1;
  }
  return out;
}

// What a key takes: "a number > 0 N/m", "an array of [amplitude, order, phase_deg], ...".
template <class E>
std::string allowed(const ElementKey<E>& key) {
  return std::visit(
      [&](auto member) -> std::string {
        using T = std::remove_reference_t<decltype(std::declval<E&>().*member)>;
        const std::string unit = key.unit.empty() ? "" : fmt::format(" {}", key.unit);
        const std::string bound = key.range.text(std::is_same_v<T, int>);
        if constexpr (std::is_same_v<T, std::string> || std::is_enum_v<T>) {
          if (std::is_enum_v<T> || !key.choices.empty()) {
            // "a" or "b"; "a", "b" or "c".
            std::vector<std::string_view> all;
            if constexpr (std::is_enum_v<T>)
              all = words_of_enum(T{});
            else
              all = words_of(key.choices);
            std::string words;
            for (std::size_t i = 0; i < all.size(); ++i)
              words += fmt::format("{}\"{}\"",
                                   i == 0                ? ""
                                   : i + 1 == all.size() ? " or "
                                                         : ", ",
                                   all[i]);
            return words;
          }
          return key.file ? "a file's path in quotes" : "a name in quotes";
        } else if constexpr (std::is_same_v<T, bool>) {
          return "true or false";
        } else if constexpr (std::is_same_v<T, int>) {
          return fmt::format("a whole number {}", bound);
        } else if constexpr (std::is_same_v<T, std::vector<OrderHarmonic>>) {
          return fmt::format("an array of [amplitude, order, phase_deg], amplitude {}{}, order > 0",
                             bound, unit);
        } else if constexpr (std::is_same_v<T, std::vector<StiffnessHarmonic>> ||
                             std::is_same_v<T, std::vector<ErrorHarmonic>>) {
          return fmt::format("an array of [value, phase_deg], value {}{}", bound, unit);
        } else {
          return bound.empty() ? "a number" : fmt::format("a number {}{}", bound, unit);
        }
      },
      key.field);
}

// Reads one table of an element kind with its keys; names the key as train.<kind>[i].<key>.
class ElementReader {
 public:
  ElementReader(std::string source, std::string prefix, const toml::table& t,
                const std::vector<Override>& overrides)
      : source_(std::move(source)), prefix_(std::move(prefix)), table_(t), overrides_(overrides) {}

  template <class E>
  E read(const std::vector<ElementKey<E>>& keys) {
    E e;
    for (auto&& [k, node] : table_) {
      bool known = false;
      for (const ElementKey<E>& key : keys) known = known || key.leaf == k.str();
      if (!known) {
        std::string allowed;
        std::vector<std::string> leaves;
        for (const ElementKey<E>& key : keys) {
          allowed += fmt::format("{}{}", allowed.empty() ? "" : ", ", key.leaf);
          leaves.emplace_back(key.leaf);
        }
        throw InputError(fmt::format("{}: unknown key '{}.{}'{}; allowed: {}",
                                     origin(fmt::format("{}.{}", prefix_, k.str()), k.source()),
                                     prefix_, k.str(), did_you_mean(k.str(), leaves), allowed));
      }
    }
    for (const ElementKey<E>& key : keys) {
      const toml::node* n = table_.get(key.leaf);
      if (!n) {
        if (key.required)
          throw InputError(fmt::format("{}: {} has no {}: it must be given ({})",
                                       origin(prefix_, table_.source()), prefix_, key.leaf,
                                       allowed(key)));
        continue;
      }
      std::visit([&](auto member) { set(*n, key, e.*member); }, key.field);
    }
    return e;
  }

 private:
  template <class E>
  [[noreturn]] void fail(const toml::node& n, const ElementKey<E>& key) const {
    throw InputError(fmt::format("{}: {}.{} = {}: must be {}",
                                 origin(fmt::format("{}.{}", prefix_, key.leaf), n.source()),
                                 prefix_, key.leaf, node_text(n), allowed(key)));
  }

  template <class E>
  double number(const toml::node& n, const ElementKey<E>& key, const Range& range) const {
    if (!n.is_number()) fail(n, key);
    const double v = *n.value<double>();
    if (!range.contains(v)) fail(n, key);
    return v;
  }

  template <class E>
  void set(const toml::node& n, const ElementKey<E>& key, std::string& out) const {
    if (!n.is_string() || n.value<std::string>()->empty()) fail(n, key);
    out = *n.value<std::string>();
    if (!key.choices.empty()) {
      const std::vector<std::string_view> words = words_of(key.choices);
      if (std::find(words.begin(), words.end(), out) == words.end()) fail(n, key);
    }
  }
  // An enumeration: one of its words, read into its value once, here.
  template <class E, class T>
  requires std::is_enum_v<T>
  void set(const toml::node& n, const ElementKey<E>& key, T& out) const {
    if (!n.is_string()) fail(n, key);
    const std::vector<std::string_view> words = words_of_enum(T{});
    const auto at = std::find(words.begin(), words.end(), *n.value<std::string>());
    if (at == words.end()) fail(n, key);
    out = static_cast<T>(at - words.begin());
  }
  template <class E>
  void set(const toml::node& n, const ElementKey<E>& key, double& out) const {
    out = number(n, key, key.range);
  }
  template <class E>
  void set(const toml::node& n, const ElementKey<E>& key, std::optional<double>& out) const {
    out = number(n, key, key.range);
  }
  template <class E>
  void set(const toml::node& n, const ElementKey<E>& key, bool& out) const {
    if (!n.is_boolean()) fail(n, key);
    out = *n.value<bool>();
  }
  template <class E>
  void set(const toml::node& n, const ElementKey<E>& key, int& out) const {
    if (!n.is_integer()) fail(n, key);
    const double v = static_cast<double>(*n.value<std::int64_t>());
    if (!key.range.contains(v)) fail(n, key);
    out = static_cast<int>(v);
  }
  // Arrays of harmonics: [[a, phase], ...] or [[a, order, phase], ...].
  template <class E, class H>
  void set(const toml::node& n, const ElementKey<E>& key, std::vector<H>& out) const {
    constexpr std::size_t kWidth = std::is_same_v<H, OrderHarmonic> ? 3 : 2;
    const toml::array* a = n.as_array();
    if (!a || a->size() > static_cast<std::size_t>(kMaxErrorHarmonics)) fail(n, key);
    out.clear();
    for (const toml::node& term : *a) {
      const toml::array* t = term.as_array();
      if (!t || t->size() != kWidth) fail(n, key);
      for (const toml::node& x : *t)
        if (!x.is_number() || !std::isfinite(*x.value<double>())) fail(n, key);
      const double v0 = *(*t)[0].value<double>();
      if (!key.range.contains(v0)) fail(n, key);
      if constexpr (kWidth == 3) {
        const double order = *(*t)[1].value<double>();
        if (!(order > 0)) fail(n, key);
        out.push_back({v0, order, *(*t)[2].value<double>()});
      } else {
        out.push_back({v0, *(*t)[1].value<double>()});
      }
    }
  }

  std::string origin(const std::string& dotted, const toml::source_region& src) const {
    return origin_of(overrides_, dotted, src, source_);
  }

  std::string source_, prefix_;
  const toml::table& table_;
  const std::vector<Override>& overrides_;
};

// Each array of element tables, read with its keys; a default name when none is given.
template <class E>
void read_array(const toml::table& train, const std::string& source,
                const std::vector<Override>& overrides, std::string_view kind,
                const std::vector<ElementKey<E>>& keys, std::vector<E>& out,
                std::map<std::string, std::string>& origins) {
  const toml::node* n = train.get(kind);
  if (!n) return;
  const toml::array* a = n->as_array();
  // An empty array is none of the elements (Python's `mesh=[]` writes one), not a wrong type.
  if (!a || (!a->empty() && !a->is_array_of_tables()))
    throw InputError(fmt::format("{}: train.{} = {}: must be tables [[train.{}]], one per {}",
                                 where(n->source(), source), kind, node_text(*n), kind, kind));
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::table& t = *(*a)[i].as_table();
    const std::string prefix = fmt::format("train.{}[{}]", kind, i);
    ElementReader r(source, prefix, t, overrides);
    E e = r.read(keys);
    if (e.name.empty()) e.name = fmt::format("{}{}", kind, i + 1);
    const std::string label = fmt::format("{} '{}'", kind, e.name);
    origins[label] = origin_of(overrides, prefix, t.source(), source);
    // Each key where it was written (key_origin): a --set of another key of the element moves
    // the element's origin, not this one's.
    for (auto&& [k, node] : t)
      origins[fmt::format("{}: {}", label, k.str())] =
          origin_of(overrides, fmt::format("{}.{}", prefix, k.str()), node.source(), source);
    out.push_back(std::move(e));
  }
}

// The keys of [train] itself; its elements' arrays follow, one per kind (element_kinds()).
constexpr std::array<std::string_view, 8> kTrainOwnKeys = {
    "reference", "reference_speed_hz", "mesh_phase",          "frame_terms", "planet",
    "planets",   "planet_angles_deg",  "planet_pin_errors_um"};
// At most this many planets: sets are built with 3 to 7, and the regions of 2 N meshes grow
// as 3^(2 N).
constexpr int kMaxPlanets = 12;

}  // namespace

TrainCase read_train_case(const toml::node& node, const std::string& source,
                          const std::vector<Override>& overrides) {
  const toml::table* train = node.as_table();
  if (!train)
    throw InputError(fmt::format("{}: train = {}: must be a table [train]",
                                 where(node.source(), source), node_text(node)));
  TrainCase t;
  std::vector<std::string_view> keys(kTrainOwnKeys.begin(), kTrainOwnKeys.end());
  for_each_kind([&](const auto& kind) { keys.push_back(kind.name); });
  const std::set<std::string_view> known(keys.begin(), keys.end());
  for (auto&& [k, v] : *train) {
    if (!known.count(k.str()))
      throw InputError(fmt::format(
          "{}: unknown key 'train.{}'{}; allowed in [train]: {}", where(k.source(), source),
          k.str(), did_you_mean(k.str(), {known.begin(), known.end()}), fmt::join(keys, ", ")));
  }
  // A body's name given in [train] (its reference, its planet), with where it was given.
  const auto body_name = [&](std::string_view leaf, std::string& out) {
    const toml::node* p = train->get(leaf);
    if (!p) return;
    const std::string where_given =
        origin_of(overrides, fmt::format("train.{}", leaf), p->source(), source);
    if (!p->is_string() || p->value<std::string>()->empty())
      throw InputError(fmt::format("{}: train.{} = {}: must be a body's name in quotes",
                                   where_given, leaf, node_text(*p)));
    out = *p->value<std::string>();
    t.origins[fmt::format("the train: {}", leaf)] = where_given;
  };
  body_name("reference", t.reference);
  if (const toml::node* p = train->get("mesh_phase")) {
    const std::string where_given = origin_of(overrides, "train.mesh_phase", p->source(), source);
    if (!p->is_string() ||
        (*p->value<std::string>() != "given" && *p->value<std::string>() != "layout"))
      throw InputError(fmt::format("{}: train.mesh_phase = {}: must be \"given\" or \"layout\"",
                                   where_given, node_text(*p)));
    t.mesh_phase = *p->value<std::string>();
    t.origins["the train: mesh_phase"] = where_given;
  }
  if (const toml::node* p = train->get("frame_terms")) {
    const std::string where_given = origin_of(overrides, "train.frame_terms", p->source(), source);
    if (!p->is_boolean())
      throw InputError(fmt::format("{}: train.frame_terms = {}: must be true or false", where_given,
                                   node_text(*p)));
    t.frame_terms = *p->value<bool>();
    t.origins["the train: frame_terms"] = where_given;
  }
  body_name("planet", t.planet);
  if (const toml::node* p = train->get("planets")) {
    const std::string where_given = origin_of(overrides, "train.planets", p->source(), source);
    if (!p->is_integer() || *p->value<std::int64_t>() < 1 ||
        *p->value<std::int64_t>() > kMaxPlanets)
      throw InputError(fmt::format("{}: train.planets = {}: must be a whole number from 1 to {}",
                                   where_given, node_text(*p), kMaxPlanets));
    t.planets = static_cast<int>(*p->value<std::int64_t>());
    t.origins["the train: planets"] = where_given;
  }
  if (const toml::node* p = train->get("planet_angles_deg")) {
    const std::string where_given =
        origin_of(overrides, "train.planet_angles_deg", p->source(), source);
    const toml::array* angles = p->as_array();
    const auto bad_angles = [&] {
      return InputError(fmt::format(
          "{}: train.planet_angles_deg = {}: must be an array of angles in deg, each in "
          "[-360, 360]",
          where_given, node_text(*p)));
    };
    if (!angles) throw bad_angles();
    for (const toml::node& a : *angles) {
      if (!a.is_number() || !(std::abs(*a.value<double>()) <= 360)) throw bad_angles();
      t.planet_angles_deg.push_back(*a.value<double>());
    }
    t.origins["the train: planet_angles_deg"] = where_given;
  }
  if (const toml::node* p = train->get("planet_pin_errors_um")) {
    const std::string where_given =
        origin_of(overrides, "train.planet_pin_errors_um", p->source(), source);
    const auto bad_errors = [&] {
      return InputError(fmt::format(
          "{}: train.planet_pin_errors_um = {}: must be an array of [radial, tangential] pairs "
          "in um, one per planet",
          where_given, node_text(*p)));
    };
    const toml::array* pairs = p->as_array();
    if (!pairs) throw bad_errors();
    for (const toml::node& pair : *pairs) {
      const toml::array* e = pair.as_array();
      if (!e || e->size() != 2 || !(*e)[0].is_number() || !(*e)[1].is_number() ||
          !std::isfinite(*(*e)[0].value<double>()) || !std::isfinite(*(*e)[1].value<double>()))
        throw bad_errors();
      t.planet_pin_errors_um.push_back({*(*e)[0].value<double>(), *(*e)[1].value<double>()});
    }
    t.origins["the train: planet_pin_errors_um"] = where_given;
  }
  const toml::node* f = train->get("reference_speed_hz");
  if (!f)
    throw InputError(fmt::format(
        "{}: [train] has no reference_speed_hz: the rotation frequency of train.reference (the "
        "first body when absent) must be given, a number > 0 Hz",
        where(train->source(), source)));
  if (!f->is_number() || !(*f->value<double>() > 0) || !std::isfinite(*f->value<double>()))
    throw InputError(fmt::format(
        "{}: train.reference_speed_hz = {}: must be a number > 0 Hz",
        origin_of(overrides, "train.reference_speed_hz", f->source(), source), node_text(*f)));
  t.reference_speed_hz = *f->value<double>();
  t.origins["the train: reference_speed_hz"] =
      origin_of(overrides, "train.reference_speed_hz", f->source(), source);
  for_each_kind([&](const auto& kind) {
    read_array(*train, source, overrides, kind.name, kind.keys(), t.*kind.list, t.origins);
  });
  add_planetary_elements(t);
  if (t.reference.empty() && !t.bodies.empty()) t.reference = t.bodies.front().name;
  t.origins["the train"] = where(train->source(), source);
  return t;
}

namespace {

// The message of the assembler (which names the element first: "mesh 'stage2': ...") with
// where that element was written.
[[noreturn]] void rethrow_with_origin(const TrainCase& t, const std::string& message) {
  // The longest label the message starts with: "the train: reference" (where the reference was
  // given) before "the train" (the [train] table); an element's key ("mesh 'm': driven") when
  // the message gives its value ("mesh 'm': driven = \"c\": ..."), not when it goes on in
  // words ("bearing 'pin1': body 'sun' carries ...").
  std::string where_given, matched;
  for (const auto& [label, origin] : t.origins) {
    if (message.rfind(label, 0) != 0 || label.size() <= matched.size()) continue;
    const bool of_key = label.find("': ") != std::string::npos;
    const std::string_view rest = std::string_view(message).substr(label.size());
    if (of_key ? rest.rfind(" =", 0) == 0
               : rest.empty() || rest.front() == ':' || rest.front() == ' ') {
      where_given = origin;
      matched = label;
    }
  }
  // "train: mesh 'm': ...", but "the train: ..." as it is (not "train: the train: ...").
  const std::string said =
      message.rfind("the train", 0) == 0 ? message : fmt::format("train: {}", message);
  throw InputError(where_given.empty() ? said : fmt::format("{}: {}", where_given, said));
}

struct GearGeometry {
  double base_radius_m = 0, base_helix_rad = 0, inertia_kg_m2 = 0, mass_kg = 0,
         tilt_inertia_kg_m2 = 0;
};

// A body whose centre moves in the plane: planar, axial or spatial, or held to its line.
bool keeps_plane(const TrainBodyData& b) { return b.dof != BodyDof::kTorsion; }

// A body that moves along its axis: axial (or line_axial), or spatial (which tilts too).
bool keeps_axis(const TrainBodyData& b) {
  return b.dof == BodyDof::kAxial || b.dof == BodyDof::kSpatial || b.dof == BodyDof::kLineAxial;
}

// A body's base radius, base helix angle and inertia (docs/model.md, "Geometry", as the gear
// pair's).
GearGeometry body_geometry(const TrainCase& t, const TrainBodyData& b) {
  GearGeometry g;
  const std::string label = fmt::format("body '{}'", b.name);
  if (b.teeth > 0 && !(b.normal_module_mm > 0))
    rethrow_with_origin(
        t, fmt::format("{}: teeth = {} needs normal_module_mm > 0 (a gear's)", label, b.teeth));
  const double beta = b.helix_angle_deg * kDegToRad;
  const double alpha_t =
      std::atan(std::tan(b.normal_pressure_angle_deg * kDegToRad) / std::cos(beta));
  const double d = b.teeth * b.normal_module_mm * kMmToM / std::cos(beta);  // reference
  g.base_radius_m = 0.5 * d * std::cos(alpha_t);
  g.base_helix_rad = std::atan(std::tan(beta) * std::cos(alpha_t));
  // The blank, a cylinder of the reference diameter: for what is not given.
  const bool planar = keeps_plane(b), spatial = b.dof == BodyDof::kSpatial;
  if (!b.inertia_kg_m2 || (planar && !b.mass_kg) || (spatial && !b.tilt_inertia_kg_m2)) {
    const double di = b.bore_diameter_mm * kMmToM;
    if (!(b.teeth > 0 && b.face_width_mm > 0))
      rethrow_with_origin(
          t, fmt::format("{}: has no {}; give it, or teeth, normal_module_mm and face_width_mm "
                         "for a gear's",
                         label,
                         !b.inertia_kg_m2       ? "inertia_kg_m2"
                         : planar && !b.mass_kg ? "mass_kg"
                                                : "tilt_inertia_kg_m2"));
    if (!(di < d))
      rethrow_with_origin(
          t, fmt::format("{}: bore_diameter_mm = {} must be below the reference diameter {:.6g} "
                         "mm{}",
                         label, b.bore_diameter_mm, d / kMmToM,
                         b.normal_module_mm < kFinestModuleMm
                             ? fmt::format(" (its normal_module_mm = {} is finer than any gear "
                                           "is cut with: a module is in millimetres; was it "
                                           "written in metres?)",
                                           b.normal_module_mm)
                             : std::string()));
    // In this order: bit for bit the inertia a train has always had (a rattle depends on it).
    g.inertia_kg_m2 =
        b.density_kg_m3 * kPi * b.face_width_mm * kMmToM * (std::pow(d, 4) - std::pow(di, 4)) / 32;
    g.mass_kg = b.density_kg_m3 * kPi * b.face_width_mm * kMmToM * (d * d - di * di) / 4;
  }
  if (b.inertia_kg_m2) g.inertia_kg_m2 = *b.inertia_kg_m2;
  if (b.mass_kg) g.mass_kg = *b.mass_kg;
  // About a diameter, the cylinder's of the body's mass (the coupled pair's blank).
  const double di = b.bore_diameter_mm * kMmToM, w = b.face_width_mm * kMmToM;
  g.tilt_inertia_kg_m2 = b.tilt_inertia_kg_m2
                             ? *b.tilt_inertia_kg_m2
                             : g.mass_kg * (3 * (d * d + di * di) / 4 + w * w) / 12;
  return g;
}

}  // namespace

ShiftedCenterDistance mesh_center_distance_from_gears(const TrainMeshData& m,
                                                      const TrainBodyData& a,
                                                      const TrainBodyData& b) {
  const bool internal = m.kind == MeshKind::kInternal;
  const TrainBodyData& first = internal && a.teeth > b.teeth ? b : a;
  const TrainBodyData& second = &first == &a ? b : a;
  return shifted_center_distance(internal, first.teeth, second.teeth, first.profile_shift,
                                 second.profile_shift, first.normal_module_mm,
                                 first.normal_pressure_angle_deg * kDegToRad,
                                 first.helix_angle_deg * kDegToRad);
}

std::optional<double> pin_radius_from_gears_mm(const TrainCase& t, const TrainBearingData& b) {
  if (b.on.empty()) return std::nullopt;
  const auto find = [&](const std::string& name) -> const TrainBodyData* {
    for (const TrainBodyData& x : t.bodies)
      if (x.name == name) return &x;
    return nullptr;
  };
  const auto pinned = [&](const std::string& name) {
    return std::any_of(t.bearings.begin(), t.bearings.end(),
                       [&](const TrainBearingData& x) { return x.body == name && !x.on.empty(); });
  };
  for (const TrainMeshData& m : t.meshes) {
    const std::string other = m.driving == b.body  ? m.driven
                              : m.driven == b.body ? m.driving
                                                   : std::string();
    if (other.empty() || pinned(other)) continue;
    const TrainBodyData *x = find(b.body), *y = find(other);
    if (!x || !y || x->teeth <= 0 || y->teeth <= 0 || !(x->normal_module_mm > 0)) continue;
    try {
      return mesh_center_distance_from_gears(m, *x, *y).center_distance;
    } catch (const InputError&) {
      continue;  // the mesh's assembly says why
    }
  }
  return std::nullopt;
}

TrainCase expand_planets(const TrainCase& written) {
  if (written.planet.empty() && written.planets == 0 && written.planet_angles_deg.empty() &&
      written.planet_pin_errors_um.empty())
    return written;
  const TrainCase& w = written;
  if (w.planet.empty())
    rethrow_with_origin(w, fmt::format("the train: {}: planets need train.planet, the body "
                                       "written once for them all",
                                       w.planets                      ? "planets"
                                       : !w.planet_angles_deg.empty() ? "planet_angles_deg"
                                                                      : "planet_pin_errors_um"));
  if (w.planets == 0)
    rethrow_with_origin(w, fmt::format("the train: planet = \"{}\": give train.planets, how "
                                       "many copies of it the set has",
                                       w.planet));
  if (std::none_of(w.bodies.begin(), w.bodies.end(),
                   [&](const TrainBodyData& b) { return b.name == w.planet; }))
    rethrow_with_origin(w,
                        fmt::format("the train: planet = \"{}\": no body of that name", w.planet));
  if (!w.planet_angles_deg.empty() && static_cast<int>(w.planet_angles_deg.size()) != w.planets)
    rethrow_with_origin(
        w, fmt::format("the train: planet_angles_deg has {} angles for planets = {}: give one "
                       "per planet, or none for equal spacing",
                       w.planet_angles_deg.size(), w.planets));
  if (!w.planet_pin_errors_um.empty() &&
      static_cast<int>(w.planet_pin_errors_um.size()) != w.planets)
    rethrow_with_origin(
        w, fmt::format("the train: planet_pin_errors_um has {} pairs for planets = {}: give one "
                       "[radial, tangential] pair per planet",
                       w.planet_pin_errors_um.size(), w.planets));
  TrainCase t = w;
  const auto copy_name = [](const std::string& name, int n) {
    return fmt::format("{}{}", name, n + 1);
  };
  const auto angle = [&](int n) {
    return w.planet_angles_deg.empty() ? 360.0 * n / w.planets
                                       : w.planet_angles_deg[static_cast<std::size_t>(n)];
  };
  // Each element that names the planet: its copies in its place, renamed, with the origin of
  // the template; turn(x, n) makes x copy n (its angles, the bodies it joins), false for an
  // element that does not name the planet (kept as written).
  const auto expand = [&](const char* kind, auto& elements, auto turn) {
    using E = typename std::decay_t<decltype(elements)>::value_type;
    std::vector<E> out;
    for (const E& e : elements) {
      E first = e;
      if (!turn(first, 0)) {
        out.push_back(e);
        continue;
      }
      // The template's origin and its keys' ("mesh 'sp': backlash_um"), for each copy.
      const std::string label = fmt::format("{} '{}'", kind, e.name);
      std::vector<std::pair<std::string, std::string>> written;
      for (const auto& [l, origin] : t.origins)
        if (l == label || l.rfind(label + ": ", 0) == 0)
          written.emplace_back(l.substr(label.size()), origin);
      for (int n = 0; n < w.planets; ++n) {
        E x = e;
        turn(x, n);
        x.name = copy_name(e.name, n);
        for (const auto& [rest, origin] : written)
          t.origins[fmt::format("{} '{}'{}", kind, x.name, rest)] = origin;
        out.push_back(std::move(x));
      }
    }
    elements = std::move(out);
  };
  // Renames the planet among `fields` to its copy n; true when one of them was it.
  const auto rename = [&](int n, std::initializer_list<std::string*> fields) {
    bool named = false;
    for (std::string* f : fields)
      if (*f == w.planet) {
        *f = copy_name(w.planet, n);
        named = true;
      }
    return named;
  };
  expand("body", t.bodies, [&](TrainBodyData& b, int) { return b.name == w.planet; });
  expand("mesh", t.meshes, [&](TrainMeshData& m, int n) {
    if (!rename(n, {&m.driving, &m.driven})) return false;
    m.position_angle_deg += angle(n);
    return true;
  });
  expand("shaft", t.shafts, [&](TrainShaftData& x, int n) { return rename(n, {&x.from, &x.to}); });
  expand("bearing", t.bearings, [&](TrainBearingData& x, int n) {
    const bool carries = x.body == w.planet;
    if (!rename(n, {&x.body, &x.on})) return false;
    x.pin_angle_deg += angle(n);
    if (carries && !w.planet_pin_errors_um.empty()) {
      x.pin_error_radial_um += w.planet_pin_errors_um[static_cast<std::size_t>(n)][0];
      x.pin_error_tangential_um += w.planet_pin_errors_um[static_cast<std::size_t>(n)][1];
    }
    return true;
  });
  expand("torque", t.torques, [&](TrainTorqueData& x, int n) { return rename(n, {&x.body}); });
  expand("drag", t.drags, [&](TrainDragData& x, int n) { return rename(n, {&x.body}); });
  expand("speed", t.speeds, [&](TrainSpeedData& x, int n) { return rename(n, {&x.body}); });
  if (t.reference == w.planet) t.reference = copy_name(w.planet, 0);
  return t;
}

namespace {

// Gear b of mesh m as the mesh's stiffness reads it: an internal mesh's pinion with the tip its
// external mesh gives it (pinion_as_meshed).
TrainBodyData as_meshed(const TrainCase& t, const TrainMeshData& m, const TrainBodyData& b) {
  return m.kind == MeshKind::kInternal ? pinion_as_meshed(t, b) : b;
}

// ISO 6336-1's stiffness of the meshes whose stiffness_source is "iso6336" at the load each
// carries at the train's static state (static_state): the train at their full-load stiffness,
// then again at the loads found until they settle (at once where the train's statics do not
// depend on its stiffnesses; a planetary set's load sharing does), each mesh's damping kept at
// its ratio (c ~ sqrt(k_m)). Refused when the train has no static state or a mesh carries no
// load there.
void iso_meshes_at_their_load(const TrainCase& t, train::Train& out) {
  std::vector<std::size_t> iso;
  for (std::size_t i = 0; i < t.meshes.size(); ++i)
    if (t.meshes[i].stiffness_source == "iso6336") iso.push_back(i);
  if (iso.empty()) return;
  const auto body = [&](const std::string& name) {
    return *std::find_if(t.bodies.begin(), t.bodies.end(),
                         [&](const TrainBodyData& b) { return b.name == name; });
  };
  for (int pass = 0; pass < kIsoLoadPasses; ++pass) {
    std::optional<train::Assembled> a;
    try {
      a.emplace(out);
    } catch (const InputError& e) {
      rethrow_with_origin(t, e.what());
    }
    std::string why;
    const std::optional<Eigen::VectorXd> y = static_state(*a, &why);
    const TrainMeshData& first = t.meshes[iso.front()];
    if (!y)
      rethrow_with_origin(t, fmt::format("mesh '{}': stiffness_source = \"iso6336\": ISO 6336-1's "
                                         "stiffness is read at the mesh's static load, and the "
                                         "train has none: {}",
                                         first.name, why));
    const std::vector<double> force = static_mesh_forces_n(*a, *y);
    bool settled = true;
    for (const std::size_t i : iso) {
      const TrainMeshData& m = t.meshes[i];
      train::Mesh& x = out.meshes[i];
      if (!(force[i] > 0))
        rethrow_with_origin(
            t, fmt::format("mesh '{}': stiffness_source = \"iso6336\": the mesh carries {:.4g} N "
                           "at the train's static state; ISO 6336-1's stiffness needs a load "
                           "on its drive flank{}",
                           m.name, force[i],
                           force[i] < 0 ? " (it is loaded on its back flank: are its driving and "
                                          "driven gears the wrong way round? The driving gear's "
                                          "torque pushes the other)"
                                        : ""));
      // The normal force's torque on the driving gear: F cos(beta_b) r_b.
      const double torque = force[i] * std::cos(x.base_helix_angle_rad) * x.base_radius_driving_m;
      PairMeshStiffness k;
      try {
        k = iso_mesh_stiffness(m, as_meshed(t, m, body(m.driving)), as_meshed(t, m, body(m.driven)),
                               torque);
      } catch (const InputError& e) {
        rethrow_with_origin(
            t, fmt::format("mesh '{}': stiffness_source = \"iso6336\": {}", m.name, e.what()));
      }
      settled = settled && std::abs(k.mean_n_per_m - x.mean_stiffness_n_per_m) <=
                               kIsoLoadTolerance * k.mean_n_per_m;
      x.damping_n_s_per_m *= std::sqrt(k.mean_n_per_m / x.mean_stiffness_n_per_m);
      x.mean_stiffness_n_per_m = k.mean_n_per_m;
    }
    if (settled) return;
  }
  rethrow_with_origin(t, fmt::format("mesh '{}': stiffness_source = \"iso6336\": the meshes' "
                                     "stiffnesses and static loads did not settle in {} passes",
                                     t.meshes[iso.front()].name, kIsoLoadPasses));
}

}  // namespace

namespace {

// Each shaft with a mode_damping_ratio zeta: c = 2 zeta w / (v . phi)^2 on the mode phi (mass
// normalised, of angular frequency w) whose strain energy it holds most of, so that its own
// share of that mode's damping ratio, phi^T C phi / (2 w), is zeta. The modes are the train's at
// its mean mesh stiffnesses, every other damper as given.
void damp_shafts_by_their_modes(const TrainCase& t, train::Train& out) {
  std::vector<std::size_t> which;
  for (std::size_t k = 0; k < t.shafts.size(); ++k)
    if (t.shafts[k].mode_damping_ratio) which.push_back(k);
  if (which.empty()) return;
  try {
    const train::Assembled a(out);
    const std::vector<train::TrainMode> modes = train::modes(a);
    for (const std::size_t k : which) {
      const train::TrainMode* best = nullptr;
      for (const train::TrainMode& m : modes)
        if (m.frequency_hz > 0 && (!best || m.shaft_energy[k] > best->shaft_energy[k])) best = &m;
      const double s = best ? a.shaft_vector(static_cast<int>(k)).dot(best->shape) : 0.0;
      if (!best || !(best->shaft_energy[k] > 0) || s == 0)
        throw InputError(
            fmt::format("shaft '{}': mode_damping_ratio: no mode of the train "
                        "strains it; give damping_n_m_s_per_rad",
                        t.shafts[k].name));
      out.shafts[k].damping_n_m_s_per_rad =
          2 * *t.shafts[k].mode_damping_ratio * 2 * kPi * best->frequency_hz / (s * s);
    }
  } catch (const InputError& e) {
    rethrow_with_origin(t, e.what());
  }
}

}  // namespace

train::Train train_of(const Case& c) {
  if (c.model.form != ModelForm::kTrain || !c.train)
    throw InputError(
        fmt::format("model.form = \"{}\": this is no gear train (model.form = "
                    "\"train\" with its [train] elements)",
                    to_string(c.model.form)));
  const TrainCase t = expand_planets(*c.train);
  train::Train out;
  out.reference = t.reference;
  out.reference_speed_hz = t.reference_speed_hz;
  out.mesh_phase_from_layout = t.mesh_phase == "layout";
  out.frame_terms = t.frame_terms;
  std::map<std::string, GearGeometry> gears;
  std::map<std::string, const TrainBodyData*> bodies;
  for (const TrainBodyData& b : t.bodies) {
    const GearGeometry g = body_geometry(t, b);
    // A body named twice is the assembler's to name; the first of the name is read here.
    gears.emplace(b.name, g);
    bodies.emplace(b.name, &b);
    if (b.mass_kg && !keeps_plane(b))
      rethrow_with_origin(t, fmt::format("body '{}': mass_kg = {} is read only for a planar "
                                         "body (dof = \"planar\"); this one keeps torsion only",
                                         b.name, *b.mass_kg));
    if (b.tilt_inertia_kg_m2 && b.dof != BodyDof::kSpatial)
      rethrow_with_origin(t, fmt::format("body '{}': tilt_inertia_kg_m2 = {} is read only for a "
                                         "spatial body (dof = \"spatial\"); this one is {}",
                                         b.name, *b.tilt_inertia_kg_m2, to_string(b.dof)));
    out.bodies.push_back({b.name, g.inertia_kg_m2, keeps_plane(b), g.mass_kg,
                          b.eccentricity_um * kUmToM, b.eccentricity_angle_deg * kDegToRad,
                          keeps_axis(b), b.dof == BodyDof::kSpatial ? g.tilt_inertia_kg_m2 : 0.0,
                          b.dof == BodyDof::kSpatial,
                          b.dof == BodyDof::kLine || b.dof == BodyDof::kLineAxial});
  }
  // The elements of the kinds the assembler does not know, each as its own file makes it
  // (element()).
  for_each_kind([&](const auto& kind) {
    using E = typename std::remove_cvref_t<decltype(t.*kind.list)>::value_type;
    if constexpr (requires(const E& e) { e.element(); })
      for (const E& e : t.*kind.list) try {
          out.elements.push_back(e.element());
        } catch (const InputError& error) {
          rethrow_with_origin(t, error.what());
        }
  });
  for (const TrainMeshData& m : t.meshes) {
    train::Mesh x;
    x.name = m.name;
    x.driving = m.driving;
    x.driven = m.driven;
    const auto a = bodies.find(m.driving), b = bodies.find(m.driven);
    if (a != bodies.end() && b != bodies.end()) {
      // A mesh is between gears: teeth and radii (an unknown body is the assembler's to name).
      for (const auto* g : {a->second, b->second})
        if (g->teeth <= 0)
          rethrow_with_origin(t,
                              fmt::format("mesh '{}': {} = \"{}\" is no gear (give its teeth "
                                          "and normal_module_mm)",
                                          m.name, g == a->second ? "driving" : "driven", g->name));
      if (std::abs(a->second->helix_angle_deg - b->second->helix_angle_deg) > 1e-9 ||
          std::abs(a->second->normal_module_mm - b->second->normal_module_mm) > 1e-12 ||
          std::abs(a->second->normal_pressure_angle_deg - b->second->normal_pressure_angle_deg) >
              1e-9)
        rethrow_with_origin(
            t, fmt::format("mesh '{}': its gears '{}' and '{}' differ in normal_module_mm, "
                           "normal_pressure_angle_deg or helix_angle_deg; gears that mesh share "
                           "them",
                           m.name, m.driving, m.driven));
      x.teeth_driving = a->second->teeth;
      x.teeth_driven = b->second->teeth;
      x.base_radius_driving_m = gears[m.driving].base_radius_m;
      x.base_radius_driven_m = gears[m.driven].base_radius_m;
      x.internal = m.kind == MeshKind::kInternal;
      if (x.internal) {
        // The ring's blank is no solid cylinder of its reference diameter: its inertia is given.
        const TrainBodyData* ring = a->second->teeth > b->second->teeth ? a->second : b->second;
        if (!ring->inertia_kg_m2 || (keeps_plane(*ring) && !ring->mass_kg))
          rethrow_with_origin(
              t, fmt::format("body '{}': is the ring gear of internal mesh '{}': give its "
                             "inertia_kg_m2{} (a ring's blank is no solid cylinder)",
                             ring->name, m.name, keeps_plane(*ring) ? " and mass_kg" : ""));
      }
      x.base_helix_angle_rad = gears[m.driving].base_helix_rad;
      // The line of action at the working pressure angle of the gears' shifts; a planet's, at
      // the one of its pin's radius, cos(alpha_w) = (r_b,a +- r_b,b) / a, where that radius
      // differs from the shifts' centre distance by a drawing's rounding (kPinRadiusTolerance),
      // so that the carrier's lever and the teeth's agree and the set's torques balance as its
      // speeds say. (A pin further off is warned of, and its lines keep the shifts' angle.)
      ShiftedCenterDistance at{};
      try {
        at = mesh_center_distance_from_gears(m, *a->second, *b->second);
      } catch (const InputError& e) {
        std::string what = e.what();
        what.replace(0, std::string_view("gear.profile_shift").size(),
                     fmt::format("the profile_shift of '{}' and '{}'", m.driving, m.driven));
        rethrow_with_origin(t, fmt::format("mesh '{}': {}", m.name, what));
      }
      x.transverse_pressure_angle_rad = at.working_pressure_angle_rad;
      for (const TrainBearingData& pin : t.bearings) {
        if (pin.on.empty() || (pin.body != m.driving && pin.body != m.driven)) continue;
        const double radius_mm = pin.pin_radius_mm != 0
                                     ? pin.pin_radius_mm
                                     : pin_radius_from_gears_mm(t, pin).value_or(0);
        if (radius_mm == 0 || radius_mm == at.center_distance ||
            std::abs(radius_mm - at.center_distance) > kPinRadiusTolerance * at.center_distance)
          break;
        const double base_mm =
            (x.base_radius_driving_m + (x.internal ? -1.0 : 1.0) * x.base_radius_driven_m) / kMmToM;
        const double cos_w = std::abs(base_mm) / radius_mm;
        if (!(cos_w < 1))
          rethrow_with_origin(
              t, fmt::format("bearing '{}': pin_radius_mm = {}: its planet's mesh '{}' needs a "
                             "centre distance above {:.6g} mm, where its teeth's base circles "
                             "touch",
                             pin.name, radius_mm, m.name, std::abs(base_mm)));
        x.transverse_pressure_angle_rad = std::acos(cos_w);
        break;
      }
      x.position_angle_rad = m.position_angle_deg * kDegToRad;
      x.axial_sense = m.thrust == "-z" ? -1 : 1;
      // The damping of the mesh's own oscillator: its two gears, m_n = 1 / (V J^-1 V^T).
      const double cb = std::cos(x.base_helix_angle_rad);
      const double ra = cb * x.base_radius_driving_m, rb = cb * x.base_radius_driven_m;
      const double m_n = 1.0 / (ra * ra / gears[m.driving].inertia_kg_m2 +
                                rb * rb / gears[m.driven].inertia_kg_m2);
      if (m.stiffness_source == "energy" || m.stiffness_source == "iso6336") {
        PairMeshStiffness k;
        try {
          // ISO's at its full load here; at the mesh's static load below.
          const TrainBodyData x = as_meshed(t, m, *a->second), y = as_meshed(t, m, *b->second);
          k = m.stiffness_source == "energy" ? pair_mesh_stiffness(m, x, y)
                                             : iso_mesh_stiffness(m, x, y);
        } catch (const InputError& e) {
          rethrow_with_origin(t, fmt::format("mesh '{}': stiffness_source = \"{}\": {}", m.name,
                                             m.stiffness_source, e.what()));
        }
        x.mean_stiffness_n_per_m = k.mean_n_per_m;
        for (const StiffnessHarmonic& h : k.harmonics)
          x.stiffness.push_back({h.ratio, h.phase_deg * kDegToRad});
      } else if (m.stiffness_source == "table") {
        if (m.stiffness_table.empty())
          rethrow_with_origin(
              t, fmt::format("mesh '{}': train.mesh[{}] has no stiffness_table: it must be given "
                             "with stiffness_source = \"table\" (a CSV "
                             "`position,stiffness_n_per_m` over one mesh cycle)",
                             m.name, &m - t.meshes.data()));
        PairMeshStiffness k;
        try {
          k = table_mesh_stiffness(m, c.directory);
        } catch (const InputError& e) {
          rethrow_with_origin(t, fmt::format("mesh '{}': {}", m.name, e.what()));
        }
        x.mean_stiffness_n_per_m = k.mean_n_per_m;
        for (const StiffnessHarmonic& h : k.harmonics)
          x.stiffness.push_back({h.ratio, h.phase_deg * kDegToRad});
      }
      const double k_m = m.stiffness_source != "harmonics" ? x.mean_stiffness_n_per_m
                                                           : m.mean_stiffness_n_per_m.value_or(0.0);
      x.damping_n_s_per_m = 2 * m.damping_ratio * std::sqrt(m_n * k_m);
    }
    x.damping_always = m.damping == "always";
    x.clip_tension = m.tension == "clip";
    x.backlash_m = m.backlash_um * kUmToM;
    if (m.stiffness_source == "harmonics") {
      if (!m.mean_stiffness_n_per_m)
        rethrow_with_origin(
            t, fmt::format("mesh '{}': train.mesh[{}] has no mean_stiffness_n_per_m: it must be "
                           "given with stiffness_source = \"harmonics\" (the default; "
                           "stiffness_source = \"energy\" computes it from the gears, "
                           "\"table\" reads it from stiffness_table)",
                           m.name, &m - t.meshes.data()));
      x.mean_stiffness_n_per_m = *m.mean_stiffness_n_per_m;
      for (const StiffnessHarmonic& h : m.stiffness_harmonics)
        x.stiffness.push_back({h.ratio, h.phase_deg * kDegToRad});
    }
    TableMeshError error{m.transmission_error_mean_um, m.transmission_error_um};
    if (!m.transmission_error_table.empty()) {
      if (!m.transmission_error_um.empty() || m.transmission_error_mean_um != 0)
        rethrow_with_origin(
            t, fmt::format("mesh '{}': transmission_error_table = \"{}\": the transmission error "
                           "is a table or harmonics (transmission_error_um, "
                           "transmission_error_mean_um), not both",
                           m.name, m.transmission_error_table));
      try {
        error = table_mesh_error(m, c.directory);
      } catch (const InputError& e) {
        rethrow_with_origin(t, fmt::format("mesh '{}': {}", m.name, e.what()));
      }
    }
    x.transmission_error_mean_m = error.mean_um * kUmToM;
    for (const ErrorHarmonic& h : error.harmonics)
      x.transmission_error.push_back({h.amplitude * kUmToM, h.phase_deg * kDegToRad});
    out.meshes.push_back(std::move(x));
  }
  for (const TrainShaftData& s : t.shafts) {
    // One way of damping at most: a ratio given beside another is refused, not overridden.
    const bool ratio_given = t.origins.count(fmt::format("shaft '{}': damping_ratio", s.name)) > 0;
    if (static_cast<int>(ratio_given) + static_cast<int>(s.mode_damping_ratio.has_value()) +
            static_cast<int>(s.damping_n_m_s_per_rad.has_value()) >
        1)
      rethrow_with_origin(t, fmt::format("shaft '{}': give one of damping_ratio, "
                                         "mode_damping_ratio and damping_n_m_s_per_rad",
                                         s.name));
    train::Shaft x{s.name, s.from, s.to, s.stiffness_n_m_per_rad, 0.0};
    if (s.damping_n_m_s_per_rad || s.mode_damping_ratio) {
      x.damping_n_m_s_per_rad = s.damping_n_m_s_per_rad.value_or(0.0);  // a mode's: below
      out.shafts.push_back(std::move(x));
      continue;
    }
    const auto a = gears.find(s.from), b = gears.find(s.to);
    if (a != gears.end() && b != gears.end()) {
      const double ja = a->second.inertia_kg_m2, jb = b->second.inertia_kg_m2;
      x.damping_n_m_s_per_rad =
          2 * s.damping_ratio * std::sqrt(s.stiffness_n_m_per_rad * ja * jb / (ja + jb));
    } else if (a != gears.end() && s.to == train::kGround) {
      x.damping_n_m_s_per_rad =
          2 * s.damping_ratio * std::sqrt(s.stiffness_n_m_per_rad * a->second.inertia_kg_m2);
    }
    out.shafts.push_back(std::move(x));
  }
  for (const TrainBearingData& b : t.bearings) {
    // A pin written without its radius holds its planet where the teeth mesh.
    const double pin_radius_mm = b.on.empty() || b.pin_radius_mm != 0
                                     ? b.pin_radius_mm
                                     : pin_radius_from_gears_mm(t, b).value_or(0.0);
    train::Bearing x{b.name,
                     b.body,
                     b.stiffness_n_per_m,
                     0.0,
                     b.on,
                     pin_radius_mm * kMmToM,
                     b.pin_angle_deg * kDegToRad,
                     b.pin_error_radial_um * kUmToM,
                     b.pin_error_tangential_um * kUmToM,
                     b.clearance_um * kUmToM};
    const auto carried = bodies.find(b.body);
    for (const auto& [leaf, value] :
         {std::pair{"axial_stiffness_n_per_m", b.axial_stiffness_n_per_m},
          std::pair{"tilt_stiffness_n_m_per_rad", b.tilt_stiffness_n_m_per_rad}})
      if (value != 0 && carried != bodies.end() &&
          (leaf[0] == 'a' ? !keeps_axis(*carried->second)
                          : carried->second->dof != BodyDof::kSpatial))
        rethrow_with_origin(
            t, fmt::format("bearing '{}': {} = {} is read only for a body that {} (dof = {}); "
                           "body '{}' is {}",
                           b.name, leaf, value, leaf[0] == 'a' ? "moves along its axis" : "tilts",
                           leaf[0] == 'a' ? "\"axial\" or \"spatial\"" : "\"spatial\"", b.body,
                           to_string(carried->second->dof)));
    x.axial_stiffness_n_per_m = b.axial_stiffness_n_per_m;
    x.tilt_stiffness_n_m_per_rad = b.tilt_stiffness_n_m_per_rad;
    if (const auto g = gears.find(b.body); g != gears.end()) {
      x.damping_n_s_per_m =
          2 * b.damping_ratio * std::sqrt(b.stiffness_n_per_m * g->second.mass_kg);
      x.axial_damping_n_s_per_m =
          2 * b.damping_ratio * std::sqrt(b.axial_stiffness_n_per_m * g->second.mass_kg);
      x.tilt_damping_n_m_s_per_rad =
          2 * b.damping_ratio *
          std::sqrt(b.tilt_stiffness_n_m_per_rad * g->second.tilt_inertia_kg_m2);
    }
    out.bearings.push_back(std::move(x));
  }
  for (const TrainTorqueData& q : t.torques) {
    // One way of giving its mean: a power beside a written mean_nm or a reaction is refused.
    const bool mean_given = t.origins.count(fmt::format("torque '{}': mean_nm", q.name)) > 0;
    if (q.power_kw && (mean_given || q.balances))
      rethrow_with_origin(t, fmt::format("torque '{}': give one of mean_nm, power_kw and "
                                         "balances = true",
                                         q.name));
    train::Torque x{q.name, q.body, q.balances || q.power_kw ? 0.0 : q.mean_nm, {}};
    for (const OrderHarmonic& h : q.harmonics)
      x.harmonics.push_back({h.amplitude, h.order, h.phase_deg * kDegToRad});
    out.torques.push_back(std::move(x));
  }
  // A prescribed acceleration a cos(n Omega t + phi) is the rotation a / (n Omega)^2 cos(n Omega
  // t + phi + pi): Omega, the body's speed, is known once the train is assembled.
  for (const TrainSpeedData& v : t.speeds) out.speeds.push_back({v.name, v.body, {}});
  try {
    const train::Assembled speeds_only(out);
    for (std::size_t i = 0; i < t.speeds.size(); ++i) {
      const int body = speeds_only.index(t.speeds[i].body);
      const double omega = 2 * kPi * speeds_only.turning_hz(body);
      for (const OrderHarmonic& h : t.speeds[i].acceleration_harmonics) {
        const double w = h.order * omega;
        out.speeds[i].harmonics.push_back(
            {h.amplitude / (w * w), h.order, h.phase_deg * kDegToRad + kPi});
      }
    }
    // A power given: its torque at its body's absolute speed.
    for (std::size_t k = 0; k < t.torques.size(); ++k) {
      const TrainTorqueData& q = t.torques[k];
      if (!q.power_kw) continue;
      const double hz = std::abs(speeds_only.turning_hz(speeds_only.index(q.body)));
      if (hz == 0)
        throw InputError(
            fmt::format("torque '{}': power_kw = {} on body '{}', which is at rest: "
                        "no torque there delivers power; give its mean_nm",
                        q.name, *q.power_kw, q.body));
      out.torques[k].mean_nm = *q.power_kw * 1e3 / (2 * kPi * hz);
    }
    // The reaction: the torque that balances the others' power at the train's speeds (those
    // given as a power included).
    const bool powers =
        std::any_of(t.torques.begin(), t.torques.end(),
                    [](const TrainTorqueData& q) { return q.power_kw.has_value(); });
    const std::optional<train::Assembled> with_powers =
        powers ? std::optional<train::Assembled>(std::in_place, out) : std::nullopt;
    const train::Assembled& loaded = with_powers ? *with_powers : speeds_only;
    for (std::size_t k = 0; k < t.torques.size(); ++k) {
      if (!t.torques[k].balances) continue;
      const int body = speeds_only.index(t.torques[k].body);
      const double speed = train::value(speeds_only.speed_ratios()[static_cast<std::size_t>(body)]);
      if (speed == 0)
        throw InputError(
            fmt::format("torque '{}': balances = true on body '{}', which is at "
                        "rest: a torque there does no work and balances nothing",
                        t.torques[k].name, t.torques[k].body));
      for (std::size_t j = k + 1; j < t.torques.size(); ++j)
        if (t.torques[j].balances)
          throw InputError(
              fmt::format("torque '{}': balances = true, as torque '{}' has: one "
                          "torque is the reaction to the others",
                          t.torques[j].name, t.torques[k].name));
      out.torques[k].mean_nm = -loaded.mean_power_nm() / speed;
    }
  } catch (const InputError& e) {
    rethrow_with_origin(t, e.what());
  }
  iso_meshes_at_their_load(t, out);
  damp_shafts_by_their_modes(t, out);
  return out;
}

train::Assembled assembled_train(const Case& c, const MeshStiffness* stiffness) {
  const Case form = c.model.form == ModelForm::kTrain ? Case{} : train_form_of(c, stiffness);
  const Case& as_train = c.model.form == ModelForm::kTrain ? c : form;
  train::Train t = train_of(as_train);
  try {
    train::Assembled a(std::move(t));
    settle_joints(a);
    return a;
  } catch (const InputError& e) {
    rethrow_with_origin(expand_planets(*as_train.train), e.what());
  }
}

namespace {

// Each key of an element kind, described for the docs, the listing and `geardyn keys --json`.
template <class E>
void describe(std::string_view kind, const std::vector<ElementKey<E>>& keys,
              std::vector<TrainKeyInfo>& out) {
  const E defaults{};
  for (const ElementKey<E>& k : keys) {
    const std::string value = std::visit(
        [&](auto member) -> std::string {
          const auto& v = defaults.*member;
          using T = std::remove_cvref_t<decltype(v)>;
          if (k.required) return "(required)";
          if constexpr (std::is_same_v<T, std::string>) {
            if (k.leaf == "name") return fmt::format("{0}1, {0}2, ...", kind);
            return v.empty() ? std::string("absent") : fmt::format("\"{}\"", v);
          } else if constexpr (std::is_enum_v<T>) {
            return fmt::format("\"{}\"", to_string(v));
          } else if constexpr (std::is_same_v<T, std::optional<double>>) {
            return "absent";
          } else if constexpr (std::is_arithmetic_v<T>) {
            return fmt::format("{}", v);
          } else {
            return "[]";
          }
        },
        k.field);
    out.push_back({std::string(kind), std::string(k.leaf), std::string(k.unit), value, allowed(k),
                   std::string(k.doc)});
  }
}

// A value as TOML text; an empty name is a key left out (a bearing on the ground has no `on`).
std::string toml_value(const std::string& v) {
  return v.empty() ? std::string() : fmt::format("\"{}\"", v);
}
std::string toml_value(double v) { return fmt::format("{}", v); }
std::string toml_value(BodyDof v) { return fmt::format("\"{}\"", to_string(v)); }
std::string toml_value(MeshKind v) { return fmt::format("\"{}\"", to_string(v)); }
std::string toml_value(int v) { return fmt::format("{}", v); }
std::string toml_value(bool v) { return v ? "true" : ""; }  // false: the default, left out
std::string toml_value(const std::optional<double>& v) { return v ? toml_value(*v) : ""; }
std::string toml_value(const std::vector<StiffnessHarmonic>& v) {
  std::string out;
  for (const StiffnessHarmonic& h : v)
    out += fmt::format("{}[{}, {}]", out.empty() ? "" : ", ", h.ratio, h.phase_deg);
  return "[" + out + "]";
}
std::string toml_value(const std::vector<ErrorHarmonic>& v) {
  std::string out;
  for (const ErrorHarmonic& h : v)
    out += fmt::format("{}[{}, {}]", out.empty() ? "" : ", ", h.amplitude, h.phase_deg);
  return "[" + out + "]";
}
std::string toml_value(const std::vector<OrderHarmonic>& v) {
  std::string out;
  for (const OrderHarmonic& h : v)
    out +=
        fmt::format("{}[{}, {}, {}]", out.empty() ? "" : ", ", h.amplitude, h.order, h.phase_deg);
  return "[" + out + "]";
}

// The elements' tables, each key with a value but those `left_out(element, leaf)` names (a
// key whose default another key of the element replaces).
template <class E>
std::string toml_tables(std::string_view kind, const std::vector<ElementKey<E>>& keys,
                        const std::vector<E>& elements,
                        const std::function<bool(const E&, std::string_view)>& left_out = {}) {
  std::string out;
  for (const E& e : elements) {
    out += fmt::format("\n[[train.{}]]\n", kind);
    for (const ElementKey<E>& k : keys)
      std::visit(
          [&](auto member) {
            const std::string v = toml_value(e.*member);
            if (!v.empty() && !(left_out && left_out(e, k.leaf)))
              out += fmt::format("{} = {}\n", k.leaf, v);
          },
          k.field);
  }
  return out;
}

}  // namespace

const std::vector<TrainKeyInfo>& train_key_list() {
  static const std::vector<TrainKeyInfo> list = [] {
    std::vector<TrainKeyInfo> out = {
        {"", "reference", "", "the first body", "a body's name in quotes",
         "the body whose speed is given"},
        {"", "reference_speed_hz", "Hz", "(required)", "a number > 0",
         "its absolute rotation frequency (every other body's follows from the meshes, shafts "
         "and supports, Willis's equation for each planetary set)"},
        {"", "mesh_phase", "", "\"given\"", "\"given\" or \"layout\"",
         "\"given\": each mesh's harmonic phases about t = 0 as written; \"layout\": about a "
         "tooth pair passing the mesh's pitch point, each mesh delayed by where the position "
         "angles put its gears' teeth"},
        {"", "frame_terms", "", "false", "true or false",
         "each carrier's frame's rotation terms on the planar bodies in it (a planetary set's): "
         "Coriolis and centripetal forces and the planets' centrifugal load, at the carrier's "
         "speed (docs/model.md, \"The carrier's rotation\")"},
        {"", "planet", "", "(none)", "a body's name in quotes",
         "a planetary set's planet, written once: it and every element naming it stand for "
         "train.planets copies, named <name>1 ... <name>N"},
        {"", "planets", "", "(none)", fmt::format("a whole number from 1 to {}", kMaxPlanets),
         "how many copies of train.planet the set has"},
        {"", "planet_angles_deg", "deg", "equally spaced", "one angle per planet, in [-360, 360]",
         "each copy's angle about the set's axis, added to its meshes' position_angle_deg and "
         "its bearings' pin_angle_deg (the template is written at 0)"},
        {"", "planet_pin_errors_um", "um", "none", "one [radial, tangential] pair per planet",
         "each copy's pin position error, added to the pin errors of the bearings that carry "
         "it (planet load sharing)"}};
    for_each_kind([&](const auto& kind) { describe(kind.name, kind.keys(), out); });
    return out;
  }();
  return list;
}

namespace {

// Whether `leaf` is a real number of an element of kind `keys`: a number, or one entry of a
// list of harmonics (`harmonics[i][j]`, i the harmonic and j its entry, each a real the model
// reads); nullopt when it is no key.
template <class E>
std::optional<bool> real_leaf(const std::vector<ElementKey<E>>& keys, std::string_view leaf) {
  const std::size_t open = leaf.find('[');
  const std::string_view name = leaf.substr(0, open);
  for (const ElementKey<E>& k : keys) {
    if (k.leaf != name) continue;
    const bool list = std::holds_alternative<std::vector<StiffnessHarmonic> E::*>(k.field) ||
                      std::holds_alternative<std::vector<ErrorHarmonic> E::*>(k.field) ||
                      std::holds_alternative<std::vector<OrderHarmonic> E::*>(k.field);
    if (open == std::string_view::npos)
      return std::holds_alternative<double E::*>(k.field) ||
             std::holds_alternative<std::optional<double> E::*>(k.field);
    // [i][j]: two indices of digits.
    std::string_view rest = leaf.substr(open);
    for (int n = 0; n < 2; ++n) {
      const std::size_t close = rest.find(']');
      if (!rest.starts_with('[') || close == std::string_view::npos || close == 1 ||
          rest.substr(1, close - 1).find_first_not_of("0123456789") != std::string_view::npos)
        return std::nullopt;
      rest = rest.substr(close + 1);
    }
    if (!rest.empty()) return std::nullopt;
    return list;
  }
  return std::nullopt;
}

}  // namespace

std::string train_key_not_sweepable(std::string_view dotted) {
  if (dotted == "train.reference_speed_hz") return {};
  // A copied planet's pin error, [i][0] radial or [i][1] tangential.
  if (dotted.starts_with("train.planet_pin_errors_um[")) {
    const std::string_view rest = dotted.substr(dotted.find('['));
    const std::size_t close = rest.find("][");
    if (close == std::string_view::npos || close == 1 ||
        rest.substr(1, close - 1).find_first_not_of("0123456789") != std::string_view::npos ||
        (rest.substr(close) != "][0]" && rest.substr(close) != "][1]"))
      return "unknown key (a planet's pin error is train.planet_pin_errors_um[i][0] radial or "
             "[i][1] tangential)";
    return {};
  }
  // train.<kind>[<i>].<leaf>
  const std::size_t open = dotted.find('['), close = dotted.find("].");
  if (!dotted.starts_with("train.") || open == std::string_view::npos ||
      close == std::string_view::npos || close < open ||
      dotted.find_first_not_of("0123456789", open + 1) != close || close == open + 1)
    return "unknown key (an element's key is written train.<kind>[i].<key>)";
  const std::string_view kind = dotted.substr(6, open - 6), leaf = dotted.substr(close + 2);
  std::optional<bool> real;
  for_each_kind([&](const auto& row) {
    if (kind == row.name) real = real_leaf(row.keys(), leaf);
  });
  if (!real) return "unknown key";
  if (!*real)
    return "not a real number the model reads (names and counts are not varied by a study; a "
           "harmonic's entry is, as key[i][j])";
  return {};
}

std::string TrainKeyInfo::dotted() const {
  return kind.empty() ? fmt::format("train.{}", leaf) : fmt::format("train.{}[].{}", kind, leaf);
}

std::string train_keys_markdown() {
  std::string out;
  std::string kind = "?";
  for (const TrainKeyInfo& k : train_key_list()) {
    if (k.kind != kind) {
      kind = k.kind;
      out += kind.empty() ? std::string("\n## [train]\n\n")
                          : fmt::format("\n## [[train.{}]]\n\n", kind);
      out += "| key | unit | default | allowed | meaning |\n|---|---|---|---|---|\n";
    }
    out += fmt::format("| {} | {} | {} | {} | {} |\n", k.leaf, k.unit, k.default_text, k.allowed,
                       k.meaning);
  }
  return out;
}

std::string train_keys_listing() {
  std::string out;
  for (const TrainKeyInfo& k : train_key_list())
    out +=
        fmt::format("{}{}: {}; default {}; {}\n", k.dotted(),
                    k.unit.empty() ? "" : fmt::format(" ({})", k.unit), k.allowed,
                    k.default_text.empty() ? "the kind and its place" : k.default_text, k.meaning);
  return out;
}

std::size_t mesh_to_read(const Case& c, const std::string& name) {
  if (c.model.form != ModelForm::kTrain) {
    if (!name.empty())
      throw InputError(fmt::format(
          "--mesh = \"{}\": names a gear train's mesh; this case (model.form = \"{}\") has "
          "one mesh",
          name, to_string(c.model.form)));
    return 0;
  }
  if (name.empty()) return 0;
  std::vector<std::string> names;
  const train::Assembled a = assembled_train(c);
  for (const train::Mesh& m : a.train().meshes) names.push_back(m.name);
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end())
    throw InputError(
        fmt::format("--mesh = \"{}\": the train has no mesh of that name; its meshes are {}", name,
                    fmt::join(names, ", ")));
  return static_cast<std::size_t>(it - names.begin());
}

namespace {

// Where an element's key was written; where the element was when the key was not (a default).
std::string key_origin(const TrainCase& t, std::string_view kind, const std::string& name,
                       std::string_view leaf) {
  const std::string label = fmt::format("{} '{}'", kind, name);
  for (const std::string& l : {fmt::format("{}: {}", label, leaf), label})
    if (const auto it = t.origins.find(l); it != t.origins.end()) return it->second;
  return "";
}

}  // namespace

std::vector<std::string> train_unused_settings(const TrainCase& t) {
  std::vector<std::string> out;
  const bool no_carrier = std::none_of(t.bearings.begin(), t.bearings.end(),
                                       [](const TrainBearingData& b) { return !b.on.empty(); });
  if (t.frame_terms &&
      (no_carrier || std::none_of(t.bodies.begin(), t.bodies.end(),
                                  [](const TrainBodyData& b) { return keeps_plane(b); }))) {
    const auto where_given = t.origins.find("the train: frame_terms");
    out.push_back(fmt::format(
        "train.frame_terms = true ({}): not used: {}, and the frame's terms act on the planar "
        "bodies' centres in a turning carrier's frame",
        where_given == t.origins.end() ? "" : where_given->second,
        no_carrier ? "no body carries others on pins (every axis is fixed)" : "no body is planar"));
  }
  // The gears whose layout a mesh's line of action reaches: planar, or with a runout.
  std::set<std::string> placed;
  for (const TrainBodyData& b : t.bodies)
    if (keeps_plane(b) || b.eccentricity_um != 0) placed.insert(b.name);
  for (std::size_t i = 0; i < t.meshes.size(); ++i) {
    const TrainMeshData& m = t.meshes[i];
    if (m.position_angle_deg == 0 || placed.count(m.driving) || placed.count(m.driven) ||
        t.mesh_phase == "layout")
      continue;
    out.push_back(fmt::format(
        "train.mesh[{}].position_angle_deg = {} ({}): not used: neither gear of mesh '{}' is "
        "planar or eccentric and train.mesh_phase is not \"layout\", so its layout moves "
        "nothing",
        i, m.position_angle_deg, key_origin(t, "mesh", m.name, "position_angle_deg"), m.name));
  }
  // The thrust's sense moves something only with a spatial gear in a helical mesh.
  std::map<std::string, const TrainBodyData*> by_name;
  for (const TrainBodyData& b : t.bodies) by_name.emplace(b.name, &b);
  for (std::size_t i = 0; i < t.meshes.size(); ++i) {
    const TrainMeshData& m = t.meshes[i];
    if (m.thrust == "+z") continue;
    const auto spatial_helical = [&](const std::string& name) {
      const auto it = by_name.find(name);
      return it != by_name.end() && keeps_axis(*it->second) && it->second->helix_angle_deg != 0;
    };
    if (spatial_helical(m.driving) || spatial_helical(m.driven)) continue;
    out.push_back(fmt::format(
        "train.mesh[{}].thrust = \"{}\" ({}): not used: no gear of mesh '{}' is both spatial "
        "and helical, so nothing moves along the axes",
        i, m.thrust, key_origin(t, "mesh", m.name, "thrust"), m.name));
  }
  // With damping at all times the teeth alone carry k (d - e -+ b), which never pulls.
  for (std::size_t i = 0; i < t.meshes.size(); ++i) {
    const TrainMeshData& m = t.meshes[i];
    if (m.tension != "clip" || m.damping != "always") continue;
    out.push_back(fmt::format(
        "train.mesh[{}].tension = \"clip\" ({}): not used: mesh '{}' is damped at all times "
        "(damping = \"always\"), its damper beside the teeth, and the teeth alone never pull",
        i, key_origin(t, "mesh", m.name, "tension"), m.name));
  }
  // A runout moves a gear's teeth or a carrier's pins: on a body with neither it moves nothing.
  for (std::size_t i = 0; i < t.bodies.size(); ++i) {
    const TrainBodyData& b = t.bodies[i];
    const bool meshes = std::any_of(t.meshes.begin(), t.meshes.end(), [&](const auto& m) {
      return m.driving == b.name || m.driven == b.name;
    });
    const bool pins = std::any_of(t.bearings.begin(), t.bearings.end(),
                                  [&](const TrainBearingData& x) { return x.on == b.name; });
    const auto where = [&](std::string_view leaf) { return key_origin(t, "body", b.name, leaf); };
    if (b.eccentricity_um != 0 && !meshes && !pins)
      out.push_back(fmt::format(
          "train.body[{}].eccentricity_um = {} ({}): not used: body '{}' has no teeth in a mesh "
          "and carries no pins, so its runout moves nothing",
          i, b.eccentricity_um, where("eccentricity_um"), b.name));
    if (b.eccentricity_angle_deg != 0 && b.eccentricity_um == 0)
      out.push_back(
          fmt::format("train.body[{}].eccentricity_angle_deg = {} ({}): not used: body '{}' has no "
                      "eccentricity_um to direct",
                      i, b.eccentricity_angle_deg, where("eccentricity_angle_deg"), b.name));
    // Its flanks and material are read by a mesh that computes its stiffness from its gears
    // (ISO 6336-1 reads no Poisson's ratio); the shifts by every mesh where a body moves in the
    // plane or sits on a pin (the line of action at the working pressure angle, the pin radius).
    const bool plane_read = std::any_of(t.bodies.begin(), t.bodies.end(),
                                        [](const TrainBodyData& x) { return keeps_plane(x); }) ||
                            std::any_of(t.bearings.begin(), t.bearings.end(),
                                        [](const TrainBearingData& x) { return !x.on.empty(); });
    const auto flanks_read = [&](std::string_view leaf) {
      return std::any_of(t.meshes.begin(), t.meshes.end(), [&](const auto& m) {
        return (m.stiffness_source == "energy" || (leaf == "profile_shift" && plane_read) ||
                (m.stiffness_source == "iso6336" && leaf != "poisson_ratio")) &&
               (m.driving == b.name || m.driven == b.name);
      });
    };
    const TrainBodyData plain;
    for (const auto& [leaf, value, unset] :
         {std::tuple{"profile_shift", b.profile_shift, b.profile_shift == plain.profile_shift},
          std::tuple{"outside_diameter_mm", b.outside_diameter_mm.value_or(0.0),
                     !b.outside_diameter_mm},
          std::tuple{"youngs_modulus_gpa", b.youngs_modulus_gpa,
                     b.youngs_modulus_gpa == plain.youngs_modulus_gpa},
          std::tuple{"poisson_ratio", b.poisson_ratio, b.poisson_ratio == plain.poisson_ratio},
          std::tuple{"basic_rack_dedendum", b.basic_rack_dedendum,
                     b.basic_rack_dedendum == plain.basic_rack_dedendum}})
      if (!unset && !flanks_read(leaf))
        out.push_back(fmt::format(
            "train.body[{}].{} = {} ({}): not used: no mesh of body '{}' takes its stiffness from "
            "the gears (stiffness_source = \"energy\"{})",
            i, leaf, value, where(leaf), b.name,
            std::string_view(leaf) == "poisson_ratio" ? "" : " or \"iso6336\""));
  }
  // A mesh's stiffness keys that its source does not read.
  for (std::size_t i = 0; i < t.meshes.size(); ++i) {
    const TrainMeshData& m = t.meshes[i];
    const auto where = [&](std::string_view leaf) { return key_origin(t, "mesh", m.name, leaf); };
    const TrainMeshData plain;
    if (m.stiffness_source == "iso6336" && m.mean_stiffness_n_per_m)
      out.push_back(fmt::format(
          "train.mesh[{}].mean_stiffness_n_per_m = {} ({}): not used: mesh '{}' takes k_m from "
          "ISO 6336-1 (stiffness_source = \"iso6336\")",
          i, *m.mean_stiffness_n_per_m, where("mean_stiffness_n_per_m"), m.name));
    if (m.stiffness_source != "harmonics" && m.stiffness_source != "iso6336" &&
        !m.stiffness_harmonics.empty())
      out.push_back(fmt::format(
          "train.mesh[{}].stiffness_harmonics ({}): not used: mesh '{}' takes its harmonics "
          "from {} (stiffness_source = \"{}\")",
          i, where("stiffness_harmonics"), m.name,
          m.stiffness_source == "energy" ? "its gears" : "its stiffness_table",
          m.stiffness_source));
    if (m.stiffness_source != "table" && !m.stiffness_table.empty())
      out.push_back(fmt::format(
          "train.mesh[{}].stiffness_table = \"{}\" ({}): not used: mesh '{}' does not read its "
          "stiffness from a table (stiffness_source = \"{}\")",
          i, m.stiffness_table, where("stiffness_table"), m.name, m.stiffness_source));
    if (m.transmission_error_table.empty() &&
        m.transmission_error_kept != plain.transmission_error_kept)
      out.push_back(fmt::format(
          "train.mesh[{}].transmission_error_kept = {} ({}): not used: mesh '{}' has no "
          "transmission_error_table to keep harmonics of",
          i, m.transmission_error_kept, where("transmission_error_kept"), m.name));
    if ((m.stiffness_source == "harmonics" || m.stiffness_source == "iso6336") &&
        m.harmonics_kept != plain.harmonics_kept)
      out.push_back(fmt::format(
          "train.mesh[{}].harmonics_kept = {} ({}): not used: mesh '{}' takes its harmonics as "
          "given (stiffness_source = \"{}\")",
          i, m.harmonics_kept, where("harmonics_kept"), m.name, m.stiffness_source));
    // What the gear pair of an energy or ISO mesh's gears says of their data.
    if (m.stiffness_source == "energy" || m.stiffness_source == "iso6336") {
      const auto a = std::find_if(t.bodies.begin(), t.bodies.end(),
                                  [&](const TrainBodyData& b) { return b.name == m.driving; });
      const auto b = std::find_if(t.bodies.begin(), t.bodies.end(),
                                  [&](const TrainBodyData& x) { return x.name == m.driven; });
      if (a != t.bodies.end() && b != t.bodies.end() && a->teeth > 0 && b->teeth > 0)
        for (const std::string& w : pair_mesh_warnings(m, *a, *b))
          out.push_back(fmt::format("train.mesh[{}] ('{}', {}): {}", i, m.name,
                                    key_origin(t, "mesh", m.name, "stiffness_source"), w));
    }
    if (m.stiffness_source != "energy" && m.stiffness_source != "iso6336" && m.center_distance_mm)
      out.push_back(fmt::format(
          "train.mesh[{}].center_distance_mm = {} ({}): not used: mesh '{}' takes its stiffness "
          "as given (stiffness_source = \"{}\")",
          i, *m.center_distance_mm, where("center_distance_mm"), m.name, m.stiffness_source));
  }
  for (std::size_t i = 0; i < t.bearings.size(); ++i) {
    const TrainBearingData& b = t.bearings[i];
    if (!b.on.empty()) continue;
    // On the ground its pin angle is read only as the direction of its errors.
    const bool errors = b.pin_error_radial_um != 0 || b.pin_error_tangential_um != 0;
    for (const auto& [leaf, value, why] :
         {std::tuple{"pin_radius_mm", b.pin_radius_mm, "so it has no pin"},
          std::tuple{"pin_angle_deg", errors ? 0.0 : b.pin_angle_deg,
                     "and no pin error to direct"}})
      if (value != 0)
        out.push_back(fmt::format(
            "train.bearing[{}].{} = {} ({}): not used: bearing '{}' has no `on` (it sits on the "
            "ground), {}",
            i, leaf, value, key_origin(t, "bearing", b.name, leaf), b.name, why));
  }
  return out;
}

namespace {

// Hands element i's member `leaf` of `kind` (keys its table), with its key, to set(key,
// member), which returns whether it took the value; then the element's and the key's origins
// are `label`, as the reader gives them. False when there is no such element or key, or set
// refused.
template <class E, class Set>
bool set_element_member(TrainCase& t, std::vector<E>& elements, std::string_view kind,
                        const std::vector<ElementKey<E>>& keys, std::size_t i,
                        std::string_view leaf, const std::string& label, Set&& set) {
  // A preset's element is set through the preset's keys (read again from the case's text).
  if (i >= elements.size() || t.generated.count(fmt::format("{} '{}'", kind, elements[i].name)))
    return false;
  for (const ElementKey<E>& key : keys) {
    if (key.leaf != leaf) continue;
    E& e = elements[i];
    if (!std::visit([&](auto member) { return set(key, e.*member); }, key.field)) return false;
    const std::string element = fmt::format("{} '{}'", kind, e.name);
    t.origins[element] = label;
    t.origins[fmt::format("{}: {}", element, leaf)] = label;
    return true;
  }
  return false;
}

// Sets element i's `leaf` to v, within the key's bounds, as the reader would; false when the
// key is not one number or v is out of bounds.
template <class E>
bool set_element_number(TrainCase& t, std::vector<E>& elements, std::string_view kind,
                        const std::vector<ElementKey<E>>& keys, std::size_t i,
                        std::string_view leaf, double v, const std::string& label) {
  return set_element_member(
      t, elements, kind, keys, i, leaf, label, [v](const ElementKey<E>& key, auto& member) {
        using T = std::remove_reference_t<decltype(member)>;
        if constexpr (std::is_same_v<T, double> || std::is_same_v<T, std::optional<double>>) {
          if (!key.range.contains(v)) return false;
          member = v;
          return true;
        }
        return false;
      });
}

// A harmonic's first entry: its amplitude (a stiffness harmonic's ratio k_ai / k_m).
double& amplitude_of(StiffnessHarmonic& h) { return h.ratio; }
double& amplitude_of(ErrorHarmonic& h) { return h.amplitude; }
double& amplitude_of(OrderHarmonic& h) { return h.amplitude; }

template <class T>
constexpr bool kIsHarmonics =
    std::is_same_v<T, std::vector<StiffnessHarmonic>> ||
    std::is_same_v<T, std::vector<ErrorHarmonic>> || std::is_same_v<T, std::vector<OrderHarmonic>>;

// The same for entry [row][column] of element i's harmonics `leaf`, as the reader takes it:
// the amplitude (column 0) within the key's bounds, an order (the middle of [amplitude, order,
// phase_deg]) > 0, a phase any finite number; false when there is no such entry (the reader
// then says why).
template <class E>
bool set_element_entry(TrainCase& t, std::vector<E>& elements, std::string_view kind,
                       const std::vector<ElementKey<E>>& keys, std::size_t i, std::string_view leaf,
                       std::size_t row, std::size_t column, double v, const std::string& label) {
  return set_element_member(
      t, elements, kind, keys, i, leaf, label, [&](const ElementKey<E>& key, auto& member) {
        using T = std::remove_reference_t<decltype(member)>;
        if constexpr (kIsHarmonics<T>) {
          using H = typename T::value_type;
          constexpr std::size_t kWidth = std::is_same_v<H, OrderHarmonic> ? 3 : 2;
          if (row >= member.size() || column >= kWidth) return false;
          H& h = member[row];
          if (column == 0) {
            if (!key.range.contains(v)) return false;
            amplitude_of(h) = v;
          } else if (column + 1 == kWidth) {
            h.phase_deg = v;
          } else if constexpr (kWidth == 3) {
            if (!(v > 0)) return false;
            h.order = v;
          }
          return true;
        }
        return false;
      });
}

}  // namespace

bool set_train_number_in_place(TrainCase& t, const Override& o) {
  double v = 0;
  const char* end = o.value.data() + o.value.size();
  const auto [ptr, ec] = std::from_chars(o.value.data(), end, v);
  if (ec != std::errc{} || ptr != end || !std::isfinite(v)) return false;
  if (o.key == "train.reference_speed_hz") {
    if (!(v > 0)) return false;
    t.reference_speed_hz = v;
    t.origins["the train: reference_speed_hz"] = o.label();
    return true;
  }
  // train.<kind>[i].<leaf>
  const std::string_view key = o.key;
  constexpr std::string_view kPrefix = "train.";
  if (key.rfind(kPrefix, 0) != 0) return false;
  const std::size_t open = key.find('['), close = key.find(']');
  if (open == std::string_view::npos || close == std::string_view::npos || close < open ||
      close + 1 >= key.size() || key[close + 1] != '.')
    return false;
  const std::string_view kind = key.substr(kPrefix.size(), open - kPrefix.size());
  std::string_view leaf = key.substr(close + 2);
  std::size_t i = 0;
  const auto [at, bad] = std::from_chars(key.data() + open + 1, key.data() + close, i);
  if (bad != std::errc{} || at != key.data() + close || leaf.find('.') != std::string_view::npos)
    return false;
  const std::string label = o.label();
  // A harmonic's entry: <leaf>[row][column].
  if (const std::size_t bracket = leaf.find('['); bracket != std::string_view::npos) {
    std::size_t index[2] = {0, 0};
    std::string_view rest = leaf.substr(bracket);
    for (std::size_t& x : index) {
      const std::size_t shut = rest.find(']');
      if (rest.empty() || rest[0] != '[' || shut == std::string_view::npos) return false;
      const auto [end, error] = std::from_chars(rest.data() + 1, rest.data() + shut, x);
      if (error != std::errc{} || end != rest.data() + shut) return false;
      rest = rest.substr(shut + 1);
    }
    if (!rest.empty()) return false;
    leaf = leaf.substr(0, bracket);
    bool set = false;
    for_each_kind([&](const auto& row) {
      if (row.set_by_index && kind == row.name)
        set = set_element_entry(t, t.*row.list, kind, row.keys(), i, leaf, index[0], index[1], v,
                                label);
    });
    return set;
  }
  bool set = false;
  for_each_kind([&](const auto& row) {
    if (row.set_by_index && kind == row.name)
      set = set_element_number(t, t.*row.list, kind, row.keys(), i, leaf, v, label);
  });
  return set;
}

std::string train_toml(const TrainCase& t) {
  std::string out =
      fmt::format("\n[train]\nreference = \"{}\"\nreference_speed_hz = {}\nmesh_phase = \"{}\"\n",
                  t.reference, t.reference_speed_hz, t.mesh_phase);
  if (t.frame_terms) out += "frame_terms = true\n";
  if (!t.planet.empty()) out += fmt::format("planet = \"{}\"\n", t.planet);
  if (t.planets > 0) out += fmt::format("planets = {}\n", t.planets);
  if (!t.planet_angles_deg.empty())
    out += fmt::format("planet_angles_deg = [{}]\n", fmt::join(t.planet_angles_deg, ", "));
  if (!t.planet_pin_errors_um.empty()) {
    std::vector<std::string> pairs;
    for (const auto& e : t.planet_pin_errors_um)
      pairs.push_back(fmt::format("[{}, {}]", e[0], e[1]));
    out += fmt::format("planet_pin_errors_um = [{}]\n", fmt::join(pairs, ", "));
  }
  // Every kind's elements, a preset's as the preset alone.
  for_each_kind([&](const auto& kind) {
    std::remove_cvref_t<decltype(t.*kind.list)> written;
    for (const auto& e : t.*kind.list)
      if (!t.generated.count(fmt::format("{} '{}'", kind.name, e.name))) written.push_back(e);
    using E = typename decltype(written)::value_type;
    out += toml_tables<E>(kind.name, kind.keys(), written, kind.left_out);
  });
  return out;
}

std::string_view to_string(BodyDof dof) { return kBodyDofWords.at(static_cast<std::size_t>(dof)); }
std::string_view to_string(MeshKind kind) {
  return kMeshKindWords.at(static_cast<std::size_t>(kind));
}

}  // namespace geardyn
