#include "geardyn/figures.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

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

// A spectrum of 20000 lines on a log axis: the figure's rows are those in the axis's range,
// about two per bin of log f, and every bin's peak and trough survive in each column, however
// narrow (one-line peaks at 1234.5 Hz in the first column and 3000 Hz in the second).
TEST(LogDecimatedCsv, KeepsEveryBinsPeakAndTroughInTheAxisRange) {
  std::vector<double> f;
  for (int k = 0; k < 20000; ++k) f.push_back(0.25 * k);
  const auto columns = [&](std::size_t k) {
    const double a = f[k] == 1234.5 ? 7.0 : 1.0 / (1.0 + f[k]) * (1.0 + 0.5 * std::sin(0.9 * k));
    const double b = f[k] == 3000.0 ? 5.0 : 1e-3 * (1.0 + 0.5 * std::cos(1.3 * k));
    return std::vector<double>{a, b};
  };
  const double x_min = 0.25, x_max = 4000;
  std::istringstream rows(log_decimated_csv("frequency_hz,a,b", f, x_min, x_max, columns));
  std::string row;
  std::getline(rows, row);
  EXPECT_EQ(row, "frequency_hz,a,b");
  std::vector<std::array<double, 3>> drawn;
  while (std::getline(rows, row)) {
    std::array<double, 3> v{};
    ASSERT_EQ(std::sscanf(row.c_str(), "%lf,%lf,%lf", &v[0], &v[1], &v[2]), 3) << row;
    drawn.push_back(v);
  }
  EXPECT_LE(drawn.size(), 2 * static_cast<std::size_t>(kSpectrumPlotBins) + 2);
  EXPECT_GT(drawn.size(), static_cast<std::size_t>(kSpectrumPlotBins) / 2);
  EXPECT_EQ(drawn.front()[0], x_min);
  EXPECT_LE(drawn.back()[0], x_max);
  EXPECT_GT(drawn.back()[0], x_max - 1);
  // Each bin of the full spectrum: its largest and smallest value of each column drawn at a
  // frequency inside the bin.
  const double span = std::log(x_max / x_min);
  const auto bin = [&](double x) {
    return static_cast<long>(std::floor(kSpectrumPlotBins * std::log(x / x_min) / span));
  };
  std::map<long, std::array<double, 4>> full, kept;  // max a, min a, max b, min b
  const auto add = [](std::map<long, std::array<double, 4>>& m, long key, double a, double b) {
    auto [it, fresh] = m.try_emplace(key, std::array<double, 4>{a, a, b, b});
    if (fresh) return;
    it->second = {std::max(it->second[0], a), std::min(it->second[1], a),
                  std::max(it->second[2], b), std::min(it->second[3], b)};
  };
  for (std::size_t k = 0; k < f.size(); ++k)
    if (f[k] >= x_min && f[k] <= x_max) add(full, bin(f[k]), columns(k)[0], columns(k)[1]);
  for (const auto& v : drawn) add(kept, bin(v[0]), v[1], v[2]);
  ASSERT_EQ(kept.size(), full.size());
  for (const auto& [key, v] : full)
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(kept[key][i], v[i], 1e-6 * std::abs(v[i])) << key;
  EXPECT_EQ(std::max_element(drawn.begin(), drawn.end(),
                             [](const auto& p, const auto& q) { return p[1] < q[1]; })
                ->at(1),
            7.0);
  EXPECT_EQ(std::max_element(drawn.begin(), drawn.end(),
                             [](const auto& p, const auto& q) { return p[2] < q[2]; })
                ->at(2),
            5.0);
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
