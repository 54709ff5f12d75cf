// geardyn: mesh stiffness, pipeline stage 3 (geometry -> mesh stiffness).
//
// The mesh stiffness in the normal direction as the series of eq. 11,
// k(t) = k_m + sum_i k_ai cos(i z1 omega_1 t + phi_i). For now it comes from the case's
// [mesh] mean_stiffness_n_per_m and stiffness_harmonics; computing it from the gear data
// (ISO 6336-1, the potential-energy slice method) is the next stage of this module.
#pragma once

#include "geardyn/case.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/harmonic_series.hpp"

namespace geardyn {

// k(t) in N/m as a series in time for the case's shaft speed: the i-th listed harmonic is at
// i times the mesh frequency z1 f_1.
HarmonicSeries mesh_stiffness_series(const Case& c, const Geometry& g);

// Mesh frequency z1 f_1 in Hz.
double mesh_frequency_hz(const Case& c);

}  // namespace geardyn
