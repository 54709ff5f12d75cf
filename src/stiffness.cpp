#include "geardyn/stiffness.hpp"

#include <numbers>

namespace geardyn {

double mesh_frequency_hz(const Case& c) { return c.gear.teeth[0] * c.speed.shaft_frequency_hz; }

HarmonicSeries mesh_stiffness_series(const Case& c, const Geometry& /*g*/) {
  HarmonicSeries k;
  k.offset = c.mesh.mean_stiffness_n_per_m;
  const double w_mesh = 2.0 * std::numbers::pi * mesh_frequency_hz(c);
  for (std::size_t i = 0; i < c.mesh.stiffness_harmonics.size(); ++i) {
    const StiffnessHarmonic& h = c.mesh.stiffness_harmonics[i];
    k.terms.push_back({h.ratio * k.offset, static_cast<double>(i + 1) * w_mesh,
                       h.phase_deg * std::numbers::pi / 180.0});
  }
  return k;
}

}  // namespace geardyn
