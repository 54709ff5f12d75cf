// geardyn: the coupled gear-pair model, the gears as rigid bodies on bearings (the paper's
// 12-degree-of-freedom outlook; [model] form = "coupled"). Pipeline stage 4 beside model.hpp:
// it holds physics only and describes itself as a piecewise-linear system for the exact engine.
//
// Axes: y along the line of action in the transverse plane (positive where the pinion's
// rotation pushes its contact point), x normal to it in that plane, z along the axes. The
// pinion touches at its base tangent point (R_b1, 0, 0) from its centre, the wheel at
// (-R_b2, 0, 0) from its own. The tooth normal in the plane of action is n = cos(beta_b) y +
// sin(beta_b) z, so the normal mesh deflection of the rigid bodies is
//
//     d = V q = cos(beta_b) (u + y1 - y2) + sin(beta_b) (z1 - z2 - R_b1 ty1 - R_b2 ty2)
//
// with u = R_b1 theta_1 + R_b2 theta_2 (the rotations enter only through u, as in the one-degree
// model whose delta is cos(beta_b) u; the pair's rigid rotation is not a coordinate) and ty_i
// the tilt about the y axis. The mesh force along n is the one-degree model's,
// F_n = k(t) (d - e(t) - b) + c (d' - e'(t)) on the drive side (back side, backlash, tension
// rule and damping forms as there), and enters every coordinate through V (virtual work):
//
//     M q'' + C_b q' + K_b q + V^T F_n = Q(t),
//
// M = diag(m_eq, m_1, m_2, ...), K_b and C_b the bearings (diagonal), Q the torques on u
// (m_eq (R_b1 T1(t) / J1 + R_b2 T2(t) / J2), eq. 6 over cos(beta_b)).
//
// Shafts ([shafts]): a motor of inertia J_m joined to the pinion by a torsional shaft k_s1 and
// a load J_L joined to the wheel by k_s2 add the twists phi_1 = theta_m - theta_1 and
// phi_2 = theta_L - theta_2 (theta_2 and theta_L counted as the one-degree model counts
// theta_2). The torsional coordinates r = (u, phi_1, phi_2) are r = S theta of the absolute
// rotations theta = (theta_1, theta_2, theta_m, theta_L), S's null space the pair's rigid
// rotation. With J = diag of the inertias and f the torques on theta (T1 on the motor, T2 on
// the load, or on the gears without shafts), theta'' = J^-1 (f - S^T (elastic forces on r)), so
// r'' = S J^-1 S^T (-elastic forces) + S J^-1 f exactly: the torsional block of M is
// (S J^-1 S^T)^-1 (full, not diagonal) and Q = M S J^-1 f on r. Without shafts this is m_eq
// and eq. 6. The shafts' springs k_s phi_i and dampers are diagonal in K_b and C_b.
//
// A bearing with a radial clearance c_i acts on y_i as a dead zone, k (y_i -+ c_i) beyond +-c_i
// and nothing inside (Kahraman and Singh 1991), with its damping in contact only. x_i and the
// tilts about x are not touched by a frictionless mesh at one point: they are kept with
// dof = 12, on their bearings alone.
//
// Coordinates by dof: 3 keeps u, y1, y2 (Kahraman and Singh 1991); 6 adds z1, z2; 12 adds ty1,
// ty2, x1, x2, tx1, tx2 (11 coordinates: the 12 of two rigid bodies less the pair's rotation).
// Each shaft adds its twist after u, whatever the dof.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/harmonic_series.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn {

struct MeshStiffness;  // stiffness.hpp

enum class Coordinate {
  kTorsion,  // u = R_b1 theta_1 + R_b2 theta_2, m
  kLine1,    // y_1, along the line of action, m
  kLine2,
  kAxial1,  // z_1, m
  kAxial2,
  kTilt1,  // ty_1, about the y axis, rad
  kTilt2,
  kCross1,  // x_1, normal to the line of action in the transverse plane, m
  kCross2,
  kRock1,  // tx_1, about the x axis, rad
  kRock2,
  kShaft1,  // phi_1 = theta_motor - theta_1, the drive shaft's twist, rad
  kShaft2,  // phi_2 = theta_load - theta_2, the load shaft's twist, rad
};
// Its name in files and tables: "u_m", "y1_m", ..., "ty1_rad".
const char* to_string(Coordinate c);

// The constants of the coupled model, SI, derived once from the case.
struct CoupledParameters {
  int dof = 12;
  std::vector<Coordinate> coordinates;
  // M: diagonal (the gear masses and tilt inertias) but for the torsional block of u and the
  // shaft twists, (S J^-1 S^T)^-1 (m_eq alone without shafts).
  Eigen::MatrixXd mass;
  Eigen::VectorXd bearing_stiffness;    // diagonal of K_b, bearings and shafts (N/m, N m/rad; 0: u)
  Eigen::VectorXd bearing_damping;      // diagonal of C_b
  Eigen::RowVectorXd mesh_vector;       // V, d = V q (m per unit coordinate)
  std::array<int, 2> line = {1, 2};     // the coordinate index of y_1, y_2
  std::array<int, 2> shaft = {-1, -1};  // the index of phi_1, phi_2; -1: no shaft
  std::array<double, 2> clearance_m = {0, 0};  // bearing clearance along y_i, 0: none
  double backlash_m = 0;
  double cos_base_helix = 1, sin_base_helix = 0;
  std::array<double, 2> base_radius_m = {0, 0};  // R_b1, R_b2
  HarmonicSeries stiffness_n_per_m;              // k(t)
  HarmonicSeries transmission_error_m;           // e(t)
  double mesh_damping_n_s_per_m = 0;             // c, as the one-degree model's
  DampingForm damping = DampingForm::kContact;
  TensionRule tension = TensionRule::kAllow;
  // The torques' generalized force Q(t) = drive_gain T1(t) + load_gain T2(t) (N on u, N m on
  // the twists): drive_gain per N m of T1 (with the matched load's share R_b2 T1(t) / R_b1
  // when T2 is not given), load_gain per N m of a given T2 (0 with the matched load). Without
  // shafts Q on u is the one-degree model's F(t) / cos(beta_b).
  HarmonicSeries drive_torque_nm;  // T1(t)
  HarmonicSeries load_torque_nm;   // T2(t), given (0 with the matched load)
  Eigen::VectorXd drive_gain;
  Eigen::VectorXd load_gain;
  double equivalent_mass_kg = 0;  // m_eq of the gears alone

  Eigen::Index size() const { return static_cast<Eigen::Index>(coordinates.size()); }
  // The index of a coordinate, or -1 when the dof or the shafts leave it out.
  int index(Coordinate c) const;
  // Q(t), and its mean.
  Eigen::VectorXd force(double t_s) const;
  Eigen::VectorXd mean_force() const;
  // The static normal mesh force: Q_u / cos(beta_b) of the mean loads (the u row of K q = Q
  // holds the mesh alone). F_m / cos^2(beta_b) as the one-degree model's without shafts.
  double static_mesh_force_n() const;
  // The static torque of shaft i, k_s phi_i = Q_phi of the mean loads (0 without the shaft).
  double static_shaft_torque_nm(int i) const;
};

// The one-degree gear pair of a coupled case: the same gears, mesh, loads and speed, without
// bearings or shafts (form "gear_pair"); its constants (m_eq, k(t), c, periods) are the coupled
// model's.
Case gear_pair_of(const Case& c);

// Throws InputError for a case that is not of the coupled form or whose geometry or stiffness
// is bad (naming the keys and where they were given). `stiffness`, when given, is used in place
// of computing the case's mesh stiffness (shared_stiffness in run.hpp).
CoupledParameters coupled_parameters(const Case& c, const MeshStiffness* stiffness = nullptr);

// Contact states of a region: the mesh (-2 .. 2 as model.hpp's Region) and each bearing (-1 on
// the -c side, 0 inside the clearance or without one, 1 on the +c side).
struct CoupledState {
  int mesh = 0;
  std::array<int, 2> bearing = {0, 0};
};
constexpr int kCoupledRegions = 5 * 3 * 3;
constexpr int coupled_region(const CoupledState& s) {
  return (s.mesh + 2) + 5 * (s.bearing[0] + 1) + 15 * (s.bearing[1] + 1);
}
constexpr CoupledState coupled_state(int region) {
  return {region % 5 - 2, {(region / 5) % 3 - 1, region / 15 - 1}};
}

class CoupledModel {
 public:
  explicit CoupledModel(CoupledParameters p);
  const CoupledParameters& parameters() const { return p_; }

  // The system for the exact engine: state (q, q'), region index coupled_region(state). The
  // observables, the same in every region: kObservableDeflection d - e (m), kObservableForce
  // F_n (N), kObservableBearing + i the line-of-action bearing force on gear i (N, the force
  // on the gear is minus it), kObservableAxial + i the axial one (0 without z),
  // kObservableShaft + i shaft i's torque (0 without the shaft).
  static constexpr int kObservableDeflection = 0;
  static constexpr int kObservableForce = 1;
  static constexpr int kObservableBearing = 2;
  static constexpr int kObservableAxial = 4;
  static constexpr int kObservableShaft = 6;  // + i: shaft i's torque k_s phi + c_s phi' (N m)
  static constexpr int kObservableCount = 8;
  ode::LinearSwitchedSystem linear_system() const;

  // The region a state at rest or in motion belongs to with no history.
  int classify(double t_s, const Eigen::VectorXd& y) const;
  // The static state under the mean loads, the mesh in drive contact and each bearing on the
  // side the mesh force pushes it to (q, q' = 0), with the transmission error's mean; with
  // `at_start`, a run's start at t = 0, at rest relative to the error as the one-degree model
  // starts (e(0) in place of its mean, q' following e'(0) quasi-statically). Throws
  // std::runtime_error when no such consistent state exists (the mean load does not close the
  // backlash).
  Eigen::VectorXd static_state(bool at_start = false) const;
  // At rest in the middle of the backlash and the clearances relative to the transmission error
  // at t = 0 (the one-degree model's x = delta - e = 0, x' = 0): the quasi-static state under
  // the error alone, d = e(0), d' = e'(0), the bearings unloaded; 0 without an error.
  Eigen::VectorXd rest_state() const;

  // The linearised stiffness and damping in drive contact at the mean stiffness (every bearing
  // in contact): K_b + k_m V^T V and C_b + c V^T V.
  Eigen::MatrixXd contact_stiffness() const;
  Eigen::MatrixXd contact_damping() const;

 private:
  CoupledParameters p_;
};

// Natural modes of the coupled model linearised in contact at the mean stiffness.
struct Mode {
  double frequency_hz = 0;               // undamped, from K phi = w^2 M phi
  double damping_ratio = 0;              // modal: phi^T C phi / (2 w phi^T M phi)
  Eigen::VectorXd shape;                 // phi, mass-normalised, largest component positive
  double mesh_energy = 0;                // fraction of the mode's strain energy in the mesh
  std::array<double, 2> line_energy{};   // in each gear's line-of-action bearing
  std::array<double, 2> axial_energy{};  // in each axial bearing
  std::array<double, 2> tilt_energy{};   // in each gear's tilt bearings
  std::array<double, 2> cross_energy{};  // in each gear's cross (x) bearing
  std::array<double, 2> shaft_energy{};  // in each shaft
};
struct ModeSet {
  std::vector<Coordinate> coordinates;
  std::vector<Mode> modes;  // ascending frequency
  // The damped system's eigenvalues (one of each conjugate pair), as frequency |lambda| / 2 pi
  // and damping ratio -Re lambda / |lambda|, ascending.
  std::vector<std::array<double, 2>> damped;
};
ModeSet modes(const CoupledModel& m);

}  // namespace geardyn
