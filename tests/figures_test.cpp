#include "geardyn/figures.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
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
  c.solver.output_interval_s = 1e-5;  // 1001 samples: drawn as they are
  const RunResult r = run(c);
  write_run(d, r);
  write_run_figures(d, r);
  for (const char* name : {"run_time", "run_spectrum", "run_phase"}) {
    for (const char* ext : {".png", ".svg", ".gp", "_body.gp"})
      EXPECT_GT(fs::file_size(d / (std::string(name) + ext)), 100u) << name << ext;
  }
  EXPECT_EQ(png_size(d / "run_time.png"), std::make_pair(1000, 700));
  EXPECT_EQ(png_size(d / "run_spectrum.png"), std::make_pair(1000, 500));
  // The figure plots the run's own samples (few enough here to be drawn as they are).
  ASSERT_LE(r.samples.size(), kMaxPlotPoints);
  EXPECT_EQ(slurp(d / "plot.csv"), plot_csv(r.samples));
  EXPECT_NE(slurp(d / "run_time_body.gp").find("'plot.csv'"), std::string::npos);
  std::istringstream rows(slurp(d / "plot.csv"));
  std::string row;
  std::getline(rows, row);
  for (std::size_t i = 0; std::getline(rows, row); ++i) {
    double t, db, fb;
    ASSERT_EQ(std::sscanf(row.c_str(), "%lf,%lf,%lf", &t, &db, &fb), 3);
    EXPECT_NEAR(db, r.samples.delta_bar[i], 1e-7 * std::abs(r.samples.delta_bar[i]) + 1e-12);
  }
  EXPECT_EQ(slurp(d / "spectrum.csv"), spectrum_csv(r));
  EXPECT_NE(slurp(d / "run_time.svg").find("<svg"), std::string::npos);
}

TEST(RunFigures, ShowOnlyWhatHappenedAndMarkTheNaturalFrequency) {
  // A rattling run: separation in the legend, no back-side contact there; a run in contact
  // from the start: neither. The spectrum marks f_n on a log frequency axis.
  const auto body = [](const Case& c, const char* name) {
    const fs::path d = fs::temp_directory_path() /
                       (std::string("geardyn_figures_") + name + std::to_string(getpid()));
    fs::remove_all(d);
    const RunResult r = run(c);
    write_run(d, r);
    write_run_figures(d, r);
    return std::make_pair(slurp(d / "run_time_body.gp"), slurp(d / "run_spectrum_body.gp"));
  };
  Case rattle;
  rattle.solver.duration_s = 0.01;
  const auto [time, spectrum] = body(rattle, "rattle");
  EXPECT_NE(time.find("title 'separated'"), std::string::npos);
  EXPECT_EQ(time.find("title 'back-side contact'"), std::string::npos);
  EXPECT_NE(spectrum.find("set logscale xy"), std::string::npos);
  EXPECT_NE(spectrum.find("'f_n'"), std::string::npos);
  Case contact = rattle;
  contact.solver.initial = InitialCondition::kStatic;
  contact.load.fluctuation_ratio = 0;
  EXPECT_EQ(body(contact, "contact").first.find("title '"), std::string::npos);
}

TEST(RunFigures, PhysicalUnitsScaleByTheBacklashAndTheMeshStiffness) {
  // delta in um is delta_bar b, F_G in N is F_bar b k_m; the contact surfaces at +-b (um).
  const fs::path d = fs::temp_directory_path() / ("geardyn_figures_si_" + std::to_string(getpid()));
  fs::remove_all(d);
  Case c;
  c.solver.duration_s = 0.005;
  const RunResult r = run(c);
  write_run(d, r);
  write_run_figures(d, r, /*physical=*/true);
  const std::string body = slurp(d / "run_time_body.gp");
  const double b_um = c.mesh.backlash_um, bk = 1e-6 * c.mesh.backlash_um * 2.34e8;
  EXPECT_NE(body.find("δ (μm)"), std::string::npos);
  EXPECT_NE(body.find("F_G (N)"), std::string::npos);
  EXPECT_NE(body.find(fmt::format("($2*{})", b_um)), std::string::npos);
  EXPECT_NE(body.find(fmt::format("($3*{})", bk)), std::string::npos) << body;
  EXPECT_NE(body.find(fmt::format("{} with lines dt 2", b_um)), std::string::npos);
  Case nd;
  nd.model.form = ModelForm::kNondimensional;
  nd.solver.duration_s = 10;
  EXPECT_THROW(write_run_figures(d, run(nd), true), InputError);
  // The non-dimensional form is drawn in its own terms: tau on the axis, its parameters above.
  const RunResult ndr = run(nd);
  write_run(d, ndr);
  write_run_figures(d, ndr);
  const std::string nd_body = slurp(d / "run_time_body.gp");
  EXPECT_NE(nd_body.find("set xlabel \"τ\""), std::string::npos);
  EXPECT_NE(nd_body.find("set xrange [0:10]"), std::string::npos);
  EXPECT_NE(nd_body.find("Ω = 1, ζ = 0.05"), std::string::npos);
  EXPECT_EQ(nd_body.find("μm"), std::string::npos);
  EXPECT_NE(slurp(d / "run_phase_body.gp").find("dδ/dτ"), std::string::npos);
}

TEST(PlotCsv, DecimatesToTheEnvelope) {
  Timeseries s;
  for (int i = 0; i < 100000; ++i) {
    s.t_s.push_back(i * 1e-6);
    s.delta_bar.push_back(std::sin(i * 0.37));
    s.force_bar.push_back(i == 54321 ? 9.0 : std::cos(i * 0.11));
    s.velocity_m_s.push_back(0);
    s.contact.push_back(0);
  }
  std::istringstream rows(plot_csv(s));
  std::string row;
  std::getline(rows, row);
  std::size_t count = 0;
  double fmax = -1e300, dmin = 1e300;
  while (std::getline(rows, row)) {
    double t, db, fb;
    ASSERT_EQ(std::sscanf(row.c_str(), "%lf,%lf,%lf", &t, &db, &fb), 3);
    fmax = std::max(fmax, fb);
    dmin = std::min(dmin, db);
    ++count;
  }
  EXPECT_LE(count, kMaxPlotPoints);
  EXPECT_EQ(fmax, 9.0);  // a one-sample spike survives
  EXPECT_NEAR(dmin, *std::min_element(s.delta_bar.begin(), s.delta_bar.end()), 1e-7);
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
