// geardyn: mesh stiffness, pipeline stage 3 (geometry -> mesh stiffness).
//
// Three ways to the mesh stiffness, which check each other (docs/stiffness.md):
//  - ISO 6336-1 Method B: the single stiffness c' and the mesh stiffness c_gamma_alpha,
//    c_gamma_beta, constants per unit face width;
//  - the potential-energy method: per tooth pair the bending, shear and axial-compression
//    compliances of both teeth, the Hertzian contact and the fillet-foundation compliance
//    (Sainsot et al. 2004), the pairs in contact summed; a helical pair is cut into face-width
//    slices, each shifted along the line of action by its helix position;
//  - a table of k over one mesh cycle from another program.
// The energy method and the table give k over one mesh cycle; its DFT gives the mean and the
// harmonics of eq. 11, k(t) = k_m + sum_i k_ai cos(i z1 omega_1 t + phi_i). Stiffnesses are in
// the normal direction (transverse stiffness / cos^2 beta_b), N/m, SI inside.
//
// Reference mesh position: position 0 (t = 0) is the instant a tooth pair enters contact at the
// start of the active profile (point A of the path of contact) on the front face of the pinion;
// positions are fractions of the mesh cycle, the time of one transverse base pitch.
#pragma once

#include <array>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/harmonic_series.hpp"

namespace geardyn {

// ISO 6336-1:2006 Method B. Per unit face width, N/(mm um).
struct Iso6336Stiffness {
  std::array<double, 2> virtual_teeth{};  // z_n = z / (cos^2 beta_b cos beta)
  double q_prime = 0;                     // minimum flexibility of a tooth pair, mm um / N
  double c_prime_th = 0;                  // 1 / q'
  double c_m = 0.8;                       // theoretical-to-measured correction
  double c_r = 1;                         // gear blank factor (rim and web)
  double c_b = 1;                         // basic rack factor
  double material_factor = 1;             // E / E_st, E = 2 E1 E2 / (E1 + E2)
  double line_load_n_per_mm = 0;          // F_t K_A / b
  double load_factor = 1;                 // (F_t K_A / b / 100)^0.25 below 100 N/mm, else 1
  double c_prime = 0;                     // c'_th C_M C_R C_B cos(beta) (material, load factors)
  double c_gamma_alpha = 0;               // c' (0.75 eps_alpha + 0.25)
  double c_gamma_beta = 0;                // 0.85 c_gamma_alpha
  // c_gamma_alpha over the whole face width, converted to N/m.
  double mesh_stiffness_n_per_m = 0;
};

Iso6336Stiffness iso6336_stiffness(const Case& c, const Geometry& g);

// The same for an internal pair, gear 0 the pinion and gear 1 the ring (c's gear data and their
// internal_geometry g): the standard takes the ring's virtual number of teeth as
// infinite (z_n2 = inf: the terms C3 / z_n2 and C7 x2 / z_n2 of q' vanish, virtual_teeth[1] is
// infinite; the ring's shift x2 enters C6 x2 + C9 x2^2 in ISO 21771's sign) and c_gamma_alpha
// from the internal pair's transverse contact ratio.
Iso6336Stiffness iso6336_internal_stiffness(const Case& c, const InternalGeometry& g);

// Numerical settings of the energy method beyond the case's positions and slices.
struct EnergyMethodOptions {
  // Points along the path of contact at which a tooth pair's compliance is integrated (it is
  // interpolated between them by a cubic B-spline).
  int path_points = 257;
  // Composite 10-point Gauss-Legendre intervals over each tooth's involute (uniform in
  // sqrt(r - r_b)) and as many over its radial flank below the base circle, at whose nodes the
  // compliance integrals are tabulated once per tooth: converged to rounding at 8 on the
  // ISO/TR 6336-30 example (stiffness_test).
  int quadrature_intervals = 8;
  // Integrate every contact radius's compliance afresh over [r_f, r_c] with
  // quadrature_intervals intervals, without the table: the slow reference the table is
  // tested against.
  bool direct = false;
  // Position of the first sample, in mesh cycles (the cycle is periodic: 1 gives position 0).
  double first_position = 0.0;
};

// k over one mesh cycle at uniform positions.
struct StiffnessCycle {
  std::vector<double> position;       // fraction of the mesh cycle, [0, 1)
  std::vector<double> total_n_per_m;  // mesh stiffness, normal direction
  // Contribution of tooth pair j (the pair that entered at position -j) at each position.
  std::vector<std::vector<double>> pair_n_per_m;
  std::vector<int> pairs_in_contact;     // tooth pairs in contact anywhere on the face
  std::vector<double> contact_length_m;  // total length of the contact lines
  double mean_n_per_m() const;
  double min_n_per_m() const;
  double max_n_per_m() const;
  double mean_pairs_in_contact() const;
};

StiffnessCycle energy_method_cycle(const Case& c, const Geometry& g,
                                   const EnergyMethodOptions& o = {});

// One tooth's compliance per unit face width at contact radius rc (m/N per m), gear `gear` of
// an external pair, integrated afresh by the force's vector in the tooth's frame (the form a
// ring's tooth is computed in, and the reference of the energy method's tables), `intervals`
// Gauss intervals each side of the base circle; without `foundation`, the tooth's beam alone
// (bending, shear and compression).
double tooth_compliance_vector(const Case& c, const Geometry& g, int gear, double rc, int intervals,
                               bool foundation = true);

// The ring's tooth compliance per unit face width at contact radius rc (energy method, concave
// flank; docs/stiffness.md); without `foundation`, its beam alone.
double ring_tooth_compliance(const Case& c, double rc, int intervals = 8, bool foundation = true);

// The energy method's mesh cycle of an internal pair (internal_geometry of c.gear, whose
// InputErrors it throws): the pinion's tooth as an external pair's, the ring's with its concave
// flanks thickening to its root circle outside, both with their profile shifts.
StiffnessCycle internal_energy_method_cycle(const Case& c, const EnergyMethodOptions& o = {});

// A table over one mesh cycle, as a CSV `position,<column>`: positions increasing in [0, 1),
// values finite (and > 0 when `positive`).
struct CycleTableSpec {
  std::string file;           // relative to the case file's directory
  std::string key;            // the case key that names it, for messages
  std::string what;           // "stiffness table"
  std::string column;         // "stiffness_n_per_m"
  std::string value_allowed;  // "a stiffness > 0 N/m"
  bool positive = false;
  int positions = 256;  // resampled to this many equidistant positions
};
// The table's values at positions n / spec.positions, n = 0 .. positions - 1, periodically and
// linearly interpolated between its rows. Throws InputError naming the key, the file and the
// line.
std::vector<double> read_cycle_table(const Case& c, const CycleTableSpec& spec);

// The cycle of a table (the case's mesh.stiffness_table, resampled periodically and linearly to
// mesh.stiffness_positions). Throws InputError naming the key, the file and the line.
StiffnessCycle table_cycle(const Case& c);

// Mean and harmonics (ratio k_ai / k_m and phase) of a cycle by its DFT (FFTW), in the form of
// eq. 11 with position 0 at t = 0.
struct StiffnessFourier {
  double mean_n_per_m = 0;
  std::vector<StiffnessHarmonic> harmonics;
  // k at a position in the mesh cycle (a fraction in [0, 1)), N/m: the one evaluation of the
  // kept series over the cycle (the model's, in time, is HarmonicSeries).
  double at(double position) const;
};
StiffnessFourier fourier_harmonics(const StiffnessCycle& cycle, int kept);

// Largest |k - series| over the cycle's positions, relative to the mean.
double truncation_error(const StiffnessCycle& cycle, const StiffnessFourier& f);

// The mesh stiffness a case runs with: its source, kept harmonics and scaling ("iso6336":
// c_gamma_alpha b, the harmonics as given; InputError when no torque loads it).
struct MeshStiffness {
  StiffnessFourier fourier;             // what the model uses (scaled, truncated)
  std::optional<StiffnessCycle> cycle;  // the computed or tabulated curve, unscaled
  double scale = 1;                     // applied to the cycle to reach mean_stiffness_n_per_m
};
MeshStiffness mesh_stiffness(const Case& c, const Geometry& g);
// An internal pair's (internal_energy_method_cycle), kept and scaled as mesh_stiffness keeps an
// energy cycle.
MeshStiffness internal_mesh_stiffness(const Case& c);

// k(t) in N/m as a series in time for the case's shaft speed: the i-th harmonic is at i times
// the mesh frequency z1 f_1.
HarmonicSeries mesh_stiffness_series(const Case& c, const MeshStiffness& k);
HarmonicSeries mesh_stiffness_series(const Case& c, const Geometry& g);

// Mesh frequency z1 f_1 in Hz.
double mesh_frequency_hz(const Case& c);

}  // namespace geardyn
