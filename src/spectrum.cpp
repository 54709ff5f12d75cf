#include "geardyn/spectrum.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>

namespace geardyn {
namespace {
// FFTW's planner is not thread-safe; execution of a plan is.
std::mutex& planner_mutex() {
  static std::mutex m;
  return m;
}
}  // namespace

std::vector<std::complex<double>> real_dft(const std::vector<double>& x) {
  const int n = static_cast<int>(x.size());
  std::vector<double> in(x);
  std::vector<std::complex<double>> out(n / 2 + 1);
  fftw_plan plan;
  {
    std::lock_guard<std::mutex> lock(planner_mutex());
    plan = fftw_plan_dft_r2c_1d(n, in.data(), reinterpret_cast<fftw_complex*>(out.data()),
                                FFTW_ESTIMATE);
  }
  fftw_execute(plan);
  {
    std::lock_guard<std::mutex> lock(planner_mutex());
    fftw_destroy_plan(plan);
  }
  return out;
}

Spectrum amplitude_spectrum(const std::vector<double>& samples, double dt_s) {
  Spectrum out;
  const std::size_t n = samples.size();
  if (n < 4 || !(dt_s > 0)) return out;
  double mean = 0;
  for (double x : samples) mean += x;
  mean /= static_cast<double>(n);

  std::vector<double> in(n);
  double gain = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * static_cast<double>(i) /
                                          static_cast<double>(n - 1));
    in[i] = (samples[i] - mean) * w;
    gain += w;
  }
  const std::vector<std::complex<double>> spectrum = real_dft(in);
  const std::size_t bins = spectrum.size();
  out.frequency_hz.resize(bins);
  out.amplitude.resize(bins);
  const double df = 1.0 / (static_cast<double>(n) * dt_s);
  for (std::size_t k = 0; k < bins; ++k) {
    out.frequency_hz[k] = static_cast<double>(k) * df;
    out.amplitude[k] = (k == 0 ? 1.0 : 2.0) * std::abs(spectrum[k]) / gain;
  }
  return out;
}

std::vector<SpectralPeak> dominant_peaks(const Spectrum& s, std::size_t count) {
  std::vector<SpectralPeak> peaks;
  const auto& a = s.amplitude;
  for (std::size_t k = 1; k + 1 < a.size(); ++k) {
    if (!(a[k] > a[k - 1] && a[k] >= a[k + 1])) continue;
    // Parabola through the log of the three bins (exact for a Gaussian-shaped peak).
    double offset = 0;
    const double l = std::log(a[k - 1] + 1e-300), c = std::log(a[k] + 1e-300),
                 r = std::log(a[k + 1] + 1e-300);
    const double den = l - 2 * c + r;
    if (den < 0) offset = 0.5 * (l - r) / den;
    const double df = s.frequency_hz[1] - s.frequency_hz[0];
    peaks.push_back({s.frequency_hz[k] + offset * df, std::exp(c - 0.25 * (l - r) * offset)});
  }
  std::sort(peaks.begin(), peaks.end(),
            [](const SpectralPeak& x, const SpectralPeak& y) { return x.amplitude > y.amplitude; });
  if (peaks.size() > count) peaks.resize(count);
  return peaks;
}

}  // namespace geardyn
