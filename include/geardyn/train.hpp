// geardyn: gear trains assembled from elements (docs/model.md, "Gear trains from elements").
// Pipeline stage 4 beside model.hpp: physics only; the assembled train describes itself as the
// piecewise-linear system of linear_system.hpp, which the exact engine integrates without knowing
// what it holds.
//
// Coordinates. Each body turns about its own axis; its coordinate theta_i (rad) is its rotation
// away from the train's nominal rotation at constant speed, counted positive in the body's own
// nominal direction of rotation (so that one sign rule serves external and internal meshes).
// The train's rigid rotation is kept as a coordinate: a train whose torques balance on average
// has it as a free mode (zero frequency), as the gear pair's u leaves it out. (Its solver steps a
// freely turning train on the complement of that rotation: train_run.hpp, rigid_split.hpp.) A
// planar body (Body::planar) also moves in the plane of the gears: its centre's displacement (x_i,
// y_i) (m) in a frame fixed to the ground, the reference body turning counterclockwise (+z) in it.
// The coordinates are every body's theta first, in the bodies' order, then (x, y) of each planar
// body in that order (w alone for one held to its line, Body::line: u = n w along its mesh's
// line of action n), and after them a spatial body's (Body::spatial) z (m, along the axes) and
// its tilts tx, ty (rad, about x and y): a torsional train's coordinates are its bodies'.
//
// Frames and speeds (kinematics.hpp). Every body turns at its absolute nominal speed, solved
// from the reference's by Willis's equation for each mesh seen from the carrier whose pins hold
// one of its gears (the ground's for a fixed-axis mesh), shafts (equal speeds) and supports (a
// shaft to the ground holds its body at rest). A mesh's frequency is its driving gear's teeth
// times its speed relative to its carrier; a torque's or a prescribed speed's orders are of its
// body's absolute speed. The deviations theta from the nominal rotation are the same in every
// frame (each frame turns uniformly at its carrier's nominal speed). A planar body's
// translations are read in its frame: a planetary set's members (carrier, planets, sun, ring) in
// their carrier's, which turns at the carrier's speed, so that the planets' centres stay put and
// the meshes' lines of action keep their directions; fixed-axis bodies in the ground's. Each
// carrier's frame's rotation terms are left out unless Train::frame_terms asks for them (they
// scale with the carrier's speed over the lowest elastic frequency).
//
// The frame's rotation terms (Train::frame_terms; Lin and Parker 1999, eq. 1, with the pins'
// preloads that keep the set's rigid rotation free). A carrier's frame turns at Omega in the
// absolute (counterclockwise positive), its carrier's nominal speed. Each planar body's
// translation u in it then
// feels its Coriolis and centripetal forces, -2 m Omega z x u' + m Omega^2 u: Lin and Parker's
// Omega G q' and -Omega^2 K_Omega q, G = 2 m [[0, -1], [1, 0]] and K_Omega = m I on (x, y),
// with one change: a body carried on a pin at R from its carrier's centre softens on its
// displacement from its pin's turned place, v = u - theta_c d_c (d_c = s_c z x R, the pin's
// displacement per unit theta_c), not on u. Lin and Parker's own term gives the set's rigid turn
// (theta_c, each planet moved by d_c theta_c) the stiffness -Omega^2 sum m R^2: its centripetal
// force m Omega^2 d_c theta_c meets nothing, because the turning of the pins' centrifugal
// preloads (a geometric stiffness their linearisation leaves out) is what opposes it. With v,
// K stays symmetric and keeps the rigid motion in its null space exactly. The planets' constant
// centrifugal force m Omega^2 R is a load on the bodies (like a seat error's), which moves them
// outward on their pins at rest. C holds the skew G: modes() solves the gyroscopic
// eigenproblem.
//
// Elements, each stamping itself into M q'' + C_r q' + K_r(t) q = Q_r(t) through the indices of
// the coordinates it joins (the finite-element habit: an element knows its local matrices and
// its degrees of freedom, the assembler adds them and never asks what it holds):
//
//   Body    J_i on the diagonal of M; a planar body's mass m_i on its x and y; a spatial body's
//           m_i on its z and its inertia about a diameter I_d on its tilts.
//   Shaft   k_s, c_s between two bodies: the twist theta_a - theta_b; to the ground (kGround):
//           theta_a.
//   Bearing k_b, c_b on the displacement w = B q (2 rows, x and y) of a planar body's centre
//           from its seat (isotropic): w = u_i on the ground; on a pin of body j at r (pin
//           radius and angle), w = u_i - u_j - theta_j s_j z x r, the pin's point moving with
//           j's centre (u_j, when j is planar) and turning with j (s_j its sense, z x r =
//           (-r_y, r_x)): Lin and Parker's planet bearing. Its force k_b (w - o) + c_b w', o
//           the seat's position error (a pin's radial and tangential error): a constant load
//           k_b B^T o on the bodies. On a spatial body (on the ground) also k_a, c_a on its z and
//           k_t, c_t on each tilt: w_s = A q = (z_i, tx_i, ty_i) (support_matrix).
//   Mesh    between a driving gear a and a driven gear b, along the line of action: the normal
//           deflection d = cos(beta_b) (R_a theta_a - R_b theta_b + n . (u_a - u_b)), u a
//           planar body's (x, y) (absent for a body that keeps torsion only: held on rigid
//           bearings), n the unit vector of the drive flank's line of action in the transverse
//           plane (below). Its force is the one-degree model's F = k(t) (d - e(t) -+ b) + c (d'
//           - e'(t)) on the drive (-) or back (+) side, 0 in the backlash (|d - e| < b),
//           entering the bodies by virtual work as V^T F with d = V q; k(t) and e(t) at the
//           mesh's own frequency z_a f_a. As in the lumped models of Kahraman and Singh (1991)
//           and Lin and Parker (1999), the back side acts along the same line n. A helical
//           mesh's tooth normal also has the axial part sin(beta_b) h z (h = Mesh::axial_sense):
//           with a spatial gear, d gains sin(beta_b) h (w_a - w_b), w_i = z_i + tx_i r_y - ty_i
//           r_x the axial displacement of gear i's contact point r = s_i R_i (n_y, -n_x) from
//           its centre (its base circle's tangent point on the line of action, where the
//           coupled pair places it: the tilts are the small rotations (tx, ty, 0) of its face).
//   Torque  a torque T(t) = T_mean + sum_i T_i cos(i Omega t + phi_i) on a body (a drive
//           positive, a load negative), Omega the body's own angular speed.
//   Joint   a piecewise-linear force along one deformation (joint.hpp), given by an element
//           of a kind this file does not know (Train::elements): a drag (drag.hpp), a clutch
//           damper (damper.hpp).
//   Speed   a prescribed rotation of a body (below): its row of the equations is the
//           prescription's acceleration.
//
// Internal meshes. A mesh between a pinion and a ring gear with internal teeth (Mesh::internal;
// the ring is the gear with more teeth) turns both the same way: the speed ratio is the
// external one's, the sense of rotation is kept. d = cos(beta_b) (R_a theta_a - R_b theta_b)
// holds as it is, each theta counted in its own body's sense.
//
// The line of action. With psi the position angle of the driven gear's centre seen from the
// driving gear's (Mesh::position_angle_rad, counterclockwise from x), psi_P that of the pitch
// point seen from the driving gear's centre (psi for an external mesh and for a ring driving
// its pinion, whose centre lies between the ring's and the pitch point; psi + pi for a pinion
// driving its ring), e = (cos psi_P, sin psi_P), t = (-sin psi_P, cos psi_P), and s_a = +1
// when the driving gear turns counterclockwise (the reference does; each external mesh reverses
// the sense, an internal mesh and a shaft keep it), the drive flank's force on the driven gear
// is F n with n = s_a cos(alpha_t) t + sigma sin(alpha_t) e: tangent to both base circles along
// the driving gear's motion, and pressing the driven gear's tooth into its own body (sigma =
// +1: toward an external gear's centre, outward into a ring's rim; sigma = -1 for a pinion
// driven by its ring, pressed toward its centre), alpha_t the transverse pressure angle.
//
// Mesh phase from the layout (Train::mesh_phase_from_layout). Each gear's teeth are placed at
// t = 0 by the layout: the reference's (or, in a part of the train joined to it by shafts
// alone, the first gear's) tooth centred on +x, and every other gear's so that the teeth of
// each mesh interlock at its pitch point (standard teeth: half a pitch thick at the pitch
// circle). A mesh's phase u in [0, 1) is the fraction of its cycle the driving gear's leading
// flank has passed the pitch point at t = 0, so that its stiffness and transmission error,
// given over a cycle that starts as a tooth pair passes the pitch point, are delayed to
// k(t + u T_mesh): each harmonic i's phase grows by 2 pi i u. A loop of meshes whose teeth
// cannot all interlock (planets whose spacing the tooth counts do not allow) is refused naming
// the mesh that closes it. Without it, each mesh's harmonics are taken as given, about t = 0.
//
// Eccentricity (Body::eccentricity_m). A gear's teeth turn about a centre that is not its
// axis: each mesh's deflection gains cos(beta_b) n . (epsilon_a(t) - epsilon_b(t)), its gears'
// runouts along the line of action as a translation of their centres would (a gear that keeps
// torsion only too: its runout still moves its teeth), taken into the mesh's error e(t) as
// -cos(beta_b) n . (epsilon_a - epsilon_b), at each gear's speed relative to its mesh's frame.
// A carrier, at rest in its own frame, shifts its pins: each bearing on them has its seat moved
// by epsilon, a load like a pin error's.
//
// Regions: each mesh has three contact states (back side -1, backlash 0, drive side 1), a mesh
// that clips its tension (Mesh::clips) five (-2 and 2: in contact on the back or drive side
// with the force held at 0 where it would pull), and each joint (joint.hpp: a bearing's
// clearance direction, an element's piecewise-linear spring) one per stage; a region is one
// state per mesh and per joint, index sum_m (s_m + 1) 3^m for meshes of three states (a mixed
// radix with five, and with each joint's stage count). Guards: for each mesh, d - e crossing -+b,
// for a clipping mesh in contact its force F crossing 0, for each joint its x crossing the edges
// of its stage.
// Observables per mesh m: 2m its deflection d - e (m), 2m + 1 its force F (N; 0 clipped, its
// damper's in the backlash when damped at all times); then, the same in every region, each
// shaft's torque k_s (theta_a - theta_b) + c_s (theta_a' - theta_b') (N m, positive when a
// leads b), then each bearing's force on its seat k w + c w' in x and in y (N), on a spatial
// body followed by its axial force and, when it tilts, its tilt moments, then each joint read as
// a part (Joint::read) its force and its x: shaft_observable and bearing_observable give their
// index.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/harmonic_series.hpp"
#include "geardyn/joint.hpp"
#include "geardyn/kinematics.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn::train {

struct Body {
  std::string name;
  double inertia_kg_m2 = 0;  // J > 0
  bool planar = false;       // also moves in the plane (x, y): needs a bearing
  double mass_kg = 0;        // m > 0 of a planar body
  // Runout: the centre of the body's teeth and pins lies eccentricity_m from its axis (its
  // bearing's seat), at eccentricity_angle_rad counterclockwise from x at t = 0, and turns with
  // the body: epsilon(t) = e (cos(s w t + phi), sin(s w t + phi)), s w its rotation relative
  // to its mesh's frame (constant on a carrier in its own: its pins all shifted). Its mass stays
  // centred on the axis (no unbalance). Below, "Eccentricity".
  double eccentricity_m = 0;
  double eccentricity_angle_rad = 0;
  // A spatial body is planar and also moves along its axis (z) and tilts about x and y: all six
  // degrees of freedom of a rigid body. It needs tilt_inertia_kg_m2 > 0 (about a diameter) and
  // bearings on the ground whose axial and tilt stiffnesses hold it. Not in a train with pins
  // (a planetary set is planar here) nor with Train::frame_terms (its tilts' gyroscopic terms
  // are not modelled).
  bool spatial = false;
  double tilt_inertia_kg_m2 = 0;
  // A spatial body that does not tilt (its tilts held by its bearings): it keeps z alone beside
  // its x and y, and needs no tilt inertia (the coupled pair's dof 6).
  bool tilts = true;
  // A planar body held to its line: its centre moves along the line of action of its one mesh
  // only, u = n w (one coordinate w, m, instead of x and y), as in the lumped pair of Kahraman
  // and Singh (1991) and the coupled pair's dof 3 and 6, whose bearings hold it across the line
  // rigidly. Spatial and not tilting too: w, then z.
  bool line = false;
  // Its coordinates in the plane (w, or x and y), and beyond the rotation: those, then z and the
  // tilts it keeps.
  int plane_extent() const { return planar ? (line ? 1 : 2) : 0; }
  int extent() const { return plane_extent() + (spatial ? (tilts ? 3 : 1) : 0); }
};

// k(t) = mean (1 + sum_i ratio_i cos(i w_mesh t + phase_i)) and e(t) = sum_i a_i cos(i w_mesh t
// + phase_i): harmonics of the mesh frequency.
struct MeshHarmonic {
  double value = 0;  // ratio k_i / k_mean, or amplitude a_i (m)
  double phase_rad = 0;
};

struct Mesh {
  std::string name;
  std::string driving, driven;  // body names
  int teeth_driving = 0, teeth_driven = 0;
  double base_radius_driving_m = 0, base_radius_driven_m = 0;
  // beta_b of a helical pair (0: spur): d and b are then along the normal line of action,
  // d = cos(beta_b) (R_a theta_a - R_b theta_b), as the one-degree model's delta (docs/model.md).
  double base_helix_angle_rad = 0;
  double backlash_m = 0;  // b, half the total normal backlash
  double mean_stiffness_n_per_m = 0;
  std::vector<MeshHarmonic> stiffness;           // ratios
  std::vector<MeshHarmonic> transmission_error;  // amplitudes, m
  double transmission_error_mean_m = 0;          // e's constant part
  double damping_n_s_per_m = 0;                  // in contact only, unless damping_always
  // The damping forms and tension rules of the one-degree model (case.hpp's DampingForm and
  // TensionRule): c (d' - e') at all times, beside the teeth (Kahraman and Singh), instead of in
  // contact only; and a contact force k (d - e -+ b) + c (d' - e') held at 0 where it would pull
  // (two more contact states, below), which means nothing with damping at all times (the teeth
  // alone never pull: clips() is false then).
  bool damping_always = false;
  bool clip_tension = false;
  bool clips() const { return clip_tension && !damping_always; }
  // The layout, read only when a planar body is in the mesh: psi and alpha_t (above).
  double position_angle_rad = 0;
  double transverse_pressure_angle_rad = 0;
  bool internal = false;  // a pinion and a ring gear (the one with more teeth)
  // h: the drive flank pushes the driven gear along +z (1) or -z (-1), read with a spatial gear
  // of a helical mesh (the helix hands and the senses of rotation set it).
  int axial_sense = 1;
};

// A shaft whose b is kGround holds body a's rotation against the ground: a torsional support
// (a ring gear held in its housing), acting on a's deviation theta_a whatever a's nominal speed.
inline constexpr const char* kGround = "ground";

struct Shaft {
  std::string name;
  std::string a, b;  // b may be kGround
  double stiffness_n_m_per_rad = 0;
  double damping_n_m_s_per_rad = 0;
};

// A bearing carrying a planar body's centre, the same in x and y: on the ground (`on` empty),
// or on a pin of another body (`on`: a planet on its carrier), the pin's centre at
// pin_radius_m from that body's centre in the direction pin_angle_rad (counterclockwise from
// x). A body that carries pins is a carrier: the frame of the meshes of its planets (above).
struct Bearing {
  std::string name;
  std::string body;
  double stiffness_n_per_m = 0;
  double damping_n_s_per_m = 0;
  std::string on;  // the carrying body; "": the ground
  double pin_radius_m = 0;
  double pin_angle_rad = 0;
  // The seat's position error (a planet pin's): the seat lies at e_r (cos psi, sin psi) + e_t
  // (-sin psi, cos psi) from its nominal place, psi = pin_angle_rad (a bearing on the ground
  // too), so that the bearing's force is k (w - o) + c w'.
  double pin_error_radial_m = 0, pin_error_tangential_m = 0;
  // A radial clearance c: the bearing then acts in x and in y each as a dead zone, k (w - o -+
  // c) beyond +-c and nothing inside, its damping in contact only (Kahraman and Singh's
  // clearance, per direction: a round clearance is not piecewise linear). 0: none. On a body
  // held to its line, in those of x and y its line has a part along.
  double clearance_m = 0;
  // On a spatial body: its axial stiffness and damping (N/m, N s/m) on z, and its tilt
  // stiffness and damping (N m/rad, N m s/rad) on each tilt; 0 on any other body.
  double axial_stiffness_n_per_m = 0, axial_damping_n_s_per_m = 0;
  double tilt_stiffness_n_m_per_rad = 0, tilt_damping_n_m_s_per_rad = 0;
};

struct TorqueHarmonic {
  double amplitude_nm = 0;
  double order = 1;  // of the body's own speed
  double phase_rad = 0;
};

struct Torque {
  std::string name;
  std::string body;
  double mean_nm = 0;
  std::vector<TorqueHarmonic> harmonics;
};

// A prescribed speed: the body's rotation about its nominal one is
// theta(t) = sum_i a_i cos(order_i Omega t + phase_i), Omega its nominal angular speed, whatever
// the train does to it (an engine's speed fluctuation at its firing orders driving a gearbox).
// Its equation is replaced by theta'' = the prescription's: the body keeps its coordinate, which
// follows the prescription, and no force of the train reaches it.
struct SpeedHarmonic {
  double amplitude_rad = 0;
  double order = 1;
  double phase_rad = 0;
};

struct Speed {
  std::string name;
  std::string body;
  std::vector<SpeedHarmonic> harmonics;
};

struct Train {
  std::vector<Body> bodies;
  std::vector<Mesh> meshes;
  std::vector<Shaft> shafts;
  std::vector<Bearing> bearings;
  std::vector<Torque> torques;
  std::vector<Speed> speeds;
  // The elements of the kinds the assembler does not know (joint.hpp's Element: a drag, a
  // clutch damper), in the case's order.
  std::vector<std::shared_ptr<const Element>> elements;
  std::string reference;                // the body whose speed is given
  double reference_speed_hz = 0;        // its rotation frequency
  bool mesh_phase_from_layout = false;  // (above); false: each mesh's phases as given
  bool frame_terms = false;             // the frame's rotation terms (above)
};

// An order given as a real number counts as a fraction p/q within this relative distance...
constexpr double kOrderTolerance = 1e-12;
// ...with q at most this (an engine's half orders, a gear train's ratios of teeth).
constexpr std::int64_t kMaxOrderDenominator = 10000;
// A common period longer than this many periods of the slowest excitation is no period a study
// can use (it would be run period by period): the excitations count as quasi-periodic.
constexpr double kMaxPeriodMultiple = 1e4;

// The train assembled: matrices at the mean stiffness, speeds, frequencies and the system.
class Assembled {
 public:
  // Throws InputError (case.hpp) naming the element and the key: an unknown body, a body in two
  // places, no mesh, a non-positive inertia or radius, a train that cannot turn (a loop of
  // meshes and shafts whose ratios disagree, a support holding a body the train turns), a
  // train whose speeds the reference's leaves free, a body that no mesh or shaft joins to the
  // reference, a bearing on a body that keeps torsion only, a planar body without a bearing
  // (its centre would be free to wander), without a mass or meshing in two frames, a layout
  // whose teeth cannot interlock around a loop (with the phase from the layout), a carrier that
  // meshes with its own planets (kinematics.hpp), a body named kGround, a torque's harmonic or a
  // prescribed speed on a body at rest (its orders have no frequency).
  explicit Assembled(Train t);

  const Train& train() const { return t_; }
  // The number of coordinates (every body's rotation, then the planar bodies' x and y).
  int size() const { return static_cast<int>(names_.size()); }
  int body_count() const { return static_cast<int>(t_.bodies.size()); }
  // The coordinate of a body's rotation (its index among the bodies), -1 when there is none.
  int index(const std::string& body) const;
  // The coordinate of a planar body's x (its y follows; its w alone when held to its line), -1
  // for a body that keeps torsion only.
  int translation(int body) const { return translation_[static_cast<std::size_t>(body)]; }
  // P of a planar body: its centre's displacement u = P q_p (x and y rows) from its coordinates
  // in the plane q_p, translation(body) on: the identity (2 x 2), or n (2 x 1) for a body held
  // to its line (Body::line); 2 x 0 for a body that keeps torsion only.
  const Eigen::MatrixXd& plane_basis(int body) const {
    return basis_[static_cast<std::size_t>(body)];
  }
  // The coordinate of a spatial body's z (its tilts tx, ty follow when it tilts), -1 for any
  // other body.
  int axial(int body) const {
    const Body& b = t_.bodies[static_cast<std::size_t>(body)];
    return b.spatial ? translation(body) + b.plane_extent() : -1;
  }
  // The coordinate of a spatial body's tx (its ty follows), -1 for a body that does not tilt.
  int tilt(int body) const {
    const Body& b = t_.bodies[static_cast<std::size_t>(body)];
    return b.spatial && b.tilts ? translation(body) + b.plane_extent() + 1 : -1;
  }
  // Each coordinate's name with its unit, as outputs write it: "<body>_rad" for a rotation,
  // "<body>_x_m" and "<body>_y_m" for a planar body's centre ("<body>_line_m": its w, held to
  // its line).
  const std::vector<std::string>& coordinate_names() const { return names_; }
  // Each body's sense of rotation, in which its coordinate is counted (kinematics.hpp): +1
  // counterclockwise (the reference's).
  int sense(int body) const { return motion_.sense[static_cast<std::size_t>(body)]; }
  // The frame a body's translations are read in (a carrier's index, kGroundFrame, or
  // kMixedFrame for a torsional body meshing in two), and a mesh's (kinematics.hpp).
  int frame(int body) const { return motion_.frame[static_cast<std::size_t>(body)]; }
  int mesh_frame(int mesh) const { return motion_.mesh_frame[static_cast<std::size_t>(mesh)]; }
  // Whether the body carries others on pins.
  bool carrier(int body) const { return motion_.is_carrier[static_cast<std::size_t>(body)]; }
  // A body's absolute speed (Hz), positive in the reference's direction of rotation
  // (counterclockwise); how fast it turns, |that|, which its orders are of; and its speed over
  // the reference's relative to frame f, in its own sense.
  double body_speed_hz(int body) const;
  double turning_hz(int body) const;
  Ratio relative_speed_ratio(int body, int f) const { return motion_.relative(body, f); }
  // The net power of the mean torques and of the joints' and links' constant forces (a drag's
  // constant torque) at the nominal speeds over the reference's angular speed (N m): sum T_k
  // w_k / w_ref, 0 when they balance. A joint's at its operating stage: -f_s (row r), r the
  // speed ratios.
  double mean_power_nm() const;
  // Whether a joint's or link's damping acts along a rigid motion (rigid_motions(): a viscous drag
  // on a turning body), so that the motion's rate is damped rather than neutral.
  bool damps_rigid_motions() const;
  // Omega, the angular speed (rad/s, counterclockwise positive) of the first carrier's frame
  // that Train::frame_terms turns a planar body in; 0 without them. Each body's own: its
  // carrier's absolute speed when it is planar in a carrier's frame, 0 otherwise.
  double frame_rate_rad_s() const { return frame_rate_; }
  double frame_rate_rad_s(int body) const { return frame_rates_[static_cast<std::size_t>(body)]; }
  // K_f, C_f and Q_f: the frame's rotation terms on K, C and the constant load (above); zero
  // without them.
  Eigen::MatrixXd frame_stiffness() const;
  Eigen::MatrixXd frame_damping() const;
  Eigen::VectorXd frame_load() const;
  // B of bearing k: its body's centre's displacement from its seat, w = B q (x and y rows).
  Eigen::MatrixXd bearing_matrix(int bearing) const;
  // A of bearing k on a spatial body: w_s = A q, its z, tx and ty (3 rows; z alone, 1 row, on a
  // body that does not tilt); 0 rows otherwise.
  Eigen::MatrixXd support_matrix(int bearing) const;
  // o of bearing k: its seat's error in x and y (Bearing's pin errors, and its carrier's
  // eccentricity), 0 without one.
  Eigen::Vector2d bearing_offset(int bearing) const;
  // n of mesh m: the unit vector of its drive flank's line of action in the transverse plane
  // (above), whether or not its gears are planar.
  Eigen::Vector2d line_of_action(int mesh) const;
  // The twist of shaft k, theta_a - theta_b (theta_a to the ground) = v q.
  Eigen::RowVectorXd shaft_vector(int shaft) const;
  // The train's rigid rotation as coordinates: each body's speed ratio on its theta, 0 on every
  // translation.
  Eigen::VectorXd rigid_rotation() const;
  // The motions no element resists (the null space of contact_stiffness() over the bodies whose
  // speed is not prescribed), as columns, each scaled to 1 on the reference where it moves it:
  // - a train with neither pins nor shafts to the ground: rigid_rotation() exactly when no
  //   speed is prescribed (the speeds are the ratios of the teeth), none when one is;
  // - otherwise computed: a planetary set whose ring is held keeps one (the set turning about
  //   the held ring), a set with no member held two, a train a support holds none.
  Eigen::MatrixXd rigid_motions() const;

  // Each body's absolute speed over the reference speed in its own sense (negative where it
  // turns against it, 0 at rest), and each mesh's frequency over it, z_a |w_a - w_c| of its
  // driving gear relative to its carrier (kinematics.hpp).
  const std::vector<Ratio>& speed_ratios() const { return motion_.speed; }
  std::vector<Ratio> mesh_frequency_ratios() const;
  double mesh_frequency_hz(int mesh) const;
  // The common period of every mesh's stiffness and transmission error: 1 / (f_ref g), g the
  // greatest common divisor of the mesh frequency ratios; 0 when every mesh is constant.
  double coefficient_period_s() const;
  // The index among the observables of shaft k's torque, and of bearing k's force in x (its y
  // follows, then on a spatial body its axial force (N) and its moments about x and y (N m),
  // k w_s + c w_s' each). The joints read as parts follow the bearings, two each (their force
  // and x, in joints()' order).
  int shaft_observable(int shaft) const;
  int bearing_observable(int bearing) const;
  // Each mesh's phase u from the layout (above), in cycles; 0 for every mesh without it.
  const std::vector<double>& mesh_phases() const { return phase_; }
  // The period of every excitation together (each mesh's stiffness and transmission error,
  // every torque's and prescribed speed's harmonics, every turning gear's runout): 1 / (f_ref
  // g), g the greatest common divisor of their frequencies over the reference speed, each a
  // ratio of whole numbers (an order counts as one when it is within kOrderTolerance of a
  // fraction whose denominator is at most kMaxOrderDenominator). Empty, with `why` saying which
  // excitation, when there is no such period within kMaxPeriodMultiple of the slowest excitation's
  // own period: the train is driven quasi-periodically, and a study that needs a period must say
  // so. 0 when nothing varies.
  std::optional<double> system_period_s(std::string* why = nullptr) const;

  const Eigen::MatrixXd& mass() const { return m_; }
  // V of mesh m: d = V q.
  Eigen::RowVectorXd mesh_vector(int mesh) const;
  // K and C with every mesh in drive contact at its mean stiffness (the shafts', bearings' and
  // joints' terms included): the linearisation that modes() uses.
  Eigen::MatrixXd contact_stiffness() const;
  Eigen::MatrixXd contact_damping() const;

  // The system for the exact engine (state (theta, theta'), regions as above): its regions
  // built on demand, as a flow first enters each (3^meshes of them, most never visited: 729
  // for three planets, 6561 for four; a run in permanent contact enters one), or all here.
  enum class RegionBuild { kEager, kLazy };
  ode::LinearSwitchedSystem linear_system(RegionBuild how = RegionBuild::kLazy) const;
  // The region of a mesh-state vector (and the joints' states, 0 when not given: at rest),
  // and back. A region is every mesh's state (1 drive, 0 backlash, -1 back; 2 and -2 clipped in
  // contact on a mesh that clips) and every joint's (its stage less its rest stage), 3^meshes
  // times the joints' stage counts of them (5 for each mesh that clips).
  int region(const std::vector<int>& states, const std::vector<int>& joint_states = {}) const;
  std::vector<int> states(int region) const;
  std::vector<int> joint_states(int region) const;
  int region_count() const;
  // The joints (joint.hpp): first each bearing clearance direction, bearing k's x then y for each
  // bearing with a clearance, as clearances() lists them (bearing, axis 0 or 1); of a body held
  // to its line, only those the line has a part along (a direction it cannot move in never
  // closes its gap); then each element's (Train::elements), in their order, but its links.
  const std::vector<Joint>& joints() const { return joints_; }
  // The elements' links: each joint of one stage that is not read as a part (a drag). A link
  // has no contact states and no reading: it acts in every region alike, its K, C and constant
  // force stamped with the shafts' (and in joint_load()), and it is no contact part of any
  // study. (Its strain energy is in no mode's reading: a drag stores none.)
  const std::vector<Joint>& links() const { return links_; }
  const std::vector<std::array<int, 2>>& clearances() const { return clearances_; }
  // Each joint's stage in the linearisation that modes() and the static state take
  // (contact_stiffness()): each joint's Joint::operating as assembled, the stage its x lies in
  // at the static state once settle_joints has placed it; -1 for a joint its owner linearises
  // (Joint::linearised false).
  const std::vector<int>& operating_stages() const { return operating_; }
  // Sets them (settle_joints, train_statics.hpp): one stage per joint, each a stage it has
  // (ignored for a joint its owner linearises).
  void set_operating_stages(std::vector<int> stages);
  // The linearised joints' constant load on the coordinates, row^T (k_s offset - f_s) at their
  // operating stages, and the links': what the static state adds to the torques'.
  Eigen::VectorXd joint_load() const;
  // The region a state belongs to with no history (each mesh by its d - e against +-b, a
  // clipping mesh in contact also by its force's sign, each joint by its x against its edges).
  int classify(double t_s, const Eigen::VectorXd& y) const;
  // Sets the coordinates and rates of the bodies with a prescribed speed in y = (theta,
  // theta') to the prescription's at t; the others are left as they are.
  void prescribe(double t_s, Eigen::VectorXd& y) const;
  // The prescribed rotation of body i, and whether it has one.
  bool prescribed(int body) const;
  // The coordinates in which the train's own motion is read by its studies of stability, as
  // the orthonormal columns Q of a 2 size() x m matrix: a Jacobian J of the state (theta,
  // theta') reduces to Q^T J Q.
  // - With a prescribed speed: the free bodies' coordinates and rates (a prescribed body's state
  //   follows its prescription whatever the train does, so its perturbations are zero).
  // - Without one: the complement of the rigid rotation (theta = the speed ratios times an
  //   angle, rates 0), which no force of the train changes: a perturbation along it stays
  //   (multiplier 1, with the rate's a Jordan block that rounding splits by about 1e-8), so the
  //   motion is read modulo it. The rate of the rigid rotation stays among the coordinates: its
  //   multiplier is 1 (neutral) unless a viscous drag damps it.
  // - Either way, the complement of every rigid motion (rigid_motions()) among them: a train a
  //   support holds has none and is read whole.
  Eigen::MatrixXd reduced_basis() const;

  // Each mesh's stiffness and transmission error in time (the error with its gears' runouts,
  // "Eccentricity" above).
  HarmonicSeries stiffness_series(int mesh) const;
  HarmonicSeries error_series(int mesh) const;
  // Each torque's T(t) on its body.
  HarmonicSeries torque_series(int torque) const;

 private:
  // Places every gear's teeth from the layout and delays each mesh's harmonics by its phase.
  void place_teeth();

  Train t_;
  std::vector<int> translation_;
  std::vector<Eigen::MatrixXd> basis_;  // plane_basis
  std::vector<double> phase_;           // each mesh's, in cycles
  double frame_rate_ = 0;               // Omega, rad/s
  std::vector<double> frame_rates_;     // each body's, rad/s
  KinematicGraph graph_;
  NominalMotion motion_;
  std::vector<std::array<int, 2>> clearances_;
  std::vector<Joint> joints_;
  std::vector<Joint> links_;
  std::vector<int> operating_;
  std::vector<std::string> names_;
  Eigen::MatrixXd m_;
};

// Two natural frequencies within this relative distance are one, repeated (a planetary set's
// degenerate pairs: equal in exact arithmetic, to some 1e-10 in the eigensolver's).
constexpr double kSameModeFrequency = 1e-6;
// A part of a mass-normalised shape whose kinetic share is below this moves not at all in it
// (the eigensolver leaves some 1e-12 there, a mode of another type at least 1e-3).
constexpr double kStillShare = 1e-8;

// Natural modes of the train in drive contact at every mesh's mean stiffness, the bodies with a
// prescribed speed held (their shape entries 0).
struct TrainMode {
  double frequency_hz = 0;
  Eigen::VectorXd shape;  // over the coordinates, mass-normalised
  // With the frame's rotation terms a mode whirls: its shape is complex, shape + i shape_imag
  // (phased so that its largest entry is real and positive); empty otherwise.
  Eigen::VectorXd shape_imag;
  std::vector<double> mesh_energy;     // fraction of the strain energy in each mesh
  std::vector<double> shaft_energy;    // and in each shaft
  std::vector<double> bearing_energy;  // and in each bearing (all its directions)
  // And in each joint read as a part (Joint::read), at its operating stage, in joints() order
  // among those.
  std::vector<double> joint_energy;
  // Each bearing's by direction: x, y (its seat's radial stiffness; a body held to its line
  // along the line's parts in them), axial, tilt about x, tilt about y (0 where it has none).
  std::vector<std::array<double, 5>> bearing_parts;
  // A rigid motion (frequency 0, no element strained) has every share 0.
  // The modal damping ratio phi^H C phi / (2 w) of the mass-normalised shape (C in contact, as
  // contact_damping(): exact for damping proportional in the modes, the first-order estimate
  // otherwise); 0 for a rigid motion.
  double damping_ratio = 0;
  // How many modes share its frequency (within kSameModeFrequency), itself included.
  int multiplicity = 1;
  // In a train with pins (a planetary set), Lin and Parker's type, read from the shape: the
  // central members (the bodies no pin carries: sun, ring, carrier) only turn ("rotational"),
  // only translate ("translational"), or stay still while the planets move ("planet"); a shape
  // that fits none is "mixed" (planets not equally spaced). Empty in a train without pins.
  std::string type;
};
std::vector<TrainMode> modes(const Assembled& a);

// The damped system's eigenvalues (one of each conjugate pair) of M q'' + C q' + K q = 0, K and
// M symmetric and M positive definite, as frequency |lambda| / 2 pi and damping ratio
// -Re lambda / |lambda|, ascending; a rigid motion's zero eigenvalues (|lambda|^2 within
// rounding of the largest undamped w^2) left out.
std::vector<std::array<double, 2>> damped_eigenvalues(const Eigen::MatrixXd& m,
                                                      const Eigen::MatrixXd& k,
                                                      const Eigen::MatrixXd& c);
// Those of the train as modes() reads it: every mesh in drive contact at its mean stiffness,
// the prescribed bodies held (C with the frame's gyroscopic terms when it has them).
std::vector<std::array<double, 2>> damped_eigenvalues(const Assembled& a);

}  // namespace geardyn::train
