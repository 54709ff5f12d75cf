#include "geardyn/harmonic_series.hpp"

#include <gtest/gtest.h>

namespace geardyn {
namespace {

TEST(HarmonicGrid, FollowsTheDirectValueOverManySteps) {
  HarmonicSeries s;
  s.offset = 2.34e8;
  s.terms = {{0.05 * 2.34e8, 2 * 3.14159265358979 * 56e3, 0.3},
             {0.02 * 2.34e8, 4 * 3.14159265358979 * 56e3, -1.2}};
  // Arguments stay below ~400 rad, so the direct reference itself is exact to ~1e-13.
  const double t0 = 0.0, dt = 1.7e-9;
  HarmonicGrid grid(s, t0, dt);
  double worst = 0;
  for (std::int64_t n = 1; n <= 300000; ++n) {
    const double direct = s(t0 + static_cast<double>(n) * dt);
    worst = std::max(worst, std::abs(grid.next() - direct));
  }
  // Rotation drift within a resync block of 1024 steps, relative to the amplitude.
  EXPECT_LT(worst / (0.07 * 2.34e8), 1e-12);
}

TEST(HarmonicSeries, ConstantHasNoFrequency) {
  HarmonicSeries s;
  s.offset = 3;
  EXPECT_EQ(s(12.0), 3.0);
  EXPECT_EQ(s.max_angular_frequency_rad_s(), 0.0);
  HarmonicGrid g(s, 0, 0.1);
  EXPECT_EQ(g.next(), 3.0);
}

}  // namespace
}  // namespace geardyn
