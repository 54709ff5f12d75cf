#include "geardyn/output.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

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

}  // namespace
}  // namespace geardyn
