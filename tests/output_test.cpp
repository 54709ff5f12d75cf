#include "geardyn/output.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "geardyn/case_keys.hpp"
#include "geardyn/csv.hpp"

namespace geardyn {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("geardyn_output_test_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  return d;
}

TEST(Output, SummaryHasEveryDocumentedKey) {
  Case c;
  c.solver.duration_s = 0.005;
  const nlohmann::json j = nlohmann::json::parse(summary_json(run(c)));
  for (const char* k :
       {"regime", "double_sided", "impacts", "backside_impacts", "separations", "last_separation_s",
        "separated_fraction", "max_force_bar", "min_force_bar", "mean_force_bar", "rms_force_bar",
        "max_delta_bar", "min_delta_bar", "dynamic_factor", "steps", "derived", "termination"})
    EXPECT_TRUE(j.contains(k)) << k;
  for (const char* k : {"m_eq_kg", "natural_frequency_hz", "damping_n_s_per_m", "mean_force_n",
                        "static_delta_bar", "mesh_frequency_hz", "base_helix_angle_deg",
                        "working_pressure_angle_deg", "transverse_contact_ratio", "overlap_ratio"})
    EXPECT_TRUE(j["derived"].contains(k)) << k;
  EXPECT_EQ(j["regime"], "sustained");
}

TEST(Output, SummaryKeysAndColumnsAreInTheUnitsOfTheForm) {
  // The non-dimensional form is in tau and units of b, m and b k_m: no key or column of it
  // names seconds or SI units (but the wall time); the gear pair's names stay SI.
  Case c;
  c.model.form = ModelForm::kNondimensional;
  c.solver.duration_s = 60;
  const RunResult r = run(c);
  const nlohmann::json j = nlohmann::json::parse(summary_json(r));
  for (const char* k : {"last_separation_tau", "max_impact_velocity", "duration_tau"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_TRUE(j["steady"].contains("from_tau"));
  EXPECT_TRUE(j["derived"].contains("mesh_frequency_per_tau"));
  EXPECT_TRUE(j["derived"].contains("mean_force"));
  std::vector<std::string> si;
  const auto walk = [&](const auto& self, const nlohmann::json& x) -> void {
    if (!x.is_object() && !x.is_array()) return;
    for (const auto& [key, value] : x.items()) {
      if (x.is_object() && key != "wall_time_s") {
        for (std::string_view unit : {"_s", "_hz", "_kg", "_n", "_m_s", "_per_m"})
          if (key.size() > unit.size() && key.ends_with(unit)) si.push_back(key);
      }
      self(self, value);
    }
  };
  walk(walk, j);
  EXPECT_TRUE(si.empty()) << si.front();
  EXPECT_EQ(timeseries_csv(r.samples, c.model.form).substr(0, 41),
            "tau,delta_bar,velocity,force_bar,contact\n");
  EXPECT_EQ(events_csv(r.events, c.model.form).substr(0, 18), "tau,kind,velocity\n");
  EXPECT_EQ(form_key("velocity_m_s", ModelForm::kGearPair), "velocity_m_s");
  EXPECT_EQ(form_key("damping_n_s_per_m", ModelForm::kNondimensional), "damping");
  EXPECT_EQ(form_key("wall_time_s", ModelForm::kNondimensional), "wall_time_s");
}

TEST(Output, LastSeparationIsNullWhenNone) {
  Case c;
  c.solver.duration_s = 3e-4;  // before the first impact
  const nlohmann::json j = nlohmann::json::parse(summary_json(run(c)));
  EXPECT_TRUE(j["last_separation_s"].is_null());
}

TEST(Output, TimeseriesCsvHasTheDocumentedHeader) {
  Timeseries s;
  s.t_s = {0, 1e-5};
  s.delta_bar = {0, 0.5};
  s.velocity_m_s = {0, 0.1};
  s.force_bar = {0, 0.02};
  s.contact = {0, 1};
  EXPECT_EQ(timeseries_csv(s),
            "t_s,delta_bar,velocity_m_s,force_bar,contact\n0,0,0,0,0\n1e-05,0.5,0.1,0.02,1\n");
}

TEST(Output, RowsFormattedInBlocksOnThreadsAreTheRowsWrittenOneByOne) {
  // Rows of numbers of every size, zeros, negative zeros and integers, written by one
  // CsvWriter row by row and by write_csv_rows on 1, 2 and 3 threads: the same text, for a count
  // of whole blocks, for one row past them, for a file short enough for one thread and for none. A
  // mutant that hands a batch's blocks to the stream out of order, drops the last partial block or
  // formats a row twice fails.
  const auto row = [](CsvWriter& csv, std::size_t i) {
    const double x = static_cast<double>(i);
    csv.number(std::sin(x) * std::pow(10.0, static_cast<double>(i % 23) - 11.0));
    csv.number(i % 5 == 0 ? (i % 2 == 0 ? 0.0 : -0.0) : 1.0 / (x + 0.5))
        .integer(static_cast<long long>(i % 3) - 1);
    csv.number(x * 1e-6).end_row();
  };
  for (const std::size_t count : {std::size_t{0}, 3 * kCsvRowsPerBlock, 1 + 5 * kCsvRowsPerBlock,
                                  8 * kCsvRowsPerBlock, 1 + 27 * kCsvRowsPerBlock}) {
    SCOPED_TRACE(count);
    std::ostringstream one;
    CsvWriter csv(one);
    for (std::size_t i = 0; i < count; ++i) row(csv, i);
    csv.finish();
    const std::string text = one.str();
    EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), static_cast<std::ptrdiff_t>(count));
    for (const unsigned threads : {1U, 2U, 3U}) {
      std::ostringstream blocks;
      write_csv_rows(blocks, count, row, threads);
      EXPECT_EQ(blocks.str(), text) << threads << " threads";
    }
  }
}

TEST(Output, WritesAllFilesAndLeavesNoTemporaries) {
  const fs::path d = fresh_dir("ok");
  write_files_atomically(d, {{"a.txt", "alpha"}, {"b.txt", "beta"}});
  std::ifstream a(d / "a.txt");
  std::string text;
  a >> text;
  EXPECT_EQ(text, "alpha");
  int count = 0;
  for (const auto& e : fs::directory_iterator(d)) {
    (void)e;
    ++count;
  }
  EXPECT_EQ(count, 2);
}

TEST(Output, FailureLeavesNothingBehind) {
  const fs::path d = fresh_dir("fail");
  fs::create_directories(d);
  fs::create_directories(d / "b.txt");  // a directory where a file must go: the rename fails
  EXPECT_THROW(write_files_atomically(d, {{"a.txt", "alpha"}, {"b.txt", "beta"}}),
               std::runtime_error);
  EXPECT_FALSE(fs::exists(d / "a.txt"));
  int count = 0;
  for (const auto& e : fs::directory_iterator(d)) {
    (void)e;
    ++count;
  }
  EXPECT_EQ(count, 1);  // only the obstacle
}

TEST(Output, AFailedMoveLeavesTheDirectoryAsItWas) {
  // The second move into place fails (as a full disk or a vanished directory would make it):
  // the first file, already in place, is taken back, the old version it replaced restored,
  // and no temporary is left.
  const fs::path d = fresh_dir("rename");
  write_files_atomically(d, {{"a.txt", "old alpha"}});
  int moves = 0;
  const RenameFunction failing_second = [&](const fs::path& from, const fs::path& to,
                                            std::error_code& ec) {
    if (from.filename().string().starts_with("b.txt")) {
      ec = std::make_error_code(std::errc::no_space_on_device);
      return;
    }
    ++moves;
    fs::rename(from, to, ec);
  };
  EXPECT_THROW(
      write_files_atomically(d, {{"a.txt", "new alpha"}, {"b.txt", "beta"}}, failing_second),
      std::runtime_error);
  EXPECT_EQ(moves, 2);  // a.txt set aside, the new a.txt moved in: the rollback had work
  std::ifstream a(d / "a.txt");
  std::string text;
  std::getline(a, text);
  EXPECT_EQ(text, "old alpha");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(d)) names.push_back(e.path().filename().string());
  EXPECT_EQ(names, std::vector<std::string>{"a.txt"});
}

}  // namespace
}  // namespace geardyn
