#include "geardyn/stiffness.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <boost/math/interpolators/cardinal_cubic_b_spline.hpp>
#include <boost/math/quadrature/gauss.hpp>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <sstream>

#include "geardyn/case_keys.hpp"
#include "geardyn/spectrum.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
// ISO 6336-1 steel, E_st.
constexpr double kIsoSteelModulusGpa = 206.0;
// ISO 6336-1 Method B: q' = C1 + C2/z_n1 + C3/z_n2 + C4 x1 + C5 x1/z_n1 + C6 x2 + C7 x2/z_n2
// + C8 x1^2 + C9 x2^2, mm um / N.
constexpr std::array<double, 9> kIsoQ = {0.04723,  0.15551,  0.25791, -0.00635, -0.11654,
                                         -0.00193, -0.24188, 0.00529, 0.00182};
// Below this line load (N/mm) ISO 6336-1 reduces c' by (F_t K_A / b / 100)^0.25.
constexpr double kIsoLineLoadNPerMm = 100.0;
// Sainsot et al. (2004) fillet-foundation fit, rows L*, M*, P*, Q*, columns A..F of
// X* = A / theta_f^2 + B h_fi^2 + C h_fi / theta_f + D / theta_f + E h_fi + F.
constexpr double kSainsot[4][6] = {
    {-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045},
    {60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086},
    {-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236},
    {-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904},
};
// A solid blank has no bore for h_fi = r_f / r_int: it is taken as a hub of r_f / 3, inside the
// range of geometries Sainsot et al. fitted (h_fi from about 1.4 to 6.8).
constexpr double kSolidBlankHubRatio = 3.0;
// Points over a mesh cycle at which the kept series is checked to stay positive.
constexpr int kPositivitySamples = 4096;
// Timoshenko's shear coefficient of a rectangular section.
constexpr double kShearCoefficient = 1.2;

double involute_fn(double a) { return std::tan(a) - a; }

// One tooth, for its compliance along the path of contact (per unit face width).
//
// The beam part of the compliance at contact radius rc is the integral over the tooth height,
// from the root radius rf to rc, of
//   [arm^2 / (E (2/3) h^3) + k_s cos^2(a1) / (2 G h) + sin^2(a1) / (2 E h)] dy/dr,
// where the moment arm (yc - y) cos(a1) - hc sin(a1) is A - cos(a1) (y - rf) with
// A = (yc - rf) cos(a1) - hc sin(a1): only A and a1 depend on rc. Expanding the square, the
// integral is A^2 F0 - 2 A cos(a1) F1 + cos^2(a1) F2 + (k_s cos^2(a1) / (2 G) + sin^2(a1) /
// (2 E)) F3 with the cumulative integrals from rf of
//   F0: w,  F1: w (y - rf),  F2: w (y - rf)^2  (w = dy/dr / (E (2/3) h^3)),  F3: dy/dr / h,
// which do not depend on rc. They are tabulated once per tooth at the nodes of a composite
// Gauss-Legendre grid over the height, the base circle a node (the flank's kink), and a
// contact radius adds the part from the node below it: ten integrand values instead of a
// whole quadrature per contact radius.
struct Tooth {
  double rb, rf, psi_b, e, g;
  double theta_f, sf, h_fi;
  // A ring gear's tooth: its flanks concave (the involute of its tooth space), the tooth
  // thickening outwards to its root circle rf outside the contact, all of it above the base
  // circle; psi_b is then the half angle its flank's involute would have at the base circle.
  bool ring = false;

  // tan(acos(rb / r)) = sqrt(r^2 - rb^2) / rb, the pressure angle's tangent at r > rb.
  double tan_pressure(double r) const { return std::sqrt(r * r - rb * rb) / rb; }
  // Half tooth angle at radius r: involute above the base circle, radial flank below it; a
  // ring's grows with r by the involute function.
  double psi(double r) const {
    if (ring) return psi_b + (tan_pressure(r) - std::acos(rb / r));
    return r > rb ? psi_b - (tan_pressure(r) - std::acos(rb / r)) : psi_b;
  }

  // The integrands of F0..F3 at r.
  std::array<double, 4> integrands(double r) const {
    const double p = psi(r), sp = std::sin(p), cp = std::cos(p);
    const double h = r * sp, u = r * cp - rf;
    const double dy_dr = r > rb ? cp + sp * tan_pressure(r) : cp;
    const double w = dy_dr / (e * (2.0 / 3.0) * h * h * h);
    return {w, w * u, w * u * u, dy_dr / h};
  }

  // The fillet foundation's compliance (Sainsot et al. 2004) of a unit load whose line meets the
  // tooth's centre line uf from the root circle, cos2 the square of the cosine of its angle to
  // the root section and tan_a that angle's tangent.
  double foundation_compliance(double cos2, double tan_a, double uf) const {
    double x[4];
    for (int i = 0; i < 4; ++i) {
      const double* k = kSainsot[i];
      x[i] = k[0] / (theta_f * theta_f) + k[1] * h_fi * h_fi + k[2] * h_fi / theta_f +
             k[3] / theta_f + k[4] * h_fi + k[5];
    }
    const double u = uf / sf;
    return cos2 / e * (x[0] * u * u + x[1] * u + x[2] * (1 + x[3] * tan_a * tan_a));
  }

  // The load point's terms at rc: A, cos(a1), sin(a1), and the fillet foundation's compliance.
  struct LoadPoint {
    double arm0, ca, sa, foundation;
  };
  LoadPoint load_point(double rc) const {
    const double psi_c = psi(rc);
    const double alpha1 = std::acos(std::min(1.0, rb / rc)) - psi_c;
    const double ca = std::cos(alpha1), sa = std::sin(alpha1);
    const double yc = rc * std::cos(psi_c), hc = rc * std::sin(psi_c);
    const double uf = yc - hc * std::tan(alpha1) - rf;
    const double foundation = foundation_compliance(ca * ca, std::tan(alpha1), uf);
    return {(yc - rf) * ca - hc * sa, ca, sa, foundation};
  }

  double compliance(double rc, const std::array<double, 4>& f) const {
    const LoadPoint q = load_point(rc);
    const double beam = q.arm0 * q.arm0 * f[0] - 2 * q.arm0 * q.ca * f[1] + q.ca * q.ca * f[2] +
                        (kShearCoefficient * q.ca * q.ca / (2 * g) + q.sa * q.sa / (2 * e)) * f[3];
    return beam + q.foundation;
  }

  // The integrals over [a, b] of the values of f(r) (an std::array), by `intervals` 10-point
  // Gauss-Legendre intervals. Above the base circle the involute's sqrt(r^2 - rb^2) has a
  // square-root branch at rb, where plain Gauss converges only algebraically: there the
  // variable is t = sqrt(r - rb) (dr = 2 t dt), in which the integrands are smooth, and the
  // intervals are uniform in t.
  template <class F>
  auto integrate(double a, double b, int intervals, F&& f) const {
    using Rule = boost::math::quadrature::gauss<double, 10>;  // nodes +-x_i, weights w_i
    decltype(f(a)) sum{};
    if (!(b > a)) return sum;
    const bool involute = a >= rb;
    const double lo = involute ? std::sqrt(a - rb) : a, hi = involute ? std::sqrt(b - rb) : b;
    const double half = 0.5 * (hi - lo) / intervals;
    const auto add = [&](double x, double weight) {
      const double r = involute ? rb + x * x : x;
      const double w = involute ? weight * 2 * x : weight;
      const auto values = f(r);
      for (std::size_t m = 0; m < values.size(); ++m) sum[m] += w * values[m];
    };
    for (int k = 0; k < intervals; ++k) {
      const double mid = lo + (2 * k + 1) * half;
      for (std::size_t i = 0; i < Rule::abscissa().size(); ++i) {
        const double x = half * Rule::abscissa()[i], w = half * Rule::weights()[i];
        add(mid + x, w);
        add(mid - x, w);
      }
    }
    return sum;
  }

  // F0..F3 over [a, b].
  std::array<double, 4> integrals(double a, double b, int intervals) const {
    return integrate(a, b, intervals, [this](double r) { return integrands(r); });
  }

  // The compliance at rc per unit face width, in the tooth's own frame (its centre line the x
  // axis, the loaded flank at angle psi(rc)): the unit force along the flank's normal, the line
  // through the contact point P tangent to the base circle (at angle psi(rc) - alpha_c for a
  // convex flank, + alpha_c for a ring's concave one), its moment about each section's centre
  // (r cos psi(r), 0), its shear and axial parts, integrated from the contact to the root
  // circle over the section's half thickness r sin psi(r); and the fillet foundation's
  // compliance (Sainsot et al. 2004) at the force's angle to the section and the distance from
  // the root circle at which its line crosses the centre line. The energy the tables hold in the
  // external tooth's angles (alpha_1 = alpha_c - psi_c, the arm expanded), stated without them:
  // the form a ring's tooth is computed in, and for an external tooth, integrated afresh at
  // every contact radius, the reference its tables are checked against
  // (EnergyMethodOptions::direct, `EnergyMethod.TheTabulatedIntegralsAreTheDirectQuadrature`).
  double compliance_vector(double rc, int intervals, bool foundation = true) const {
    const double psi_c = psi(rc), alpha_c = std::acos(std::min(1.0, rb / rc));
    const double px = rc * std::cos(psi_c), py = rc * std::sin(psi_c);
    const double theta_t = ring ? psi_c + alpha_c : psi_c - alpha_c;
    double fx = rb * std::cos(theta_t) - px, fy = rb * std::sin(theta_t) - py;
    const double length = std::hypot(fx, fy);
    fx /= length;
    fy /= length;
    const auto energy = [&](double r) {
      const double p = psi(r);
      const double h = r * std::sin(p), y = r * std::cos(p);
      const double dy_dr = !(r > rb) ? std::cos(p)
                           : ring    ? std::cos(p) - std::sin(p) * tan_pressure(r)
                                     : std::cos(p) + std::sin(p) * tan_pressure(r);
      const double moment = (px - y) * fy - py * fx;
      const double bending = moment * moment / (e * (2.0 / 3.0) * h * h * h);
      const double shear = kShearCoefficient * fy * fy / (g * 2.0 * h);
      const double axial = fx * fx / (e * 2.0 * h);
      return std::array<double, 1>{(bending + shear + axial) * dy_dr};
    };
    double beam = 0;
    if (ring) {
      beam = integrate(rc, rf, intervals, energy)[0];
    } else if (rf < rb && rc > rb) {
      beam = integrate(rf, rb, intervals, energy)[0] + integrate(rb, rc, intervals, energy)[0];
    } else {
      beam = integrate(rf, rc, intervals, energy)[0];
    }
    if (!foundation) return beam;
    // The foundation: cos^2 of the force's angle to the section is fy^2; its line meets the
    // centre line at px - py fx / fy, uf from the root circle towards the tip (negative for a
    // contact below an external tooth's root circle, as load_point has it).
    const double tan_a = std::abs(fx / fy);
    const double cross = px - py * fx / fy;
    const double uf = ring ? rf - cross : cross - rf;
    return beam + foundation_compliance(fy * fy, tan_a, uf);
  }
};

// F0..F3 of a tooth tabulated at the nodes of a composite Gauss grid from rf to r_top:
// `intervals` intervals below the base circle (when the root is below it) and as many above.
class ToothTable {
 public:
  ToothTable(const Tooth& t, double r_top, int intervals) : t_(t) {
    // Uniform in r on the radial flank, in t = sqrt(r - rb) on the involute (as `integrals`).
    const auto segment = [&](double a, double b) {
      if (!(b > a)) return;
      const bool involute = a >= t.rb;
      const double lo = involute ? std::sqrt(a - t.rb) : a, hi = involute ? std::sqrt(b - t.rb) : b;
      const double step = (hi - lo) / intervals;
      for (int k = 0; k < intervals; ++k) {
        const double x = lo + k * step;
        nodes_.push_back(involute ? t.rb + x * x : x);
      }
    };
    if (t.rf < t.rb) segment(t.rf, t.rb);
    segment(std::max(t.rf, t.rb), r_top);
    nodes_.push_back(r_top);
    cumulative_.assign(nodes_.size(), {});
    for (std::size_t k = 1; k < nodes_.size(); ++k) {
      const std::array<double, 4> part = t.integrals(nodes_[k - 1], nodes_[k], 1);
      for (int m = 0; m < 4; ++m) cumulative_[k][m] = cumulative_[k - 1][m] + part[m];
    }
  }

  double compliance(double rc) const {
    // The node at or below rc, and the rest of the way from it.
    const auto above = std::upper_bound(nodes_.begin(), nodes_.end(), rc);
    const std::size_t k =
        above == nodes_.begin() ? 0 : static_cast<std::size_t>(above - nodes_.begin()) - 1;
    std::array<double, 4> f = cumulative_[k];
    const std::array<double, 4> rest = t_.integrals(nodes_[k], rc, 1);
    for (int m = 0; m < 4; ++m) f[m] += rest[m];
    return t_.compliance(rc, f);
  }

 private:
  const Tooth& t_;
  std::vector<double> nodes_;
  std::vector<std::array<double, 4>> cumulative_;
};

Tooth make_tooth(const Case& c, const Geometry& g, int i) {
  Tooth t;
  const GearData& gd = c.gear;
  t.rb = g.base_radius_m[i];
  t.rf = 0.5 * g.root_diameter_m[i];
  t.psi_b =
      (kPi / 2 + 2 * gd.profile_shift[i] * std::tan(g.normal_pressure_angle_rad)) / gd.teeth[i] +
      involute_fn(g.transverse_pressure_angle_rad);
  t.e = gd.youngs_modulus_gpa[i] * 1e9;
  t.g = t.e / (2 * (1 + gd.poisson_ratio[i]));
  t.theta_f = t.psi(t.rf);
  t.sf = 2 * t.rf * t.theta_f;
  const double r_int =
      gd.bore_diameter_mm[i] > 0 ? 0.5e-3 * gd.bore_diameter_mm[i] : t.rf / kSolidBlankHubRatio;
  t.h_fi = t.rf / r_int;
  return t;
}

// Gear 1 of an internal pair, the ring (z teeth, profile shift x in ISO 21771's sign; transverse
// base radius rb and pressure angle alpha_t): its tooth space is an external tooth's, so its
// tooth's half angle at r is (pi / 2 + 2 x tan(alpha_n)) / z - inv(alpha_t) + inv(alpha_r), its
// thickness at the reference circle m_t (pi / 2 + 2 x tan(alpha_n)); its root circle
// r + m_n (h_fP - x) outside. The foundation is Sainsot's with the ring's root angle and a solid
// body (h_fi = kSolidBlankHubRatio): a rim thick against the tooth, its own bending not modelled.
Tooth make_ring_tooth(const Case& c, double rb, double alpha_t) {
  const GearData& gd = c.gear;
  Tooth t;
  t.ring = true;
  t.rb = rb;
  const double r = rb / std::cos(alpha_t), x = gd.profile_shift[1];
  t.rf = r + 1e-3 * gd.normal_module_mm * (gd.basic_rack_dedendum[1] - x);
  t.psi_b = (kPi / 2 + 2 * x * std::tan(gd.normal_pressure_angle_deg * kPi / 180)) / gd.teeth[1] -
            involute_fn(alpha_t);
  t.e = gd.youngs_modulus_gpa[1] * 1e9;
  t.g = t.e / (2 * (1 + gd.poisson_ratio[1]));
  t.theta_f = t.psi(t.rf);
  t.sf = 2 * t.rf * t.theta_f;
  t.h_fi = kSolidBlankHubRatio;
  return t;
}

// The mesh cycle of a pair whose tooth pairs have the stiffness per unit face width k_unit
// along the path of contact [s_a, s_e] (uniform points, the ends included): each pair's contact
// line on the face (width b, base helix angle beta_b) cut into c.mesh.stiffness_slices slices,
// each a spring of its width, summed over the pairs in contact at c.mesh.stiffness_positions
// positions a base pitch p_bt apart (the normal direction: over cos^2 beta_b).
StiffnessCycle cycle_from_path(const Case& c, double b, double beta_b, double pbt, double s_a,
                               double s_e, const std::vector<double>& k_unit,
                               double first_position) {
  const double ds = (s_e - s_a) / static_cast<double>(k_unit.size() - 1);
  const boost::math::interpolators::cardinal_cubic_b_spline<double> spline(k_unit.begin(),
                                                                           k_unit.end(), s_a, ds);

  const int n_pos = c.mesh.stiffness_positions, n_sl = c.mesh.stiffness_slices;
  const double dw = b / n_sl;
  const double tan_bb = std::tan(beta_b), cos_bb = std::cos(beta_b);
  const double to_normal = 1.0 / (cos_bb * cos_bb);
  const int n_pairs = static_cast<int>(std::ceil((s_e - s_a + b * tan_bb) / pbt)) + 1;

  StiffnessCycle out;
  out.position.resize(n_pos);
  out.total_n_per_m.assign(n_pos, 0.0);
  out.pair_n_per_m.assign(n_pairs, std::vector<double>(n_pos, 0.0));
  out.pairs_in_contact.assign(n_pos, 0);
  out.contact_length_m.assign(n_pos, 0.0);
  for (int n = 0; n < n_pos; ++n) {
    const double phi = first_position + static_cast<double>(n) / n_pos;
    out.position[n] = phi;
    // Pair j entered at position -j; those that can touch the face at phi, whatever phi is.
    const int j_first = static_cast<int>(std::floor(-phi));
    for (int j = j_first; j < j_first + n_pairs + 1; ++j) {
      const double lead = s_a + (phi + j) * pbt;  // the pair's contact on the front face
      // In contact somewhere on the face when [lead - b tan(beta_b), lead] meets [s_a, s_e].
      if (lead >= s_a && lead - b * tan_bb <= s_e) ++out.pairs_in_contact[n];
      double k = 0;
      for (int sl = 0; sl < n_sl; ++sl) {
        const double s = lead - (sl + 0.5) * dw * tan_bb;
        if (s < s_a || s > s_e) continue;
        k += spline(s) * dw;
        out.contact_length_m[n] += dw / cos_bb;
      }
      const int slot = j - j_first;  // the pair that entered last is slot 0
      if (slot < n_pairs) out.pair_n_per_m[slot][n] += k * to_normal;
      out.total_n_per_m[n] += k * to_normal;
    }
  }
  return out;
}

}  // namespace

double StiffnessCycle::mean_n_per_m() const {
  double s = 0;
  for (double k : total_n_per_m) s += k;
  return total_n_per_m.empty() ? 0 : s / static_cast<double>(total_n_per_m.size());
}
double StiffnessCycle::min_n_per_m() const {
  return total_n_per_m.empty() ? 0 : *std::min_element(total_n_per_m.begin(), total_n_per_m.end());
}
double StiffnessCycle::max_n_per_m() const {
  return total_n_per_m.empty() ? 0 : *std::max_element(total_n_per_m.begin(), total_n_per_m.end());
}
double StiffnessCycle::mean_pairs_in_contact() const {
  double s = 0;
  for (int n : pairs_in_contact) s += n;
  return pairs_in_contact.empty() ? 0 : s / static_cast<double>(pairs_in_contact.size());
}

namespace {
// ISO 6336-1 Method B for an external pair or (`internal`: gear 1 a ring, z_n2 infinite) an
// internal one, with the pair's transverse contact ratio eps_alpha.
Iso6336Stiffness iso6336(const Case& c, const Geometry& g, bool internal, double eps_alpha) {
  Iso6336Stiffness s;
  const GearData& gd = c.gear;
  const double cos_beta = std::cos(g.helix_angle_rad);
  const double cos_bb = std::cos(g.base_helix_angle_rad);
  for (int i = 0; i < 2; ++i) s.virtual_teeth[i] = gd.teeth[i] / (cos_bb * cos_bb * cos_beta);
  if (internal) s.virtual_teeth[1] = std::numeric_limits<double>::infinity();
  const double zn1 = s.virtual_teeth[0], zn2 = s.virtual_teeth[1];
  const double x1 = gd.profile_shift[0], x2 = gd.profile_shift[1];
  s.q_prime = kIsoQ[0] + kIsoQ[1] / zn1 + kIsoQ[2] / zn2 + kIsoQ[3] * x1 + kIsoQ[4] * x1 / zn1 +
              kIsoQ[5] * x2 + kIsoQ[6] * x2 / zn2 + kIsoQ[7] * x1 * x1 + kIsoQ[8] * x2 * x2;
  s.c_prime_th = 1.0 / s.q_prime;
  double cr = 0, cb = 0;
  for (int i = 0; i < 2; ++i) {
    // Gear blank factor: 1 for a solid blank, else 1 + ln(b_s/b) / (5 exp(s_R / (5 m_n))) with
    // b_s/b in [0.2, 1.2] and s_R/m_n >= 1, as the standard bounds them.
    double cri = 1.0;
    if (gd.web_thickness_mm[i] > 0 && gd.rim_thickness_mm[i] > 0) {
      const double bs_b = std::clamp(gd.web_thickness_mm[i] / gd.face_width_mm, 0.2, 1.2);
      const double sr_mn = std::max(1.0, gd.rim_thickness_mm[i] / gd.normal_module_mm);
      cri = 1.0 + std::log(bs_b) / (5.0 * std::exp(sr_mn / 5.0));
    }
    cr += 0.5 * cri;
    cb += 0.5 * (1.0 + 0.5 * (1.2 - gd.basic_rack_dedendum[i])) *
          (1.0 - 0.02 * (20.0 - gd.normal_pressure_angle_deg));
  }
  s.c_r = cr;
  s.c_b = cb;
  const double e1 = gd.youngs_modulus_gpa[0], e2 = gd.youngs_modulus_gpa[1];
  s.material_factor = (2 * e1 * e2 / (e1 + e2)) / kIsoSteelModulusGpa;
  const double ft_n = 2.0 * std::abs(c.load.torque_nm) / g.reference_diameter_m[0];
  const double line_load = ft_n * c.mesh.application_factor / gd.face_width_mm;
  s.line_load_n_per_mm = line_load;
  s.load_factor =
      line_load < kIsoLineLoadNPerMm ? std::pow(line_load / kIsoLineLoadNPerMm, 0.25) : 1.0;
  s.c_prime = s.c_prime_th * s.c_m * s.c_r * s.c_b * cos_beta * s.material_factor * s.load_factor;
  s.c_gamma_alpha = s.c_prime * (0.75 * eps_alpha + 0.25);
  s.c_gamma_beta = 0.85 * s.c_gamma_alpha;
  s.mesh_stiffness_n_per_m = s.c_gamma_alpha * gd.face_width_mm * 1e6;
  return s;
}

// The Hertzian compliance of a tooth pair's contact per unit face width, 1/k_h = 2 / (pi E*)
// (Yang and Lin 1987), E* the pair's plane-strain modulus (m/N times m of width).
double hertz_compliance(const GearData& gd) {
  const double e_star =
      1.0 / ((1 - gd.poisson_ratio[0] * gd.poisson_ratio[0]) / (gd.youngs_modulus_gpa[0] * 1e9) +
             (1 - gd.poisson_ratio[1] * gd.poisson_ratio[1]) / (gd.youngs_modulus_gpa[1] * 1e9));
  return 2.0 / (kPi * e_star);
}
}  // namespace

Iso6336Stiffness iso6336_stiffness(const Case& c, const Geometry& g) {
  return iso6336(c, g, false, g.transverse_contact_ratio);
}

Iso6336Stiffness iso6336_internal_stiffness(const Case& c, const InternalGeometry& g) {
  // What Method B reads of the geometry: the helix angles and the pinion's reference diameter.
  Geometry read;
  read.helix_angle_rad = c.gear.helix_angle_deg * kPi / 180;
  read.base_helix_angle_rad = g.base_helix_angle_rad;
  read.reference_diameter_m[0] =
      c.gear.teeth[0] * (c.gear.normal_module_mm * 1e-3 / std::cos(read.helix_angle_rad));
  return iso6336(c, read, true, g.transverse_contact_ratio());
}

StiffnessCycle energy_method_cycle(const Case& c, const Geometry& g, const EnergyMethodOptions& o) {
  const Tooth t1 = make_tooth(c, g, 0), t2 = make_tooth(c, g, 1);
  const double rb1 = g.base_radius_m[0], rb2 = g.base_radius_m[1];
  const double ra1 = g.tip_radius_m[0], ra2 = g.tip_radius_m[1];
  // Path of contact on the line of action, measured from the pinion's base tangent point T1.
  const double t1t2 = g.center_distance_m * std::sin(g.working_pressure_angle_rad);
  const double s_a = t1t2 - std::sqrt(ra2 * ra2 - rb2 * rb2);
  const double s_e = std::sqrt(ra1 * ra1 - rb1 * rb1);
  const double pbt = g.transverse_base_pitch_m;

  const double hertz = hertz_compliance(c.gear);

  // A tooth pair's stiffness per unit face width along the path, on a uniform grid.
  const int np = o.path_points;
  const double ds = (s_e - s_a) / (np - 1);
  std::vector<double> k_unit(np);
  // The contact radii reach the tips at the path's ends.
  const ToothTable table1(t1, std::max(ra1, std::hypot(rb1, s_e)), o.quadrature_intervals);
  const ToothTable table2(t2, std::max(ra2, std::hypot(rb2, t1t2 - s_a)), o.quadrature_intervals);
  for (int i = 0; i < np; ++i) {
    const double s = s_a + i * ds;
    const double rc1 = std::hypot(rb1, s), rc2 = std::hypot(rb2, t1t2 - s);
    const double c1 =
        o.direct ? t1.compliance_vector(rc1, o.quadrature_intervals) : table1.compliance(rc1);
    const double c2 =
        o.direct ? t2.compliance_vector(rc2, o.quadrature_intervals) : table2.compliance(rc2);
    k_unit[i] = 1.0 / (hertz + c1 + c2);
  }
  return cycle_from_path(c, g.face_width_m, g.base_helix_angle_rad, pbt, s_a, s_e, k_unit,
                         o.first_position);
}

double tooth_compliance_vector(const Case& c, const Geometry& g, int gear, double rc, int intervals,
                               bool foundation) {
  return make_tooth(c, g, gear).compliance_vector(rc, intervals, foundation);
}

double ring_tooth_compliance(const Case& c, double rc, int intervals, bool foundation) {
  const InternalGeometry p = internal_geometry(c.gear);
  return make_ring_tooth(c, p.rb2, p.transverse_pressure_angle_rad)
      .compliance_vector(rc, intervals, foundation);
}

StiffnessCycle internal_energy_method_cycle(const Case& c, const EnergyMethodOptions& o) {
  const InternalGeometry p = internal_geometry(c.gear);
  const double alpha_t = p.transverse_pressure_angle_rad;
  // The pinion's tooth from its own geometry (its base and root circles and pressure angles).
  Geometry g;
  g.normal_pressure_angle_rad = c.gear.normal_pressure_angle_deg * kPi / 180;
  g.transverse_pressure_angle_rad = alpha_t;
  g.base_radius_m = {p.rb1, p.rb2};
  const double r1 = p.rb1 / std::cos(alpha_t);
  g.root_diameter_m[0] = 2 * r1 - 2e-3 * c.gear.normal_module_mm *
                                      (c.gear.basic_rack_dedendum[0] - c.gear.profile_shift[0]);
  const Tooth t1 = make_tooth(c, g, 0), t2 = make_ring_tooth(c, p.rb2, alpha_t);
  const GearData& gd = c.gear;
  const double hertz = hertz_compliance(gd);
  const int np = o.path_points;
  const double ds = (p.s_e - p.s_a) / (np - 1);
  std::vector<double> k_unit(np);
  const ToothTable table1(t1, std::max(p.ra1, std::hypot(p.rb1, p.s_e)), o.quadrature_intervals);
  for (int i = 0; i < np; ++i) {
    const double s = p.s_a + i * ds;
    // On the line of action both base tangent points lie on the same side of the contact: the
    // ring's is t1t2 beyond the pinion's.
    const double rc1 = std::hypot(p.rb1, s), rc2 = std::hypot(p.rb2, s + p.t1t2);
    const double c1 =
        o.direct ? t1.compliance_vector(rc1, o.quadrature_intervals) : table1.compliance(rc1);
    const double c2 = t2.compliance_vector(rc2, o.quadrature_intervals);
    k_unit[i] = 1.0 / (hertz + c1 + c2);
  }
  return cycle_from_path(c, 1e-3 * gd.face_width_mm, p.base_helix_angle_rad, p.pbt, p.s_a, p.s_e,
                         k_unit, o.first_position);
}

std::vector<double> read_cycle_table(const Case& c, const CycleTableSpec& spec) {
  std::filesystem::path path = spec.file;
  if (path.is_relative()) path = c.directory / path;
  const std::string key = fmt::format("{} = \"{}\"", spec.key, spec.file);
  std::string text;
  try {
    text = read_input_file(path, spec.what);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", key, e.what()));
  }
  std::istringstream in(text);
  std::string line;
  // Lines as editors save them: CRLF ends, trailing blanks, a last line without a newline.
  const auto next_line = [&] {
    if (!std::getline(in, line)) return false;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
      line.pop_back();
    return true;
  };
  next_line();
  const std::string header = fmt::format("position,{}", spec.column);
  if (line.rfind(header, 0) != 0)
    throw InputError(fmt::format("{}: {}:1: the header must be {}", key, path.string(), header));
  std::vector<double> pos, values;
  int number = 1;
  while (next_line()) {
    ++number;
    if (line.empty()) continue;
    double p, v;
    char comma;
    std::istringstream row(line);
    if (!(row >> p >> comma >> v) || comma != ',' || !(p >= 0 && p < 1) || !std::isfinite(v) ||
        (spec.positive && !(v > 0)) || (!pos.empty() && !(p > pos.back())))
      throw InputError(
          fmt::format("{}: {}:{}: '{}': must be a position in [0, 1) above the previous one and {}",
                      key, path.string(), number, line, spec.value_allowed));
    pos.push_back(p);
    values.push_back(v);
  }
  if (pos.size() < 4)
    throw InputError(fmt::format("{}: {}: needs at least 4 rows", key, path.string()));
  std::vector<double> out;
  for (int n = 0; n < spec.positions; ++n) {
    const double p = static_cast<double>(n) / spec.positions;
    // Periodic linear interpolation between the table's rows.
    std::size_t hi = std::upper_bound(pos.begin(), pos.end(), p) - pos.begin();
    const double p_hi = hi < pos.size() ? pos[hi] : pos[0] + 1.0;
    const double v_hi = hi < pos.size() ? values[hi] : values[0];
    const double p_lo = hi > 0 ? pos[hi - 1] : pos.back() - 1.0;
    const double v_lo = hi > 0 ? values[hi - 1] : values.back();
    out.push_back(v_lo + (v_hi - v_lo) * (p - p_lo) / (p_hi - p_lo));
  }
  return out;
}

StiffnessCycle table_cycle(const Case& c) {
  StiffnessCycle out;
  out.total_n_per_m = read_cycle_table(
      c, {c.mesh.stiffness_table, "mesh.stiffness_table", "stiffness table", "stiffness_n_per_m",
          "a stiffness > 0 N/m", true, c.mesh.stiffness_positions});
  for (int n = 0; n < c.mesh.stiffness_positions; ++n)
    out.position.push_back(static_cast<double>(n) / c.mesh.stiffness_positions);
  return out;
}

StiffnessFourier fourier_harmonics(const StiffnessCycle& cycle, int kept) {
  StiffnessFourier f;
  const int n = static_cast<int>(cycle.total_n_per_m.size());
  const std::vector<std::complex<double>> x = real_dft(cycle.total_n_per_m);
  f.mean_n_per_m = x[0].real() / n;
  for (int i = 1; i <= kept && i <= n / 2; ++i) {
    const double amplitude = 2.0 * std::abs(x[i]) / n;
    const double phase = std::arg(x[i]);
    f.harmonics.push_back({amplitude / f.mean_n_per_m, phase * 180.0 / kPi});
  }
  return f;
}

double StiffnessFourier::at(double position) const {
  double k = mean_n_per_m;
  for (std::size_t i = 0; i < harmonics.size(); ++i)
    k += harmonics[i].ratio * mean_n_per_m *
         std::cos(2 * kPi * static_cast<double>(i + 1) * position +
                  harmonics[i].phase_deg * kPi / 180);
  return k;
}

double truncation_error(const StiffnessCycle& cycle, const StiffnessFourier& f) {
  double worst = 0;
  for (std::size_t n = 0; n < cycle.position.size(); ++n)
    worst = std::max(worst, std::abs(f.at(cycle.position[n]) - cycle.total_n_per_m[n]));
  return worst / f.mean_n_per_m;
}

namespace {
// The energy method's curves computed in this process, by the text of every key that changes
// the stiffness (CaseKey::changes_stiffness, the keys a study's shared stiffness relies on
// too): a gear run again (from Python, a study whose samples vary other keys, a benchmark)
// computes its curve once. Emptied when it holds kCachedCurves.
constexpr std::size_t kCachedCurves = 32;

std::string stiffness_inputs(const Case& c) {
  std::string text;
  for (const CaseKey& k : case_keys())
    if (k.changes_stiffness) {
      text += k.name;
      text += '=';
      text += k.value_text(c);
      text += '\n';
    }
  return text;
}

StiffnessCycle cached_energy_cycle(const Case& c, const Geometry& g) {
  static std::mutex mutex;
  static std::map<std::string, StiffnessCycle> curves;
  std::string inputs = stiffness_inputs(c);
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (const auto found = curves.find(inputs); found != curves.end()) return found->second;
  }
  StiffnessCycle cycle = energy_method_cycle(c, g);
  const std::lock_guard<std::mutex> lock(mutex);
  if (curves.size() >= kCachedCurves) curves.clear();
  curves.emplace(std::move(inputs), cycle);
  return cycle;
}

// A cycle's mesh stiffness as the case keeps it: its harmonics (mesh.harmonics_kept), scaled to
// mesh.mean_stiffness_n_per_m when given, checked to stay positive.
MeshStiffness cycle_stiffness(const Case& c, MeshStiffness m) {
  m.fourier = fourier_harmonics(*m.cycle, c.mesh.harmonics_kept);
  if (c.mesh.mean_stiffness_n_per_m > 0) {
    m.scale = c.mesh.mean_stiffness_n_per_m / m.fourier.mean_n_per_m;
    m.fourier.mean_n_per_m = c.mesh.mean_stiffness_n_per_m;
  }
  // The stiffness the run uses must stay positive: kept harmonics of a steep table (or of a
  // computed curve) can dip below zero where the curve itself does not.
  double bound = 1;
  for (const StiffnessHarmonic& h : m.fourier.harmonics) bound -= std::abs(h.ratio);
  if (!(bound > 0)) {
    double lowest = m.fourier.mean_n_per_m;
    for (int n = 0; n < kPositivitySamples; ++n)
      lowest = std::min(lowest, m.fourier.at(static_cast<double>(n) / kPositivitySamples));
    if (!(lowest > 0)) {
      const char* key = c.mesh.stiffness_source == StiffnessSource::kTable
                            ? "mesh.stiffness_table"
                            : "mesh.stiffness_source = \"energy\"";
      throw InputError(fmt::format(
          "{} with mesh.harmonics_kept = {}: the kept harmonics make the mesh stiffness "
          "negative (down to {:.4g} N/m over a mesh cycle); keep fewer or more harmonics, or "
          "give the harmonics",
          key, c.mesh.harmonics_kept, lowest));
    }
  }
  return m;
}
}  // namespace

MeshStiffness mesh_stiffness(const Case& c, const Geometry& g) {
  MeshStiffness m;
  switch (c.mesh.stiffness_source) {
    case StiffnessSource::kHarmonics:
      m.fourier.mean_n_per_m = c.mesh.mean_stiffness_n_per_m;
      m.fourier.harmonics = c.mesh.stiffness_harmonics;
      return m;
    case StiffnessSource::kIso6336: {
      const Iso6336Stiffness iso = iso6336_stiffness(c, g);
      if (!(iso.mesh_stiffness_n_per_m > 0))
        throw InputError(fmt::format(
            "mesh.stiffness_source = \"iso6336\": ISO 6336-1 gives c_gamma_alpha b = {:.4g} N/m "
            "here (line load {:.4g} N/mm, its load factor {:.4g}): its stiffness needs a "
            "driving torque load.torque_nm != 0",
            iso.mesh_stiffness_n_per_m, iso.line_load_n_per_mm, iso.load_factor));
      m.fourier.mean_n_per_m = iso.mesh_stiffness_n_per_m;
      m.fourier.harmonics = c.mesh.stiffness_harmonics;
      return m;
    }
    case StiffnessSource::kEnergy:
      m.cycle = cached_energy_cycle(c, g);
      break;
    case StiffnessSource::kTable:
      m.cycle = table_cycle(c);
      break;
  }
  return cycle_stiffness(c, std::move(m));
}

MeshStiffness internal_mesh_stiffness(const Case& c) {
  MeshStiffness m;
  m.cycle = internal_energy_method_cycle(c);
  return cycle_stiffness(c, std::move(m));
}

double mesh_frequency_hz(const Case& c) { return c.gear.teeth[0] * c.speed.shaft_frequency_hz; }

HarmonicSeries mesh_stiffness_series(const Case& c, const MeshStiffness& m) {
  HarmonicSeries k;
  k.offset = m.fourier.mean_n_per_m;
  const double w_mesh = 2.0 * kPi * mesh_frequency_hz(c);
  for (std::size_t i = 0; i < m.fourier.harmonics.size(); ++i) {
    const StiffnessHarmonic& h = m.fourier.harmonics[i];
    k.terms.push_back(
        {h.ratio * k.offset, static_cast<double>(i + 1) * w_mesh, h.phase_deg * kPi / 180.0});
  }
  return k;
}

HarmonicSeries mesh_stiffness_series(const Case& c, const Geometry& g) {
  return mesh_stiffness_series(c, mesh_stiffness(c, g));
}

}  // namespace geardyn
