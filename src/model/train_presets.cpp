// The gear pair's dimensional forms as trains of elements (train_form_of, train_presets.hpp), and
// the gear pair of a train mesh's two gears (pair_mesh_stiffness).
#include "geardyn/train_presets.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include "geardyn/case_model.hpp"
#include "geardyn/coupled_model.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/model.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_statics.hpp"
#include "geardyn/transmission_error.hpp"

namespace geardyn {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kRadToDeg = 180 / kPi;
// A harmonic's frequency counts as the i-th multiple of the mesh frequency within this relative
// distance (the model forms its terms as i times the mesh frequency: equal to rounding).
constexpr double kMultipleTolerance = 1e-9;
// ISO 6336-1's line load F_t K_A / b (N/mm) from which its load factor on c' is 1.
constexpr double kIsoFullLoadNPerMm = 100;

// The key's place for a message: " (case.toml:12:3)", or "" when it was not given.
std::string where(const Case& c, const std::string& key) {
  const auto it = c.origins.find(key);
  return it == c.origins.end() ? "" : fmt::format(" ({})", it->second);
}

[[noreturn]] void refuse(const Case& c, const std::string& key, const std::string& value,
                         const std::string& why) {
  throw InputError(fmt::format("{} = {}{}: the train form {}", key, value, where(c, key), why));
}

// The i-th term of a series of multiples of w: i >= 1, or refused naming `what`.
int multiple(const Case& c, const Harmonic& h, double w, const char* key) {
  const double i = h.angular_frequency_rad_s / w;
  const double whole = std::round(i);
  if (!(whole >= 1 && std::abs(i - whole) <= kMultipleTolerance * whole))
    refuse(
        c, key, fmt::format("a term at {} rad/s", h.angular_frequency_rad_s),
        fmt::format("writes a mesh's harmonics at whole multiples of its frequency {} rad/s", w));
  return static_cast<int>(whole);
}

// A series' terms as [value, phase_deg] at multiples 1, 2, ... of w (zeros where absent), each
// value scaled by `scale`.
template <class H>
std::vector<H> harmonics_of(const Case& c, const HarmonicSeries& s, double w, double scale,
                            const char* key) {
  std::vector<H> out;
  for (const Harmonic& h : s.terms) {
    const auto i = static_cast<std::size_t>(multiple(c, h, w, key));
    if (out.size() < i) out.resize(i, H{0.0, 0.0});
    // A negative value as its opposite half a cycle later (the keys take values >= 0).
    const double v = h.amplitude * scale;
    out[i - 1] = H{std::abs(v), (h.phase_rad + (v < 0 ? kPi : 0.0)) * kRadToDeg};
  }
  return out;
}

// A torque's terms as [amplitude, order, phase_deg] at orders of its body's speed w_body,
// times `sign` (a negative amplitude as its opposite half a turn later).
std::vector<OrderHarmonic> orders_of(const HarmonicSeries& s, double w_body, double sign) {
  std::vector<OrderHarmonic> out;
  for (const Harmonic& h : s.terms) {
    if (h.amplitude == 0) continue;
    const double a = sign * h.amplitude;
    out.push_back({std::abs(a), h.angular_frequency_rad_s / w_body,
                   (h.phase_rad + (a < 0 ? kPi : 0.0)) * kRadToDeg});
  }
  return out;
}

// The non-dimensional oscillator x'' + 2 zeta x' + k(tau) f(x - e(tau)) = F_m + F_a cos(Omega
// tau) (b = 1, damping at all times) as a train in units where it is itself: two equal spur
// gears of kTeeth teeth on base circles of 1 m (a module of 2 / (kTeeth cos 20 deg) m), each of
// inertia 2 kg m^2 (so m_eq = J / (2 R^2) = 1 kg), a mesh of 1 N/m and a backlash of 1 m, the
// mesh frequency Omega / (2 pi) (1 s of the train is one tau); F(tau) is the pinion's torque
// F R and the wheel's the matched -F R (m_eq (R T1 / J + R T2' / J) = F with T2' = -T2).
constexpr int kTeeth = 50;
constexpr double kPressureAngleDeg = 20;

// An empty train case with c's name, description and solver.
Case train_case_of(const Case& c) {
  Case out;
  out.name = c.name;
  out.description = c.description;
  out.solver = c.solver;
  out.model.form = ModelForm::kTrain;
  return out;
}

Case nondimensional_train(const Case& c) {
  const ModelData& m = c.model;
  Case out = train_case_of(c);
  TrainCase t;
  t.reference = "pinion";
  t.reference_speed_hz = m.omega / (2 * kPi * kTeeth);
  const double module_mm = 2e3 / (kTeeth * std::cos(kPressureAngleDeg / kRadToDeg));
  for (const char* name : {"pinion", "wheel"}) {
    TrainBodyData b;
    b.name = name;
    b.inertia_kg_m2 = 2.0;
    b.teeth = kTeeth;
    b.normal_module_mm = module_mm;
    b.normal_pressure_angle_deg = kPressureAngleDeg;
    t.bodies.push_back(b);
  }
  TrainMeshData mesh;
  mesh.name = "mesh";
  mesh.driving = "pinion";
  mesh.driven = "wheel";
  mesh.backlash_um = 1e6;
  mesh.mean_stiffness_n_per_m = 1;
  mesh.stiffness_harmonics = m.stiffness_harmonics;
  for (const ErrorHarmonic& h : m.transmission_error)
    mesh.transmission_error_um.push_back({h.amplitude * 1e6, h.phase_deg});
  mesh.damping_ratio = m.zeta;
  mesh.damping = "always";
  t.meshes.push_back(mesh);
  // Omega is the mesh frequency: order kTeeth of either gear's speed.
  const auto torque = [&](const char* name, const char* body, double sign) {
    TrainTorqueData q{name, body, sign * m.force_mean, {}, false, std::nullopt};
    if (m.force_alternating != 0)
      q.harmonics.push_back(
          {m.force_alternating, static_cast<double>(kTeeth), sign > 0 ? 0.0 : 180.0});
    return q;
  };
  t.torques.push_back(torque("drive", "pinion", 1.0));
  t.torques.push_back(torque("load", "wheel", -1.0));
  out.train = std::make_shared<TrainCase>(std::move(t));
  return out;
}

}  // namespace

namespace {

// A train mesh's message of its gear pair with the pair's keys as the train has them.
std::string train_keys_in(std::string what, const TrainBodyData& driving,
                          const TrainBodyData& driven) {
  const std::string both = fmt::format("of '{}' and '{}'", driving.name, driven.name);
  // A gear's own entry first: "gear.profile_shift[1]" is the driven gear's profile_shift.
  for (const char* leaf : {"outside_diameter_mm", "profile_shift", "bore_diameter_mm",
                           "basic_rack_dedendum", "youngs_modulus_gpa", "poisson_ratio"})
    for (int i = 0; i < 2; ++i) {
      const std::string from = fmt::format("gear.{}[{}]", leaf, i);
      const std::string to =
          fmt::format("the {} of '{}'", leaf, i == 0 ? driving.name : driven.name);
      for (std::size_t at = what.find(from); at != std::string::npos;
           at = what.find(from, at + to.size()))
        what.replace(at, from.size(), to);
    }
  const std::array<std::pair<const char*, std::string>, 9> keys = {{
      {"gear.center_distance_mm", "center_distance_mm"},
      {"mesh.backlash_um", "backlash_um"},
      {"gear.outside_diameter_mm", "the outside_diameter_mm " + both},
      {"gear.profile_shift", "the profile_shift " + both},
      {"gear.face_width_mm", "the face_width_mm " + both},
      {"gear.bore_diameter_mm", "the bore_diameter_mm " + both},
      {"gear.basic_rack_dedendum", "the basic_rack_dedendum " + both},
      {"mesh.harmonics_kept", "harmonics_kept"},
      {"gear.", "the gears' "},
  }};
  for (const auto& [from, to] : keys)
    for (std::size_t at = what.find(from); at != std::string::npos;
         at = what.find(from, at + to.size()))
      what.replace(at, std::strlen(from), to);
  return what;
}

// An internal mesh's gears, its pinion and its ring, whichever drives.
struct PinionInRing {
  const TrainBodyData& pinion;
  const TrainBodyData& ring;
  bool ring_drives;
};
PinionInRing pinion_in_ring(const TrainBodyData& driving, const TrainBodyData& driven) {
  const bool ring_drives = driving.teeth > driven.teeth;
  return {ring_drives ? driven : driving, ring_drives ? driving : driven, ring_drives};
}

// The gear pair of a train mesh's two gears (pair_mesh_stiffness): its [gear] and [mesh] keys
// from the bodies' and the mesh's; of an internal mesh, `first` the pinion and `second` the ring
// (pinion_in_ring), the ring's outside_diameter_mm its tip (inner) diameter. The centre distance
// absent: the shifts' (an internal pair's computed by internal_geometry, 0 here); the tips
// absent: the standard basic rack's, an external pair's with its tip shortening. Throws
// InputError in the train's keys.
Case mesh_pair_case(const TrainMeshData& m, const TrainBodyData& first,
                    const TrainBodyData& second) {
  const bool internal = m.kind == MeshKind::kInternal;
  const std::array<const TrainBodyData*, 2> body = {&first, &second};
  Case c;
  GearData& g = c.gear;
  g.normal_module_mm = first.normal_module_mm;
  g.normal_pressure_angle_deg = first.normal_pressure_angle_deg;
  g.helix_angle_deg = first.helix_angle_deg;
  g.face_width_mm = std::min(first.face_width_mm, second.face_width_mm);
  const double beta = g.helix_angle_deg / kRadToDeg;
  for (std::size_t i = 0; i < 2; ++i) {
    const TrainBodyData& b = *body[i];
    g.teeth[i] = b.teeth;
    g.profile_shift[i] = b.profile_shift;
    const double sign = internal && i == 1 ? -1.0 : 1.0;  // a ring's tip lies inside
    g.outside_diameter_mm[i] =
        b.outside_diameter_mm.value_or(b.teeth * b.normal_module_mm / std::cos(beta) +
                                       sign * 2 * b.normal_module_mm * (1 + b.profile_shift));
    g.bore_diameter_mm[i] = b.bore_diameter_mm;
    g.youngs_modulus_gpa[i] = b.youngs_modulus_gpa;
    g.poisson_ratio[i] = b.poisson_ratio;
    g.basic_rack_dedendum[i] = b.basic_rack_dedendum;
    g.rim_thickness_mm[i] = 0;
    g.web_thickness_mm[i] = 0;
  }
  g.inertia_kg_m2.reset();
  if (!(g.face_width_mm > 0))
    throw InputError(
        train_keys_in("gear.face_width_mm = 0: a stiffness from the gears needs their face width",
                      first, second));
  if (m.center_distance_mm) {
    g.center_distance_mm = *m.center_distance_mm;
  } else if (internal) {
    g.center_distance_mm = 0;
  } else {
    try {
      g.center_distance_mm =
          shifted_center_distance(false, g.teeth[0], g.teeth[1], g.profile_shift[0],
                                  g.profile_shift[1], g.normal_module_mm,
                                  g.normal_pressure_angle_deg / kRadToDeg, beta)
              .center_distance;
    } catch (const InputError& e) {
      throw InputError(
          train_keys_in(std::string(e.what()) + "; give center_distance_mm", first, second));
    }
  }
  // An external pair's tips not given: the standard basic rack's less the tip shortening k m_n
  // that the centre distance leaves of the shifts, k = x1 + x2 - (a - a_0) / m_n (ISO 21771),
  // as compute_geometry expects them.
  if (!internal) {
    const double a0 = 0.5 * (g.teeth[0] + g.teeth[1]) * g.normal_module_mm / std::cos(beta);
    const double k = std::max(0.0, g.profile_shift[0] + g.profile_shift[1] -
                                       (g.center_distance_mm - a0) / g.normal_module_mm);
    for (std::size_t i = 0; i < 2; ++i)
      if (!body[i]->outside_diameter_mm && k > 0)
        g.outside_diameter_mm[i] -= 2 * g.normal_module_mm * k;
  }
  c.mesh.stiffness_source = StiffnessSource::kEnergy;
  // Absent: 0, the curve's own mean.
  c.mesh.mean_stiffness_n_per_m = m.mean_stiffness_n_per_m.value_or(0.0);
  c.mesh.harmonics_kept = m.harmonics_kept;
  c.mesh.stiffness_harmonics.clear();
  c.speed.shaft_frequency_hz = 1;  // the series' frequencies only; read as mesh orders
  return c;
}

}  // namespace

TrainBodyData pinion_as_meshed(const TrainCase& t, const TrainBodyData& b) {
  if (b.outside_diameter_mm || b.teeth <= 0) return b;
  for (const TrainMeshData& m : t.meshes) {
    if (m.kind == MeshKind::kInternal || (m.driving != b.name && m.driven != b.name)) continue;
    const std::string& other = m.driving == b.name ? m.driven : m.driving;
    const auto x = std::find_if(t.bodies.begin(), t.bodies.end(),
                                [&](const TrainBodyData& y) { return y.name == other; });
    if (x == t.bodies.end() || x->teeth <= 0) continue;
    const bool first = m.driving == b.name;
    TrainBodyData out = b;
    try {
      out.outside_diameter_mm = (first ? mesh_pair_case(m, b, *x) : mesh_pair_case(m, *x, b))
                                    .gear.outside_diameter_mm[first ? 0 : 1];
    } catch (const InputError&) {
      return b;  // that mesh says why
    }
    return out;
  }
  return b;
}

namespace {
// A pair's mesh stiffness `of` it (a series in time at its gear 0's speed) as a train mesh has
// it: k_m and the ratios and phases at orders of its mesh frequency; an InputError of the pair
// in the train's keys of `first` and `second`.
template <class Series>
PairMeshStiffness pair_stiffness_of(const Case& c, Series&& of, const TrainBodyData& first,
                                    const TrainBodyData& second) {
  HarmonicSeries k;
  try {
    k = of();
  } catch (const InputError& e) {
    throw InputError(train_keys_in(e.what(), first, second));
  }
  PairMeshStiffness out;
  out.mean_n_per_m = k.offset;
  out.harmonics = harmonics_of<StiffnessHarmonic>(c, k, 2 * kPi * c.gear.teeth[0], 1 / k.offset,
                                                  "stiffness_source");
  return out;
}

// The energy method of an internal mesh (internal_mesh_stiffness): the pinion first, the ring
// second, at the mesh's centre distance when given (else the one their shifts give).
PairMeshStiffness internal_pair_mesh_stiffness(const TrainMeshData& m, const TrainBodyData& driving,
                                               const TrainBodyData& driven) {
  const PinionInRing g = pinion_in_ring(driving, driven);
  const Case c = mesh_pair_case(m, g.pinion, g.ring);
  return pair_stiffness_of(
      c, [&] { return mesh_stiffness_series(c, internal_mesh_stiffness(c)); }, g.pinion, g.ring);
}
}  // namespace

PairMeshStiffness pair_mesh_stiffness(const TrainMeshData& m, const TrainBodyData& driving,
                                      const TrainBodyData& driven) {
  if (m.kind == MeshKind::kInternal) return internal_pair_mesh_stiffness(m, driving, driven);
  const Case c = mesh_pair_case(m, driving, driven);
  return pair_stiffness_of(
      c, [&] { return mesh_stiffness_series(c, case_geometry(c)); }, driving, driven);
}

namespace {
// ISO 6336-1 Method B of an internal mesh (iso6336_internal_stiffness): the pinion first, the
// ring second, under the pinion's share of the driving torque (the same tangential force).
PairMeshStiffness iso_internal_mesh_stiffness(const TrainMeshData& m, const TrainBodyData& driving,
                                              const TrainBodyData& driven,
                                              std::optional<double> driving_torque_nm) {
  const auto [pinion, ring, ring_drives] = pinion_in_ring(driving, driven);
  Case c = mesh_pair_case(m, pinion, ring);
  c.mesh.stiffness_source = StiffnessSource::kIso6336;
  c.mesh.stiffness_harmonics = m.stiffness_harmonics;
  const double beta = pinion.helix_angle_deg / kRadToDeg;
  const double d_m = pinion.teeth * pinion.normal_module_mm * 1e-3 / std::cos(beta);
  const double share = ring_drives ? static_cast<double>(pinion.teeth) / ring.teeth : 1.0;
  c.load.torque_nm = driving_torque_nm ? *driving_torque_nm * share
                                       : 2 * kIsoFullLoadNPerMm * c.gear.face_width_mm * d_m / 2;
  PairMeshStiffness out;
  try {
    const Iso6336Stiffness iso = iso6336_internal_stiffness(c, internal_geometry(c.gear));
    out.mean_n_per_m = iso.mesh_stiffness_n_per_m;
    out.harmonics = m.stiffness_harmonics;
  } catch (const InputError& e) {
    throw InputError(train_keys_in(e.what(), pinion, ring));
  }
  return out;
}
}  // namespace

PairMeshStiffness iso_mesh_stiffness(const TrainMeshData& m, const TrainBodyData& driving,
                                     const TrainBodyData& driven,
                                     std::optional<double> driving_torque_nm) {
  if (m.kind == MeshKind::kInternal)
    return iso_internal_mesh_stiffness(m, driving, driven, driving_torque_nm);
  Case c = mesh_pair_case(m, driving, driven);
  c.mesh.stiffness_source = StiffnessSource::kIso6336;
  c.mesh.stiffness_harmonics = m.stiffness_harmonics;
  c.mesh.mean_stiffness_n_per_m = 0;
  // T = F_t d / 2 with F_t / b twice the line load above which ISO's load factor is 1.
  const double d_m = driving.teeth * driving.normal_module_mm * 1e-3 /
                     std::cos(driving.helix_angle_deg / kRadToDeg);
  c.load.torque_nm =
      driving_torque_nm.value_or(2 * kIsoFullLoadNPerMm * c.gear.face_width_mm * d_m / 2);
  PairMeshStiffness out;
  try {
    const MeshStiffness k = mesh_stiffness(c, case_geometry(c));
    out.mean_n_per_m = k.fourier.mean_n_per_m;
    out.harmonics = k.fourier.harmonics;
  } catch (const InputError& e) {
    throw InputError(train_keys_in(e.what(), driving, driven));
  }
  return out;
}

namespace {

// The gear pair's case that reads a train mesh's tables: a mesh frequency of 1 Hz (the series'
// terms read as mesh orders), the tables resampled as the pair's (its stiffness_positions).
Case mesh_table_case(const TrainMeshData& m, const std::filesystem::path& directory) {
  Case c;
  c.directory = directory;
  c.gear.teeth[0] = 1;
  c.speed.shaft_frequency_hz = 1;
  c.mesh.stiffness_source = StiffnessSource::kTable;
  c.mesh.stiffness_table = m.stiffness_table;
  c.mesh.mean_stiffness_n_per_m = m.mean_stiffness_n_per_m.value_or(0.0);  // 0: its own
  c.mesh.harmonics_kept = m.harmonics_kept;
  c.mesh.stiffness_harmonics.clear();
  c.mesh.transmission_error_um.clear();
  c.mesh.transmission_error_table = m.transmission_error_table;
  c.mesh.transmission_error_kept = m.transmission_error_kept;
  return c;
}

// The pair's message of a table in the mesh's keys.
std::string mesh_keys_in(std::string what) {
  for (const auto& [from, to] : std::array<std::pair<std::string_view, std::string_view>, 3>{
           {{"mesh.stiffness_table", "stiffness_table"},
            {"mesh.transmission_error_table", "transmission_error_table"},
            {"mesh.harmonics_kept", "harmonics_kept"}}})
    for (std::size_t at = what.find(from); at != std::string::npos;
         at = what.find(from, at + to.size()))
      what.replace(at, from.size(), to);
  return what;
}

}  // namespace

PairMeshStiffness table_mesh_stiffness(const TrainMeshData& m,
                                       const std::filesystem::path& directory) {
  const Case c = mesh_table_case(m, directory);
  HarmonicSeries k;
  try {
    k = mesh_stiffness_series(c, mesh_stiffness(c, Geometry{}));
  } catch (const InputError& e) {
    throw InputError(mesh_keys_in(e.what()));
  }
  PairMeshStiffness out;
  out.mean_n_per_m = k.offset;
  out.harmonics = harmonics_of<StiffnessHarmonic>(c, k, 2 * kPi, 1 / k.offset, "stiffness_table");
  return out;
}

TableMeshError table_mesh_error(const TrainMeshData& m, const std::filesystem::path& directory) {
  const Case c = mesh_table_case(m, directory);
  HarmonicSeries e;
  try {
    e = transmission_error_series(c);
  } catch (const InputError& x) {
    throw InputError(mesh_keys_in(x.what()));
  }
  TableMeshError out;
  out.mean_um = e.offset * 1e6;
  out.harmonics = harmonics_of<ErrorHarmonic>(c, e, 2 * kPi, 1e6, "transmission_error_table");
  return out;
}

namespace {

// A train's body by its name (one the assembler has checked).
const TrainBodyData& body_named(const TrainCase& t, const std::string& name) {
  return *std::find_if(t.bodies.begin(), t.bodies.end(),
                       [&](const TrainBodyData& b) { return b.name == name; });
}

// Defined below with train_mesh_pair.
Case internal_mesh_pair(const Case& c, const std::string& mesh);

}  // namespace

GearPairToRead gear_pair_to_read(const Case& c, const std::string& mesh, bool internal_too) {
  if (c.model.form == ModelForm::kTrain) {
    const TrainCase t = expand_planets(*c.train);
    const TrainMeshData& m = t.meshes.at(mesh_to_read(c, mesh));
    if (m.kind == MeshKind::kInternal) {
      if (!internal_too) {
        const auto origin = t.origins.find(fmt::format("mesh '{}'", m.name));
        throw InputError(fmt::format("{}train: {}",
                                     origin == t.origins.end() ? "" : origin->second + ": ",
                                     internal_pair_has_no_geometry(m.name)));
      }
      return {internal_mesh_pair(c, mesh), train_mesh_pair_warnings(c, mesh), true};
    }
    return {train_mesh_pair(c, mesh), train_mesh_pair_warnings(c, mesh)};
  }
  (void)mesh_to_read(c, mesh);  // refuses a name
  return {c, case_geometry(c).warnings};
}

std::string internal_pair_has_no_geometry(const std::string& mesh) {
  return fmt::format(
      "mesh '{0}': is internal: its geometry is no external gear pair's (`geardyn stiffness "
      "--mesh {0}` reads its stiffness: ISO 6336-1 and the energy method of a pinion in its ring)",
      mesh);
}

std::vector<std::string> train_mesh_pair_warnings(const Case& c, const std::string& mesh) {
  const std::size_t i = mesh_to_read(c, mesh);
  const TrainCase t = expand_planets(*c.train);
  const TrainMeshData& m = t.meshes.at(i);
  std::vector<std::string> out;
  for (const std::string& w :
       pair_mesh_warnings(m, body_named(t, m.driving), body_named(t, m.driven)))
    out.push_back(fmt::format("mesh '{}': {}", m.name, w));
  return out;
}

namespace {
// The mesh's stiffness source, k_m, harmonics or table as the train mesh x runs with them, and as
// load.torque_nm the torque F cos(beta_b) r_b of its force at the train's static state on its
// gear `first` (0 without one), on the pair `pair`.
void take_mesh_load(Case& pair, const train::Assembled& a, std::size_t i, const TrainMeshData& m,
                    double first_base_radius_m) {
  const train::Mesh& x = a.train().meshes[i];
  if (m.stiffness_source == "harmonics" || m.stiffness_source == "iso6336") {
    pair.mesh.stiffness_source =
        m.stiffness_source == "harmonics" ? StiffnessSource::kHarmonics : StiffnessSource::kIso6336;
    pair.mesh.mean_stiffness_n_per_m = x.mean_stiffness_n_per_m;
    pair.mesh.stiffness_harmonics = m.stiffness_harmonics;
  } else if (m.stiffness_source == "table") {
    pair.mesh.stiffness_source = StiffnessSource::kTable;
    pair.mesh.stiffness_table = m.stiffness_table;
  }
  if (const std::optional<Eigen::VectorXd> y = static_state(a))
    pair.load.torque_nm =
        static_mesh_forces_n(a, *y)[i] * std::cos(x.base_helix_angle_rad) * first_base_radius_m;
  else
    pair.load.torque_nm = 0;
}

// gear_pair_to_read's pair of an internal mesh.
Case internal_mesh_pair(const Case& c, const std::string& mesh) {
  const std::size_t i = mesh_to_read(c, mesh);
  const train::Assembled a = assembled_train(c);
  const TrainCase t = expand_planets(*c.train);
  const TrainMeshData& m = t.meshes.at(i);
  const TrainBodyData &driving = body_named(t, m.driving), &driven = body_named(t, m.driven);
  const auto [pinion, ring, ring_drives] = pinion_in_ring(driving, driven);
  Case pair;
  try {
    pair = mesh_pair_case(m, pinion_as_meshed(t, pinion), ring);
  } catch (const InputError& e) {
    const auto origin = t.origins.find(fmt::format("mesh '{}'", m.name));
    throw InputError(fmt::format("{}train: mesh '{}': {}",
                                 origin == t.origins.end() ? "" : origin->second + ": ", m.name,
                                 train_keys_in(e.what(), pinion, ring)));
  }
  pair.name = fmt::format("{}, mesh '{}'", c.name, m.name);
  pair.directory = c.directory;
  const train::Mesh& x = a.train().meshes[i];
  // The pinion's speed relative to the carrier: the mesh frequency over its teeth.
  pair.speed.shaft_frequency_hz = a.mesh_frequency_hz(static_cast<int>(i)) / pinion.teeth;
  take_mesh_load(pair, a, i, m, ring_drives ? x.base_radius_driven_m : x.base_radius_driving_m);
  return pair;
}
}  // namespace

Case train_mesh_pair(const Case& c, const std::string& mesh) {
  const std::size_t i = mesh_to_read(c, mesh);
  const train::Assembled a = assembled_train(c);
  const TrainCase t = expand_planets(*c.train);
  const TrainMeshData& m = t.meshes.at(i);
  const auto body = [&](const std::string& name) -> const TrainBodyData& {
    return body_named(t, name);
  };
  const auto origin = t.origins.find(fmt::format("mesh '{}'", m.name));
  const std::string where = origin == t.origins.end() ? "" : origin->second + ": ";
  if (m.kind == MeshKind::kInternal)
    throw InputError(fmt::format("{}train: {}", where, internal_pair_has_no_geometry(m.name)));
  Case pair;
  try {
    pair = mesh_pair_case(m, body(m.driving), body(m.driven));
    (void)case_geometry(pair);  // what the pair's geometry refuses, in the train's keys
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}train: mesh '{}': {}", where, m.name,
                                 train_keys_in(e.what(), body(m.driving), body(m.driven))));
  }
  pair.name = fmt::format("{}, mesh '{}'", c.name, m.name);
  pair.directory = c.directory;
  const train::Mesh& x = a.train().meshes[i];
  pair.speed.shaft_frequency_hz = a.mesh_frequency_hz(static_cast<int>(i)) / x.teeth_driving;
  take_mesh_load(pair, a, i, m, x.base_radius_driving_m);
  return pair;
}

std::vector<std::string> pair_mesh_warnings(const TrainMeshData& m, const TrainBodyData& driving,
                                            const TrainBodyData& driven) {
  std::vector<std::string> out;
  try {
    if (m.kind == MeshKind::kInternal) {
      const PinionInRing g = pinion_in_ring(driving, driven);
      for (const std::string& w :
           internal_geometry(mesh_pair_case(m, g.pinion, g.ring).gear).warnings)
        out.push_back(train_keys_in(w, g.pinion, g.ring));
      return out;
    }
    for (const std::string& w : case_geometry(mesh_pair_case(m, driving, driven)).warnings)
      out.push_back(train_keys_in(w, driving, driven));
  } catch (const InputError&) {
    // What the pair cannot take is said when the train is assembled.
  }
  return out;
}

Case train_form_of(const Case& c, const MeshStiffness* stiffness) {
  if (c.model.form == ModelForm::kNondimensional) return nondimensional_train(c);
  if (c.model.form == ModelForm::kTrain) return c;
  const bool coupled = c.model.form == ModelForm::kCoupled;
  // The coupled pair's gears, mesh and loads are its one-degree pair's (gear_pair_of).
  Geometry g;
  const GearPairModel model = build_model(coupled ? gear_pair_of(c) : c, &g, stiffness);
  const GearPairParameters& p = model.parameters();
  const double f1 = c.speed.shaft_frequency_hz;
  const double w_mesh = 2 * kPi * f1 * c.gear.teeth[0];

  Case out = train_case_of(c);
  TrainCase t;
  t.reference = "pinion";
  t.reference_speed_hz = f1;
  // The coupled model moves each gear along the line of action alone at dof 3 and 6, and keeps
  // its whole plane at dof 12.
  const BodyDof dof = !coupled           ? BodyDof::kTorsion
                      : c.model.dof == 3 ? BodyDof::kLine
                      : c.model.dof == 6 ? BodyDof::kLineAxial
                                         : BodyDof::kSpatial;
  for (int i = 0; i < 2; ++i) {
    TrainBodyData b;
    b.name = i == 0 ? "pinion" : "wheel";
    b.dof = dof;
    b.inertia_kg_m2 = g.inertia_kg_m2[static_cast<std::size_t>(i)];
    b.teeth = c.gear.teeth[static_cast<std::size_t>(i)];
    b.normal_module_mm = c.gear.normal_module_mm;
    b.normal_pressure_angle_deg = c.gear.normal_pressure_angle_deg;
    b.helix_angle_deg = c.gear.helix_angle_deg;
    b.face_width_mm = c.gear.face_width_mm;
    b.bore_diameter_mm = c.gear.bore_diameter_mm[static_cast<std::size_t>(i)];
    b.density_kg_m3 = c.gear.density_kg_m3;
    t.bodies.push_back(b);
  }
  TrainMeshData m;
  m.name = "mesh";
  m.driving = "pinion";
  m.driven = "wheel";
  m.backlash_um = c.mesh.backlash_um;
  m.mean_stiffness_n_per_m = p.stiffness_n_per_m.offset;
  m.stiffness_harmonics = harmonics_of<StiffnessHarmonic>(
      c, p.stiffness_n_per_m, w_mesh, 1 / p.stiffness_n_per_m.offset, "mesh.stiffness_source");
  m.transmission_error_um = harmonics_of<ErrorHarmonic>(c, p.transmission_error_m, w_mesh, 1e6,
                                                        "mesh.transmission_error_um");
  m.transmission_error_mean_um = p.transmission_error_m.offset * 1e6;  // a table's mean
  m.damping_ratio = c.mesh.damping_ratio;
  m.damping = c.mesh.damping == DampingForm::kAlways ? "always" : "contact";
  m.tension = c.mesh.tension == TensionRule::kClip ? "clip" : "allow";
  if (coupled) m.position_angle_deg = g.transverse_pressure_angle_rad * kRadToDeg;
  t.meshes.push_back(m);

  // The torques, on the shafts' ends when the coupled case has them.
  const bool motor = coupled && c.shafts.end_inertia_kg_m2[0] > 0,
             load = coupled && c.shafts.end_inertia_kg_m2[1] > 0;
  const std::array<const char*, 2> end = {"motor", "load"}, gear = {"pinion", "wheel"},
                                   shaft = {"drive_shaft", "load_shaft"};
  for (int i = 0; i < 2; ++i) {
    if (!(i == 0 ? motor : load)) continue;
    TrainBodyData b;
    b.name = end[static_cast<std::size_t>(i)];
    b.inertia_kg_m2 = c.shafts.end_inertia_kg_m2[static_cast<std::size_t>(i)];
    t.bodies.push_back(b);
    t.shafts.push_back({shaft[static_cast<std::size_t>(i)], end[static_cast<std::size_t>(i)],
                        gear[static_cast<std::size_t>(i)],
                        c.shafts.stiffness_n_m_per_rad[static_cast<std::size_t>(i)],
                        c.shafts.damping_ratio, std::nullopt, std::nullopt});
  }
  const double w1 = 2 * kPi * f1;
  const double w2 = w1 * c.gear.teeth[0] / c.gear.teeth[1];
  const HarmonicSeries t1 = drive_torque_nm(c);
  t.torques.push_back({"drive", motor ? "motor" : "pinion", t1.offset, orders_of(t1, w1, 1.0),
                       false, std::nullopt});
  if (c.load.load_torque_nm) {
    const HarmonicSeries t2 = load_torque_nm(c);
    t.torques.push_back({"load", load ? "load" : "wheel", -t2.offset, orders_of(t2, w2, -1.0),
                         false, std::nullopt});
  } else {
    const double ratio = g.base_radius_m[1] / g.base_radius_m[0];
    t.torques.push_back({"load", load ? "load" : "wheel", -ratio * t1.offset,
                         orders_of(t1, w2, -ratio), false, std::nullopt});
  }

  if (coupled) {
    const BearingData& x = c.bearings;
    for (std::size_t i = 0; i < 2; ++i) {
      TrainBearingData b;
      b.name = fmt::format("{}_bearing", gear[i]);
      b.body = gear[i];
      b.stiffness_n_per_m = x.radial_stiffness_n_per_m[i];
      b.damping_ratio = x.damping_ratio;
      b.clearance_um = x.radial_clearance_um[i];
      if (c.model.dof >= 6) b.axial_stiffness_n_per_m = x.axial_stiffness_n_per_m[i];
      if (c.model.dof == 12) b.tilt_stiffness_n_m_per_rad = x.tilt_stiffness_n_m_per_rad[i];
      t.bearings.push_back(b);
    }
  }
  out.train = std::make_shared<TrainCase>(std::move(t));
  return out;
}

}  // namespace geardyn
