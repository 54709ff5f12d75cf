#include "geardyn/spectrum.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <new>
#include <numbers>

namespace geardyn {
namespace {
// FFTW's planner is not thread-safe; execution of a plan is. A plan is made once per length
// (planning a new length costs more than a transform of a run's samples) on arrays of FFTW's own
// alignment, and each transform runs on this thread's arrays of that alignment (fftw_malloc)
// through the new-array interface: a plan for any alignment (FFTW_UNALIGNED) took twice the
// instructions to make for the paper's pair's spectra over 0.3 s, and its transforms 1.7 times
// (docs/performance.md, "A run's files"). The cache is emptied when it holds kMaxCachedPlans
// lengths.
constexpr std::size_t kMaxCachedPlans = 64;

struct PlanCache {
  std::mutex mutex;
  std::map<int, fftw_plan> plans;
  ~PlanCache() {
    for (auto& [n, plan] : plans) fftw_destroy_plan(plan);
  }
};

PlanCache& plan_cache() {
  static PlanCache cache;
  return cache;
}

// An array from fftw_malloc, of at least the size last asked for.
template <class T>
class AlignedArray {
 public:
  AlignedArray() = default;
  AlignedArray(const AlignedArray&) = delete;
  AlignedArray& operator=(const AlignedArray&) = delete;
  ~AlignedArray() { fftw_free(data_); }
  T* at_least(std::size_t n) {
    if (n > size_) {
      fftw_free(data_);
      data_ = static_cast<T*>(fftw_malloc(n * sizeof(T)));
      if (!data_) throw std::bad_alloc();
      size_ = n;
    }
    return data_;
  }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

fftw_plan real_plan(int n, double* in, fftw_complex* out) {
  PlanCache& cache = plan_cache();
  const std::lock_guard<std::mutex> lock(cache.mutex);
  if (const auto found = cache.plans.find(n); found != cache.plans.end()) return found->second;
  if (cache.plans.size() >= kMaxCachedPlans) {
    for (auto& [length, plan] : cache.plans) fftw_destroy_plan(plan);
    cache.plans.clear();
  }
  // FFTW_ESTIMATE leaves the arrays untouched while planning.
  const fftw_plan plan = fftw_plan_dft_r2c_1d(n, in, out, FFTW_ESTIMATE);
  cache.plans.emplace(n, plan);
  return plan;
}
}  // namespace

std::vector<std::complex<double>> real_dft(const std::vector<double>& x) {
  const int n = static_cast<int>(x.size());
  const std::size_t bins = x.size() / 2 + 1;
  thread_local AlignedArray<double> in;
  thread_local AlignedArray<fftw_complex> out;
  double* const input = in.at_least(x.size());
  fftw_complex* const spectrum = out.at_least(bins);
  std::copy(x.begin(), x.end(), input);
  fftw_execute_dft_r2c(real_plan(n, input, spectrum), input, spectrum);
  std::vector<std::complex<double>> result(bins);
  for (std::size_t k = 0; k < bins; ++k) result[k] = {spectrum[k][0], spectrum[k][1]};
  return result;
}

Spectrum amplitude_spectrum(const std::vector<double>& samples, double dt_s) {
  Spectrum out;
  const std::size_t n = samples.size();
  if (n < 4 || !(dt_s > 0)) return out;
  double mean = 0;
  for (double x : samples) mean += x;
  mean /= static_cast<double>(n);

  // The Hann window of the last length asked for on this thread (a run's two spectra, a
  // study's runs, share it).
  thread_local std::vector<double> window;
  thread_local double gain = 0;
  if (window.size() != n) {
    window.resize(n);
    gain = 0;
    for (std::size_t i = 0; i < n; ++i) {
      window[i] = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * static_cast<double>(i) /
                                       static_cast<double>(n - 1));
      gain += window[i];
    }
  }
  std::vector<double> in(n);
  for (std::size_t i = 0; i < n; ++i) in[i] = (samples[i] - mean) * window[i];
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
