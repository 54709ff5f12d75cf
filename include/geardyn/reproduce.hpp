// geardyn: reproducing a paper's study, `geardyn reproduce park2010`.
//
// A study is a list of cases, each with the paper's finding for it. Running it runs every case
// (in parallel), reads each run, and compares the reading with the finding; the report's table is
// computed from the runs, never written by hand.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "geardyn/run.hpp"

namespace geardyn {

struct StudyCase {
  std::string id;      // "fig4a": also the case's output directory
  std::string figure;  // "Fig. 4": cases of one figure are drawn together
  std::string panel;   // "(a)"
  std::string label;   // what varies, e.g. "f_1 = 10 Hz"
  Case input;
  // The paper's finding: the regime over the window shown, and whether back-side contact occurs.
  Regime paper_regime = Regime::kTransient;
  bool paper_double_sided = false;
  std::string paper_finding;  // the paper's words, in English
};

// A set of window lengths, as sorted disjoint intervals [first, second), in s.
using WindowSet = std::vector<std::pair<double, double>>;

struct Study {
  std::string name;
  std::string title;
  double window_s = 0;       // the window of every case (the paper gives none)
  double long_window_s = 0;  // a longer window, run beside it, to tell a long transient
  // The windows scanned for how each finding depends on the window: [scan_from_s,
  // long_window_s].
  double scan_from_s = 0;
  std::string window_reason;
  std::vector<std::string> assumptions;
  std::vector<StudyCase> cases;
};

// The paper's 11 cases (Figs. 4-6 of Park 2010) on top of `base` (default: Table 1).
Study park2010_study(const Case& base = Case{});

struct CaseOutcome {
  StudyCase spec;
  RunResult run;           // over study.window_s
  RunReading long_window;  // the same case over study.long_window_s
  bool holds = false;      // the reading agrees with the paper's finding
  std::string difference;  // what differs, where it does not hold
  // The windows of the scan over which the finding holds: read exactly from the long run's
  // located events (a window W is "sustained" when a separated interval reaches into its final
  // fraction, i.e. W in [separation, re-entry / (1 - final_fraction)) for some interval).
  WindowSet holds_for;
};

struct StudyResult {
  Study study;
  std::vector<CaseOutcome> outcomes;  // in the order of study.cases
  WindowSet all_hold;                 // the windows over which every finding holds
  double wall_time_s = 0;
  unsigned threads = 0;
};

// Runs every case on `threads` threads (0: all cores). `progress(done, total)` is called after
// each case, from the worker threads one at a time. Throws InputError on a bad case and
// std::runtime_error naming the case on a numerical failure.
StudyResult run_study(const Study& study, unsigned threads = 0,
                      const std::function<void(std::size_t, std::size_t)>& progress = {});

// The windows in [from_s, to_s) over which a case's finding holds, from a run of it over at
// least to_s with its events kept.
WindowSet finding_windows(const StudyCase& spec, const RunResult& long_run, double from_s,
                          double to_s);

// Whether a window lies in a set.
bool contains(const WindowSet& set, double window_s);

}  // namespace geardyn
