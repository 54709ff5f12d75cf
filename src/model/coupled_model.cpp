#include "geardyn/coupled_model.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <complex>
#include <map>
#include <numbers>
#include <stdexcept>

#include "geardyn/case_model.hpp"
#include "geardyn/model.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_statics.hpp"
#include "geardyn/transmission_error.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kUmToM = 1e-6;
constexpr double kMmToM = 1e-3;
// Two frequencies of the system's table are one when this close (relative).
constexpr double kSameFrequency = 1e-12;

using Complex = std::complex<double>;
using ode::Matrix;
using ode::RowVector;
using ode::Vector;

// A real series c0 + sum_f Re(C_f exp(i w_f t)) over a shared table of frequencies.
class Series {
 public:
  double constant = 0;
  std::map<int, Complex> terms;  // frequency index -> C_f

  Series() = default;
  explicit Series(double c) : constant(c) {}

  // A HarmonicSeries' terms A cos(w t + phi) = Re(A e^{i phi} e^{i w t}), placed in `table`.
  static Series of(const HarmonicSeries& h, std::vector<double>& table) {
    Series s(h.offset);
    for (const Harmonic& x : h.terms)
      if (x.amplitude != 0)
        s.terms[index(table, x.angular_frequency_rad_s)] += std::polar(x.amplitude, x.phase_rad);
    return s;
  }
  static int index(std::vector<double>& table, double w) {
    for (std::size_t f = 0; f < table.size(); ++f)
      if (std::abs(table[f] - w) <= kSameFrequency * w) return static_cast<int>(f);
    table.push_back(w);
    return static_cast<int>(table.size()) - 1;
  }

  Series scaled(double a) const {
    Series s = *this;
    s.constant *= a;
    for (auto& [f, c] : s.terms) c *= a;
    return s;
  }
  Series plus(const Series& o) const {
    Series s = *this;
    s.constant += o.constant;
    for (const auto& [f, c] : o.terms) s.terms[f] += c;
    return s;
  }
  // The time derivative: Re(i w C e^{iwt}).
  Series derivative(const std::vector<double>& table) const {
    Series s;
    for (const auto& [f, c] : terms) s.terms[f] = Complex(0, table[f]) * c;
    return s;
  }
  // The product, its sum and difference frequencies placed in `table`:
  // Re(A e^{iwt}) Re(B e^{ivt}) = (Re(A B e^{i(w+v)t}) + Re(A conj(B) e^{i(w-v)t})) / 2.
  Series times(const Series& o, std::vector<double>& table) const {
    Series s(constant * o.constant);
    for (const auto& [f, c] : terms) s.terms[f] += c * o.constant;
    for (const auto& [f, c] : o.terms) s.terms[f] += c * constant;
    for (const auto& [f, a] : terms) {
      for (const auto& [g, b] : o.terms) {
        const double w = table[f], v = table[g];
        s.terms[index(table, w + v)] += 0.5 * a * b;
        const double diff = w - v;
        const Complex d = 0.5 * a * std::conj(b);
        if (std::abs(diff) <= kSameFrequency * std::max(w, v)) {
          s.constant += d.real();
        } else if (diff > 0) {
          s.terms[index(table, diff)] += d;
        } else {
          s.terms[index(table, -diff)] += std::conj(d);
        }
      }
    }
    return s;
  }
  // Into engine terms: value * (constant, cos_f = Re C_f, sin_f = -Im C_f), through `put`.
  template <class T, class Put>
  void place(ode::FourierTerms<T>& out, Put put) const {
    put(out.constant, constant);
    for (const auto& [f, c] : terms) {
      put(out.cos[f], c.real());
      put(out.sin[f], -c.imag());
    }
  }
};

bool kept(int dof, Coordinate c) {
  switch (c) {
    case Coordinate::kTorsion:
    case Coordinate::kLine1:
    case Coordinate::kLine2:
      return true;
    case Coordinate::kAxial1:
    case Coordinate::kAxial2:
      return dof >= 6;
    default:
      return dof >= 12;
  }
}

}  // namespace

const char* to_string(Coordinate c) {
  switch (c) {
    case Coordinate::kTorsion:
      return "u_m";
    case Coordinate::kLine1:
      return "y1_m";
    case Coordinate::kLine2:
      return "y2_m";
    case Coordinate::kAxial1:
      return "z1_m";
    case Coordinate::kAxial2:
      return "z2_m";
    case Coordinate::kTilt1:
      return "ty1_rad";
    case Coordinate::kTilt2:
      return "ty2_rad";
    case Coordinate::kCross1:
      return "x1_m";
    case Coordinate::kCross2:
      return "x2_m";
    case Coordinate::kRock1:
      return "tx1_rad";
    case Coordinate::kRock2:
      return "tx2_rad";
    case Coordinate::kShaft1:
      return "phi1_rad";
    case Coordinate::kShaft2:
      return "phi2_rad";
  }
  return "?";
}

int CoupledParameters::index(Coordinate c) const {
  for (int i = 0; i < size(); ++i)
    if (coordinates[i] == c) return i;
  return -1;
}

Eigen::VectorXd CoupledParameters::force(double t_s) const {
  return drive_gain * drive_torque_nm(t_s) + load_gain * load_torque_nm(t_s);
}

Eigen::VectorXd CoupledParameters::mean_force() const {
  return drive_gain * drive_torque_nm.offset + load_gain * load_torque_nm.offset;
}

double CoupledParameters::static_mesh_force_n() const {
  return mean_force()[index(Coordinate::kTorsion)] / cos_base_helix;
}

double CoupledParameters::static_shaft_torque_nm(int i) const {
  return shaft[i] < 0 ? 0.0 : mean_force()[shaft[i]];
}

Case gear_pair_of(const Case& c) {
  Case pair = c;
  pair.model.form = ModelForm::kGearPair;
  pair.shafts.end_inertia_kg_m2 = {0.0, 0.0};
  return pair;
}

CoupledParameters coupled_parameters(const Case& c, const MeshStiffness* stiffness) {
  if (c.model.form != ModelForm::kCoupled)
    throw InputError("coupled_parameters: the case's model.form is not \"coupled\"");
  // The one-degree model's constants (m_eq, c, F(t), k(t)) from the same case, as a gear pair.
  const Case pair = gear_pair_of(c);
  Geometry g;
  const GearPairModel one = build_model(pair, &g, stiffness);
  GearPairParameters gp = one.parameters();

  CoupledParameters p;
  p.dof = c.model.dof;
  const ShaftData& shafts = c.shafts;
  const std::array<bool, 2> has_shaft = {shafts.end_inertia_kg_m2[0] > 0,
                                         shafts.end_inertia_kg_m2[1] > 0};
  p.coordinates.push_back(Coordinate::kTorsion);
  if (has_shaft[0]) p.coordinates.push_back(Coordinate::kShaft1);
  if (has_shaft[1]) p.coordinates.push_back(Coordinate::kShaft2);
  const Coordinate all[] = {Coordinate::kLine1,  Coordinate::kLine2,  Coordinate::kAxial1,
                            Coordinate::kAxial2, Coordinate::kTilt1,  Coordinate::kTilt2,
                            Coordinate::kCross1, Coordinate::kCross2, Coordinate::kRock1,
                            Coordinate::kRock2};
  for (Coordinate x : all)
    if (kept(p.dof, x)) p.coordinates.push_back(x);
  const Eigen::Index n = p.size();
  Vector diagonal = Vector::Zero(n);  // of M
  p.bearing_stiffness = Vector::Zero(n);
  p.bearing_damping = Vector::Zero(n);
  p.mesh_vector = RowVector::Zero(n);

  const double cb = gp.cos_base_helix;
  const double sb = std::sqrt(std::max(0.0, 1.0 - cb * cb));
  p.cos_base_helix = cb;
  p.sin_base_helix = sb;
  p.base_radius_m = {g.base_radius_m[0], g.base_radius_m[1]};
  p.equivalent_mass_kg = gp.equivalent_mass_kg;
  p.backlash_m = gp.backlash_m;
  p.stiffness_n_per_m = gp.stiffness_n_per_m;
  p.transmission_error_m = transmission_error_series(c);
  p.mesh_damping_n_s_per_m = gp.damping_n_s_per_m;
  p.damping = gp.damping;
  p.tension = gp.tension;

  // The bodies: solid blanks of the reference diameter less the bore (docs/model.md's "Geometry":
  // blank); the tilt inertia of such a disc about a diameter.
  const BearingData& b = c.bearings;
  const double zeta = b.damping_ratio;
  for (int i = 0; i < 2; ++i) {
    const double r = g.reference_diameter_m[i] / 2, ri = c.gear.bore_diameter_mm[i] * kMmToM / 2;
    const double w = g.face_width_m;
    const double mass = c.gear.density_kg_m3 * kPi * (r * r - ri * ri) * w;
    const double tilt = mass * (3 * (r * r + ri * ri) + w * w) / 12;
    const double rb = g.base_radius_m[i];
    const double sign = i == 0 ? 1.0 : -1.0;
    const auto set = [&](Coordinate x, double m, double k, double v) {
      const int j = p.index(x);
      if (j < 0) return;
      diagonal[j] = m;
      p.bearing_stiffness[j] = k;
      p.bearing_damping[j] = 2 * zeta * std::sqrt(m * k);
      p.mesh_vector[j] = v;
    };
    const bool first = i == 0;
    set(first ? Coordinate::kLine1 : Coordinate::kLine2, mass, b.radial_stiffness_n_per_m[i],
        sign * cb);
    set(first ? Coordinate::kAxial1 : Coordinate::kAxial2, mass, b.axial_stiffness_n_per_m[i],
        sign * sb);
    set(first ? Coordinate::kTilt1 : Coordinate::kTilt2, tilt, b.tilt_stiffness_n_m_per_rad[i],
        -sb * rb);
    set(first ? Coordinate::kCross1 : Coordinate::kCross2, mass, b.radial_stiffness_n_per_m[i],
        0.0);
    set(first ? Coordinate::kRock1 : Coordinate::kRock2, tilt, b.tilt_stiffness_n_m_per_rad[i],
        0.0);
    p.clearance_m[i] = b.radial_clearance_um[i] * kUmToM;
  }
  p.line = {p.index(Coordinate::kLine1), p.index(Coordinate::kLine2)};
  p.shaft = {p.index(Coordinate::kShaft1), p.index(Coordinate::kShaft2)};
  const int u = p.index(Coordinate::kTorsion);
  p.mesh_vector[u] = cb;
  p.mass = diagonal.asDiagonal();

  // The torsional block: bodies gear 1, gear 2, then the motor and the load when present;
  // r = S theta over the first t coordinates (u, then the twists).
  const Eigen::Index t = 1 + (has_shaft[0] ? 1 : 0) + (has_shaft[1] ? 1 : 0);
  std::vector<double> inertia = {g.inertia_kg_m2[0], g.inertia_kg_m2[1]};
  std::array<int, 2> end = {0, 1};  // the body each torque acts on: T1, T2
  for (int i = 0; i < 2; ++i)
    if (has_shaft[i]) {
      end[i] = static_cast<int>(inertia.size());
      inertia.push_back(shafts.end_inertia_kg_m2[i]);
    }
  const Eigen::Index bodies = static_cast<Eigen::Index>(inertia.size());
  Matrix s = Matrix::Zero(t, bodies);
  s(u, 0) = g.base_radius_m[0];
  s(u, 1) = g.base_radius_m[1];
  for (int i = 0; i < 2; ++i)
    if (has_shaft[i]) {
      s(p.shaft[i], end[i]) = 1;
      s(p.shaft[i], i) = -1;
    }
  const Vector inverse_inertia = Eigen::Map<const Vector>(inertia.data(), bodies).cwiseInverse();
  const Matrix mobility = s * inverse_inertia.asDiagonal() * s.transpose();  // S J^-1 S^T
  const Matrix block = mobility.inverse();
  p.mass.topLeftCorner(t, t) = block;
  // Q = M S J^-1 f: T1 on its body (with the matched load's R_b2 / R_b1 share on T2's), a
  // given T2(t) on its own.
  const Matrix gain = block * s * inverse_inertia.asDiagonal();  // per N m on each body
  const std::optional<double>& t2 = c.load.load_torque_nm;
  p.drive_torque_nm = drive_torque_nm(c);
  p.load_torque_nm = load_torque_nm(c);
  p.drive_gain = Vector::Zero(n);
  p.load_gain = Vector::Zero(n);
  p.drive_gain.head(t) = gain.col(end[0]);
  if (t2)
    p.load_gain.head(t) = gain.col(end[1]);
  else
    p.drive_gain.head(t) += gain.col(end[1]) * g.base_radius_m[1] / g.base_radius_m[0];
  // The shafts: springs on their twists, damped against the reduced inertia of their ends.
  for (int i = 0; i < 2; ++i) {
    if (!has_shaft[i]) continue;
    const double k = shafts.stiffness_n_m_per_rad[i], a = inertia[i], e = inertia[end[i]];
    p.bearing_stiffness[p.shaft[i]] = k;
    p.bearing_damping[p.shaft[i]] = 2 * shafts.damping_ratio * std::sqrt(k * a * e / (a + e));
  }
  return p;
}

CoupledModel::CoupledModel(CoupledParameters p) : p_(std::move(p)) {}

Eigen::MatrixXd CoupledModel::contact_stiffness() const {
  Matrix k = p_.bearing_stiffness.asDiagonal();
  return k + p_.stiffness_n_per_m.offset * p_.mesh_vector.transpose() * p_.mesh_vector;
}

Eigen::MatrixXd CoupledModel::contact_damping() const {
  Matrix c = p_.bearing_damping.asDiagonal();
  return c + p_.mesh_damping_n_s_per_m * p_.mesh_vector.transpose() * p_.mesh_vector;
}

ode::LinearSwitchedSystem CoupledModel::linear_system() const {
  const Eigen::Index n = p_.size();
  ode::LinearSwitchedSystem sys;
  sys.dimension = 2 * n;
  std::vector<double>& table = sys.frequencies_rad_s;
  // The stiffness first: its lowest frequency sets the coefficient period.
  const Series k = Series::of(p_.stiffness_n_per_m, table);
  const Series e = Series::of(p_.transmission_error_m, table);
  const Series de = e.derivative(table);
  const Series ke = k.times(e, table);
  const Series torque = Series::of(p_.drive_torque_nm, table);
  const Series load = Series::of(p_.load_torque_nm, table);
  double lowest = 0;
  for (const auto& [f, c] : k.terms)
    if (lowest == 0 || table[f] < lowest) lowest = table[f];
  sys.coefficient_period_s = lowest > 0 ? 2 * kPi / lowest : 0.0;
  const std::size_t nf = table.size();

  const Matrix inv_mass = p_.mass.inverse();  // exact zeros off the torsional block
  const Vector drive = inv_mass * p_.drive_gain, loaded = inv_mass * p_.load_gain;
  const RowVector& v = p_.mesh_vector;
  const Matrix vv = v.transpose() * v;
  const double c = p_.mesh_damping_n_s_per_m, b = p_.backlash_m;
  const bool clip = p_.tension == TensionRule::kClip && p_.damping != DampingForm::kAlways;

  // Matrices and guard rows vary only with the stiffness (their terms stay empty otherwise);
  // forcing and offsets may vary at any frequency of the table.
  const bool k_varies = !k.terms.empty();
  const auto matrix_terms = [&] {
    ode::FourierTerms<Matrix> a;
    a.constant = Matrix::Zero(2 * n, 2 * n);
    a.constant.topRightCorner(n, n) = Matrix::Identity(n, n);
    if (k_varies) {
      a.cos.assign(nf, Matrix::Zero(2 * n, 2 * n));
      a.sin.assign(nf, Matrix::Zero(2 * n, 2 * n));
    }
    return a;
  };
  const auto vector_terms = [&] {
    ode::FourierTerms<Vector> x;
    x.constant = Vector::Zero(2 * n);
    if (nf > 0) {
      x.cos.assign(nf, Vector::Zero(2 * n));
      x.sin.assign(nf, Vector::Zero(2 * n));
    }
    return x;
  };
  // An affine functional row (q, q') . y + offset(t) with time-varying parts.
  const auto functional = [&] {
    ode::LinearGuard g;
    g.row.constant = RowVector::Zero(2 * n);
    g.offset.constant = 0.0;
    if (k_varies) {
      g.row.cos.assign(nf, RowVector::Zero(2 * n));
      g.row.sin.assign(nf, RowVector::Zero(2 * n));
    }
    if (nf > 0) {
      g.offset.cos.assign(nf, 0.0);
      g.offset.sin.assign(nf, 0.0);
    }
    return g;
  };
  // sign (d - e - edge): the mesh deflection against an edge.
  const auto deflection = [&](double sign, double edge) {
    ode::LinearGuard g = functional();
    g.row.constant.head(n) = sign * v;
    e.scaled(-sign).plus(Series(-sign * edge)).place(g.offset, [](double& x, double y) { x += y; });
    g.scale = b;
    return g;
  };
  // sign F_n with the teeth at edge: k(t) (d - e - edge) + c (d' - e').
  const auto contact_force = [&](double sign, double edge) {
    ode::LinearGuard g = functional();
    k.scaled(sign).place(g.row, [&](RowVector& r, double x) { r.head(n) += x * v; });
    g.row.constant.tail(n) = sign * c * v;
    const Series offset = ke.plus(k.scaled(edge)).plus(de.scaled(c)).scaled(-sign);
    offset.place(g.offset, [](double& x, double y) { x += y; });
    g.scale = b * p_.stiffness_n_per_m.offset;
    return g;
  };
  // The damper alone, sign c (d' - e') (separated with damping "always").
  const auto damper_force = [&](double sign) {
    ode::LinearGuard g = functional();
    g.row.constant.tail(n) = sign * c * v;
    de.scaled(-sign * c).place(g.offset, [](double& x, double y) { x += y; });
    return g;
  };
  // A bearing's line-of-action force on coordinate j with state s: k (y -+ clearance) + c y'.
  const auto bearing_force = [&](int i, int s) {
    ode::LinearGuard g = functional();
    const int j = p_.line[i];
    if (p_.clearance_m[i] > 0 && s == 0) return g;
    g.row.constant(j) = p_.bearing_stiffness[j];
    g.row.constant(n + j) = p_.bearing_damping[j];
    g.offset.constant = -p_.bearing_stiffness[j] * s * p_.clearance_m[i];
    return g;
  };
  const auto axial_force = [&](int i) {
    ode::LinearGuard g = functional();
    const int j = p_.index(i == 0 ? Coordinate::kAxial1 : Coordinate::kAxial2);
    if (j < 0) return g;
    g.row.constant(j) = p_.bearing_stiffness[j];
    g.row.constant(n + j) = p_.bearing_damping[j];
    return g;
  };
  const auto shaft_torque = [&](int i) {
    ode::LinearGuard g = functional();
    const int j = p_.shaft[i];
    if (j < 0) return g;
    g.row.constant(j) = p_.bearing_stiffness[j];
    g.row.constant(n + j) = p_.bearing_damping[j];
    return g;
  };
  const auto to = [](CoupledState s) { return coupled_region(s); };

  sys.regions.resize(kCoupledRegions);
  for (int r = 0; r < kCoupledRegions; ++r) {
    const CoupledState s = coupled_state(r);
    ode::LinearRegion& region = sys.regions[r];
    region.a = matrix_terms();
    region.u = vector_terms();
    // Bearings: K_b, C_b on every coordinate, but a line bearing inside its clearance.
    Vector kb = p_.bearing_stiffness, cbv = p_.bearing_damping;
    Vector force = Vector::Zero(n);  // constant generalized forces
    for (int i = 0; i < 2; ++i) {
      if (p_.clearance_m[i] <= 0) continue;
      const int j = p_.line[i];
      if (s.bearing[i] == 0) {
        kb[j] = 0;
        cbv[j] = 0;
      } else {
        force[j] += p_.bearing_stiffness[j] * s.bearing[i] * p_.clearance_m[i];
      }
    }
    region.a.constant.bottomLeftCorner(n, n) -= inv_mass * kb.asDiagonal();
    region.a.constant.bottomRightCorner(n, n) -= inv_mass * cbv.asDiagonal();
    // The torques.
    torque.place(region.u, [&](Vector& x, double y) { x.tail(n) += y * drive; });
    load.place(region.u, [&](Vector& x, double y) { x.tail(n) += y * loaded; });
    region.u.constant.tail(n) += inv_mass * force;
    // The mesh: -V^T F_n with F_n = kappa (V q - e - edge) + gamma (V q' - e').
    const bool drive_side = s.mesh == kDriveContact, back = s.mesh == kBackContact;
    const Matrix minv_vv = inv_mass * vv;
    const Vector minv_v = inv_mass * v.transpose();
    if (drive_side || back) {
      const double edge = drive_side ? b : -b;
      k.place(region.a, [&](Matrix& a, double x) { a.bottomLeftCorner(n, n) -= x * minv_vv; });
      region.a.constant.bottomRightCorner(n, n) -= c * minv_vv;
      ke.plus(k.scaled(edge)).plus(de.scaled(c)).place(region.u, [&](Vector& x, double y) {
        x.tail(n) += y * minv_v;
      });
    } else if (s.mesh == kSeparated && p_.damping == DampingForm::kAlways) {
      region.a.constant.bottomRightCorner(n, n) -= c * minv_vv;
      de.scaled(c).place(region.u, [&](Vector& x, double y) { x.tail(n) += y * minv_v; });
    }

    // Guards: the mesh as the one-degree model's, on d - e.
    const auto add = [&](ode::LinearGuard g, CoupledState target) {
      g.target = to(target);
      region.guards.push_back(std::move(g));
    };
    CoupledState next = s;
    switch (s.mesh) {
      case kSeparated:
        next.mesh = kDriveContact;
        add(deflection(-1, b), next);
        next.mesh = kBackContact;
        add(deflection(1, -b), next);
        break;
      case kDriveContact:
        next.mesh = kSeparated;
        add(deflection(1, b), next);
        if (clip) {
          next.mesh = kDriveClipped;
          add(contact_force(1, b), next);
        }
        break;
      case kDriveClipped:
        next.mesh = kSeparated;
        add(deflection(1, b), next);
        next.mesh = kDriveContact;
        add(contact_force(-1, b), next);
        break;
      case kBackContact:
        next.mesh = kSeparated;
        add(deflection(-1, -b), next);
        if (clip) {
          next.mesh = kBackClipped;
          add(contact_force(-1, -b), next);
        }
        break;
      case kBackClipped:
        next.mesh = kSeparated;
        add(deflection(-1, -b), next);
        next.mesh = kBackContact;
        add(contact_force(1, -b), next);
        break;
      default:
        break;
    }
    // Bearing clearances: a dead zone on y_i.
    for (int i = 0; i < 2; ++i) {
      const double gap = p_.clearance_m[i];
      if (gap <= 0) continue;
      const int j = p_.line[i];
      const auto on_y = [&](double sign, double edge, int target) {
        ode::LinearGuard g = functional();
        g.row.constant(j) = sign;
        g.offset.constant = -sign * edge;
        g.scale = gap;
        CoupledState t = s;
        t.bearing[i] = target;
        add(g, t);
      };
      if (s.bearing[i] == 0) {
        on_y(-1, gap, 1);   // gap - y >= 0 inside
        on_y(1, -gap, -1);  // y + gap >= 0 inside
      } else if (s.bearing[i] == 1) {
        on_y(1, gap, 0);
      } else {
        on_y(-1, -gap, 0);
      }
    }

    // Observables.
    region.observables.push_back(deflection(1, 0));
    if (drive_side || back) {
      region.observables.push_back(contact_force(1, drive_side ? b : -b));
    } else if (s.mesh == kSeparated && p_.damping == DampingForm::kAlways) {
      region.observables.push_back(damper_force(1));
    } else {
      region.observables.push_back(functional());
    }
    for (int i = 0; i < 2; ++i) region.observables.push_back(bearing_force(i, s.bearing[i]));
    for (int i = 0; i < 2; ++i) region.observables.push_back(axial_force(i));
    for (int i = 0; i < 2; ++i) region.observables.push_back(shaft_torque(i));
    // A constant mesh stiffness, or a separated mesh, leaves A and the rows constant.
    ode::drop_zero_terms(region);
  }
  return sys;
}

int CoupledModel::classify(double t_s, const Eigen::VectorXd& y) const {
  const Eigen::Index n = p_.size();
  const double d = p_.mesh_vector.dot(y.head(n)) - p_.transmission_error_m(t_s);
  const double b = p_.backlash_m;
  CoupledState s;
  s.mesh = d >= b ? kDriveContact : d <= -b ? kBackContact : kSeparated;
  const bool clip = p_.tension == TensionRule::kClip && p_.damping != DampingForm::kAlways;
  if (clip && s.mesh != kSeparated) {
    const double e_rate = p_.transmission_error_m.rate(t_s);
    const double f = p_.stiffness_n_per_m(t_s) * (d - (s.mesh > 0 ? b : -b)) +
                     p_.mesh_damping_n_s_per_m * (p_.mesh_vector.dot(y.tail(n)) - e_rate);
    if (s.mesh > 0 && f < 0) s.mesh = kDriveClipped;
    if (s.mesh < 0 && f > 0) s.mesh = kBackClipped;
  }
  for (int i = 0; i < 2; ++i) {
    const double gap = p_.clearance_m[i];
    if (gap <= 0) continue;
    const double yi = y[p_.line[i]];
    s.bearing[i] = yi >= gap ? 1 : yi <= -gap ? -1 : 0;
  }
  return coupled_region(s);
}

Eigen::VectorXd CoupledModel::static_state(bool at_start) const {
  // K q = Q with the mesh in drive contact: (K_b + k_m V^T V) q = Q_mean + V^T k_m (e_0 + b),
  // each clearance bearing on the side the mesh force pushes its gear to.
  const Eigen::Index n = p_.size();
  const double km = p_.stiffness_n_per_m.offset, b = p_.backlash_m;
  Vector force = p_.mean_force();
  const double e = at_start ? p_.transmission_error_m(0.0) : p_.transmission_error_m.offset;
  force += p_.mesh_vector.transpose() * km * (e + b);
  Matrix k = contact_stiffness();
  for (int i = 0; i < 2; ++i) {
    if (p_.clearance_m[i] <= 0) continue;
    // The mesh force F_n > 0 pushes gear i along -V_j.
    const int j = p_.line[i];
    const double side = p_.mesh_vector[j] > 0 ? -1.0 : 1.0;
    force[j] += p_.bearing_stiffness[j] * side * p_.clearance_m[i];
  }
  const Eigen::PartialPivLU<Matrix> lu = k.partialPivLu();
  Vector y = Vector::Zero(2 * n);
  y.head(n) = lu.solve(force);
  if (const double rate = at_start ? p_.transmission_error_m.rate(0.0) : 0.0; rate != 0)
    y.tail(n) = lu.solve(Vector(p_.mesh_vector.transpose() * km * rate));
  const CoupledState s = coupled_state(classify(0.0, y));
  if (s.mesh != kDriveContact)
    throw std::runtime_error(
        "no static drive-side contact: the mean load does not close the backlash (mean mesh "
        "force <= 0)");
  for (int i = 0; i < 2; ++i)
    if (p_.clearance_m[i] > 0 && s.bearing[i] == 0)
      throw std::runtime_error(fmt::format(
          "no static contact of bearing {}: the mean mesh force does not close its clearance",
          i + 1));
  return y;
}

Eigen::VectorXd CoupledModel::rest_state() const {
  const Eigen::Index n = p_.size();
  Vector y = Vector::Zero(2 * n);
  const double e = p_.transmission_error_m(0.0), rate = p_.transmission_error_m.rate(0.0);
  if (e == 0 && rate == 0) return y;
  // K q = V^T k_m e: the mesh's spring at d = e, every bearing and shaft unloaded.
  const double km = p_.stiffness_n_per_m.offset;
  const Eigen::PartialPivLU<Matrix> lu = contact_stiffness().partialPivLu();
  y.head(n) = lu.solve(Vector(p_.mesh_vector.transpose() * km * e));
  y.tail(n) = lu.solve(Vector(p_.mesh_vector.transpose() * km * rate));
  return y;
}

ModeSet modes(const CoupledModel& model) {
  const CoupledParameters& p = model.parameters();
  const Eigen::Index n = p.size();
  const Matrix k = model.contact_stiffness(), c = model.contact_damping();
  const Matrix& m = p.mass;
  ModeSet out;
  out.coordinates = p.coordinates;
  Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> solver(k, m);
  if (solver.info() != Eigen::Success)
    throw std::runtime_error("modes: the eigenvalue problem K phi = w^2 M phi did not converge");
  const double km = p.stiffness_n_per_m.offset;
  for (int r = 0; r < n; ++r) {
    Mode mode;
    const double w2 = std::max(0.0, solver.eigenvalues()[r]);
    const double w = std::sqrt(w2);
    mode.frequency_hz = w / (2 * kPi);
    Vector phi = solver.eigenvectors().col(r);  // mass-normalised: phi^T M phi = 1
    Eigen::Index big = 0;
    phi.cwiseAbs().maxCoeff(&big);
    if (phi[big] < 0) phi = -phi;
    mode.shape = phi;
    mode.damping_ratio = w > 0 ? phi.dot(c * phi) / (2 * w) : 0.0;
    const double total = phi.dot(k * phi);
    const double mesh = km * std::pow(p.mesh_vector.dot(phi), 2);
    mode.mesh_energy = total > 0 ? mesh / total : 0.0;
    const auto share = [&](Coordinate x) {
      const int j = p.index(x);
      return j < 0 || total <= 0 ? 0.0 : p.bearing_stiffness[j] * phi[j] * phi[j] / total;
    };
    mode.line_energy = {share(Coordinate::kLine1), share(Coordinate::kLine2)};
    mode.axial_energy = {share(Coordinate::kAxial1), share(Coordinate::kAxial2)};
    mode.tilt_energy = {share(Coordinate::kTilt1) + share(Coordinate::kRock1),
                        share(Coordinate::kTilt2) + share(Coordinate::kRock2)};
    mode.cross_energy = {share(Coordinate::kCross1), share(Coordinate::kCross2)};
    mode.shaft_energy = {share(Coordinate::kShaft1), share(Coordinate::kShaft2)};
    out.modes.push_back(std::move(mode));
  }
  out.damped = train::damped_eigenvalues(m, k, c);
  return out;
}

}  // namespace geardyn
