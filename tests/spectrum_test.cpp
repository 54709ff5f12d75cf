#include "geardyn/spectrum.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace geardyn {
namespace {

TEST(Spectrum, RecoversTheAmplitudesAndFrequenciesOfTwoTones) {
  const double dt = 1e-5;
  std::vector<double> x(20000);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double t = static_cast<double>(i) * dt;
    x[i] = 3.0 + 0.5 * std::cos(2 * std::numbers::pi * 1234.0 * t) +
           0.05 * std::sin(2 * std::numbers::pi * 5678.0 * t + 0.3);
  }
  const Spectrum s = amplitude_spectrum(x, dt);
  ASSERT_EQ(s.frequency_hz.size(), x.size() / 2 + 1);
  EXPECT_NEAR(s.frequency_hz[1], 1.0 / (x.size() * dt), 1e-12);
  const std::vector<SpectralPeak> p = dominant_peaks(s, 2);
  ASSERT_EQ(p.size(), 2u);
  // Bin spacing 5 Hz: the parabolic refinement puts the peak within a fraction of a bin; the
  // Hann window's scalloping loss is at most 15 %, and the refined amplitude recovers most.
  EXPECT_NEAR(p[0].frequency_hz, 1234.0, 0.5);
  EXPECT_NEAR(p[0].amplitude, 0.5, 0.5 * 0.05);
  EXPECT_NEAR(p[1].frequency_hz, 5678.0, 0.5);
  EXPECT_NEAR(p[1].amplitude, 0.05, 0.05 * 0.05);
  // The mean (3.0) is removed; what is left in bin 0 is the tones' leakage through the window.
  EXPECT_LT(s.amplitude[0], 1e-3);
}

TEST(Spectrum, TooShortIsEmpty) {
  EXPECT_TRUE(amplitude_spectrum({1.0, 2.0}, 1e-3).amplitude.empty());
  EXPECT_TRUE(dominant_peaks(Spectrum{}, 3).empty());
}

}  // namespace
}  // namespace geardyn
