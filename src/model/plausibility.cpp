#include "geardyn/plausibility.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include "geardyn/train.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_statics.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
// A static mesh force below minus this fraction of the train's force scale is on the back flank;
// rounding leaves some 1e-16 of it.
constexpr double kBackFlankFraction = 1e-9;
// ISO 6336-2's zone factor of an unshifted 20-degree spur pair and the elasticity factor of two
// steel gears (N^0.5/mm): the nominal contact stress's order, all that a plausibility needs.
constexpr double kZoneFactor = 2.5;
constexpr double kSteelElasticityFactor = 189.8;

// Where a key of the written case came from, as " (file:line)", or "".
class Origins {
 public:
  explicit Origins(const TrainCase& t) : t_(t) {}
  std::string operator()(const std::string& label) const {
    const auto o = t_.origins.find(label);
    return o == t_.origins.end() ? std::string() : fmt::format(" ({})", o->second);
  }

 private:
  const TrainCase& t_;
};

const TrainBodyData* body_named(const TrainCase& t, const std::string& name) {
  for (const TrainBodyData& b : t.bodies)
    if (b.name == name) return &b;
  return nullptr;
}

bool is_gear(const TrainBodyData* b) { return b && b->teeth > 0 && b->normal_module_mm > 0; }

// A module finer than any gear's: a value in metres.
void check_modules(const TrainCase& t, const Origins& origin, std::vector<std::string>& out) {
  for (std::size_t i = 0; i < t.bodies.size(); ++i) {
    const TrainBodyData& b = t.bodies[i];
    if (b.teeth > 0 && b.normal_module_mm > 0 && b.normal_module_mm < kFinestModuleMm)
      out.push_back(fmt::format(
          "train.body[{}].normal_module_mm = {}{}: body '{}' has a module finer than any gear "
          "is cut with (about {} mm and up): a module is in millimetres (was it written in "
          "metres?)",
          i, b.normal_module_mm, origin(fmt::format("body '{}': normal_module_mm", b.name)), b.name,
          kFinestModuleMm));
  }
}

// A backlash no gear pair of its module and centre distance is cut with: a value in mm.
void check_backlash(const TrainCase& t, const Origins& origin, std::vector<std::string>& out) {
  for (std::size_t i = 0; i < t.meshes.size(); ++i) {
    const TrainMeshData& m = t.meshes[i];
    const TrainBodyData *a = body_named(t, m.driving), *b = body_named(t, m.driven);
    if (!is_gear(a) || !is_gear(b) || !(m.backlash_um > 0)) continue;
    double center_mm = 0;
    try {
      center_mm =
          m.center_distance_mm.value_or(mesh_center_distance_from_gears(m, *a, *b).center_distance);
    } catch (const InputError&) {
      continue;  // the assembly says why
    }
    const double least_um =
        1e3 * (2.0 / 3.0) * (0.06 + 0.0005 * center_mm + 0.03 * a->normal_module_mm) / 2;
    if (m.backlash_um < kLeastBacklashShare * least_um)
      out.push_back(fmt::format(
          "train.mesh[{}].backlash_um = {}{}: mesh '{}' has {:.3g} of the least backlash a "
          "pair of module {} mm {:.4g} mm apart is cut with (b, half the normal backlash, about "
          "{:.3g} um): a backlash is in micrometres (was it written in millimetres?)",
          i, m.backlash_um, origin(fmt::format("mesh '{}': backlash_um", m.name)), m.name,
          m.backlash_um / least_um, a->normal_module_mm, center_mm, least_um));
  }
}

// A pin off the centre distance its planet's teeth mesh at; a planet whose meshes put it at two.
void check_pins(const TrainCase& t, const Origins& origin, std::vector<std::string>& out) {
  for (std::size_t i = 0; i < t.bearings.size(); ++i) {
    const TrainBearingData& b = t.bearings[i];
    if (b.on.empty()) continue;
    const std::optional<double> gears = pin_radius_from_gears_mm(t, b);
    if (b.pin_radius_mm != 0 && gears &&
        std::abs(b.pin_radius_mm - *gears) > kPinRadiusTolerance * *gears)
      out.push_back(fmt::format(
          "train.bearing[{}].pin_radius_mm = {}{}: bearing '{}' holds its pin {:.3g} % off the "
          "centre distance its gears' teeth, module and profile shifts give, {:.6g} mm: the "
          "planet does not sit where its teeth mesh (leave pin_radius_mm out to have it from the "
          "gears)",
          i, b.pin_radius_mm, origin(fmt::format("bearing '{}': pin_radius_mm", b.name)), b.name,
          100 * (b.pin_radius_mm - *gears) / *gears, *gears));
    if (!gears) continue;
    // Each of the planet's meshes with a gear on no pin, against the first's.
    const TrainBodyData* planet = body_named(t, b.body);
    for (const TrainMeshData& m : t.meshes) {
      const std::string other = m.driving == b.body  ? m.driven
                                : m.driven == b.body ? m.driving
                                                     : std::string();
      const TrainBodyData* gear = other.empty() ? nullptr : body_named(t, other);
      if (!is_gear(planet) || !is_gear(gear)) continue;
      double a_mm = 0;
      try {
        a_mm = mesh_center_distance_from_gears(m, *planet, *gear).center_distance;
      } catch (const InputError&) {
        continue;  // the assembly says why
      }
      if (std::abs(a_mm - *gears) > kPinRadiusTolerance * *gears)
        out.push_back(fmt::format(
            "mesh '{}'{}: its gears' teeth, module and profile shifts put planet '{}' {:.6g} mm "
            "from '{}', where its other mesh puts it {:.6g} mm from the carrier's axis: one pin "
            "cannot hold it at both (a ring's profile_shift is in ISO 21771's sign: positive "
            "thickens its teeth and moves its tip circle inwards)",
            m.name, origin(fmt::format("mesh '{}'", m.name)), b.body, a_mm, other, *gears));
    }
  }
}

// What the assembled train at rest shows: a mesh on its back flank, a pitch line faster than
// any gear's, a contact stress no steel bears.
// Each joint at the static state: in the stage the linearisation takes (settle_joints stops
// after kJointSettlingPasses passes: a joint still moving then is said, as modes and the static
// state read another stage than the one its load lies in), and not resting on a stop.
void check_joints_at_rest(const train::Assembled& a, const Eigen::VectorXd& rest,
                          const Origins& origin, std::vector<std::string>& out) {
  for (std::size_t j = 0; j < a.joints().size(); ++j) {
    const train::Joint& x = a.joints()[j];
    const int operating = a.operating_stages()[j];
    if (operating < 0) continue;
    const double at = x.row.dot(rest.head(a.size())) - x.offset;
    const int stage = x.stage_at(at);
    const double force = x.force(stage, at, 0.0);
    // Its force's unit, from its reading's name ("torque_nm": N m).
    const std::string unit = x.force_what.ends_with("_nm")  ? " N m"
                             : x.force_what.ends_with("_n") ? " N"
                                                            : "";
    if (stage != operating)
      out.push_back(fmt::format(
          "{}{}: the static state did not settle it: its load ({:.6g}{}) lies in its stage {} but "
          "modes and the static state take stage {} (its stages' engagement points may lie too "
          "close to the static load to tell)",
          x.label, origin(x.label), force, unit, stage, operating));
    else if (x.stops && x.stage_count() > 1 && (stage == 0 || stage == x.stage_count() - 1))
      out.push_back(fmt::format(
          "{}{}: rests on its stop at the static load ({:.6g}{}, {} = {:.6g}): the static "
          "load is more than its stages carry before the stop; a stiffer or longer stage before "
          "the stop, or a later stop, is more likely what was meant",
          x.label, origin(x.label), force, unit, x.deformation_what, at));
  }
}

void check_at_rest(const Case& c, const Origins& origin, std::vector<std::string>& out) {
  const train::Assembled a = assembled_train(c);
  const train::Train& t = a.train();
  const TrainCase& written = *c.train;
  // The written gears of each assembled mesh (a planet's copies, the planet's name and their
  // number, share the written planet's).
  const auto gear = [&](const std::string& name) {
    const TrainBodyData* b = body_named(written, name);
    const std::string& planet = written.planet;
    if (!b && !planet.empty() && name.size() > planet.size() && name.starts_with(planet) &&
        std::all_of(name.begin() + static_cast<std::ptrdiff_t>(planet.size()), name.end(),
                    [](char ch) { return ch >= '0' && ch <= '9'; }))
      b = body_named(written, planet);
    return b;
  };
  for (std::size_t i = 0; i < t.meshes.size(); ++i) {
    const train::Mesh& m = t.meshes[i];
    const TrainBodyData* x = gear(m.driving);
    if (!is_gear(x)) continue;
    const double r_m =
        x->teeth * x->normal_module_mm * 1e-3 / (2 * std::cos(x->helix_angle_deg * kPi / 180));
    // Its driving gear's turn relative to the mesh's frame (a planet's on its carrier), from
    // the mesh frequency z f.
    const double speed = 2 * kPi * r_m * a.mesh_frequency_hz(static_cast<int>(i)) / x->teeth;
    if (speed > kFastestPitchLineSpeedMPerS)
      out.push_back(fmt::format(
          "mesh '{}': its pitch line runs at {:.4g} m/s, faster than any gear's (about {} m/s "
          "at most): is train.reference_speed_hz = {}{} a speed in rpm? (Hz = rpm / 60)",
          m.name, speed, kFastestPitchLineSpeedMPerS, t.reference_speed_hz,
          origin("the train: reference_speed_hz")));
  }
  const std::optional<Eigen::VectorXd> rest = static_state(a);
  if (!rest) return;
  check_joints_at_rest(a, *rest, origin, out);
  const std::vector<double> f = static_mesh_forces_n(a, *rest);
  // Against the largest static force or the mesh's force across its backlash: rounding leaves
  // some 1e-11 N on a train with no torque.
  double scale = 0;
  for (std::size_t m = 0; m < f.size(); ++m)
    scale = std::max(
        {scale, std::abs(f[m]), t.meshes[m].mean_stiffness_n_per_m * t.meshes[m].backlash_m});
  for (std::size_t m = 0; m < f.size(); ++m) {
    const train::Mesh& mesh = t.meshes[m];
    if (f[m] < -kBackFlankFraction * scale)
      out.push_back(fmt::format(
          "mesh '{}'{}: loaded on its back flank at rest (static force {:.6g} N): are its "
          "driving and driven gears the wrong way round (the driving gear's torque pushes the "
          "other), or a torque's sign (a drive > 0 along its body's rotation, a load < 0)?",
          mesh.name, origin(fmt::format("mesh '{}'", mesh.name)), f[m]));
    const TrainBodyData *x = gear(mesh.driving), *y = gear(mesh.driven);
    if (!is_gear(x) || !is_gear(y)) continue;
    const TrainBodyData& pinion = x->teeth <= y->teeth ? *x : *y;
    const double width_mm = std::min(x->face_width_mm, y->face_width_mm);
    if (!(width_mm > 0)) continue;
    // sigma_H0 = Z_H Z_E sqrt(F_t / (d_1 b) (u +- 1) / u), F_t the normal force's transverse
    // tangential part.
    const double u = static_cast<double>(std::max(x->teeth, y->teeth)) / pinion.teeth;
    const double d1_mm =
        pinion.teeth * pinion.normal_module_mm / std::cos(pinion.helix_angle_deg * kPi / 180);
    const double ft_n = std::abs(f[m]) * std::cos(mesh.base_helix_angle_rad) *
                        std::cos(mesh.transverse_pressure_angle_rad);
    const double sigma = kZoneFactor * kSteelElasticityFactor *
                         std::sqrt(ft_n / (d1_mm * width_mm) * (u + (mesh.internal ? -1 : 1)) / u);
    if (sigma > kMostContactStressMpa)
      out.push_back(fmt::format(
          "mesh '{}'{}: its static force, {:.4g} N, gives a nominal contact stress of about "
          "{:.3g} MPa on its {} mm face, over {} MPa where case-hardened steel bears about 1500: "
          "is a torque in N mm written as N m? (the train's torques are in N m)",
          mesh.name, origin(fmt::format("mesh '{}'", mesh.name)), f[m], sigma, width_mm,
          kMostContactStressMpa));
  }
}

}  // namespace

std::vector<std::string> train_plausibility(const Case& c) {
  std::vector<std::string> out;
  if (c.model.form != ModelForm::kTrain || !c.train) return out;
  const TrainCase& written = *c.train;
  const Origins origin(written);
  check_modules(written, origin, out);
  check_backlash(written, origin, out);
  check_pins(written, origin, out);
  try {
    check_at_rest(c, origin, out);
  } catch (const InputError&) {
    // The run names what does not assemble.
  }
  return out;
}

}  // namespace geardyn
