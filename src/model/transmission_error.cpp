#include "geardyn/transmission_error.hpp"

#include <cmath>
#include <complex>
#include <numbers>

#include "geardyn/spectrum.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kUmToM = 1e-6;

// Harmonic i (from 1) of e at i times the angular mesh frequency w, amplitude and phase as given
// (term i - 1 is order i, zero amplitudes included).
void add_terms(HarmonicSeries& e, const std::vector<ErrorHarmonic>& h, double w, double scale) {
  for (std::size_t i = 0; i < h.size(); ++i)
    e.terms.push_back(
        {h[i].amplitude * scale, static_cast<double>(i + 1) * w, h[i].phase_deg * kPi / 180.0});
}

// The mean and the first `kept` harmonics of a table's cycle by its DFT, in um.
std::vector<ErrorHarmonic> table_harmonics(const Case& c, double& mean_um) {
  const std::vector<double> v =
      read_cycle_table(c, {c.mesh.transmission_error_table, "mesh.transmission_error_table",
                           "transmission error table", "transmission_error_um",
                           "a finite transmission error in um", false, c.mesh.stiffness_positions});
  const int n = static_cast<int>(v.size());
  const std::vector<std::complex<double>> x = real_dft(v);
  mean_um = x[0].real() / n;
  std::vector<ErrorHarmonic> h;
  for (int i = 1; i <= c.mesh.transmission_error_kept && i < (n + 1) / 2; ++i)
    h.push_back({2.0 * std::abs(x[i]) / n, std::arg(x[i]) * 180.0 / kPi});
  return h;
}

}  // namespace

HarmonicSeries transmission_error_series(const Case& c) {
  HarmonicSeries e;
  if (c.model.form == ModelForm::kNondimensional) {
    add_terms(e, c.model.transmission_error, c.model.omega, 1.0);
    return e;
  }
  const double w_mesh = 2.0 * kPi * mesh_frequency_hz(c);
  if (!c.mesh.transmission_error_table.empty()) {
    double mean_um = 0;
    const std::vector<ErrorHarmonic> h = table_harmonics(c, mean_um);
    e.offset = mean_um * kUmToM;
    add_terms(e, h, w_mesh, kUmToM);
  } else {
    add_terms(e, c.mesh.transmission_error_um, w_mesh, kUmToM);
  }
  return e;
}

}  // namespace geardyn
