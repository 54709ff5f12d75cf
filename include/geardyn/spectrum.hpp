// geardyn: amplitude spectra of sampled signals (FFTW3), for the figures and the summary.
#pragma once

#include <complex>
#include <cstddef>
#include <vector>

namespace geardyn {

// The DFT X_k = sum_n x_n exp(-2 pi i k n / N) of real samples, k = 0 .. N/2 (FFTW).
// Thread-safe (FFTW planning is serialised).
std::vector<std::complex<double>> real_dft(const std::vector<double>& x);

// Single-sided amplitude spectrum: amplitude_k is the amplitude of a sinusoid at frequency_hz_k
// (a Hann window is applied and its coherent gain undone; the mean is removed first).
struct Spectrum {
  std::vector<double> frequency_hz;
  std::vector<double> amplitude;
};

// Contract: samples are uniform with spacing dt_s > 0; fewer than 4 samples give an empty
// spectrum. Thread-safe (FFTW planning is serialised).
Spectrum amplitude_spectrum(const std::vector<double>& samples, double dt_s);

struct SpectralPeak {
  double frequency_hz;
  double amplitude;
};

// The `count` largest local maxima of a spectrum, largest first, each refined by a parabola
// through the three bins around it.
std::vector<SpectralPeak> dominant_peaks(const Spectrum& s, std::size_t count);

}  // namespace geardyn
