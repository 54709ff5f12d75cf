// One sample of a study's run (study_sample.hpp): a case of any form read into the named numbers
// a study keeps, each equal to the last bit to the reading of the case's own full run, and a
// train's run for a study keeping its samples' times and forces alone.
#include "geardyn/study_sample.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "geardyn/run.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {
namespace {

Case shipped(const std::string& file, const std::vector<Override>& keys) {
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / file);
  for (const Override& k : keys) set_case_value(c, k);
  return c;
}

// `expected` as the sample's: the same names in the same order, each value the same double
// (NaN where the reading is absent).
void expect_readings(const SampleReadings& s, const std::vector<std::string>& names,
                     const std::vector<double>& values) {
  EXPECT_TRUE(s.failure.empty()) << s.failure;
  EXPECT_FALSE(s.cancelled);
  ASSERT_EQ(s.names, names);
  ASSERT_EQ(s.values.size(), values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (std::isnan(values[i])) {
      EXPECT_TRUE(std::isnan(s.values[i])) << names[i] << " = " << s.values[i];
    } else {
      EXPECT_EQ(s.values[i], values[i]) << names[i];
    }
  }
}

double nan_or(const std::optional<double>& x) { return x.value_or(std::nan("")); }

// What a study reads of a train's full run, by the names docs/studies.md gives.
void train_readings(const TrainRunResult& r, std::vector<std::string>& names,
                    std::vector<double>& values) {
  for (const TrainMeshReading& m : r.meshes) {
    for (const char* k : {"impacts", "backside_impacts", "separations", "separated_fraction",
                          "max_force_n", "dynamic_factor", "dynamic_factor_with_startup", "rattle"})
      names.push_back(m.name + "." + k);
    values.insert(values.end(),
                  {static_cast<double>(m.impacts), static_cast<double>(m.backside_impacts),
                   static_cast<double>(m.separations), m.separated_fraction, m.max_force_n,
                   nan_or(m.dynamic_factor), nan_or(m.dynamic_factor_with_startup),
                   m.regime == Regime::kSustained ? 1.0 : 0.0});
  }
  for (const TrainLoadSharing& g : r.load_sharing) {
    for (const char* k : {"static_factor", "factor", "factor_with_startup"})
      names.push_back(g.label + ".load_sharing_" + k);
    values.insert(values.end(),
                  {nan_or(g.static_factor), nan_or(g.factor), nan_or(g.factor_with_startup)});
  }
}

TEST(StudySample, ATrainsSampleIsItsFullRunsReadingOfEveryMeshAndGroup) {
  // A planetary set with one planet's pin off (its sun and ring share unevenly), the loose gear
  // that rattles, and the coupled pair run as its train.
  const std::vector<Case> cases = {
      shipped("planetary_set.toml",
              {{"solver.duration_s", "0.004"}, {"train.planet_pin_errors_um[0][1]", "15"}}),
      shipped("loose_gear_rattle.toml", {{"solver.duration_s", "0.05"}}),
      shipped("park2010_coupled.toml", {{"solver.duration_s", "0.004"}})};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const TrainRunResult full = run_train(c);
    ASSERT_TRUE(full.ok()) << full.message;
    std::vector<std::string> names;
    std::vector<double> values;
    train_readings(full, names, values);
    expect_readings(run_sample(c), names, values);
  }
  // The planetary set's groups are read, and unevenly shared.
  const SampleReadings s = run_sample(cases[0]);
  const auto at = [&](const std::string& name) {
    const auto i = std::find(s.names.begin(), s.names.end(), name);
    EXPECT_NE(i, s.names.end()) << name;
    return i == s.names.end() ? 0.0 : s.values[static_cast<std::size_t>(i - s.names.begin())];
  };
  EXPECT_GT(at("sun.load_sharing_factor_with_startup"), 1.05);
  EXPECT_GT(at("sun.load_sharing_static_factor"), 1.05);
  // The loose gear rattles (drive flank left in the final part, every time the engine slows).
  const SampleReadings loose = run_sample(cases[1]);
  EXPECT_EQ(loose.values[7], 1.0) << loose.names[7];
  EXPECT_GT(loose.values[0], 0.0) << loose.names[0];
}

TEST(StudySample, AStudysTrainRunKeepsOnlyTheSamplesTimesForcesAndLoadsAndReadsTheSame) {
  const Case c = shipped("planetary_set.toml", {{"solver.duration_s", "0.004"},
                                                {"train.planet_pin_errors_um[1][1]", "10"}});
  const TrainRunResult full = run_train(c);
  TrainRunOptions o;
  o.keep_samples = false;
  const TrainRunResult lean = run_train(c, o);
  ASSERT_TRUE(full.ok() && lean.ok());
  ASSERT_GT(full.samples.t_s.size(), 100U);
  EXPECT_EQ(lean.samples.t_s, full.samples.t_s);
  ASSERT_EQ(lean.samples.force_n.size(), full.samples.force_n.size());
  for (std::size_t i = 0; i < full.samples.force_n.size(); ++i)
    for (std::size_t m = 0; m < full.meshes.size(); ++m)
      ASSERT_EQ(lean.samples.force_n[i][m], full.samples.force_n[i][m]);
  EXPECT_TRUE(lean.samples.state.empty());
  EXPECT_TRUE(lean.samples.deflection_bar.empty());
  EXPECT_TRUE(lean.samples.deflection_rate_m_s.empty());
  EXPECT_TRUE(lean.samples.contact.empty());
  // The parts' loads are kept: the steadiness of a train judged by its statistics reads them.
  ASSERT_EQ(lean.samples.parts.size(), full.samples.parts.size());
  for (std::size_t i = 0; i < full.samples.parts.size(); ++i)
    ASSERT_EQ(lean.samples.parts[i], full.samples.parts[i]);
  for (std::size_t m = 0; m < full.meshes.size(); ++m) {
    const TrainMeshReading &a = full.meshes[m], &b = lean.meshes[m];
    EXPECT_TRUE(b.force_peaks.empty() && b.deflection_peaks.empty());
    EXPECT_FALSE(a.force_peaks.empty());
    for (const auto& [x, y] : {std::pair{&a, &b}}) {
      for (const auto& [p, q] :
           {std::pair{static_cast<const TrainMeshPart*>(x), static_cast<const TrainMeshPart*>(y)},
            std::pair{&x->steady, &y->steady}}) {
        EXPECT_EQ(q->max_force_n, p->max_force_n);
        EXPECT_EQ(q->min_force_n, p->min_force_n);
        EXPECT_EQ(q->max_deflection_m, p->max_deflection_m);
        EXPECT_EQ(q->min_deflection_m, p->min_deflection_m);
        EXPECT_EQ(q->mean_force_n, p->mean_force_n);
        EXPECT_EQ(q->rms_force_n, p->rms_force_n);
        EXPECT_EQ(q->mean_deflection_m, p->mean_deflection_m);
        EXPECT_EQ(q->rms_deflection_m, p->rms_deflection_m);
        EXPECT_EQ(q->impacts, p->impacts);
        EXPECT_EQ(q->separated_fraction, p->separated_fraction);
      }
    }
  }
  for (std::size_t k = 0; k < full.bearings.size(); ++k) {
    EXPECT_EQ(lean.bearings[k].force_x_n.max, full.bearings[k].force_x_n.max);
    EXPECT_EQ(lean.bearings[k].steady_force_y_n.min, full.bearings[k].steady_force_y_n.min);
  }
  ASSERT_EQ(lean.load_sharing.size(), full.load_sharing.size());
  for (std::size_t g = 0; g < full.load_sharing.size(); ++g) {
    EXPECT_EQ(lean.load_sharing[g].factor, full.load_sharing[g].factor);
    EXPECT_EQ(lean.load_sharing[g].factor_with_startup, full.load_sharing[g].factor_with_startup);
  }
}

TEST(StudySample, APairFormsSampleIsItsRunsReadingNamedInItsForm) {
  {
    Case c;
    set_case_value(c, {"solver.duration_s", "0.01"});
    const RunResult r = run(c);
    const RunReading& x = r.reading;
    expect_readings(run_sample(c),
                    {"impacts", "backside_impacts", "separations", "separated_fraction",
                     "max_force_bar", "max_delta_bar", "max_impact_velocity_m_s", "dynamic_factor",
                     "dynamic_factor_with_startup", "rattle", "natural_frequency_hz"},
                    {static_cast<double>(x.impacts), static_cast<double>(x.backside_impacts),
                     static_cast<double>(x.separations), x.separated_fraction, x.max_force_bar,
                     x.max_delta_bar, x.max_impact_velocity_m_s,
                     nan_or(r.steady.reading.dynamic_factor), nan_or(x.dynamic_factor),
                     x.regime == Regime::kSustained ? 1.0 : 0.0, r.derived.natural_frequency_hz});
    // The mesh stiffness shared across samples gives the same numbers.
    const MeshStiffness k = case_stiffness(c);
    EXPECT_EQ(run_sample(c, &k).values, run_sample(c).values);
  }
  {
    // The non-dimensional form: its velocity in b w_n, and no natural frequency (its unit of
    // time).
    const Case c = shipped("kahraman_singh.toml", {});
    const RunResult r = run(c);
    const RunReading& x = r.reading;
    expect_readings(
        run_sample(c),
        {"impacts", "backside_impacts", "separations", "separated_fraction", "max_force_bar",
         "max_delta_bar", "max_impact_velocity", "dynamic_factor", "dynamic_factor_with_startup",
         "rattle"},
        {static_cast<double>(x.impacts), static_cast<double>(x.backside_impacts),
         static_cast<double>(x.separations), x.separated_fraction, x.max_force_bar, x.max_delta_bar,
         x.max_impact_velocity_m_s, nan_or(r.steady.reading.dynamic_factor),
         nan_or(x.dynamic_factor), x.regime == Regime::kSustained ? 1.0 : 0.0});
    EXPECT_GT(x.impacts, 0);
  }
}

TEST(StudySample, ARunThatFailsReadsNaNUnderTheSameNamesAndSaysWhy) {
  // A torque that overflows the forces: the run fails (non-finite readings), as `geardyn run`
  // reports it; the sample keeps its names, every value NaN, and the reason.
  const std::vector<Override> overflow = {{"load.torque_nm", "1e307"},
                                          {"load.fluctuation_ratio", "1e300"}};
  Case pair;
  for (const Override& k : overflow) set_case_value(pair, k);
  for (const Case& c : {shipped("park2010_coupled.toml", overflow), pair}) {
    SCOPED_TRACE(to_string(c.model.form));
    const SampleReadings s = run_sample(c);
    EXPECT_FALSE(s.cancelled);
    EXPECT_NE(s.failure.find("numerical failure"), std::string::npos) << s.failure;
    EXPECT_NE(s.failure.find("non-finite"), std::string::npos) << s.failure;
    Case good = c;
    set_case_value(good, {"load.torque_nm", "50"});
    set_case_value(good, {"load.fluctuation_ratio", "0.25"});
    set_case_value(good, {"solver.duration_s", "0.004"});
    EXPECT_EQ(s.names, run_sample(good).names);
    ASSERT_FALSE(s.values.empty());
    for (const double x : s.values) EXPECT_TRUE(std::isnan(x));
  }
}

TEST(StudySample, ARunStoppedByItsProgressIsCancelledAndReadsNothing) {
  for (const Case& c :
       {shipped("loose_gear_rattle.toml", {{"solver.duration_s", "0.05"}}), Case{}}) {
    int calls = 0;
    const SampleReadings s = run_sample(c, nullptr, [&](double) { return ++calls > 1; });
    EXPECT_TRUE(s.cancelled) << c.name;
    EXPECT_TRUE(s.failure.empty()) << s.failure;
    EXPECT_TRUE(s.names.empty() && s.values.empty());
    EXPECT_EQ(calls, 1);
    // Going on, it reads.
    const SampleReadings all = run_sample(c, nullptr, [](double) { return true; });
    EXPECT_FALSE(all.cancelled);
    EXPECT_FALSE(all.values.empty());
  }
}

}  // namespace
}  // namespace geardyn
