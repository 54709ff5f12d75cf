// The static transmission error: a table over one mesh cycle and the harmonics it holds give the
// same series and the same run; the table's mean shifts delta, not the teeth; bad tables and
// keys are refused naming the key.
#include "geardyn/transmission_error.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "geardyn/run.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

namespace fs = std::filesystem;
using geardyn::testing::error_of;

constexpr double kPi = std::numbers::pi;

// A table of 0.3 + 1.0 cos(2 pi p) + 0.5 cos(4 pi p + 30 deg) um at `rows` positions.
fs::path write_table(const std::string& name, int rows) {
  const fs::path dir = fs::temp_directory_path() / "geardyn_te_test";
  fs::create_directories(dir);
  const fs::path path = dir / name;
  std::ofstream out(path);
  out << "position,transmission_error_um\n";
  for (int n = 0; n < rows; ++n) {
    const double p = static_cast<double>(n) / rows;
    out << fmt::format("{:.17g},{:.17g}\n", p,
                       0.3 + std::cos(2 * kPi * p) + 0.5 * std::cos(4 * kPi * p + kPi / 6));
  }
  return path;
}

Case base_case() {
  Case c;
  c.speed.shaft_frequency_hz = 100;
  c.solver.duration_s = 0.01;
  return c;
}

TEST(TransmissionError, ATableAndItsHarmonicsGiveTheSameRun) {
  Case harmonics = base_case();
  harmonics.mesh.transmission_error_um = {{1.0, 0.0}, {0.5, 30.0}};
  Case table = base_case();
  table.mesh.transmission_error_table = write_table("te.csv", 256).string();
  table.mesh.transmission_error_kept = 8;

  const HarmonicSeries eh = transmission_error_series(harmonics);
  const HarmonicSeries et = transmission_error_series(table);
  EXPECT_EQ(eh.offset, 0.0);
  EXPECT_NEAR(et.offset, 0.3e-6, 1e-20);
  ASSERT_EQ(eh.terms.size(), 2U);
  ASSERT_EQ(et.terms.size(), 8U);  // mesh.transmission_error_kept
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_NEAR(et.terms[i].amplitude, eh.terms[i].amplitude, 1e-20);
    EXPECT_NEAR(et.terms[i].phase_rad, eh.terms[i].phase_rad, 1e-12);
    EXPECT_EQ(et.terms[i].angular_frequency_rad_s, eh.terms[i].angular_frequency_rad_s);
    EXPECT_NEAR(eh.terms[i].angular_frequency_rad_s, 2 * kPi * 5600 * (i + 1), 1e-9);
  }
  for (std::size_t i = 2; i < et.terms.size(); ++i) EXPECT_LT(et.terms[i].amplitude, 1e-20);

  // The same teeth: the runs' deflections relative to e agree, and so do their readings.
  const RunResult rh = run(harmonics), rt = run(table);
  ASSERT_EQ(rh.samples.size(), rt.samples.size());
  double worst = 0;
  for (std::size_t i = 0; i < rh.samples.size(); ++i)
    worst = std::max(worst, std::abs(rh.samples.delta_bar[i] - rt.samples.delta_bar[i]));
  EXPECT_LT(worst, 1e-9);
  EXPECT_EQ(rh.reading.impacts, rt.reading.impacts);
  // And the error matters: without it the run differs.
  const RunResult none = run(base_case());
  double change = 0;
  for (std::size_t i = 0; i < rh.samples.size(); ++i)
    change = std::max(change, std::abs(rh.samples.delta_bar[i] - none.samples.delta_bar[i]));
  EXPECT_GT(change, 1e-3);
}

TEST(TransmissionError, ACoarseTableIsInterpolatedAndItsHarmonicsKept) {
  // 64 rows, resampled linearly to 256 positions: the first harmonic within the interpolation's
  // error (1 - sinc^2 of a 64th of the cycle, ~4e-4), the kept count as asked.
  Case c = base_case();
  c.mesh.transmission_error_table = write_table("coarse.csv", 64).string();
  c.mesh.transmission_error_kept = 3;
  const HarmonicSeries e = transmission_error_series(c);
  ASSERT_EQ(e.terms.size(), 3U);
  EXPECT_NEAR(e.terms[0].amplitude, 1e-6, 1e-9);
  EXPECT_NEAR(e.terms[1].amplitude, 0.5e-6, 2e-9);
}

TEST(TransmissionError, BadTablesAndKeysAreRefusedNamingTheKey) {
  const fs::path dir = fs::temp_directory_path() / "geardyn_te_test";
  fs::create_directories(dir);
  std::ofstream(dir / "header.csv") << "position,stiffness_n_per_m\n0,1\n0.25,1\n0.5,1\n0.75,1\n";
  std::ofstream(dir / "row.csv") << "position,transmission_error_um\n0,1\n0.5,x\n";
  std::ofstream(dir / "short.csv") << "position,transmission_error_um\n0,1\n0.5,1\n";
  const auto message = [&](const std::string& file) {
    Case c = base_case();
    c.mesh.transmission_error_table = (dir / file).string();
    return error_of([&] { (void)build_model(c); });
  };
  EXPECT_NE(message("header.csv").find("the header must be position,transmission_error_um"),
            std::string::npos);
  EXPECT_NE(message("row.csv").find(":3: '0.5,x'"), std::string::npos) << message("row.csv");
  EXPECT_NE(message("short.csv").find("needs at least 4 rows"), std::string::npos);
  EXPECT_NE(message("missing.csv").find("mesh.transmission_error_table"), std::string::npos);

  const std::string both = error_of([] {
    (void)load_case(std::nullopt, {{"mesh.transmission_error_um", "[[1, 0]]"},
                                   {"mesh.transmission_error_table", "te.csv"}});
  });
  EXPECT_NE(both.find("mesh.transmission_error_table = \"te.csv\": must be empty when"),
            std::string::npos)
      << both;
  const std::string many = error_of([] {
    std::string h = "[";
    for (int i = 0; i < 15; ++i) h += "[0.1, 0],";
    (void)load_case(std::nullopt, {{"mesh.transmission_error_um", h + "]"}});
  });
  // 14: room in the force's series for the two torques' fluctuations.
  EXPECT_NE(many.find("at most 14 harmonics"), std::string::npos) << many;
  const std::string negative = error_of([] {
    (void)load_case(std::nullopt, {{"mesh.transmission_error_um", "[[-1, 0]]"}});
  });
  EXPECT_NE(negative.find("mesh.transmission_error_um[0][0] = -1"), std::string::npos) << negative;
}

}  // namespace
}  // namespace geardyn
