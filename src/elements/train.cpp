#include "geardyn/train.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <map>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>
#include <queue>
#include <set>
#include <stdexcept>

#include "geardyn/input_error.hpp"

namespace geardyn::train {
namespace {

using ode::Matrix;
using ode::RowVector;
using ode::Vector;
using Complex = std::complex<double>;

constexpr double kTwoPi = 2.0 * std::numbers::pi;
// An eigenvalue of K phi = w^2 M phi below this fraction of the largest is a rigid mode's zero:
// rounding leaves some 1e-15 of the largest there, and only an elastic mode below a millionth of
// the fastest mode's frequency would be taken for rigid.
constexpr double kRigidEigenvalueFraction = 1e-12;
// A joint acts along a rigid motion when |row r| exceeds this fraction of |row| |r|: more than
// the rounding of a joint between two bodies the motion turns alike.
constexpr double kAlongRigidMotion = 1e-9;
// An eigenvalue of the gyroscopic problem whose imaginary part is below this fraction of the
// largest eigenvalue modulus is real (a divergence): rounding leaves some 1e-14 there.
constexpr double kRealEigenvalueFraction = 1e-10;
// Two frequencies of the table within this relative distance are one (they come from ratios of
// whole numbers, equal to rounding).
constexpr double kSameFrequency = 1e-12;

// A periodic signal as complex amplitudes of the harmonics of one angular frequency w:
// x(t) = Re sum_n c_n e^(i n w t), n >= 0 (c_0 real).
using Spectrum = std::map<int, Complex>;

Spectrum product(const Spectrum& a, const Spectrum& b) {
  Spectrum out;
  for (const auto& [n, x] : a)
    for (const auto& [m, y] : b) {
      out[n + m] += 0.5 * x * y;
      const int k = n - m;
      const Complex z = 0.5 * x * std::conj(y);
      if (k >= 0)
        out[k] += z;
      else
        out[-k] += std::conj(z);
    }
  // The constant term counted twice above for n = m = 0 only in its two halves: exact.
  return out;
}

Spectrum derivative(const Spectrum& a, double w) {
  Spectrum out;
  for (const auto& [n, x] : a)
    if (n > 0) out[n] = Complex(0, n * w) * x;
  return out;
}

Spectrum scaled(const Spectrum& a, double s) {
  Spectrum out;
  for (const auto& [n, x] : a) out[n] = s * x;
  return out;
}

Spectrum plus(Spectrum a, const Spectrum& b) {
  for (const auto& [n, x] : b) a[n] += x;
  return a;
}

// Harmonic i of the mesh frequency at index stride i (the base frequency its stride-th part).
Spectrum from_harmonics(double mean, const std::vector<MeshHarmonic>& h, double scale, int stride) {
  Spectrum s;
  s[0] = mean;
  for (std::size_t i = 0; i < h.size(); ++i)
    s[stride * (static_cast<int>(i) + 1)] += scale * std::polar(h[i].value, h[i].phase_rad);
  return s;
}

HarmonicSeries series_of(const Spectrum& s, double w) {
  HarmonicSeries out;
  for (const auto& [n, c] : s) {
    if (n == 0) {
      out.offset += c.real();
    } else if (std::abs(c) > 0) {
      out.terms.push_back({std::abs(c), n * w, std::arg(c)});
    }
  }
  return out;
}

int frequency_index(std::vector<double>& table, double w) {
  for (std::size_t i = 0; i < table.size(); ++i)
    if (std::abs(table[i] - w) <= kSameFrequency * w) return static_cast<int>(i);
  table.push_back(w);
  return static_cast<int>(table.size()) - 1;
}

[[noreturn]] void bad(const std::string& element, const std::string& what) {
  throw InputError(fmt::format("{}: {}", element, what));
}

}  // namespace

Assembled::Assembled(Train t) : t_(std::move(t)) {
  std::set<std::string> names;
  for (const Body& b : t_.bodies) {
    if (b.name.empty()) bad("a body", "needs a name");
    if (b.name == kGround)
      bad(fmt::format("body '{}'", b.name),
          fmt::format("the name \"{}\" is the ground's, to which shafts hold bodies", kGround));
    if (!names.insert(b.name).second)
      bad(fmt::format("body '{}'", b.name), "is named twice (a body is in one place only)");
    if (!(b.inertia_kg_m2 > 0 && std::isfinite(b.inertia_kg_m2)))
      bad(fmt::format("body '{}'", b.name),
          fmt::format("inertia_kg_m2 = {}: must be a finite inertia > 0 kg m^2", b.inertia_kg_m2));
    if (b.planar && !(b.mass_kg > 0 && std::isfinite(b.mass_kg)))
      bad(fmt::format("body '{}'", b.name),
          fmt::format("mass_kg = {}: a planar body needs a finite mass > 0 kg", b.mass_kg));
    if (b.spatial && !b.planar)
      bad(fmt::format("body '{}'", b.name),
          "is spatial but not planar: a spatial body keeps its centre's x and y too");
    if (b.line && (!b.planar || (b.spatial && b.tilts)))
      bad(fmt::format("body '{}'", b.name),
          "is held to its line but not planar, or tilts: a body held to its mesh's line of "
          "action moves along it (and along its axis) only");
    if (b.spatial && b.tilts && !(b.tilt_inertia_kg_m2 > 0 && std::isfinite(b.tilt_inertia_kg_m2)))
      bad(fmt::format("body '{}'", b.name),
          fmt::format("tilt_inertia_kg_m2 = {}: a spatial body needs a finite inertia about a "
                      "diameter > 0 kg m^2",
                      b.tilt_inertia_kg_m2));
    if (!(b.eccentricity_m >= 0 && std::isfinite(b.eccentricity_m) &&
          std::isfinite(b.eccentricity_angle_rad)))
      bad(fmt::format("body '{}'", b.name),
          fmt::format("eccentricity = {} m at {} rad: must be finite and >= 0", b.eccentricity_m,
                      b.eccentricity_angle_rad));
  }
  if (t_.meshes.empty()) bad("the train", "has no mesh: a gear train needs at least one");
  const auto body = [&](const std::string& element, const char* key, const std::string& name) {
    const int i = index(name);
    if (i < 0)
      bad(element, fmt::format("{} = \"{}\": no body of that name (bodies: {})", key, name,
                               fmt::join(names, ", ")));
    return i;
  };
  for (const Mesh& m : t_.meshes) {
    const std::string e = fmt::format("mesh '{}'", m.name);
    const int a = body(e, "driving", m.driving), b = body(e, "driven", m.driven);
    if (a == b)
      bad(e, fmt::format("driving = driven = \"{}\": a mesh joins two bodies", m.driving));
    if (m.teeth_driving < 1 || m.teeth_driven < 1)
      bad(e, fmt::format("teeth = [{}, {}]: must be whole numbers >= 1", m.teeth_driving,
                         m.teeth_driven));
    if (m.internal && m.teeth_driving == m.teeth_driven)
      bad(e, fmt::format("internal with teeth = [{}, {}]: a ring gear has more teeth than the "
                         "pinion inside it",
                         m.teeth_driving, m.teeth_driven));
    if (!(m.base_radius_driving_m > 0 && m.base_radius_driven_m > 0))
      bad(e, "base radii must be > 0 m");
    if (!(m.backlash_m > 0)) bad(e, fmt::format("backlash = {} m: must be > 0", m.backlash_m));
    if (!(m.mean_stiffness_n_per_m > 0))
      bad(e, fmt::format("mean stiffness = {} N/m: must be > 0", m.mean_stiffness_n_per_m));
    double sum = 0;
    for (const MeshHarmonic& h : m.stiffness) sum += std::abs(h.value);
    if (!(sum < 1)) bad(e, "stiffness harmonic ratios must sum to < 1 (k stays > 0)");
  }
  for (const Shaft& s : t_.shafts) {
    const std::string e = fmt::format("shaft '{}'", s.name);
    if (s.b != kGround && body(e, "a", s.a) == body(e, "b", s.b))
      bad(e, "a shaft joins two bodies");
    if (s.b == kGround) body(e, "a", s.a);
    if (!(s.stiffness_n_m_per_rad > 0)) bad(e, "stiffness must be > 0 N m/rad");
  }
  for (const auto& x : t_.elements)
    for (const auto& [key, name] : x->bodies())
      if (name != kGround) body(x->label(), key.c_str(), name);
  std::set<int> supported;
  std::vector<double> axial_held(t_.bodies.size(), 0.0), tilt_held(t_.bodies.size(), 0.0);
  const bool pinned = std::any_of(t_.bearings.begin(), t_.bearings.end(),
                                  [](const Bearing& x) { return !x.on.empty(); });
  for (const Body& b : t_.bodies)
    if (b.spatial && (pinned || t_.frame_terms))
      bad(fmt::format("body '{}'", b.name),
          pinned ? "is spatial in a train with pins: a planetary set is planar here (its bodies "
                   "keep torsion, or x and y too)"
                 : "is spatial with frame_terms = true: its tilts' gyroscopic terms in the "
                   "turning frame are not modelled");
  for (const Bearing& x : t_.bearings) {
    const std::string e = fmt::format("bearing '{}'", x.name);
    const int i = body(e, "body", x.body);
    for (const auto& [key, value] : {std::pair{"axial_stiffness", x.axial_stiffness_n_per_m},
                                     std::pair{"axial_damping", x.axial_damping_n_s_per_m},
                                     std::pair{"tilt_stiffness", x.tilt_stiffness_n_m_per_rad},
                                     std::pair{"tilt_damping", x.tilt_damping_n_m_s_per_rad}}) {
      if (!(value >= 0 && std::isfinite(value)))
        bad(e, fmt::format("{} = {}: must be finite and >= 0", key, value));
      const Body& held = t_.bodies[static_cast<std::size_t>(i)];
      if (value != 0 && !held.spatial)
        bad(e, fmt::format("{} = {} is read only for a spatial body (dof = \"spatial\"); body "
                           "'{}' is not",
                           key, value, x.body));
      if (value != 0 && held.spatial && !held.tilts && std::string_view(key).starts_with("tilt"))
        bad(e, fmt::format("{} = {} is read only for a body that tilts (dof = \"spatial\"); body "
                           "'{}' keeps z alone (dof = \"{}\")",
                           key, value, x.body, held.line ? "line_axial" : "axial"));
    }
    axial_held[static_cast<std::size_t>(i)] += x.axial_stiffness_n_per_m;
    tilt_held[static_cast<std::size_t>(i)] += x.tilt_stiffness_n_m_per_rad;
    if (!t_.bodies[i].planar)
      bad(e, fmt::format("body = \"{}\" keeps torsion only (dof = \"torsion\"): a bearing "
                         "carries a planar body (dof = \"planar\")",
                         x.body));
    if (!(x.stiffness_n_per_m > 0 && std::isfinite(x.stiffness_n_per_m)))
      bad(e, fmt::format("stiffness = {} N/m: must be finite and > 0", x.stiffness_n_per_m));
    if (!(x.clearance_m >= 0 && std::isfinite(x.clearance_m)))
      bad(e, fmt::format("clearance = {} m: must be finite and >= 0", x.clearance_m));
    if (!x.on.empty()) {
      if (t_.bodies[static_cast<std::size_t>(i)].line)
        bad(e, fmt::format("body = \"{}\" is held to its line: a body on a pin moves in the "
                           "plane (dof = \"planar\")",
                           x.body));
      if (body(e, "on", x.on) == i)
        bad(e, fmt::format("on = \"{}\": a body's pin carries another body", x.on));
      if (!(x.pin_radius_m >= 0 && std::isfinite(x.pin_radius_m) && std::isfinite(x.pin_angle_rad)))
        bad(e, fmt::format("pin radius = {} m: must be finite and >= 0", x.pin_radius_m));
    }
    supported.insert(i);
  }
  for (std::size_t i = 0; i < t_.bodies.size(); ++i) {
    // The body's dof as a case names it.
    const Body& b = t_.bodies[i];
    const char* dof = b.line       ? (b.spatial ? "line_axial" : "line")
                      : !b.spatial ? "planar"
                      : b.tilts    ? "spatial"
                                   : "axial";
    if (t_.bodies[i].planar && !supported.count(static_cast<int>(i)))
      bad(fmt::format("body '{}'", t_.bodies[i].name),
          fmt::format("is {0} (dof = \"{0}\") but no bearing carries it: its centre would be "
                      "free; add a [[train.bearing]] with body = its name",
                      dof));
    if (t_.bodies[i].spatial && !(axial_held[i] > 0 && (tilt_held[i] > 0 || !t_.bodies[i].tilts)))
      bad(fmt::format("body '{}'", t_.bodies[i].name),
          fmt::format("is {0} (dof = \"{0}\") but its bearings' {1} stiffness is 0: it "
                      "would be free to {2}; give a bearing of it that stiffness",
                      dof, axial_held[i] > 0 ? "tilt" : "axial",
                      axial_held[i] > 0 ? "tilt" : "slide along its axis"));
  }
  std::set<int> prescribed_bodies;
  for (const Speed& v : t_.speeds) {
    const std::string e = fmt::format("speed '{}'", v.name);
    if (!prescribed_bodies.insert(body(e, "body", v.body)).second)
      bad(e, fmt::format("body = \"{}\": its speed is prescribed twice", v.body));
    for (const SpeedHarmonic& h : v.harmonics)
      if (!(std::isfinite(h.amplitude_rad) && h.order > 0 && std::isfinite(h.order)))
        bad(e, "each harmonic needs a finite amplitude (rad) and an order > 0");
  }
  // A torque on a body whose speed is prescribed would do nothing: refused, not dropped.
  for (const Torque& q : t_.torques)
    if (prescribed_bodies.count(body(fmt::format("torque '{}'", q.name), "body", q.body)))
      bad(fmt::format("torque '{}'", q.name),
          fmt::format("body = \"{}\": its speed is prescribed, so no torque acts on it", q.body));
  const int ref = body("the train", "reference", t_.reference);
  if (!(t_.reference_speed_hz > 0)) bad("the train", "reference_speed_hz must be > 0");

  // The nominal motion: every body's speed, every mesh's and body's frame (kinematics.hpp).
  const int n = body_count();
  {
    KinematicGraph g;
    for (const Body& b : t_.bodies) g.bodies.push_back(b.name);
    g.reference = ref;
    for (const Mesh& m : t_.meshes)
      g.meshes.push_back({fmt::format("mesh '{}'", m.name), index(m.driving), index(m.driven),
                          m.teeth_driving, m.teeth_driven, m.internal});
    for (const Shaft& s : t_.shafts)
      g.shafts.push_back({fmt::format("shaft '{}'", s.name), index(s.a),
                          s.b == kGround ? KinematicGraph::kToGround : index(s.b)});
    for (const auto& x : t_.elements)
      for (const auto& [a, b] : x->couplings())
        g.shafts.push_back(
            {x->label(), index(a), b == kGround ? KinematicGraph::kToGround : index(b)});
    for (const Bearing& x : t_.bearings)
      if (!x.on.empty())
        g.pins.push_back({fmt::format("bearing '{}'", x.name), index(x.body), index(x.on)});
    motion_ = solve_nominal_motion(g);
    graph_ = std::move(g);
  }
  for (int i = 0; i < body_count(); ++i)
    if (t_.bodies[static_cast<std::size_t>(i)].planar && frame(i) == kMixedFrame)
      bad(fmt::format("body '{}'", t_.bodies[static_cast<std::size_t>(i)].name),
          "is planar but meshes in two frames (a planetary set's carrier's and another's, or the "
          "ground's): its translations are read in one frame; give it dof = \"torsion\"");
  // A mesh whose driving gear turns backward in its sense (a part of the train whose bodies'
  // relative speeds disagree in sign across frames) has its teeth placed the wrong way by the
  // layout's rule, which assumes forward rolling.
  if (t_.mesh_phase_from_layout)
    for (int m = 0; m < static_cast<int>(t_.meshes.size()); ++m)
      if (motion_.relative(index(t_.meshes[m].driving), mesh_frame(m)).num < 0)
        bad(fmt::format("mesh '{}'", t_.meshes[m].name),
            "mesh_phase = \"layout\": its driving gear turns backward relative to its frame "
            "(the train's senses of rotation disagree across a carrier), which the layout's rule "
            "does not place; give each mesh's phases instead");
  // Orders of a body at rest have no frequency: a fluctuation there is refused, not dropped.
  for (const Torque& q : t_.torques)
    if (motion_.speed[static_cast<std::size_t>(index(q.body))].num == 0 && !q.harmonics.empty())
      bad(fmt::format("torque '{}'", q.name),
          fmt::format("body = \"{}\" is at rest (held, or turned by nothing): harmonics at "
                      "orders of its speed have no frequency (give its mean torque only)",
                      q.body));
  for (const Speed& v : t_.speeds)
    if (motion_.speed[static_cast<std::size_t>(index(v.body))].num == 0)
      bad(fmt::format("speed '{}'", v.name),
          fmt::format("body = \"{}\" is at rest: its speed cannot be prescribed at orders of "
                      "its speed",
                      v.body));
  // The coordinates: every rotation, then each planar body's x and y (its w when held to its
  // line, along its one mesh's line of action).
  for (const Body& b : t_.bodies) names_.push_back(b.name + "_rad");
  for (const Body& b : t_.bodies) {
    translation_.push_back(b.planar ? static_cast<int>(names_.size()) : -1);
    basis_.push_back(Eigen::MatrixXd::Identity(2, b.plane_extent()));
    if (b.line) {
      std::vector<int> meshes;
      for (std::size_t m = 0; m < t_.meshes.size(); ++m)
        if (t_.meshes[m].driving == b.name || t_.meshes[m].driven == b.name)
          meshes.push_back(static_cast<int>(m));
      if (meshes.size() != 1)
        bad(fmt::format("body '{}'", b.name),
            fmt::format("is held to its line (dof = \"{}\") but is in {} meshes: it moves "
                        "along the line of action of one mesh (give it dof = \"{}\")",
                        b.spatial ? "line_axial" : "line", meshes.size(),
                        b.spatial ? "axial" : "planar"));
      basis_.back() = line_of_action(meshes[0]);
      names_.push_back(b.name + "_line_m");
    } else if (b.planar) {
      names_.push_back(b.name + "_x_m");
      names_.push_back(b.name + "_y_m");
    }
    if (b.spatial) names_.push_back(b.name + "_z_m");
    if (b.spatial && b.tilts) {
      names_.push_back(b.name + "_tx_rad");
      names_.push_back(b.name + "_ty_rad");
    }
  }
  // Each clearance's directions, x then y, but a direction a body held to its line cannot move in.
  for (std::size_t k = 0; k < t_.bearings.size(); ++k)
    if (t_.bearings[k].clearance_m > 0)
      for (const int axis : {0, 1})
        if (plane_basis(index(t_.bearings[k].body)).row(axis).norm() > 0)
          clearances_.push_back({static_cast<int>(k), axis});
  phase_.assign(t_.meshes.size(), 0.0);
  if (t_.mesh_phase_from_layout) place_teeth();
  m_ = Eigen::MatrixXd::Zero(size(), size());
  for (int i = 0; i < n; ++i) {
    m_(i, i) = t_.bodies[i].inertia_kg_m2;
    if (const int x = translation(i); x >= 0) {
      const Eigen::MatrixXd& p = plane_basis(i);
      m_.block(x, x, p.cols(), p.cols()) = t_.bodies[i].mass_kg * p.transpose() * p;
    }
    if (const int z = axial(i); z >= 0) m_(z, z) = t_.bodies[i].mass_kg;
    if (const int x = tilt(i); x >= 0)
      m_(x, x) = m_(x + 1, x + 1) = t_.bodies[i].tilt_inertia_kg_m2;
  }
  // The frames' rotation terms: each planar body in a carrier's frame turns with its carrier's
  // absolute speed. (Without a planar body in one the terms act on nothing: case_keys reports
  // the key unused.)
  frame_rates_.assign(static_cast<std::size_t>(n), 0.0);
  if (t_.frame_terms)
    for (int i = 0; i < n; ++i)
      if (const int c = frame(i); c >= 0 && t_.bodies[static_cast<std::size_t>(i)].planar) {
        frame_rates_[static_cast<std::size_t>(i)] = body_speed_hz(c) * kTwoPi;
        if (frame_rate_ == 0) frame_rate_ = frame_rates_[static_cast<std::size_t>(i)];
      }
  // The joints: each clearance direction, k (x -+ c) beyond +-c and nothing inside, its
  // damping in contact only; then each element's.
  for (const auto& [k, axis] : clearances_) {
    const Bearing& x = t_.bearings[static_cast<std::size_t>(k)];
    const double c = x.clearance_m, kb = x.stiffness_n_per_m, cb = x.damping_n_s_per_m;
    Joint j;
    j.name = x.name + (axis == 0 ? "_x" : "_y");
    j.label = fmt::format("bearing '{}'", x.name);
    j.row = bearing_matrix(k).row(axis);
    j.offset = bearing_offset(k)(axis);
    j.edges = {-c, c};
    j.stages = {{kb, kb * c, cb}, {0, 0, 0}, {kb, -kb * c, cb}};
    j.rest = 1;
    j.scale = c;
    j.linearised = false;
    joints_.push_back(std::move(j));
  }
  for (const auto& x : t_.elements)
    for (Joint& j : x->joints(*this)) {
      if (j.row.size() != size() || j.stages.size() != j.edges.size() + 1 ||
          !std::is_sorted(j.edges.begin(), j.edges.end()) || j.rest < 0 ||
          j.rest >= j.stage_count() || j.operating < 0 || j.operating >= j.stage_count())
        throw std::logic_error(x->label() + ": a joint out of its contract (joint.hpp)");
      j.label = x->label();
      (j.stage_count() == 1 && !j.read ? links_ : joints_).push_back(std::move(j));
    }
  for (const Joint& j : joints_) operating_.push_back(j.linearised ? j.operating : -1);
}

void Assembled::set_operating_stages(std::vector<int> stages) {
  if (stages.size() != joints_.size())
    throw std::logic_error("set_operating_stages: one stage per joint");
  for (std::size_t j = 0; j < stages.size(); ++j)
    if (!joints_[j].linearised)
      stages[j] = -1;
    else if (stages[j] < 0 || stages[j] >= joints_[j].stage_count())
      throw std::logic_error("set_operating_stages: a stage the joint does not have");
  operating_ = std::move(stages);
}

Eigen::VectorXd Assembled::joint_load() const {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(size());
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    if (operating_[j] < 0) continue;
    const JointStage& s = joints_[j].stages[static_cast<std::size_t>(operating_[j])];
    q += (s.stiffness * joints_[j].offset - s.force_at_zero) * joints_[j].row.transpose();
  }
  for (const Joint& x : links_)
    q += (x.stages[0].stiffness * x.offset - x.stages[0].force_at_zero) * x.row.transpose();
  return q;
}

double Assembled::body_speed_hz(int body) const {
  // + 0.0: a body at rest turning the reference's way back reads 0, not -0.
  return sense(body) * value(motion_.speed[static_cast<std::size_t>(body)]) *
             t_.reference_speed_hz +
         0.0;
}

double Assembled::mean_power_nm() const {
  double p = 0;
  for (const Torque& q : t_.torques)
    p += q.mean_nm * value(motion_.speed[static_cast<std::size_t>(index(q.body))]);
  // The joints' constant forces along the nominal motion: -f_s (row r).
  Eigen::VectorXd r = Eigen::VectorXd::Zero(size());
  for (int i = 0; i < body_count(); ++i) r(i) = value(motion_.speed[static_cast<std::size_t>(i)]);
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    const int stage = operating_[j] >= 0 ? operating_[j] : joints_[j].rest;
    p -= joints_[j].stages[static_cast<std::size_t>(stage)].force_at_zero * joints_[j].row.dot(r);
  }
  for (const Joint& x : links_) p -= x.stages[0].force_at_zero * x.row.dot(r);
  return p;
}

bool Assembled::damps_rigid_motions() const {
  const Eigen::MatrixXd rigid = rigid_motions();
  if (rigid.cols() == 0) return false;
  for (const std::vector<Joint>* joints : {&joints_, &links_})
    for (const Joint& j : *joints) {
      const bool damped = std::any_of(j.stages.begin(), j.stages.end(),
                                      [](const JointStage& s) { return s.damping != 0; });
      if (damped &&
          (j.row * rigid).cwiseAbs().maxCoeff() > kAlongRigidMotion * j.row.norm() * rigid.norm())
        return true;
    }
  return false;
}

double Assembled::turning_hz(int body) const { return std::abs(body_speed_hz(body)); }

Eigen::MatrixXd Assembled::frame_stiffness() const {
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(size(), size());
  for (int i = 0; i < body_count(); ++i)
    if (const int x = translation(i); x >= 0) {
      const double w = frame_rate_rad_s(i);
      const Eigen::MatrixXd& p = plane_basis(i);
      k.block(x, x, p.cols(), p.cols()) -=
          w * w * t_.bodies[static_cast<std::size_t>(i)].mass_kg * p.transpose() * p;
    }
  // A carried body's softening on its displacement from its pin's turned place, v = u - theta_c
  // d_c (d_c = -B's column of theta_c: w = u - ... - theta_c d_c): -m Omega^2 v v^T adds to the
  // -m Omega^2 u u^T above the cross terms m Omega^2 (d_c e_c^T + e_c d_c^T) and
  // -m Omega^2 |d_c|^2 on theta_c.
  for (std::size_t k_b = 0; k_b < t_.bearings.size(); ++k_b) {
    const Bearing& b = t_.bearings[k_b];
    if (b.on.empty()) continue;
    const int carried = index(b.body), carrier = index(b.on), x = translation(carried);
    const double w = frame_rate_rad_s(carried);
    const double mw2 = w * w * t_.bodies[static_cast<std::size_t>(carried)].mass_kg;
    const Eigen::Vector2d d = -bearing_matrix(static_cast<int>(k_b)).block(0, carrier, 2, 1);
    k.block(x, carrier, 2, 1) += mw2 * d;
    k.block(carrier, x, 1, 2) += mw2 * d.transpose();
    k(carrier, carrier) -= mw2 * d.squaredNorm();
  }
  return k;
}

Eigen::MatrixXd Assembled::frame_damping() const {
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(size(), size());
  for (int i = 0; i < body_count(); ++i)
    if (const int x = translation(i); x >= 0) {
      // 2 m Omega [[0, -1], [1, 0]] on u = P q_p (nothing on a body held to its line).
      const Eigen::MatrixXd& p = plane_basis(i);
      const double g = 2 * frame_rate_rad_s(i) * t_.bodies[static_cast<std::size_t>(i)].mass_kg;
      c.block(x, x, p.cols(), p.cols()) +=
          g * p.transpose() * (Eigen::Matrix2d() << 0, -1, 1, 0).finished() * p;
    }
  return c;
}

Eigen::VectorXd Assembled::frame_load() const {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(size());
  for (const Bearing& b : t_.bearings) {
    if (b.on.empty()) continue;
    const int carried = index(b.body);
    const double w = frame_rate_rad_s(carried);
    q.segment(translation(carried), 2) +=
        w * w * t_.bodies[static_cast<std::size_t>(carried)].mass_kg * b.pin_radius_m *
        Eigen::Vector2d(std::cos(b.pin_angle_rad), std::sin(b.pin_angle_rad));
  }
  return q;
}

namespace {

// The angle of a mesh's pitch point seen from its driving and from its driven gear's centre
// (train.hpp): external, the driven centre's direction psi and its opposite; internal, psi + pi
// from both when the pinion drives (its ring's centre lies at psi), psi from both when the ring
// drives.
std::array<double, 2> pitch_point_angles(const Mesh& m) {
  constexpr double kPi = std::numbers::pi;
  const double psi = m.position_angle_rad;
  if (!m.internal) return {psi, psi + kPi};
  const bool ring_drives = m.teeth_driving > m.teeth_driven;
  return ring_drives ? std::array<double, 2>{psi, psi}
                     : std::array<double, 2>{psi + kPi, psi + kPi};
}

// x mod 1 in [0, 1).
double cycles(double x) { return x - std::floor(x); }

}  // namespace

void Assembled::place_teeth() {
  // A gear is a body with a number of teeth; phi its tooth centre's angle at t = 0 (rad), its
  // pitch p = 2 pi / z, its teeth p / 2 thick at the pitch circle. A flank has passed an angle
  // psi by the fraction s (flank - psi) / p of a pitch, s the gear's sense: the driving gear's
  // leading flank is at phi + s p / 4, the driven gear's trailing one at phi - s p / 4, and the
  // two pass the pitch point together.
  std::map<std::pair<int, int>, double> phi;
  const auto passed = [&](int body, int teeth, double flank_offset_pitches, double psi) {
    const double p = kTwoPi / teeth, s = sense(body);
    return cycles(s * (phi.at({body, teeth}) + s * flank_offset_pitches * p - psi) / p);
  };
  const auto place = [&](int body, int teeth, double flank_offset_pitches, double psi, double u) {
    const double p = kTwoPi / teeth, s = sense(body);
    phi[{body, teeth}] = psi - s * flank_offset_pitches * p + s * u * p;
  };
  constexpr double kLeading = 0.25, kTrailing = -0.25;  // in pitches from the tooth's centre
  // A loop closes when the phase from the driven side misses the driving side's by more than
  // rounding of angles of a few turns.
  constexpr double kInterlock = 1e-9;
  std::vector<bool> done(t_.meshes.size(), false);
  const auto start = [&](int body, int teeth) {
    if (!phi.count({body, teeth})) phi[{body, teeth}] = 0.0;  // a tooth on +x
  };
  // The reference's gear first, else the first mesh's driving gear; then every mesh one of
  // whose gears is placed, and a part of the train joined to the rest by shafts alone from its
  // first mesh's driving gear.
  const int ref = index(t_.reference);
  for (const Mesh& m : t_.meshes) {
    if (index(m.driving) == ref || index(m.driven) == ref) {
      start(ref, index(m.driving) == ref ? m.teeth_driving : m.teeth_driven);
      break;
    }
  }
  for (;;) {
    bool progress = false;
    for (std::size_t j = 0; j < t_.meshes.size(); ++j) {
      const Mesh& m = t_.meshes[j];
      const int a = index(m.driving), b = index(m.driven);
      const std::pair<int, int> ga{a, m.teeth_driving}, gb{b, m.teeth_driven};
      if (done[j] || (!phi.count(ga) && !phi.count(gb))) continue;
      const std::array<double, 2> psi = pitch_point_angles(m);
      if (phi.count(ga)) {
        phase_[j] = passed(a, m.teeth_driving, kLeading, psi[0]);
        if (!phi.count(gb)) {
          place(b, m.teeth_driven, kTrailing, psi[1], phase_[j]);
        } else {
          const double miss =
              cycles(passed(b, m.teeth_driven, kTrailing, psi[1]) - phase_[j] + 0.5) - 0.5;
          if (std::abs(miss) > kInterlock)
            bad(fmt::format("mesh '{}'", m.name),
                fmt::format("closes a loop of meshes whose teeth cannot interlock at this layout "
                            "(the driven gear's teeth are {:.6g} of a pitch off the driving "
                            "gear's): the tooth counts do not allow these position angles",
                            miss));
        }
      } else {
        phase_[j] = passed(b, m.teeth_driven, kTrailing, psi[1]);
        place(a, m.teeth_driving, kLeading, psi[0], phase_[j]);
      }
      done[j] = true;
      progress = true;
    }
    if (progress) continue;
    const auto next = std::find(done.begin(), done.end(), false);
    if (next == done.end()) break;
    const Mesh& m = t_.meshes[static_cast<std::size_t>(next - done.begin())];
    start(index(m.driving), m.teeth_driving);
  }
  // Each mesh's harmonics delayed by its phase: k(t + u T), harmonic i by 2 pi i u.
  for (std::size_t j = 0; j < t_.meshes.size(); ++j) {
    Mesh& m = t_.meshes[j];
    for (std::size_t i = 0; i < m.stiffness.size(); ++i)
      m.stiffness[i].phase_rad += kTwoPi * static_cast<double>(i + 1) * phase_[j];
    for (std::size_t i = 0; i < m.transmission_error.size(); ++i)
      m.transmission_error[i].phase_rad += kTwoPi * static_cast<double>(i + 1) * phase_[j];
  }
}

int Assembled::shaft_observable(int shaft) const {
  return 2 * static_cast<int>(t_.meshes.size()) + shaft;
}

int Assembled::bearing_observable(int bearing) const {
  int i = 2 * static_cast<int>(t_.meshes.size()) + static_cast<int>(t_.shafts.size());
  for (int k = 0; k < bearing; ++k) i += 2 + static_cast<int>(support_matrix(k).rows());
  return i;
}

Eigen::VectorXd Assembled::rigid_rotation() const {
  Eigen::VectorXd r = Eigen::VectorXd::Zero(size());
  for (int i = 0; i < body_count(); ++i) r(i) = value(motion_.speed[static_cast<std::size_t>(i)]);
  return r;
}

int Assembled::index(const std::string& body) const {
  for (std::size_t i = 0; i < t_.bodies.size(); ++i)
    if (t_.bodies[i].name == body) return static_cast<int>(i);
  return -1;
}

bool Assembled::prescribed(int body) const {
  return std::any_of(t_.speeds.begin(), t_.speeds.end(),
                     [&](const Speed& v) { return index(v.body) == body; });
}

Eigen::MatrixXd Assembled::rigid_motions() const {
  const bool supported = std::any_of(t_.shafts.begin(), t_.shafts.end(),
                                     [](const Shaft& s) { return s.b == kGround; });
  const bool pinned = std::any_of(t_.bearings.begin(), t_.bearings.end(),
                                  [](const Bearing& b) { return !b.on.empty(); });
  if (!supported && !pinned) {
    if (!t_.speeds.empty()) return Eigen::MatrixXd::Zero(size(), 0);
    return rigid_rotation();
  }
  // The null space of K over the free coordinates, from K phi = w^2 M phi as modes() reads it.
  std::vector<Eigen::Index> free;
  for (int i = 0; i < size(); ++i)
    if (!prescribed(i)) free.push_back(i);
  const auto nf = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd select = Eigen::MatrixXd::Zero(size(), nf);
  for (Eigen::Index j = 0; j < nf; ++j) select(free[static_cast<std::size_t>(j)], j) = 1;
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> solver(
      select.transpose() * contact_stiffness() * select, select.transpose() * m_ * select);
  const Eigen::VectorXd& w2 = solver.eigenvalues();
  Eigen::Index rigid = 0;
  while (rigid < w2.size() && w2(rigid) <= kRigidEigenvalueFraction * w2.maxCoeff()) ++rigid;
  Eigen::MatrixXd out = select * solver.eigenvectors().leftCols(rigid);
  const int ref = index(t_.reference);
  for (Eigen::Index c = 0; c < rigid; ++c)
    if (std::abs(out(ref, c)) > kRigidEigenvalueFraction * out.col(c).cwiseAbs().maxCoeff())
      out.col(c) /= out(ref, c);
  return out;
}

Eigen::MatrixXd Assembled::reduced_basis() const {
  const Eigen::Index n = size();
  const Eigen::MatrixXd rigid_q = rigid_motions();
  const Eigen::Index k = rigid_q.cols();
  if (!t_.speeds.empty() || k == 0) {
    std::vector<Eigen::Index> free;
    for (Eigen::Index i = 0; i < n; ++i)
      if (!prescribed(static_cast<int>(i))) free.push_back(i);
    const auto m = static_cast<Eigen::Index>(free.size());
    Eigen::MatrixXd q = Eigen::MatrixXd::Zero(2 * n, 2 * m);
    for (Eigen::Index j = 0; j < m; ++j) {
      q(free[static_cast<std::size_t>(j)], j) = 1;
      q(n + free[static_cast<std::size_t>(j)], m + j) = 1;
    }
    if (k == 0) return q;
    // The rigid motions left among the free coordinates: their complement there.
    Eigen::MatrixXd rigid = Eigen::MatrixXd::Zero(2 * m, k);
    rigid.topRows(m) = q.topLeftCorner(n, m).transpose() * rigid_q;
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(rigid);
    const Eigen::MatrixXd full = qr.householderQ() * Eigen::MatrixXd::Identity(2 * m, 2 * m);
    return q * full.rightCols(2 * m - k);
  }
  // The rigid motions (r, 0), r the speed ratios in a train of meshes and shafts; Q the rest of
  // an orthonormal basis whose first columns are them (Householder).
  Eigen::MatrixXd rigid = Eigen::MatrixXd::Zero(2 * n, k);
  rigid.topRows(n) = rigid_q;
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(rigid);
  const Eigen::MatrixXd full = qr.householderQ() * Eigen::MatrixXd::Identity(2 * n, 2 * n);
  return full.rightCols(2 * n - k);
}

namespace {

// The prescribed rotation of a speed element, theta(t), at its body's own speed.
HarmonicSeries rotation_series(const Assembled& a, const Speed& v) {
  const double w = kTwoPi * a.turning_hz(a.index(v.body));
  HarmonicSeries s;
  for (const SpeedHarmonic& h : v.harmonics)
    s.terms.push_back({h.amplitude_rad, h.order * w, h.phase_rad});
  return s;
}

}  // namespace

void Assembled::prescribe(double t_s, Eigen::VectorXd& y) const {
  const int n = size();
  for (const Speed& v : t_.speeds) {
    const int i = index(v.body);
    const HarmonicSeries rotation = rotation_series(*this, v);
    y(i) = rotation(t_s);  // no offset: about the nominal rotation
    y(n + i) = rotation.rate(t_s);
  }
}

std::vector<Ratio> Assembled::mesh_frequency_ratios() const {
  std::vector<Ratio> out;
  for (std::size_t m = 0; m < t_.meshes.size(); ++m)
    out.push_back(motion_.mesh_frequency(static_cast<int>(m), graph_));
  return out;
}

double Assembled::mesh_frequency_hz(int mesh) const {
  return t_.reference_speed_hz * value(mesh_frequency_ratios()[mesh]);
}

double Assembled::coefficient_period_s() const {
  // gcd of p_i / q_i = gcd(p_i) / lcm(q_i), over the meshes that vary.
  std::int64_t num = 0, den = 1;
  const std::vector<Ratio> f = mesh_frequency_ratios();
  for (std::size_t m = 0; m < f.size(); ++m) {
    const Mesh& x = t_.meshes[m];
    if (x.stiffness.empty() && x.transmission_error.empty()) continue;
    num = std::gcd(num, f[m].num);
    den = std::lcm(den, f[m].den);
  }
  if (num == 0) return 0;
  return static_cast<double>(den) / (static_cast<double>(num) * t_.reference_speed_hz);
}

namespace {

// The fraction p/q (q <= kMaxOrderDenominator) within kOrderTolerance of x > 0, by continued
// fractions; none when there is no such fraction.
std::optional<Ratio> as_fraction(double x) {
  std::int64_t p0 = 0, q0 = 1, p1 = 1, q1 = 0;
  double r = x;
  for (int k = 0; k < 64; ++k) {
    const double a = std::floor(r);
    if (!(a < 1e15)) break;
    const auto ai = static_cast<std::int64_t>(a);
    const std::int64_t p2 = ai * p1 + p0, q2 = ai * q1 + q0;
    if (q2 > kMaxOrderDenominator) break;
    if (std::abs(static_cast<double>(p2) / static_cast<double>(q2) - x) <= kOrderTolerance * x)
      return reduced(p2, q2);
    p0 = p1;
    q0 = q1;
    p1 = p2;
    q1 = q2;
    if (r - a <= 0) break;
    r = 1.0 / (r - a);
  }
  return std::nullopt;
}

}  // namespace

std::optional<double> Assembled::system_period_s(std::string* why) const {
  // Every excitation's frequency over the reference speed, with what it is.
  std::vector<std::pair<Ratio, std::string>> ratios;
  const std::vector<Ratio> mesh = mesh_frequency_ratios();
  for (std::size_t m = 0; m < mesh.size(); ++m)
    if (!t_.meshes[m].stiffness.empty() || !t_.meshes[m].transmission_error.empty())
      ratios.emplace_back(mesh[m], fmt::format("mesh '{}'", t_.meshes[m].name));
  const auto orders = [&](const std::string& element, const std::string& body, double order,
                          double amplitude) {
    if (amplitude == 0) return true;
    const Ratio speed = absolute(motion_.speed[static_cast<std::size_t>(index(body))]);
    const std::optional<Ratio> o = as_fraction(order);
    if (!o) {
      if (why)
        *why = fmt::format(
            "{}: order {} is no fraction with a denominator up to {}: the "
            "excitations have no common period (quasi-periodic)",
            element, order, kMaxOrderDenominator);
      return false;
    }
    ratios.emplace_back(times(speed, o->num, o->den), element);
    return true;
  };
  for (const Torque& q : t_.torques)
    for (const TorqueHarmonic& h : q.harmonics)
      if (!orders(fmt::format("torque '{}'", q.name), q.body, h.order, h.amplitude_nm))
        return std::nullopt;
  for (const Speed& v : t_.speeds)
    for (const SpeedHarmonic& h : v.harmonics)
      if (!orders(fmt::format("speed '{}'", v.name), v.body, h.order, h.amplitude_rad))
        return std::nullopt;
  // A turning gear's runout, once per its turn relative to its mesh's frame.
  for (std::size_t m = 0; m < t_.meshes.size(); ++m)
    for (const std::string& gear : {t_.meshes[m].driving, t_.meshes[m].driven})
      if (t_.bodies[static_cast<std::size_t>(index(gear))].eccentricity_m > 0)
        ratios.emplace_back(
            absolute(motion_.relative(index(gear), mesh_frame(static_cast<int>(m)))),
            fmt::format("body '{}' (its runout)", gear));
  if (ratios.empty()) return 0.0;
  // gcd of p_i / q_i = gcd(p_i) / lcm(q_i); past the bound, the excitations are quasi-periodic.
  std::int64_t num = 0, den = 1;
  double slowest = ratios.front().first.num / static_cast<double>(ratios.front().first.den);
  for (const auto& [r, element] : ratios) {
    num = std::gcd(num, r.num);
    den = std::lcm(den, r.den);
    slowest = std::min(slowest, value(r));
  }
  const double base = static_cast<double>(num) / static_cast<double>(den);
  if (!(slowest / base <= kMaxPeriodMultiple)) {
    if (why)
      *why = fmt::format(
          "the excitations' common period is {:.6g} periods of the slowest of "
          "them; at most {:g} count as periodic (quasi-periodic)",
          slowest / base, kMaxPeriodMultiple);
    return std::nullopt;
  }
  return 1.0 / (base * t_.reference_speed_hz);
}

Eigen::Vector2d Assembled::line_of_action(int mesh) const {
  // n = s_a cos(alpha_t) t + sigma sin(alpha_t) e at the pitch point's angle psi_P (train.hpp).
  const Mesh& m = t_.meshes[static_cast<std::size_t>(mesh)];
  const bool ring_drives = m.internal && m.teeth_driving > m.teeth_driven;
  const double psi = pitch_point_angles(m)[0];
  const double alpha = m.transverse_pressure_angle_rad;
  const double s = sense(index(m.driving)) * std::cos(alpha),
               r = (ring_drives ? -1.0 : 1.0) * std::sin(alpha);
  return {-s * std::sin(psi) + r * std::cos(psi), s * std::cos(psi) + r * std::sin(psi)};
}

Eigen::RowVectorXd Assembled::mesh_vector(int mesh) const {
  const Mesh& m = t_.meshes[mesh];
  Eigen::RowVectorXd v = Eigen::RowVectorXd::Zero(size());
  const double cb = std::cos(m.base_helix_angle_rad);
  const int a = index(m.driving), b = index(m.driven);
  v(a) += cb * m.base_radius_driving_m;
  v(b) -= cb * m.base_radius_driven_m;
  const Eigen::Vector2d n = line_of_action(mesh);
  const double nx = n.x(), ny = n.y();
  if (const int x = translation(a); x >= 0)
    v.segment(x, plane_basis(a).cols()) += cb * n.transpose() * plane_basis(a);
  if (const int x = translation(b); x >= 0)
    v.segment(x, plane_basis(b).cols()) -= cb * n.transpose() * plane_basis(b);
  // The axial part sin(beta_b) h (w_a - w_b), w = z + tx r_y - ty r_x at the contact point
  // r = s R (n_y, -n_x).
  const double sb = m.axial_sense * std::sin(m.base_helix_angle_rad);
  const auto axial_part = [&](int body, double radius, double sign) {
    const int z = axial(body), x = tilt(body);
    if (z < 0 || sb == 0) return;
    v(z) += sign * sb;
    if (x < 0) return;
    const double rx = sense(body) * radius * ny, ry = -sense(body) * radius * nx;
    v(x) += sign * sb * ry;
    v(x + 1) -= sign * sb * rx;
  };
  axial_part(a, m.base_radius_driving_m, 1.0);
  axial_part(b, m.base_radius_driven_m, -1.0);
  return v;
}

Eigen::MatrixXd Assembled::bearing_matrix(int bearing) const {
  const Bearing& x = t_.bearings[static_cast<std::size_t>(bearing)];
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(2, size());
  const int i = index(x.body);
  b.block(0, translation(i), 2, plane_basis(i).cols()) = plane_basis(i);
  if (!x.on.empty()) {
    const int j = index(x.on);
    if (const int u = translation(j); u >= 0)
      b.block(0, u, 2, plane_basis(j).cols()) -= plane_basis(j);
    // The pin's point turns with j: theta_j s_j z x r, r = R (cos psi, sin psi).
    const double s = sense(j) * x.pin_radius_m;
    b(0, j) += s * std::sin(x.pin_angle_rad);
    b(1, j) -= s * std::cos(x.pin_angle_rad);
  }
  return b;
}

Eigen::MatrixXd Assembled::support_matrix(int bearing) const {
  const int body = index(t_.bearings[static_cast<std::size_t>(bearing)].body);
  const int z = axial(body);
  if (z < 0) return Eigen::MatrixXd::Zero(0, size());
  const int rows = tilt(body) < 0 ? 1 : 3;
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(rows, size());
  s.block(0, z, rows, rows) = Eigen::MatrixXd::Identity(rows, rows);
  return s;
}

Eigen::Vector2d Assembled::bearing_offset(int bearing) const {
  const Bearing& x = t_.bearings[static_cast<std::size_t>(bearing)];
  const double c = std::cos(x.pin_angle_rad), s = std::sin(x.pin_angle_rad);
  Eigen::Vector2d o(x.pin_error_radial_m * c - x.pin_error_tangential_m * s,
                    x.pin_error_radial_m * s + x.pin_error_tangential_m * c);
  // A pin turns with its carrier's centre of pins: the carrier, at rest, shifts it by its
  // eccentricity.
  if (!x.on.empty()) {
    const Body& carrier = t_.bodies[static_cast<std::size_t>(index(x.on))];
    o += carrier.eccentricity_m * Eigen::Vector2d(std::cos(carrier.eccentricity_angle_rad),
                                                  std::sin(carrier.eccentricity_angle_rad));
  }
  return o;
}

RowVector Assembled::shaft_vector(int shaft) const {
  const Shaft& s = t_.shafts[static_cast<std::size_t>(shaft)];
  RowVector v = RowVector::Zero(size());
  v(index(s.a)) = 1;
  if (s.b != kGround) v(index(s.b)) = -1;
  return v;
}

namespace {

// A spatial body's bearing's stiffnesses (or dampings) on its z, tx and ty.
Eigen::Vector3d support_diagonal(const Bearing& x, bool damping) {
  return damping ? Eigen::Vector3d(x.axial_damping_n_s_per_m, x.tilt_damping_n_m_s_per_rad,
                                   x.tilt_damping_n_m_s_per_rad)
                 : Eigen::Vector3d(x.axial_stiffness_n_per_m, x.tilt_stiffness_n_m_per_rad,
                                   x.tilt_stiffness_n_m_per_rad);
}

// The shafts', bearings' and links' K and C, which every region shares; with `engaged` (the
// linearisation that modes and the static state read) a bearing with a clearance as if it had
// none and every other joint at its operating stage, each joint its region's otherwise.
void stamp_common(const Assembled& a, Eigen::MatrixXd& k, Eigen::MatrixXd& c, bool engaged) {
  const Train& t = a.train();
  k = Eigen::MatrixXd::Zero(a.size(), a.size());
  c = k;
  for (std::size_t i = 0; i < t.shafts.size(); ++i) {
    const RowVector v = a.shaft_vector(static_cast<int>(i));
    k += t.shafts[i].stiffness_n_m_per_rad * v.transpose() * v;
    c += t.shafts[i].damping_n_m_s_per_rad * v.transpose() * v;
  }
  for (std::size_t i = 0; i < t.bearings.size(); ++i) {
    if (t.bearings[i].clearance_m > 0 && !engaged) continue;
    const Eigen::MatrixXd b = a.bearing_matrix(static_cast<int>(i));
    k += t.bearings[i].stiffness_n_per_m * b.transpose() * b;
    c += t.bearings[i].damping_n_s_per_m * b.transpose() * b;
  }
  for (std::size_t i = 0; i < t.bearings.size(); ++i) {
    const Eigen::MatrixXd s = a.support_matrix(static_cast<int>(i));
    if (s.rows() == 0) continue;
    const Bearing& x = t.bearings[i];
    k += s.transpose() * support_diagonal(x, false).head(s.rows()).asDiagonal() * s;
    c += s.transpose() * support_diagonal(x, true).head(s.rows()).asDiagonal() * s;
  }
  if (a.frame_rate_rad_s() != 0) {
    k += a.frame_stiffness();
    c += a.frame_damping();
  }
  for (const Joint& x : a.links()) {
    k += x.stages[0].stiffness * x.row.transpose() * x.row;
    c += x.stages[0].damping * x.row.transpose() * x.row;
  }
  // The linearised joints at their operating stages (with `engaged`: in a region each joint
  // stamps its region's stage).
  if (!engaged) return;
  for (std::size_t j = 0; j < a.joints().size(); ++j) {
    const int stage = a.operating_stages()[j];
    if (stage < 0) continue;
    const Joint& x = a.joints()[j];
    const JointStage& g = x.stages[static_cast<std::size_t>(stage)];
    k += g.stiffness * x.row.transpose() * x.row;
    c += g.damping * x.row.transpose() * x.row;
  }
}

}  // namespace

namespace {

// K and C with every mesh in drive contact at its mean stiffness.
void stamp_contact(const Assembled& a, Eigen::MatrixXd& k, Eigen::MatrixXd& c) {
  stamp_common(a, k, c, true);
  const std::vector<Mesh>& meshes = a.train().meshes;
  for (int m = 0; m < static_cast<int>(meshes.size()); ++m) {
    const Eigen::RowVectorXd v = a.mesh_vector(m);
    const Eigen::MatrixXd vtv = v.transpose() * v;
    k += meshes[m].mean_stiffness_n_per_m * vtv;
    c += meshes[m].damping_n_s_per_m * vtv;
  }
}

}  // namespace

Eigen::MatrixXd Assembled::contact_stiffness() const {
  Eigen::MatrixXd k, c;
  stamp_contact(*this, k, c);
  return k;
}

Eigen::MatrixXd Assembled::contact_damping() const {
  Eigen::MatrixXd k, c;
  stamp_contact(*this, k, c);
  return c;
}

namespace {

// The contact states of mesh x: 3 (-1, 0, 1), or 5 (-2 .. 2) when it clips its tension.
int radix(const Mesh& x) { return x.clips() ? 5 : 3; }

}  // namespace

int Assembled::region_count() const {
  int n = 1;
  for (const Mesh& x : t_.meshes) n *= radix(x);
  for (const Joint& j : joints_) n *= j.stage_count();
  return n;
}

int Assembled::region(const std::vector<int>& states, const std::vector<int>& joint_states) const {
  int r = 0, p = 1;
  for (std::size_t m = 0; m < states.size(); ++m) {
    const int base = radix(t_.meshes[m]);
    r += (states[m] + base / 2) * p;
    p *= base;
  }
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    r += ((j < joint_states.size() ? joint_states[j] : 0) + joints_[j].rest) * p;
    p *= joints_[j].stage_count();
  }
  return r;
}

std::vector<int> Assembled::states(int region) const {
  std::vector<int> s;
  for (const Mesh& x : t_.meshes) {
    const int base = radix(x);
    s.push_back(region % base - base / 2);
    region /= base;
  }
  return s;
}

std::vector<int> Assembled::joint_states(int region) const {
  for (const Mesh& x : t_.meshes) region /= radix(x);
  std::vector<int> s;
  for (const Joint& j : joints_) {
    s.push_back(region % j.stage_count() - j.rest);
    region /= j.stage_count();
  }
  return s;
}

namespace {

// A mesh's stiffness k(t) and error e(t) (its transmission error, less its gears' runouts) as
// harmonics of one base frequency w: the mesh frequency w_m = z_a w_a = z_b w_b, or with a
// runout w_m / lcm(z_a, z_b), of which each gear's speed is a whole multiple.
struct MeshSignals {
  double w = 0;
  Spectrum k, e;
};

MeshSignals mesh_signals(const Assembled& a, int mesh) {
  const Train& t = a.train();
  const Mesh& x = t.meshes[static_cast<std::size_t>(mesh)];
  const int ia = a.index(x.driving), ib = a.index(x.driven);
  const auto eccentric = [&](int body) {
    return t.bodies[static_cast<std::size_t>(body)].eccentricity_m > 0;
  };
  const int stride = eccentric(ia) || eccentric(ib) ? std::lcm(x.teeth_driving, x.teeth_driven) : 1;
  MeshSignals s;
  s.w = kTwoPi * a.mesh_frequency_hz(mesh) / stride;
  s.k = from_harmonics(x.mean_stiffness_n_per_m, x.stiffness, x.mean_stiffness_n_per_m, stride);
  s.e = from_harmonics(x.transmission_error_mean_m, x.transmission_error, 1.0, stride);
  const Eigen::Vector2d n = a.line_of_action(mesh);
  const double cb = std::cos(x.base_helix_angle_rad);
  // e -= sign cb n . epsilon(t), epsilon = e (cos(s w_g t + phi), sin(s w_g t + phi)) at the
  // gear's speed w_g = w_m / z: Re[cb e (n_x - i s n_y) e^(i s phi) e^(i w_g t)].
  const auto runout = [&](int body, int teeth, double sign) {
    const Body& b = t.bodies[static_cast<std::size_t>(body)];
    if (!(b.eccentricity_m > 0)) return;
    // Its direction of turning in the mesh's frame, counterclockwise positive.
    const double turn =
        a.sense(body) * (a.relative_speed_ratio(body, a.mesh_frame(mesh)).num < 0 ? -1 : 1);
    s.e[stride / teeth] -= sign * cb * b.eccentricity_m * Complex(n.x(), -turn * n.y()) *
                           std::polar(1.0, turn * b.eccentricity_angle_rad);
  };
  runout(ia, x.teeth_driving, 1.0);
  runout(ib, x.teeth_driven, -1.0);
  return s;
}

}  // namespace

HarmonicSeries Assembled::stiffness_series(int mesh) const {
  const MeshSignals s = mesh_signals(*this, mesh);
  return series_of(s.k, s.w);
}

HarmonicSeries Assembled::error_series(int mesh) const {
  const MeshSignals s = mesh_signals(*this, mesh);
  return series_of(s.e, s.w);
}

HarmonicSeries Assembled::torque_series(int torque) const {
  const Torque& q = t_.torques[torque];
  const double w = kTwoPi * turning_hz(index(q.body));
  HarmonicSeries s;
  s.offset = q.mean_nm;
  for (const TorqueHarmonic& h : q.harmonics)
    s.terms.push_back({h.amplitude_nm, h.order * w, h.phase_rad});
  return s;
}

int Assembled::classify(double t_s, const Eigen::VectorXd& y) const {
  std::vector<int> s;
  for (int m = 0; m < static_cast<int>(t_.meshes.size()); ++m) {
    const Mesh& mesh = t_.meshes[m];
    const HarmonicSeries e = error_series(m);
    const double x = mesh_vector(m).dot(y.head(size())) - e(t_s);
    const double b = mesh.backlash_m;
    const int side = x >= b ? 1 : x <= -b ? -1 : 0;
    s.push_back(side);
    if (side == 0 || !mesh.clips()) continue;
    // F = k (d - e -+ b) + c (d' - e') pulls: held at 0.
    const double f = stiffness_series(m)(t_s) * (x - side * b) +
                     mesh.damping_n_s_per_m * (mesh_vector(m).dot(y.tail(size())) - e.rate(t_s));
    if (side * f < 0) s.back() = 2 * side;
  }
  std::vector<int> c;
  for (const Joint& j : joints_)
    c.push_back(j.stage_at(j.row.dot(y.head(size())) - j.offset) - j.rest);
  return region(s, c);
}

ode::LinearSwitchedSystem Assembled::linear_system(RegionBuild how) const {
  const int n = size(), dim = 2 * n;
  const int meshes = static_cast<int>(t_.meshes.size());
  ode::LinearSwitchedSystem sys;
  sys.dimension = dim;
  sys.coefficient_period_s = coefficient_period_s();

  // Per mesh, in harmonics of its base frequency w (mesh_signals): k(t), k(t) e(t), e(t) and
  // e'(t).
  struct Signals : MeshSignals {
    Spectrum ke, de;
  };
  std::vector<Signals> sig(meshes);
  for (int m = 0; m < meshes; ++m) {
    Signals& s = sig[m];
    static_cast<MeshSignals&>(s) = mesh_signals(*this, m);
    s.ke = product(s.k, s.e);
    s.de = derivative(s.e, s.w);
  }
  // The frequency table: every mesh harmonic present, then the torques'.
  for (int m = 0; m < meshes; ++m)
    for (const Spectrum* s : {&sig[m].k, &sig[m].ke, &sig[m].e})
      for (const auto& [h, c] : *s)
        if (h > 0 && std::abs(c) > 0) frequency_index(sys.frequencies_rad_s, h * sig[m].w);
  for (int q = 0; q < static_cast<int>(t_.torques.size()); ++q)
    for (const Harmonic& h : torque_series(q).terms)
      if (h.amplitude != 0) frequency_index(sys.frequencies_rad_s, h.angular_frequency_rad_s);
  for (const Speed& v : t_.speeds)
    for (const Harmonic& h : rotation_series(*this, v).terms)
      if (h.amplitude != 0) frequency_index(sys.frequencies_rad_s, h.angular_frequency_rad_s);
  const std::size_t nf = sys.frequencies_rad_s.size();
  // A and the guards' rows vary only when some mesh's stiffness does (then with the coefficient
  // period); the forcing and the guards' offsets may hold any frequency.
  const std::size_t n_coefficient = sys.coefficient_period_s > 0 ? nf : 0;

  const Eigen::MatrixXd m_inv = m_.inverse();
  Eigen::MatrixXd k_common, c_common;
  stamp_common(*this, k_common, c_common, false);
  // The loads of the bearings' seat errors k B^T o and the links' constant forces (the joints'
  // are their stages').
  Eigen::VectorXd q_common = Eigen::VectorXd::Zero(n);
  for (const Joint& x : links_)
    q_common += (x.stages[0].stiffness * x.offset - x.stages[0].force_at_zero) * x.row.transpose();
  for (std::size_t k = 0; k < t_.bearings.size(); ++k)
    if (!(t_.bearings[k].clearance_m > 0))  // with one: its joints' stages
      q_common += t_.bearings[k].stiffness_n_per_m *
                  bearing_matrix(static_cast<int>(k)).transpose() *
                  bearing_offset(static_cast<int>(k));
  if (frame_rate_ != 0) q_common += frame_load();

  // Region r from what every region shares: built on demand (ode::LinearSwitchedSystem::
  // make_lazy) from a copy of the train, or here when asked.
  auto build = [self = std::make_shared<const Assembled>(*this), sig, freqs = sys.frequencies_rad_s,
                nf, n_coefficient, m_inv, k_common, c_common, q_common, n, dim,
                meshes](int r) -> ode::LinearRegion {
    const Assembled& a = *self;
    const Train& t = a.train();
    std::vector<double> table = freqs;  // complete: each lookup below finds its frequency
    // x(t) = scale * spectrum into FourierTerms, each value placed by put(T&, double).
    const auto add = [&](auto& terms, const Spectrum& s, double w, double scale, auto put) {
      for (const auto& [h, c] : s) {
        if (h == 0) {
          put(terms.constant, scale * c.real());
        } else if (std::abs(c) > 0) {
          const int f = frequency_index(table, h * w);
          put(terms.cos[f], scale * c.real());
          put(terms.sin[f], -scale * c.imag());
        }
      }
    };
    const auto functional = [&] {
      ode::LinearGuard g;
      g.row.constant = RowVector::Zero(dim);
      g.row.cos.assign(n_coefficient, RowVector::Zero(dim));
      g.row.sin.assign(n_coefficient, RowVector::Zero(dim));
      g.offset.constant = 0;
      g.offset.cos.assign(nf, 0.0);
      g.offset.sin.assign(nf, 0.0);
      return g;
    };
    // d - e of mesh m, times `sign`, minus `edge`.
    const auto deflection = [&](int m, double sign, double edge) {
      ode::LinearGuard g = functional();
      g.row.constant.head(n) = sign * a.mesh_vector(m);
      add(g.offset, sig[m].e, sig[m].w, -sign, [](double& x, double v) { x += v; });
      g.offset.constant -= edge;
      g.scale = t.meshes[m].backlash_m;
      return g;
    };
    // sign F of mesh m in contact at `edge` (+-b): k (d - e - edge) + c (d' - e'), or its damper
    // alone (edge 0, `spring` false: a mesh damped at all times in its backlash).
    const auto mesh_force = [&](int m, double sign, double edge, bool spring) {
      ode::LinearGuard g = functional();
      const Eigen::RowVectorXd v = a.mesh_vector(m);
      const double c = t.meshes[m].damping_n_s_per_m;
      Spectrum offset = scaled(sig[m].de, c);
      if (spring) {
        add(g.row, sig[m].k, sig[m].w, sign,
            [&](RowVector& row, double x) { row.head(n) += x * v; });
        offset = plus(plus(sig[m].ke, scaled(sig[m].k, edge)), offset);
      }
      g.row.constant.tail(n) += sign * c * v;
      add(g.offset, offset, sig[m].w, -sign, [](double& x, double y) { x += y; });
      g.scale = t.meshes[m].backlash_m * t.meshes[m].mean_stiffness_n_per_m;
      return g;
    };

    const std::vector<int> st = a.states(r), cs = a.joint_states(r);
    ode::LinearRegion lr;
    lr.a.constant = Matrix::Zero(dim, dim);
    lr.a.constant.topRightCorner(n, n) = Matrix::Identity(n, n);
    lr.a.cos.assign(n_coefficient, Matrix::Zero(dim, dim));
    lr.a.sin.assign(n_coefficient, Matrix::Zero(dim, dim));
    lr.u.constant = Vector::Zero(dim);
    lr.u.cos.assign(nf, Vector::Zero(dim));
    lr.u.sin.assign(nf, Vector::Zero(dim));
    lr.a.constant.bottomLeftCorner(n, n) -= m_inv * k_common;
    lr.a.constant.bottomRightCorner(n, n) -= m_inv * c_common;
    lr.u.constant.tail(n) += m_inv * q_common;
    for (int q = 0; q < static_cast<int>(t.torques.size()); ++q) {
      const HarmonicSeries s = a.torque_series(q);
      const Vector col = m_inv.col(a.index(t.torques[q].body));
      lr.u.constant.tail(n) += s.offset * col;
      for (const Harmonic& h : s.terms) {
        if (h.amplitude == 0) continue;
        const int f = frequency_index(table, h.angular_frequency_rad_s);
        lr.u.cos[f].tail(n) += h.amplitude * std::cos(h.phase_rad) * col;
        lr.u.sin[f].tail(n) -= h.amplitude * std::sin(h.phase_rad) * col;
      }
    }
    for (int m = 0; m < meshes; ++m) {
      const Eigen::RowVectorXd v = a.mesh_vector(m);
      const Eigen::MatrixXd vtv = v.transpose() * v;
      const Vector mv = m_inv * v.transpose();
      const Mesh& x = t.meshes[m];
      const double b = x.backlash_m, c = x.damping_n_s_per_m;
      // The side of contact (+-1), 0 in the backlash; a clipped mesh (+-2) touches but carries
      // nothing.
      const int side = st[m] > 0 ? 1 : st[m] < 0 ? -1 : 0;
      const bool contact = st[m] == side && side != 0, damper = side == 0 && x.damping_always;
      const Matrix block = m_inv * vtv;
      if (contact) {
        // J theta'' += -V^T (k (V theta - e -+ b) + c (V theta' - e')).
        add(lr.a, sig[m].k, sig[m].w, 1.0,
            [&](Matrix& a, double x) { a.bottomLeftCorner(n, n) -= x * block; });
        const Spectrum force =
            plus(plus(sig[m].ke, scaled(sig[m].k, side * b)), scaled(sig[m].de, c));
        add(lr.u, force, sig[m].w, 1.0, [&](Vector& u, double x) { u.tail(n) += x * mv; });
      } else if (damper) {
        // J theta'' += -V^T c (V theta' - e').
        add(lr.u, scaled(sig[m].de, c), sig[m].w, 1.0,
            [&](Vector& u, double x) { u.tail(n) += x * mv; });
      }
      if (contact || damper) lr.a.constant.bottomRightCorner(n, n) -= c * block;
      // Guards: d - e against -+b; in contact on a mesh that clips, F against 0 (sign F < 0:
      // it would pull), and clipped, the same back.
      std::vector<int> to = st;
      const auto guard = [&](ode::LinearGuard g, int state) {
        to[m] = state;
        g.target = a.region(to, cs);
        lr.guards.push_back(std::move(g));
      };
      if (side == 0) {
        guard(deflection(m, -1.0, -b), 1);  // b - (d - e)
        guard(deflection(m, 1.0, -b), -1);  // (d - e) + b
      } else {
        guard(deflection(m, side, b), 0);
        if (contact && x.clips()) guard(mesh_force(m, side, side * b, true), 2 * side);
        if (!contact) guard(mesh_force(m, -side, side * b, true), side);
      }
      // Observables: d - e, and the force.
      lr.observables.push_back(deflection(m, 1.0, 0.0));
      if (contact || damper) {
        lr.observables.push_back(mesh_force(m, 1.0, side * b, contact));
      } else {
        ode::LinearGuard f = functional();
        f.scale = b * x.mean_stiffness_n_per_m;
        lr.observables.push_back(f);
      }
    }
    // Each joint j in its stage: k_s x + f_s + c_s x' on -row^T, x = row q - offset; its
    // guards on x against its stage's edges, as a mesh's on d - e against +-b.
    for (std::size_t j = 0; j < a.joints().size(); ++j) {
      const Joint& x = a.joints()[j];
      const int stage = cs[j] + x.rest;
      const JointStage& g = x.stages[static_cast<std::size_t>(stage)];
      const Matrix block = m_inv * x.row.transpose() * x.row;
      lr.a.constant.bottomLeftCorner(n, n) -= g.stiffness * block;
      lr.a.constant.bottomRightCorner(n, n) -= g.damping * block;
      lr.u.constant.tail(n) +=
          (g.stiffness * x.offset - g.force_at_zero) * (m_inv * x.row.transpose());
      // sign x - edge.
      const auto beyond = [&](double sign, double edge) {
        ode::LinearGuard guard = functional();
        guard.row.constant.head(n) = sign * x.row;
        guard.offset.constant = -sign * x.offset - edge;
        guard.scale = x.scale;
        return guard;
      };
      std::vector<int> to = cs;
      if (stage + 1 < x.stage_count()) {
        to[j] = cs[j] + 1;
        ode::LinearGuard up = beyond(-1.0, -x.edges[static_cast<std::size_t>(stage)]);
        up.target = a.region(st, to);
        lr.guards.push_back(up);
      }
      if (stage > 0) {
        to[j] = cs[j] - 1;
        ode::LinearGuard down = beyond(1.0, x.edges[static_cast<std::size_t>(stage - 1)]);
        down.target = a.region(st, to);
        lr.guards.push_back(down);
      }
    }
    // Each shaft's torque and each bearing's force on the ground, the same in every region.
    for (std::size_t k = 0; k < t.shafts.size(); ++k) {
      const Shaft& x = t.shafts[k];
      const RowVector v = a.shaft_vector(static_cast<int>(k));
      ode::LinearGuard g = functional();
      g.row.constant.head(n) = x.stiffness_n_m_per_rad * v;
      g.row.constant.tail(n) = x.damping_n_m_s_per_rad * v;
      lr.observables.push_back(g);
    }
    for (std::size_t k = 0; k < t.bearings.size(); ++k) {
      const Bearing& x = t.bearings[k];
      const Eigen::MatrixXd b = a.bearing_matrix(static_cast<int>(k));
      const Eigen::Vector2d o = a.bearing_offset(static_cast<int>(k));
      for (const int axis : {0, 1}) {
        // With a clearance: its direction's state, 0 (no force) inside (its joints are the
        // first, in clearances()' order).
        int state = 1;
        double edge = 0;
        for (std::size_t j = 0; j < a.clearances().size(); ++j)
          if (a.clearances()[j] == std::array<int, 2>{static_cast<int>(k), axis}) {
            state = cs[j];
            edge = cs[j] * x.clearance_m;
          }
        ode::LinearGuard g = functional();
        if (state != 0) {
          g.row.constant.head(n) = x.stiffness_n_per_m * b.row(axis);
          g.row.constant.tail(n) = x.damping_n_s_per_m * b.row(axis);
          g.offset.constant = -x.stiffness_n_per_m * (o(axis) + edge);
        }
        lr.observables.push_back(g);
      }
      // A spatial body's axial force and tilt moments.
      const Eigen::MatrixXd s = a.support_matrix(static_cast<int>(k));
      const Eigen::Vector3d ks = support_diagonal(x, false), cs_ = support_diagonal(x, true);
      for (Eigen::Index row = 0; row < s.rows(); ++row) {
        ode::LinearGuard g = functional();
        g.row.constant.head(n) = ks(row) * s.row(row);
        g.row.constant.tail(n) = cs_(row) * s.row(row);
        lr.observables.push_back(g);
      }
    }
    // Each joint read as a part: its force k_s x + f_s + c_s x', then x.
    for (std::size_t j = 0; j < a.joints().size(); ++j) {
      const Joint& x = a.joints()[j];
      if (!x.read) continue;
      const int stage = cs[j] + x.rest;
      const JointStage& g = x.stages[static_cast<std::size_t>(stage)];
      ode::LinearGuard f = functional();
      f.row.constant.head(n) = g.stiffness * x.row;
      f.row.constant.tail(n) = g.damping * x.row;
      f.offset.constant = g.force_at_zero - g.stiffness * x.offset;
      lr.observables.push_back(f);
      ode::LinearGuard d = functional();
      d.row.constant.head(n) = x.row;
      d.offset.constant = -x.offset;
      lr.observables.push_back(d);
    }
    // A prescribed body's row is its prescription's acceleration, nothing of the train's.
    for (const Speed& v : t.speeds) {
      const int row = n + a.index(v.body);
      lr.a.constant.row(row).setZero();
      lr.u.constant(row) = 0;
      for (std::size_t f = 0; f < nf; ++f) {
        if (f < n_coefficient) {
          lr.a.cos[f].row(row).setZero();
          lr.a.sin[f].row(row).setZero();
        }
        lr.u.cos[f](row) = 0;
        lr.u.sin[f](row) = 0;
      }
      for (const Harmonic& h : rotation_series(a, v).terms) {
        if (h.amplitude == 0) continue;
        const double w = h.angular_frequency_rad_s;
        const int f = frequency_index(table, w);
        lr.u.cos[f](row) -= h.amplitude * w * w * std::cos(h.phase_rad);
        lr.u.sin[f](row) += h.amplitude * w * w * std::sin(h.phase_rad);
      }
    }
    // A mesh of constant stiffness with a transmission error gives the system a coefficient
    // period, but its A and rows have no varying term: stepped as constant (ode::drop_zero_terms).
    ode::drop_zero_terms(lr);
    return lr;
  };
  if (how == RegionBuild::kLazy) {
    sys.make_lazy(region_count(), std::move(build));
  } else {
    for (int r = 0; r < region_count(); ++r) sys.regions.push_back(build(r));
  }
  return sys;
}

namespace {

// 1/2 k |d|^2 of a deflection d, real or complex (a whirl's).
double strain(double k, double d) { return 0.5 * k * d * d; }
double strain(double k, Complex d) { return 0.5 * k * std::norm(d); }

// A mode's strain energy in each mesh, shaft and bearing, as fractions of `total`.
template <class Shape>
void strain_energies(const Assembled& a, const Shape& shape, double total, TrainMode& mode) {
  using Scalar = typename Shape::Scalar;
  const Train& t = a.train();
  const auto share = [&](double e) { return total > 0 ? e / total : 0.0; };
  for (int m = 0; m < static_cast<int>(t.meshes.size()); ++m)
    mode.mesh_energy.push_back(share(strain(t.meshes[m].mean_stiffness_n_per_m,
                                            a.mesh_vector(m).template cast<Scalar>().dot(shape))));
  for (std::size_t s = 0; s < t.shafts.size(); ++s)
    mode.shaft_energy.push_back(
        share(strain(t.shafts[s].stiffness_n_m_per_rad,
                     a.shaft_vector(static_cast<int>(s)).template cast<Scalar>().dot(shape))));
  for (std::size_t b = 0; b < t.bearings.size(); ++b) {
    // x and y on the radial stiffness, then z, tx and ty on the support's.
    const auto w = (a.bearing_matrix(static_cast<int>(b)).template cast<Scalar>() * shape).eval();
    const auto w_s = (a.support_matrix(static_cast<int>(b)).template cast<Scalar>() * shape).eval();
    const Eigen::Vector3d k_s = support_diagonal(t.bearings[b], false);
    std::array<double, 5> parts{};
    for (Eigen::Index row = 0; row < 2; ++row)
      parts[static_cast<std::size_t>(row)] =
          share(strain(t.bearings[b].stiffness_n_per_m, Scalar(w(row))));
    for (Eigen::Index row = 0; row < w_s.size(); ++row)
      parts[static_cast<std::size_t>(2 + row)] = share(strain(k_s(row), Scalar(w_s(row))));
    double sum = 0;
    for (const double x : parts) sum += x;
    mode.bearing_energy.push_back(sum);
    mode.bearing_parts.push_back(parts);
  }
  for (std::size_t j = 0; j < a.joints().size(); ++j) {
    const Joint& x = a.joints()[j];
    if (!x.read) continue;
    const int stage = a.operating_stages()[j];
    mode.joint_energy.push_back(
        stage < 0 ? 0.0
                  : share(strain(x.stages[static_cast<std::size_t>(stage)].stiffness,
                                 x.row.template cast<Scalar>().dot(shape))));
  }
}

// phi^H C phi / (2 w) of a mass-normalised shape at w = 2 pi frequency_hz; 0 at frequency 0.
template <class Shape>
double modal_damping_ratio(const Assembled& a, const Shape& shape, double frequency_hz) {
  using Scalar = typename Shape::Scalar;
  if (!(frequency_hz > 0)) return 0.0;
  const Scalar c = shape.dot(a.contact_damping().template cast<Scalar>() * shape);
  return std::real(c) / (2 * kTwoPi * frequency_hz);
}

// The modes of a train in a turning frame (Train::frame_terms): M q'' + G q' + K q = 0 with G
// the frame's skew Coriolis matrix, as the first-order eigenproblem of (q, q'); each
// oscillating mode's eigenvalue pair +-i w read once (i w), the rigid motions' zeros once each
// (their shapes rigid_motions()'). A frame fast enough to make a mode diverge (a real pair +-s)
// gives it frequency 0.
std::vector<TrainMode> gyroscopic_modes(const Assembled& a, const Eigen::MatrixXd& select) {
  const Eigen::Index nf = select.cols();
  const Eigen::MatrixXd m = select.transpose() * a.mass() * select;
  const Eigen::MatrixXd k = select.transpose() * a.contact_stiffness() * select;
  const Eigen::MatrixXd g = select.transpose() * a.frame_damping() * select;
  const Eigen::MatrixXd m_inv = m.inverse();
  // The state (q, q' / s), s the fastest rate: its blocks of one size, which the nonsymmetric
  // eigensolver (unbalanced) needs for its accuracy; the eigenvalues are the same.
  const Eigen::MatrixXd m_inv_k = m_inv * k;
  const double s = std::sqrt(std::max(m_inv_k.cwiseAbs().maxCoeff(), 1.0));
  Eigen::MatrixXd state = Eigen::MatrixXd::Zero(2 * nf, 2 * nf);
  state.topRightCorner(nf, nf) = s * Eigen::MatrixXd::Identity(nf, nf);
  state.bottomLeftCorner(nf, nf) = -m_inv_k / s;
  state.bottomRightCorner(nf, nf) = -m_inv * g;
  const Eigen::EigenSolver<Eigen::MatrixXd> solver(state);
  const Eigen::VectorXcd& lambda = solver.eigenvalues();
  const double scale = lambda.cwiseAbs().maxCoeff();
  // The rigid motions' zeros (a Jordan pair each, which rounding splits by about sqrt(eps)
  // scale): the 2 r eigenvalues nearest 0. Of the others each +-i w once (i w), and of a pair
  // +-s a fast frame makes diverge, +s.
  const Eigen::MatrixXd rigid = a.rigid_motions();
  std::vector<Eigen::Index> order(static_cast<std::size_t>(lambda.size()));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](Eigen::Index x, Eigen::Index y) {
    return std::abs(lambda(x)) < std::abs(lambda(y));
  });
  const auto r = static_cast<std::size_t>(rigid.cols());
  std::vector<Eigen::Index> kept;
  for (std::size_t j = 2 * r; j < order.size(); ++j) {
    const Complex l = lambda(order[j]);
    const bool real = std::abs(l.imag()) <= kRealEigenvalueFraction * scale;
    if (real ? l.real() > 0 : l.imag() > 0) kept.push_back(order[j]);
  }
  std::vector<TrainMode> out;
  for (std::size_t j = 0; j < r + kept.size(); ++j) {
    TrainMode mode;
    Eigen::VectorXcd shape;
    if (j < r) {
      shape = rigid.col(static_cast<Eigen::Index>(j)).cast<Complex>();
    } else {
      const Eigen::Index i = kept[j - r];
      mode.frequency_hz = std::max(lambda(i).imag(), 0.0) / kTwoPi;
      shape = select * solver.eigenvectors().col(i).head(nf);
    }
    // Mass-normalised, its largest entry real and positive.
    shape /= std::sqrt(std::abs(shape.dot(a.mass().cast<Complex>() * shape)));
    Eigen::Index top = 0;
    shape.cwiseAbs().maxCoeff(&top);
    shape *= std::polar(1.0, -std::arg(shape(top)));
    mode.shape = shape.real();
    mode.shape_imag = shape.imag();
    // A rigid motion strains nothing: its shares stay 0 (a ratio of roundings otherwise).
    const bool rigid_motion = j < r;
    strain_energies(a, shape,
                    rigid_motion
                        ? 0.0
                        : 0.5 * shape.dot(a.contact_stiffness().cast<Complex>() * shape).real() +
                              0.5 * shape.dot(-a.frame_stiffness().cast<Complex>() * shape).real(),
                    mode);
    mode.damping_ratio = modal_damping_ratio(a, shape, mode.frequency_hz);
    out.push_back(std::move(mode));
  }
  std::stable_sort(out.begin(), out.end(), [](const TrainMode& x, const TrainMode& y) {
    return x.frequency_hz < y.frequency_hz;
  });
  return out;
}

}  // namespace

namespace {

// The coordinates modes read, as the columns of a selection: the free bodies' (a prescribed
// one is held).
Eigen::MatrixXd free_coordinates(const Assembled& a) {
  std::vector<int> free;
  for (int i = 0; i < a.size(); ++i)
    if (!a.prescribed(i)) free.push_back(i);
  const auto nf = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd select = Eigen::MatrixXd::Zero(a.size(), nf);
  for (Eigen::Index j = 0; j < nf; ++j) select(free[j], j) = 1;
  return select;
}

}  // namespace

std::vector<std::array<double, 2>> damped_eigenvalues(const Eigen::MatrixXd& m,
                                                      const Eigen::MatrixXd& k,
                                                      const Eigen::MatrixXd& c) {
  using Matrix = Eigen::MatrixXd;
  const Eigen::Index n = m.rows();
  const Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> solver(k, m, Eigen::EigenvaluesOnly);
  if (solver.info() != Eigen::Success)
    throw std::runtime_error("modes: the eigenvalue problem K phi = w^2 M phi did not converge");
  // Balanced: in mass-scaled coordinates L^T q (M = L L^T) and velocities over the highest
  // undamped w (the same eigenvalues; the blocks then have norms of one order, not 1 and w^2).
  const double top = std::max(solver.eigenvalues().maxCoeff(), 1e-300), w_top = std::sqrt(top);
  Matrix s = Matrix::Zero(2 * n, 2 * n);
  s.topRightCorner(n, n) = w_top * Matrix::Identity(n, n);
  const Eigen::LLT<Matrix> cholesky(m);
  const auto scaled = [&](const Matrix& x) {  // L^-1 x L^-T
    const Matrix left = cholesky.matrixL().solve(x);
    return Matrix(cholesky.matrixL().solve(left.transpose()).transpose());
  };
  s.bottomLeftCorner(n, n) = -scaled(k) / w_top;
  s.bottomRightCorner(n, n) = -scaled(c);
  const Eigen::EigenSolver<Matrix> damped(s, false);
  std::vector<std::array<double, 2>> out;
  for (Eigen::Index i = 0; i < damped.eigenvalues().size(); ++i) {
    const Complex lambda = damped.eigenvalues()[i];
    if (lambda.imag() < 0) continue;  // one of each pair (overdamped roots have imag 0)
    const double mag = std::abs(lambda);
    if (mag * mag <= kRigidEigenvalueFraction * top) continue;  // a rigid motion
    out.push_back({mag / kTwoPi, -lambda.real() / mag});
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::array<double, 2>> damped_eigenvalues(const Assembled& a) {
  const Eigen::MatrixXd select = free_coordinates(a);
  return damped_eigenvalues(select.transpose() * a.mass() * select,
                            select.transpose() * a.contact_stiffness() * select,
                            select.transpose() * a.contact_damping() * select);
}

std::vector<TrainMode> modes(const Assembled& a) {
  const Eigen::MatrixXd select = free_coordinates(a);
  std::vector<TrainMode> out;
  const Train& t = a.train();
  if (a.frame_rate_rad_s() != 0) {
    out = gyroscopic_modes(a, select);
  } else {
    const Eigen::MatrixXd k = a.contact_stiffness();
    const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> solver(
        select.transpose() * k * select, select.transpose() * a.mass() * select);
    for (Eigen::Index r = 0; r < solver.eigenvalues().size(); ++r) {
      TrainMode mode;
      const double w2 = solver.eigenvalues()(r);
      // A rigid rotation's eigenvalue is zero to the rounding of the largest: its frequency is 0.
      mode.frequency_hz = w2 > kRigidEigenvalueFraction * solver.eigenvalues().maxCoeff()
                              ? std::sqrt(w2) / kTwoPi
                              : 0.0;
      mode.shape = select * solver.eigenvectors().col(r);
      // A rigid motion strains nothing: its shares stay 0 (a ratio of roundings otherwise).
      strain_energies(a, mode.shape,
                      mode.frequency_hz > 0 ? 0.5 * mode.shape.dot(k * mode.shape) : 0.0, mode);
      mode.damping_ratio = modal_damping_ratio(a, mode.shape, mode.frequency_hz);
      out.push_back(std::move(mode));
    }
  }
  // Repeated frequencies, and the planetary type from the shape's kinetic shares.
  for (TrainMode& m : out)
    m.multiplicity =
        static_cast<int>(std::count_if(out.begin(), out.end(), [&](const TrainMode& x) {
          return std::abs(x.frequency_hz - m.frequency_hz) <=
                 kSameModeFrequency * std::max(x.frequency_hz, m.frequency_hz);
        }));
  std::vector<bool> central(static_cast<std::size_t>(a.body_count()), true);
  bool pinned = false;
  for (const Bearing& b : t.bearings)
    if (!b.on.empty()) {
      central[static_cast<std::size_t>(a.index(b.body))] = false;
      pinned = true;
    }
  if (pinned) {
    const Eigen::MatrixXd& mass = a.mass();
    for (TrainMode& m : out) {
      double turn = 0, shift = 0;  // the central members' kinetic shares (the shape's is 1)
      const bool whirl = m.shape_imag.size() > 0;
      const auto square = [&](int i) {
        return m.shape(i) * m.shape(i) + (whirl ? m.shape_imag(i) * m.shape_imag(i) : 0.0);
      };
      for (int i = 0; i < a.body_count(); ++i) {
        if (!central[static_cast<std::size_t>(i)]) continue;
        turn += mass(i, i) * square(i);
        if (const int x = a.translation(i); x >= 0)
          for (int j = x; j < x + a.plane_basis(i).cols(); ++j) shift += mass(j, j) * square(j);
      }
      const bool turns = turn > kStillShare, shifts = shift > kStillShare;
      m.type = turns && shifts ? "mixed"
               : turns         ? "rotational"
               : shifts        ? "translational"
                               : "planet";
    }
  }
  return out;
}

}  // namespace geardyn::train
