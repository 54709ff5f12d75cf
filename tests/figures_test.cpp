#include "geardyn/figures.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "geardyn/output.hpp"

namespace geardyn {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Width and height from a PNG's IHDR chunk.
std::pair<int, int> png_size(const fs::path& p) {
  const std::string b = slurp(p);
  EXPECT_GE(b.size(), 24u);
  EXPECT_EQ(b.substr(1, 3), "PNG");
  auto be32 = [&](std::size_t i) {
    return (static_cast<unsigned char>(b[i]) << 24) | (static_cast<unsigned char>(b[i + 1]) << 16) |
           (static_cast<unsigned char>(b[i + 2]) << 8) | static_cast<unsigned char>(b[i + 3]);
  };
  return {be32(16), be32(20)};
}

TEST(ContactIntervals, AddUpToTheSeparatedFraction) {
  Case c;
  c.solver.duration_s = 0.02;
  const RunResult r = run(c);
  std::istringstream in(contact_intervals_csv(r));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "t_start_s,t_end_s,contact");
  double separated = 0;
  int rows = 0;
  while (std::getline(in, line)) {
    double a, b;
    int state;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%d", &a, &b, &state), 3);
    if (state == 0) separated += b - a;
    ++rows;
  }
  EXPECT_EQ(rows, r.reading.separations + 1);  // the initial flight, then one per separation
  EXPECT_NEAR(separated / c.solver.duration_s, r.reading.separated_fraction, 1e-12);
}

TEST(RunFigures, AreWrittenWithTheirDataAndScripts) {
  const fs::path d = fs::temp_directory_path() / ("geardyn_figures_" + std::to_string(getpid()));
  fs::remove_all(d);
  Case c;
  c.solver.duration_s = 0.01;
  const RunResult r = run(c);
  write_run(d, r);
  write_run_figures(d, r);
  for (const char* name : {"run_time", "run_spectrum", "run_phase"}) {
    for (const char* ext : {".png", ".svg", ".gp", "_body.gp"})
      EXPECT_GT(fs::file_size(d / (std::string(name) + ext)), 100u) << name << ext;
  }
  EXPECT_EQ(png_size(d / "run_time.png"), std::make_pair(1000, 700));
  EXPECT_EQ(png_size(d / "run_spectrum.png"), std::make_pair(1000, 500));
  // The figure plots the run's own samples.
  EXPECT_EQ(slurp(d / "timeseries.csv"), timeseries_csv(r.samples));
  EXPECT_NE(slurp(d / "run_time_body.gp").find("'timeseries.csv'"), std::string::npos);
  EXPECT_EQ(slurp(d / "spectrum.csv"), spectrum_csv(r));
  EXPECT_NE(slurp(d / "run_time.svg").find("<svg"), std::string::npos);
}

TEST(RenderFigure, ReportsAGnuplotFailure) {
  const fs::path d =
      fs::temp_directory_path() / ("geardyn_figures_bad_" + std::to_string(getpid()));
  fs::create_directories(d);
  try {
    render_figure(d, "broken", "plot 'no_such_file.csv' using 1:2\n", 300, 200);
    FAIL() << "no FigureError";
  } catch (const FigureError& e) {
    EXPECT_NE(std::string(e.what()).find("gnuplot failed"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace geardyn
