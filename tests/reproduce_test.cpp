#include "geardyn/reproduce.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "geardyn/reproduce_output.hpp"

namespace geardyn {
namespace {

namespace fs = std::filesystem;

TEST(Park2010Study, HasThePapersElevenCases) {
  const Study s = park2010_study();
  ASSERT_EQ(s.cases.size(), 11u);
  EXPECT_EQ(s.cases[0].id, "fig4a");
  EXPECT_EQ(s.cases[0].input.speed.shaft_frequency_hz, 10.0);
  EXPECT_EQ(s.cases[5].input.mesh.damping_ratio, 0.07);
  EXPECT_EQ(s.cases[7].input.load.fluctuation_ratio, 0.55);
  EXPECT_EQ(s.cases[10].input.mesh.backlash_um, 200.0);
  for (const StudyCase& c : s.cases) EXPECT_EQ(c.input.solver.duration_s, s.window_s);
}

TEST(Park2010Study, ResultsAreTheSameOnOneThreadAndOnMany) {
  const Study s = park2010_study();
  const StudyResult one = run_study(s, 1), many = run_study(s, 4);
  ASSERT_EQ(one.outcomes.size(), many.outcomes.size());
  for (std::size_t i = 0; i < one.outcomes.size(); ++i) {
    EXPECT_EQ(one.outcomes[i].run.reading.impacts, many.outcomes[i].run.reading.impacts);
    EXPECT_EQ(one.outcomes[i].run.reading.last_separation_s,
              many.outcomes[i].run.reading.last_separation_s);
  }
}

TEST(Park2010Study, TheTableComesFromTheRuns) {
  Study s = park2010_study();
  const StudyResult before = run_study(s);
  const std::string md_before = report_markdown(before);
  EXPECT_NE(md_before.find("| Fig. 4 (c) |"), std::string::npos);
  // Change one case: at 1 kHz without torque fluctuation the rattle dies out.
  s.cases[2].input.load.fluctuation_ratio = 0.0;
  const StudyResult after = run_study(s);
  EXPECT_NE(after.outcomes[2].run.reading.regime, before.outcomes[2].run.reading.regime);
  EXPECT_FALSE(after.outcomes[2].holds);
  EXPECT_NE(after.outcomes[2].difference.find("the paper"), std::string::npos);
  const std::string md_after = report_markdown(after);
  EXPECT_NE(md_after, md_before);
  EXPECT_NE(md_after.find("F_a/F_m = 0 |"), std::string::npos);
  EXPECT_NE(md_after.find("| no: "), std::string::npos);
}

TEST(Park2010Study, ElevenFindingsHoldAtTwentyMillisecondsAndOnlyInANarrowBandOfWindows) {
  const StudyResult r = run_study(park2010_study());
  std::size_t holding = 0;
  for (const CaseOutcome& o : r.outcomes) holding += o.holds;
  EXPECT_EQ(holding, 11U);
  EXPECT_EQ(holding_at(r, r.study.window_s), holding);  // the scan agrees with the runs
  ASSERT_EQ(r.all_hold.size(), 1U);
  // Fig. 4(b) separates last at about 16.6 ms (transient from 18.4 ms on); Fig. 6(b) is in
  // contact again for good at its last impact (sustained only while that separation reaches
  // into the final 10 % of the window).
  EXPECT_NEAR(r.all_hold[0].first, 0.01842, 5e-5);
  const CaseOutcome& fig6b = r.outcomes[9];
  ASSERT_EQ(fig6b.spec.id, "fig6b");
  ASSERT_FALSE(fig6b.run.events.empty());
  EXPECT_EQ(fig6b.run.events.back().kind, EventKind::kImpact);
  EXPECT_NEAR(r.all_hold[0].second, fig6b.run.events.back().t_s / 0.9, 1e-9);
  EXPECT_EQ(holding_at(r, 0.015), 9U);
  EXPECT_EQ(holding_at(r, 0.025), 9U);
  EXPECT_EQ(holding_at(r, 0.03), 9U);
  EXPECT_NE(study_headline(r).find("all 11 hold together for 18.42-20.80 ms"), std::string::npos)
      << study_headline(r);
}

TEST(Park2010Study, TheWindowScanAgreesWithRunsOverThoseWindows) {
  // Each window set is read from one long run's events; runs over windows just inside and
  // just outside its ends must agree with it.
  const Study s = park2010_study();
  const StudyResult r = run_study(s);
  int checked = 0;
  for (const CaseOutcome& o : r.outcomes) {
    std::vector<double> windows;
    for (const auto& [from, to] : o.holds_for)
      for (double edge : {from, to})
        if (edge > s.scan_from_s + 1e-4 && edge < s.long_window_s - 1e-4)
          for (double w : {edge - 1e-4, edge + 1e-4}) windows.push_back(w);
    for (double w : windows) {
      Case c = o.spec.input;
      c.solver.duration_s = w;
      const RunReading x = run(c).reading;
      const bool holds = x.regime == o.spec.paper_regime && !x.double_sided;
      EXPECT_EQ(holds, contains(o.holds_for, w)) << o.spec.id << " over " << w * 1e3 << " ms";
      ++checked;
    }
  }
  EXPECT_GE(checked, 12);
}

TEST(Park2010Study, ReplacesItsOwnEarlierFilesAsASetAndKeepsTheUsers) {
  // The study is one set in its folder (output_folder.hpp): written again without figures, the
  // figures of the earlier study go with it; a file of the user's stays, and nothing is left
  // beside the folder or in it.
  const fs::path parent =
      fs::temp_directory_path() / ("geardyn_study_set_" + std::to_string(getpid()));
  fs::remove_all(parent);
  const fs::path d = parent / "study";
  fs::create_directories(d);
  std::ofstream(d / "thesis.tex") << "the user's own";
  const StudyResult r = run_study(park2010_study());
  write_study(d, r, /*figures=*/true);
  ASSERT_TRUE(fs::exists(d / "fig4.png"));
  write_study(d, r, /*figures=*/false);
  EXPECT_FALSE(fs::exists(d / "fig4.png"));
  EXPECT_FALSE(fs::exists(d / "fig4_body.gp"));
  EXPECT_TRUE(fs::exists(d / "study.json"));
  EXPECT_TRUE(fs::exists(d / "cases" / "fig4a" / "timeseries.csv"));
  std::ifstream in(d / "thesis.tex");
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "the user's own");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(d)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{".geardyn-files.json", "cases", "report.html",
                                             "report.md", "study.json", "thesis.tex"}));
  std::size_t entries = 0;
  for (const auto& e : fs::directory_iterator(parent)) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 1U);
  fs::remove_all(parent);
}

TEST(Park2010Study, WritesReportDataAndOneFigurePerPaperFigure) {
  const fs::path d = fs::temp_directory_path() / ("geardyn_reproduce_" + std::to_string(getpid()));
  fs::remove_all(d);
  const StudyResult r = run_study(park2010_study());
  write_study(d, r);
  for (const char* f : {"report.md", "report.html", "study.json", "fig4.png", "fig4.svg",
                        "fig5.png", "fig6.png", "fig6.gp", "fig6_body.gp"})
    EXPECT_GT(fs::file_size(d / f), 100u) << f;
  for (const CaseOutcome& o : r.outcomes) {
    EXPECT_TRUE(fs::exists(d / "cases" / o.spec.id / "timeseries.csv")) << o.spec.id;
    EXPECT_TRUE(fs::exists(d / "cases" / o.spec.id / "intervals.csv")) << o.spec.id;
  }
  std::ifstream in(d / "study.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["cases"].size(), 11u);
  EXPECT_EQ(j["cases"][2]["regime"], to_string(r.outcomes[2].run.reading.regime));
  EXPECT_EQ(j["holding"], 11);
  ASSERT_EQ(j["all_hold_windows_s"].size(), 1U);
  EXPECT_EQ(j["all_hold_windows_s"][0][0].get<double>(), r.all_hold[0].first);
  EXPECT_EQ(j["cases"][9]["holds_for_windows_s"].size(), r.outcomes[9].holds_for.size());
  std::ifstream html(d / "report.html");
  std::stringstream h;
  h << html.rdbuf();
  EXPECT_NE(h.str().find("<img src=\"fig5.png\""), std::string::npos);
}

}  // namespace
}  // namespace geardyn
