// geardyn command-line tool: parses arguments, calls the library, prints and writes. No
// numerics here.
//
// Exit codes: 0 success, 1 numerical failure (reported with its reason) or a failed validation
// check, 2 bad input, 3 a figure could not be drawn (gnuplot missing or failing; the data files
// are written), 130 interrupted.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "geardyn/case.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/continuation.hpp"
#include "geardyn/continuation_output.hpp"
#include "geardyn/describe.hpp"
#include "geardyn/figures.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/mesh_stiffness_report.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/output.hpp"
#include "geardyn/output_folder.hpp"
#include "geardyn/plausibility.hpp"
#include "geardyn/reproduce.hpp"
#include "geardyn/reproduce_output.hpp"
#include "geardyn/run.hpp"
#include "geardyn/stability.hpp"
#include "geardyn/stability_output.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/sweep.hpp"
#include "geardyn/sweep_output.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_figures.hpp"
#include "geardyn/train_orbit.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_steadiness.hpp"
#include "geardyn/validation.hpp"
#include "geardyn/validation_output.hpp"

namespace {

constexpr int kExitNumerical = 1;
constexpr int kExitInput = 2;
constexpr int kExitFigure = 3;
constexpr int kExitInterrupted = 130;  // 128 + SIGINT, as shells report it
constexpr double kUmPerM = 1e6;

// Set by Ctrl-C during a sweep: the sweep stops after the points under way.
std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) { g_interrupted = true; }

// The one progress display of the command line: a bar on stderr once the work has taken more
// than a second, redrawn in place on a terminal and in a log a line per 10 %, or after 10 s
// without one (a continuation that snakes about one value of its key does not advance).
class ProgressBar {
 public:
  explicit ProgressBar(std::string label, std::string unit = "")
      : label_(std::move(label)), unit_(std::move(unit)), tty_(isatty(2) != 0) {}
  ~ProgressBar() { finish(); }

  // `fraction` done in [0, 1], with what to show beside the bar.
  void show(double fraction, const std::string& detail) {
    using namespace std::chrono;
    const double elapsed = duration<double>(steady_clock::now() - start_).count();
    if (elapsed < kQuietSeconds) return;
    const int percent = static_cast<int>(fraction * 100.0);
    if (!tty_ && percent < last_percent_ + 10 && elapsed < last_line_s_ + kLogSeconds) return;
    last_percent_ = percent;
    last_line_s_ = elapsed;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    const double left = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
    fmt::print(stderr, "{}{} [{:<{}}] {}, {:.1f} s left{}", tty_ ? "\r" : "", label_,
               std::string(std::clamp(filled, 0, kWidth), '#'), kWidth, detail, left,
               tty_ ? "" : "\n");
    std::fflush(stderr);
    shown_ = true;
  }
  bool operator()(double fraction) {
    show(fraction, fmt::format("{:3d}%", static_cast<int>(fraction * 100.0)));
    return true;
  }
  // `done` of `total` points, a share of each point under way included.
  bool points(double done, std::size_t total) {
    show(done / static_cast<double>(std::max<std::size_t>(total, 1)),
         fmt::format("{:.1f}/{} {}", done, total, unit_));
    return true;
  }
  bool operator()(std::size_t done, std::size_t total) {
    show(static_cast<double>(done) / static_cast<double>(std::max<std::size_t>(total, 1)),
         fmt::format("{}/{} {}", done, total, unit_));
    return true;
  }
  void finish() {
    if (shown_ && tty_) fmt::print(stderr, "\n");
    shown_ = false;
  }

 private:
  static constexpr double kQuietSeconds = 1.0;
  static constexpr double kLogSeconds = 10.0;
  std::string label_, unit_;
  bool tty_;
  bool shown_ = false;
  int last_percent_ = -10;
  double last_line_s_ = 0;  // when the log's last line was printed, s from the start
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

// Prints an error on stderr and never throws (stderr may be closed). A long message keeps its
// head and its tail (the key and what is allowed) and says how much it left out.
void print_error(const char* kind, const std::string& message) noexcept {
  constexpr std::size_t kKept = 400;
  std::string shown = message;
  try {
    if (message.size() > 2 * kKept + 100)
      shown = message.substr(0, kKept) +
              fmt::format(" [... {} characters left out ...] ", message.size() - 2 * kKept) +
              message.substr(message.size() - kKept);
  } catch (...) {
    shown.clear();
  }
  std::fprintf(stderr, "geardyn: %s: %s\n", kind, shown.c_str());
}

// An output directory must be a directory, or not exist yet with a writable directory above it:
// found before any work, exit 2. Nothing is created here.
void check_output_directory(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path p = fs::absolute(dir, ec);
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw geardyn::InputError(fmt::format("--out {}: exists and is not a directory", dir));
  while (!p.empty() && !fs::exists(p, ec)) p = p.parent_path();
  if (!fs::is_directory(p, ec))
    throw geardyn::InputError(fmt::format("--out {}: {} is not a directory", dir, p.string()));
  if (access(p.c_str(), W_OK) != 0)
    throw geardyn::InputError(fmt::format("--out {}: {} is not writable", dir, p.string()));
}

std::vector<geardyn::Override> parse_overrides(const std::vector<std::string>& sets) {
  std::vector<geardyn::Override> out;
  out.reserve(sets.size());
  for (const std::string& s : sets) out.push_back(geardyn::parse_override(s));
  return out;
}

std::optional<std::filesystem::path> case_path(const std::string& s) {
  if (s.empty()) return std::nullopt;
  return std::filesystem::path(s);
}

// What the command line says of each model form, one row a form: its name as the train it
// runs as (`{dof}` the coupled form's degrees of freedom; empty for a train itself), what its
// modes' units are when they are not SI, and why `geardyn reproduce park2010` refuses it
// (empty: it takes it).
struct FormWords {
  geardyn::ModelForm form;
  const char* name;
  const char* units;
  const char* reproduce_refused;
};
constexpr std::array<FormWords, 4> kFormWords = {{
    {geardyn::ModelForm::kGearPair, "gear pair", "", ""},
    {geardyn::ModelForm::kNondimensional, "non-dimensional",
     "a second is a tau, Hz are cycles per tau",
     "this form reads none of them, so every case would be the same"},
    {geardyn::ModelForm::kCoupled, "coupled, dof {dof}", "",
     "this form is the pair on its bearings, another model than the paper's"},
    {geardyn::ModelForm::kTrain, "", "",
     "a train spreads them over its elements (its reference speed, each mesh, each torque)"},
}};

const FormWords& form_words(geardyn::ModelForm form) {
  for (const FormWords& w : kFormWords)
    if (w.form == form) return w;
  throw std::logic_error("a model form without its row in kFormWords");
}

// "train", or a pair's form named as the train it runs as ("coupled, dof 12, as a train").
std::string as_train(const geardyn::Case& c) {
  const FormWords& w = form_words(c.model.form);
  if (*w.name == '\0') return "train";
  return fmt::format(fmt::runtime(w.name), fmt::arg("dof", c.model.dof)) + ", as a train";
}

// The case a model command works on; every setting it gives that the model does not use is
// said (case_keys.hpp, unused_settings), never dropped silently.
// Every command takes every form but `reproduce park2010`: the paper's study of its dimensional
// gear pair, whose panels set the pair's keys (speed.shaft_frequency_hz, mesh.damping_ratio,
// load.fluctuation_ratio, mesh.backlash_um). The non-dimensional form does not read them, the
// coupled form is another model than the paper's, and a train spreads them over its elements:
// each is refused before any case runs, naming its form and where it was set.
void check_command_takes(const geardyn::Case& c, std::string_view command) {
  const char* why = form_words(c.model.form).reproduce_refused;
  if (command != "reproduce" || *why == '\0') return;
  throw geardyn::InputError(geardyn::with_origins(
      c, fmt::format("model.form = \"{}\": `geardyn reproduce park2010` is the paper's study of "
                     "its gear pair, whose panels set the pair's shaft speed, damping ratio, "
                     "torque fluctuation and backlash; {}. It "
                     "takes a case of model.form = \"gear_pair\" (each of its cases runs on the "
                     "pair's train); `geardyn sweep` and `continue` study any form",
                     geardyn::to_string(c.model.form), why)));
}

geardyn::Case load_model_case(const std::string& file,
                              const std::vector<geardyn::Override>& overrides,
                              std::string_view command) {
  geardyn::Case c = geardyn::load_case(case_path(file), overrides);
  check_command_takes(c, command);
  const bool exact = command == "orbit" || command == "continue" || command == "stability";
  for (const std::string& w : geardyn::unused_settings(
           c, exact ? geardyn::Integration::kExactEngine : geardyn::Integration::kCaseMethod))
    fmt::print(stderr, "geardyn: warning: {}\n", w);
  for (const std::string& w : geardyn::train_plausibility(c))
    fmt::print(stderr, "geardyn: warning: {}\n", w);
  return c;
}

void print_warnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) fmt::print(stderr, "warning: {}\n", w);
}

// Writes a command's files into `dir` as one named set (output_folder.hpp): the user's files
// stay, the command's earlier files are replaced together. A file of the earlier set that the
// user changed since is kept, and said so.
void write_output(const std::string& dir, const std::string& command,
                  const std::function<void(const std::filesystem::path&)>& stage) {
  for (const std::string& kept : geardyn::write_set(dir, command, stage))
    fmt::print(stderr,
               "geardyn: note: {}/{} was written by an earlier `geardyn {}` and changed since: "
               "kept as it is\n",
               dir, kept, command);
}

// The files each writing command always writes (its figures aside): checked before its work
// (check_output_folder), so that a file of the user's under one of these names stops it at once
// rather than after the work, at the commit (output_folder.hpp, which checks every file).
const std::map<std::string_view, std::vector<std::string>>& command_files() {
  static const std::map<std::string_view, std::vector<std::string>> files{
      {"run", {"summary.json", "timeseries.csv", "events.csv", "case.toml"}},
      {"sweep", {"sweep.csv", "strobe.csv", "summary.json"}},
      {"continue", {"branch.csv", "bifurcations.json", "bifurcations.csv"}},
      {"stability", {"stability.csv", "boundaries.json"}},
      {"modes", {"modes.json", "campbell.csv"}},
      {"stiffness", {"stiffness.csv", "harmonics.json"}},
      {"reproduce", {"report.md", "report.html", "study.json"}},
      {"validate", {"validation.md", "validation.html", "validation.json"}}};
  return files;
}

// Refuses an output folder holding a file that `command` would have to replace and that
// geardyn did not write there (or that changed since): exit 2 before any work, nothing written.
void check_output_folder(const std::string& out_dir, std::string_view command,
                         const std::vector<std::string>& more = {}) {
  if (out_dir.empty()) return;
  std::vector<std::string> files = command_files().at(command);
  files.insert(files.end(), more.begin(), more.end());
  const std::vector<std::string> foreign = geardyn::foreign_files(out_dir, files);
  if (!foreign.empty())
    throw geardyn::InputError(fmt::format(
        "--out {}: {} there {} not written by geardyn, or changed since it was: `geardyn {}` "
        "writes under {} and never replaces a file it did not write; move {} away, or give "
        "another folder",
        out_dir, fmt::join(foreign, ", "), foreign.size() == 1 ? "was" : "were", command,
        foreign.size() == 1 ? "that name" : "those names", foreign.size() == 1 ? "it" : "them"));
}

std::string fmt_optional(const std::optional<double>& x, const char* spec_unit) {
  if (!x) return "none";
  return fmt::format("{:.6g}{}", *x, spec_unit);
}

// Where a run's steady part starts, and why: one line (the one-degree run's and a train's).
void print_steady_start(const geardyn::SteadyStart& st, const char* t_name, const char* t_after) {
  switch (st.basis) {
    case geardyn::SteadyBasis::kSettled:
      fmt::print("  steady part       from {} = {:.6g}{}: periodic (period {} x T0) to {:.2g} b\n",
                 t_name, st.from_s, t_after, st.period_multiple, st.error);
      break;
    case geardyn::SteadyBasis::kStatistics:
      fmt::print(
          "  steady part       from {} = {:.6g}{}: its statistics over {:.4g} s windows agree "
          "(means to {:g} of their scale, standard deviations to {:g} of themselves, no decay "
          "predicting more)\n",
          t_name, st.from_s, t_after, st.window_s, geardyn::kStatisticsTolerance,
          geardyn::kDynamicTolerance);
      break;
    case geardyn::SteadyBasis::kNotSettled:
      if (st.window_s > 0 && !std::isfinite(st.error)) {
        fmt::print(
            "  steady part       not judged: its statistics are compared over {:.4g} s windows and "
            "the run holds fewer than {} (a solver.duration_s of at least {:.4g} s): the final "
            "half, from {} = {:.6g}{}\n",
            st.window_s, geardyn::kJudgedChanges + 2,
            static_cast<double>(geardyn::kJudgedChanges + 2) * st.window_s, t_name, st.from_s,
            t_after);
        break;
      }
      if (st.window_s > 0) {
        fmt::print(
            "  steady part       not reached in the window (its statistics over {:.4g} s windows "
            "still move by {:.2g} times what is steady, the change to come predicted; a longer "
            "solver.duration_s): the final "
            "half, from {} = {:.6g}{}\n",
            st.window_s, st.error / geardyn::kStatisticsTolerance, t_name, st.from_s, t_after);
        break;
      }
      // No distance is predicted without a decay seen over enough section times (steady.hpp).
      fmt::print(
          "  steady part       not reached in the window ({}): the final half, from {} = "
          "{:.6g}{}\n",
          std::isfinite(st.error)
              ? fmt::format("distance {:.2g} b", st.error)
              : std::string("no decay seen over its system periods to predict a distance"),
          t_name, st.from_s, t_after);
      break;
    case geardyn::SteadyBasis::kAperiodic:
      fmt::print(
          "  steady part       the excitations have no common period: the final half, from {} = "
          "{:.6g}{}\n",
          t_name, st.from_s, t_after);
      break;
  }
}

void print_run_summary(const geardyn::RunResult& r) {
  const auto& x = r.reading;
  const auto& d = r.derived;
  const auto& c = r.input;
  // Units by form: tau and b omega_n (= 1) in the non-dimensional one.
  const bool nd = c.model.form == geardyn::ModelForm::kNondimensional;
  const char* t_unit = nd ? " (tau)" : " s";
  const char* v_unit = nd ? "" : " m/s";
  const char* t_name = nd ? "tau" : "t";
  const char* t_after = nd ? "" : " s";  // after "tau = x" or "t = x"
  fmt::print("geardyn run: {}{}\n", c.name, c.description.empty() ? "" : " - " + c.description);
  const char* method = geardyn::to_string(c.solver.method);
  if (c.model.form == geardyn::ModelForm::kNondimensional) {
    fmt::print("  non-dimensional: Omega = {}, zeta = {}, F_m = {}, F_a = {}, {} over tau = {}\n",
               c.model.omega, c.model.zeta, c.model.force_mean, c.model.force_alternating, method,
               c.solver.duration_s);
  } else {
    fmt::print("  f1 = {} Hz (mesh {:.6g} Hz), b = {} um, xi = {}, F_a/F_m = {}, {} over {} s\n",
               c.speed.shaft_frequency_hz, d.mesh_frequency_hz, c.mesh.backlash_um,
               c.mesh.damping_ratio, c.load.fluctuation_ratio, method, c.solver.duration_s);
    fmt::print(
        "  m_eq = {:.6g} kg, contact natural frequency {:.6g} Hz, F_m = {:.6g} N, static "
        "delta_bar = {:.6g}\n",
        d.m_eq_kg, d.natural_frequency_hz, d.mean_force_n, d.static_delta_bar);
  }
  fmt::print("  regime            {}{}\n", geardyn::to_string(x.regime),
             x.double_sided ? " (double-sided)" : "");
  fmt::print("  impacts           {} ({} back side), max velocity {:.4g}{}\n", x.impacts,
             x.backside_impacts, x.max_impact_velocity_m_s, v_unit);
  fmt::print("  separations       {}, last at {}\n", x.separations,
             fmt_optional(x.last_separation_s, t_unit));
  fmt::print("  separated         {:.4g} % of the time\n", 100.0 * x.separated_fraction);
  fmt::print("  F_bar             min {:.5g}  max {:.5g}  mean {:.5g}  rms {:.5g}\n",
             x.min_force_bar, x.max_force_bar, x.mean_force_bar, x.rms_force_bar);
  fmt::print("  delta_bar         min {:.5g}  max {:.5g}  mean {:.5g}\n", x.min_delta_bar,
             x.max_delta_bar, x.mean_delta_bar);
  const geardyn::SteadyPart& st = r.steady;
  const geardyn::RunReading& y = st.reading;
  print_steady_start(st, t_name, t_after);
  fmt::print("    regime          {}, {} impacts, F_bar max {:.5g}, delta_bar {:.5g} to {:.5g}\n",
             geardyn::to_string(y.regime), y.impacts, y.max_force_bar, y.min_delta_bar,
             y.max_delta_bar);
  fmt::print("  dynamic factor    {} (steady part; with the start-up {})\n",
             fmt_optional(y.dynamic_factor, ""), fmt_optional(x.dynamic_factor, ""));
  fmt::print("  steps             {} ({} transitions located){}, {:.3g} s wall\n",
             r.integration.steps, r.integration.transitions,
             d.time_step_s > 0 ? fmt::format(", step {:.4g}{}", d.time_step_s, t_unit) : "",
             r.wall_time_s);
  if (r.integration.unsplit_steps > 0)
    fmt::print("  note: {} steps met more contact changes than are located per step\n",
               r.integration.unsplit_steps);
}

// A run of a train (or of the coupled pair as one) with a progress bar and Ctrl-C (which stops it
// where it is, its part read): says on stderr when it was interrupted, or why it failed.
template <class Options, class Run>
auto run_with_progress(const geardyn::Case& c, const std::string& out_dir, const Run& run,
                       bool& interrupted) {
  ProgressBar bar("run " + c.name);
  Options opts;
  opts.progress = [&](double fraction) { return bar(fraction) && !g_interrupted.load(); };
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);  // a polite kill stops as Ctrl-C does
  auto r = run(c, opts);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  bar.finish();
  interrupted = r.termination == geardyn::ode::Termination::kCancelled;
  if (interrupted)
    fmt::print(stderr, "interrupted: {}; the run up to there is read{}\n", r.message,
               out_dir.empty() ? "" : " and written");
  if (!r.ok() && !interrupted)
    fmt::print(stderr, "geardyn: numerical failure ({}): {}\n",
               geardyn::ode::to_string(r.termination), r.message);
  return r;
}

// A run of a gear train, or of the coupled pair as its train form (train_form_of): each mesh
// read as the one-degree run reads its mesh, each shaft and bearing by its name.
int cmd_run_train(const geardyn::Case& c, const std::string& out_dir, bool plot, bool physical) {
  bool interrupted = false;
  const geardyn::TrainRunResult r =
      run_with_progress<geardyn::TrainRunOptions>(c, out_dir, geardyn::run_train, interrupted);
  if (!r.ok() && !interrupted) return kExitNumerical;
  fmt::print("geardyn run: {} ({}: {} bodies, {} mesh{})\n", c.name, as_train(c), r.bodies.size(),
             r.meshes.size(), r.meshes.size() == 1 ? "" : "es");
  if (r.system_period_s)
    fmt::print("  system period     {:.6g} s\n", *r.system_period_s);
  else
    fmt::print("  system period     none: {}\n", r.system_period_note);
  if (!r.method_note.empty())
    fmt::print("  method            {}: {}\n", geardyn::to_string(r.method), r.method_note);
  // Every body's absolute speed, the reference's direction positive (summary.json's bodies).
  std::vector<std::string> speeds;
  for (std::size_t i = 0; i < r.bodies.size(); ++i)
    speeds.push_back(fmt::format("{} {:.6g}", r.bodies[i], 60 * r.body_speed_hz[i]));
  fmt::print("  speeds (rpm)      {}\n", fmt::join(speeds, ", "));
  std::vector<std::string> torques;
  for (std::size_t k = 0; k < r.torques.size(); ++k)
    torques.push_back(fmt::format("{} {:.6g}", r.torques[k], r.torque_mean_nm[k]));
  if (!torques.empty()) fmt::print("  mean torques (N m) {}\n", fmt::join(torques, ", "));
  print_steady_start(r.steady, "t", " s");
  for (const geardyn::TrainMeshReading& m : r.meshes) {
    fmt::print(
        "  mesh {:<12} {:.6g} Hz: {}, {} impacts ({} back side, max velocity {:.4g} m/s), "
        "separated {:.2f} % of the time\n",
        m.name, m.mesh_frequency_hz, geardyn::to_string(m.regime), m.impacts, m.backside_impacts,
        m.max_impact_velocity_m_s, 100 * m.separated_fraction);
    fmt::print(
        "  {:<17} force {:.6g} to {:.6g} N, static {}, dynamic factor {} (steady part; with "
        "the start-up {})\n",
        "", m.min_force_n, m.max_force_n, fmt_optional(m.static_force_n, " N"),
        fmt_optional(m.dynamic_factor, ""), fmt_optional(m.dynamic_factor_with_startup, ""));
    fmt::print("  {:<17} steady part: {}, {} impacts, force {:.6g} to {:.6g} N\n", "",
               geardyn::to_string(m.steady.regime), m.steady.impacts, m.steady.min_force_n,
               m.steady.max_force_n);
    // k_m as the run took it: given, or from the mesh's stiffness source (ISO 6336 at its load).
    fmt::print("  {:<17} mean stiffness {:.6g} N/m, backlash {:.6g} um\n", "",
               m.mean_stiffness_n_per_m, m.backlash_m * kUmPerM);
    if (m.layout_phase)
      fmt::print("  {:<17} phase from the layout: {:.6g} of a mesh cycle at t = 0\n", "",
                 *m.layout_phase);
  }
  // A part's dynamic factors (geardyn::part_dynamic_factor) where the static load has them, by
  // quantity (geardyn::part_quantities: the summary's list).
  const std::vector<geardyn::TrainPartQuantity> quantities = geardyn::part_quantities(r);
  const auto factors = [&](const std::string& part) {
    static const std::map<std::string, std::string> kLabel = {
        {"torque_nm", ""},           {"force_x_n", "x "},          {"force_y_n", "y "},
        {"axial_force_n", "axial "}, {"moment_x_nm", "moment x "}, {"moment_y_nm", "moment y "},
        {"twist_rad", "twist "}};
    std::vector<std::string> out;
    for (const geardyn::TrainPartQuantity& q : quantities)
      if (q.part == part)
        if (const auto f = geardyn::part_dynamic_factor(r, *q.steady, *q.at_rest))
          out.push_back(fmt::format(
              "{}{:.4g}", kLabel.count(q.what) ? kLabel.at(q.what) : std::string(q.what) + " ",
              *f));
    return out.empty() ? std::string() : fmt::format(", dynamic factor {}", fmt::join(out, ", "));
  };
  for (const geardyn::TrainShaftReading& x : r.shafts)
    fmt::print("  shaft {:<11} torque {:.6g} to {:.6g} N m, static {}{}\n", x.name, x.torque_nm.min,
               x.torque_nm.max, fmt_optional(x.static_torque_nm, " N m"), factors(x.name));
  for (const geardyn::TrainBearingReading& x : r.bearings) {
    fmt::print(
        "  bearing {:<9} force x {:.6g} to {:.6g} N, y {:.6g} to {:.6g} N, static ({}, {}){}\n",
        x.name, x.force_x_n.min, x.force_x_n.max, x.force_y_n.min, x.force_y_n.max,
        fmt_optional(x.static_force_x_n, " N"), fmt_optional(x.static_force_y_n, " N"),
        factors(x.name));
    if (x.spatial)
      fmt::print("                    axial {:.6g} to {:.6g} N (static {}){}\n",
                 x.axial_force_n.min, x.axial_force_n.max,
                 fmt_optional(x.static_axial_force_n, " N"),
                 x.tilts ? fmt::format(", moment x {:.6g} to {:.6g} N m, y {:.6g} to {:.6g} N m",
                                       x.moment_x_nm.min, x.moment_x_nm.max, x.moment_y_nm.min,
                                       x.moment_y_nm.max)
                         : std::string());
    if (x.clearance_x.present)
      fmt::print(
          "                    clearance: x {} impacts, {:.2f} % inside; y {} impacts, {:.2f} % "
          "inside\n",
          x.clearance_x.impacts, 100 * x.clearance_x.separated_fraction, x.clearance_y.impacts,
          100 * x.clearance_y.separated_fraction);
  }
  // A joint read as a part (a clutch damper): its force and x, in the units their names end in,
  // and its contact history.
  for (const geardyn::TrainJointReading& x : r.joints) {
    if (!x.read) continue;
    fmt::print("  {:<17} {} {:.6g} to {:.6g}, {} {:.6g} to {:.6g}, static ({}, {}){}\n", x.name,
               x.force_what, x.force.min, x.force.max, x.deformation_what, x.deformation.min,
               x.deformation.max, fmt_optional(x.static_force, ""),
               fmt_optional(x.static_deformation, ""), factors(x.name));
    fmt::print("                    {} impacts out of its rest stage, {:.2f} % of the time in it\n",
               x.contact.impacts, 100 * x.contact.separated_fraction);
  }
  for (const geardyn::TrainLoadSharing& x : r.load_sharing)
    fmt::print(
        "  load sharing {:<4} over {} meshes: factor {} (steady part; with the start-up {}), "
        "static {}{}{}\n",
        x.gear, x.meshes.size(), fmt_optional(x.factor, ""),
        fmt_optional(x.factor_with_startup, ""), fmt_optional(x.static_factor, ""),
        x.unloaded_at_rest.empty()
            ? ""
            : fmt::format("; unloaded at rest: {}", fmt::join(x.unloaded_at_rest, ", ")),
        x.lost_contact.empty()
            ? ""
            : fmt::format("; lost contact: {}", fmt::join(x.lost_contact, ", ")));
  if (!r.static_note.empty()) fmt::print("  no static state:  {}\n", r.static_note);
  fmt::print("  {:<17} {} ({} events located), {:.3g} s wall\n",
             r.method == geardyn::Method::kExact ? "cells" : "steps", r.cells, r.events,
             r.wall_time_s);
  if (r.unsplit_steps > 0)
    fmt::print("  note: {} steps met more contact changes than are located per step\n",
               r.unsplit_steps);
  if (!out_dir.empty()) {
    const std::vector<std::string> unused = geardyn::unused_settings(c);
    write_output(out_dir, "run", [&](const std::filesystem::path& d) {
      geardyn::write_train_run(d, r, unused);
      if (plot) geardyn::write_train_run_figures(d, r, physical);
    });
    fmt::print("  written to        {}/ (summary.json, timeseries.csv, events.csv, case.toml)\n",
               out_dir);
    if (plot)
      fmt::print(
          "  figures           {}/train_time, train_spectrum, train_phase{} (.png, .svg, .gp)\n",
          out_dir, r.load_sharing.empty() ? "" : ", load_sharing");
  }
  return interrupted ? kExitInterrupted : 0;
}

// The modes of a train, or of a pair's form as its train (train_form_of: the one-degree pair's
// are its rigid rotation and its contact mode), linearised with every mesh in contact at its
// mean stiffness.
int cmd_modes(const std::string& case_file, const std::vector<std::string>& sets, bool json,
              const std::string& out_dir) {
  geardyn::Case c = load_model_case(case_file, parse_overrides(sets), "modes");
  check_output_folder(out_dir, "modes");
  const geardyn::train::Assembled a = geardyn::assembled_train(c);
  const std::vector<geardyn::train::TrainMode> m = geardyn::train::modes(a);
  if (json) {
    fmt::print("{}\n", geardyn::train_modes_json(a, m));
  } else {
    const char* units = form_words(c.model.form).units;
    const std::string form = as_train(c) + (*units == '\0' ? "" : fmt::format(": {}", units));
    const bool held = c.model.form == geardyn::ModelForm::kTrain && !c.train->speeds.empty();
    fmt::print("modes of {} ({}), every mesh in contact at its mean stiffness{}\n", c.name, form,
               held ? ", the prescribed bodies held" : "");
    fmt::print("{}", geardyn::train_modes_table(a, m));
  }
  if (!out_dir.empty()) {
    write_output(out_dir, "modes", [&](const std::filesystem::path& d) {
      geardyn::write_files_atomically(
          d,
          {{"modes.json", [&](std::ostream& o) { o << geardyn::train_modes_json(a, m) << "\n"; }}});
      geardyn::write_train_campbell_figure(d, a, m);
    });
    if (!json)
      fmt::print("written to {}/ (modes.json, campbell.csv, campbell .png .svg .gp)\n", out_dir);
  }
  return 0;
}

int cmd_run(const std::string& case_file, const std::vector<std::string>& sets,
            const std::string& out_dir, bool plot, bool physical) {
  if (plot && out_dir.empty())
    throw geardyn::InputError("--plot: needs --out DIR, the directory the figures go to");
  if (physical && !plot) throw geardyn::InputError("--physical: needs --plot (it sets its units)");
  geardyn::Case c = load_model_case(case_file, parse_overrides(sets), "run");
  check_output_folder(out_dir, "run");
  if (geardyn::runs_as_train(c)) return cmd_run_train(c, out_dir, plot, physical);
  ProgressBar bar("run " + c.name);
  geardyn::RunOptions opts;
  opts.progress = [&](double fraction) { return bar(fraction) && !g_interrupted.load(); };
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);  // a polite kill stops as Ctrl-C does
  geardyn::RunResult r = geardyn::run(c, opts);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  bar.finish();
  print_warnings(r.geometry.warnings);
  const bool interrupted = r.integration.termination == geardyn::ode::Termination::kCancelled;
  if (interrupted)
    fmt::print(stderr, "interrupted: {}; the run up to there is read{}\n", r.integration.message,
               out_dir.empty() ? "" : " and written");
  if (!r.integration.ok() && !interrupted) {
    fmt::print(stderr, "geardyn: numerical failure ({}): {}\n",
               geardyn::ode::to_string(r.integration.termination), r.integration.message);
    return kExitNumerical;
  }
  print_run_summary(r);
  if (!out_dir.empty()) {
    write_output(out_dir, "run", [&](const std::filesystem::path& d) {
      geardyn::write_run(d, r);
      if (plot) geardyn::write_run_figures(d, r, physical);
    });
    fmt::print("  written to        {}/ (summary.json, timeseries.csv, events.csv, case.toml)\n",
               out_dir);
    if (plot)
      fmt::print("  figures           {}/run_time, run_spectrum, run_phase (.png, .svg, .gp)\n",
                 out_dir);
  }
  return interrupted ? kExitInterrupted : 0;
}

// Every case key with its unit, default, bounds and meaning: a listing, the tables of
// docs/case-files.md (--markdown), or JSON.
int cmd_keys(bool markdown, bool json) {
  if (markdown) {
    fmt::print("{}{}", geardyn::case_keys_markdown(), geardyn::train_keys_markdown());
    return 0;
  }
  const geardyn::Case defaults;
  nlohmann::json all = nlohmann::json::array();
  for (const geardyn::CaseKey& k : geardyn::case_keys()) {
    if (json) {
      all.push_back({{"key", k.name},
                     {"unit", k.unit},
                     {"default", k.value_text(defaults)},
                     {"allowed", k.allowed()},
                     {"sweepable", k.sweepable},
                     {"changes_stiffness", k.changes_stiffness},
                     {"meaning", k.doc}});
    } else {
      fmt::print("{:<34} {:<8} {}\n{:<43} default {}; must be {}\n", k.name, k.unit,
                 k.sweepable ? "(a study may vary it)" : "", "", k.value_text(defaults),
                 k.allowed());
    }
  }
  if (json) {
    for (const geardyn::TrainKeyInfo& k : geardyn::train_key_list())
      all.push_back({{"key", k.dotted()},
                     {"unit", k.unit},
                     {"default", k.default_text},
                     {"allowed", k.allowed},
                     {"sweepable", false},
                     {"changes_stiffness", false},
                     {"meaning", k.meaning}});
    fmt::print("{}\n", all.dump(2));
  }
  if (!json)
    fmt::print("\nthe elements of a gear train (model.form = \"train\"):\n{}",
               geardyn::train_keys_listing());
  return 0;
}

// Prints the train form of a gear pair's case (train_form_of) as a case file.
int cmd_train_form(const std::string& case_file, const std::vector<std::string>& sets) {
  const geardyn::Case c = geardyn::load_case(case_path(case_file), parse_overrides(sets));
  const geardyn::Case t = geardyn::train_form_of(c);
  // Assembled before it is printed: a train that cannot be built (a mesh to no body, a body
  // named twice) is refused as every command refuses it, never printed as if it were one.
  (void)geardyn::assembled_train(t);
  fmt::print("{}", geardyn::to_toml(t));
  return 0;
}

// The gear pair a geometry or stiffness command reads (gear_pair_to_read).
geardyn::GearPairToRead pair_to_read(const std::string& case_file,
                                     const std::vector<std::string>& sets, const std::string& mesh,
                                     std::string_view command) {
  const geardyn::Case c = geardyn::load_case(case_path(case_file), parse_overrides(sets));
  check_command_takes(c, command);
  return geardyn::gear_pair_to_read(c, mesh);
}

int cmd_geometry(const std::string& case_file, const std::vector<std::string>& sets,
                 const std::string& mesh, bool json) {
  const geardyn::GearPairToRead read = pair_to_read(case_file, sets, mesh, "geometry");
  const geardyn::Case& c = read.pair;
  const geardyn::Geometry g = geardyn::case_geometry(c);
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  constexpr double kMm = 1e3;
  if (json) {
    fmt::print("{}\n", geardyn::geometry_json(g));
    return 0;
  }
  print_warnings(read.warnings);
  fmt::print("geometry of {}\n", c.name);
  fmt::print("  transverse module          {:.6f} mm\n", g.transverse_module_m * kMm);
  fmt::print("  transverse pressure angle  {:.6f} deg\n", g.transverse_pressure_angle_rad * kDeg);
  fmt::print("  base helix angle           {:.6f} deg\n", g.base_helix_angle_rad * kDeg);
  fmt::print("  reference diameters        {:.4f}, {:.4f} mm\n", g.reference_diameter_m[0] * kMm,
             g.reference_diameter_m[1] * kMm);
  fmt::print("  base diameters             {:.4f}, {:.4f} mm\n", 2 * g.base_radius_m[0] * kMm,
             2 * g.base_radius_m[1] * kMm);
  fmt::print("  outside diameters          {:.4f}, {:.4f} mm (standard rack: {:.4f}, {:.4f})\n",
             2 * g.tip_radius_m[0] * kMm, 2 * g.tip_radius_m[1] * kMm,
             g.expected_outside_diameter_m[0] * kMm, g.expected_outside_diameter_m[1] * kMm);
  fmt::print(
      "  centre distance            {:.4f} mm (profile shifts imply {:.4f}, reference "
      "{:.4f})\n",
      g.center_distance_m * kMm, g.shift_center_distance_m * kMm,
      g.reference_center_distance_m * kMm);
  fmt::print("  working pressure angle     {:.6f} deg (from the shifts {:.6f})\n",
             g.working_pressure_angle_rad * kDeg, g.shift_working_pressure_angle_rad * kDeg);
  fmt::print("  contact ratios             eps_alpha {:.4f}, eps_beta {:.4f}, total {:.4f}\n",
             g.transverse_contact_ratio, g.overlap_ratio, g.total_contact_ratio());
  fmt::print("  inertias                   {:.6g}, {:.6g} kg m^2\n", g.inertia_kg_m2[0],
             g.inertia_kg_m2[1]);
  fmt::print("  equivalent mass m_eq       {:.6g} kg\n", g.equivalent_mass_kg);
  return 0;
}

// What the case assembles to, before any run (describe.hpp): the warnings are in it.
int cmd_describe(const std::string& case_file, const std::vector<std::string>& sets, bool json) {
  const geardyn::Case c = geardyn::load_case(case_path(case_file), parse_overrides(sets));
  fmt::print("{}", json ? geardyn::describe_json(c) + "\n" : geardyn::describe_text(c));
  return 0;
}

// A wall time as a reader takes it in: seconds, minutes or hours.
std::string duration_text(double seconds) {
  constexpr double kMinute = 60, kHour = 3600;
  if (seconds < 2 * kMinute) return fmt::format("{:.2g} s", seconds);
  if (seconds < 2 * kHour) return fmt::format("{:.2g} min", seconds / kMinute);
  return fmt::format("{:.2g} h", seconds / kHour);
}

int cmd_sweep(const std::string& case_file, const std::vector<std::string>& sets,
              geardyn::SweepOptions o, const std::string& out_dir, bool figures) {
  const geardyn::Case base = load_model_case(case_file, parse_overrides(sets), "sweep");
  check_output_folder(out_dir, "sweep");
  if (const std::string e = o.validate(); !e.empty()) throw geardyn::InputError(e);
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);  // a polite kill stops as Ctrl-C does
  // Its cost, before the work: one period of the first point timed, the rest bracketed.
  const geardyn::SweepPlan plan = geardyn::plan_sweep(base, o);
  fmt::print(
      stderr, "sweep: {} points on {} thread{}, each {} to {} periods of {:.4g}{} (steady: {})",
      plan.points, plan.threads, plan.threads == 1 ? "" : "s", plan.least_periods,
      plan.most_periods, plan.period_s,
      base.model.form == geardyn::ModelForm::kNondimensional ? " (tau)" : " s", plan.steadiness);
  if (std::isfinite(plan.first_period_wall_s))
    fmt::print(stderr, "; the first period took {:.3g} s: about {} to {}\n",
               plan.first_period_wall_s, duration_text(plan.least_wall_s()),
               duration_text(plan.most_wall_s()));
  else
    fmt::print(stderr, "\n");
  ProgressBar bar("sweep", "points");
  o.progress = [&](double done, std::size_t total) {
    bar.points(done, total);
    return !g_interrupted.load();
  };
  const geardyn::SweepResult r = geardyn::sweep(base, o);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  bar.finish();
  if (r.cancelled)
    fmt::print(stderr, "interrupted: writing the {} completed points\n", r.points.size());
  std::vector<std::string> drawn;
  write_output(out_dir, "sweep", [&](const std::filesystem::path& d) {
    drawn = geardyn::write_sweep(d, r, figures && !r.cancelled);
  });
  fmt::print("geardyn sweep: {} from {} to {}, {} points{}, {} ({} threads, {:.2f} s)\n",
             o.axis.key, o.axis.from, o.axis.to, o.axis.points,
             o.axis2 ? fmt::format(" x {} from {} to {}, {} points", o.axis2->key, o.axis2->from,
                                   o.axis2->to, o.axis2->points)
                     : "",
             geardyn::to_string(o.direction), r.threads, r.wall_time_s);
  fmt::print(
      "  system period {:.6g}{} at the first point; {} points computed, {} not settled "
      "(steady: {})\n",
      r.period_s, r.form == geardyn::ModelForm::kNondimensional ? " (tau)" : " s", r.points.size(),
      r.unsettled, r.steadiness);
  if (!r.mesh.empty())
    fmt::print("  each of the train's meshes read ({}); the statistics and jumps below: mesh {}\n",
               fmt::join(r.meshes, ", "), r.mesh);
  // Each load-sharing group: its factor's range over the points, and where a mesh of it left
  // its drive flank.
  for (std::size_t g = 0; g < r.load_sharing.size(); ++g) {
    const geardyn::SweepPoint *low = nullptr, *high = nullptr;
    std::size_t lost = 0;
    for (const geardyn::SweepPoint& p : r.points) {
      if (g >= p.load_sharing.size() || !std::isfinite(p.load_sharing[g].factor)) continue;
      if (!low || p.load_sharing[g].factor < low->load_sharing[g].factor) low = &p;
      if (!high || p.load_sharing[g].factor > high->load_sharing[g].factor) high = &p;
      if (p.load_sharing[g].lost_contact > 0) ++lost;
    }
    if (!low) continue;
    fmt::print("  load-sharing factor of {}'s meshes from {:.5g} (at {:.6g}) to {:.5g} (at {:.6g})",
               r.load_sharing[g].label, low->load_sharing[g].factor, low->value,
               high->load_sharing[g].factor, high->value);
    fmt::print("{}\n", lost > 0 ? fmt::format("; a mesh left its drive flank at {} point{}", lost,
                                              lost == 1 ? "" : "s")
                                : std::string{});
  }
  if (!r.period_note.empty()) fmt::print("  {}\n", r.period_note);
  if (r.failed > 0) {
    const auto first = std::find_if(r.points.begin(), r.points.end(),
                                    [](const auto& p) { return !p.failure.empty(); });
    fmt::print(
        "  {} point{} failed numerically (kept in sweep.csv with the reason), the first at "
        "{} = {}: {}\n",
        r.failed, r.failed == 1 ? "" : "s", o.axis.key, first->value, first->failure);
  }
  // In a map, each line names its row.
  const auto row = [&](double value2) {
    return o.axis2 ? fmt::format("at {} = {:.6g}: ", o.axis2->key, value2) : std::string{};
  };
  // Where points did not settle (their readings a stretch of the motion), the first few
  // stretches by name, the rest counted.
  constexpr std::size_t kRangesShown = 6;
  const std::vector<geardyn::UnsettledRange>& ur = r.unsettled_ranges;
  if (!ur.empty()) {
    std::vector<std::string> shown;
    for (std::size_t i = 0; i < std::min(ur.size(), kRangesShown); ++i)
      shown.push_back(fmt::format(
          "{}{} {}", row(ur[i].value2), geardyn::to_string(ur[i].direction),
          ur[i].points == 1 ? fmt::format("at {:.6g}", ur[i].from_value)
                            : fmt::format("{:.6g} to {:.6g} ({} points)", ur[i].from_value,
                                          ur[i].to_value, ur[i].points)));
    fmt::print("  not settled (each read as it is, a stretch of its motion): {}{}\n",
               fmt::join(shown, "; "),
               ur.size() > kRangesShown
                   ? fmt::format("; {} more stretches (summary.json)", ur.size() - kRangesShown)
                   : "");
  }
  const auto unsettled_note = [](bool unsettled) {
    return unsettled ? " (reads a point not settled)" : "";
  };
  // Where the teeth first strike, sequence by sequence: a rattle's or a whine's onset.
  if (r.impact_onsets.empty()) fmt::print("  no impacts at any point\n");
  for (const geardyn::ImpactOnset& x : r.impact_onsets)
    fmt::print("  {}{} sweep: impacts from {} = {:.6g}{}\n", row(x.value2),
               geardyn::to_string(x.direction), o.axis.key, x.value,
               x.meshes.empty() ? std::string()
                                : fmt::format(" (mesh{} {})", x.meshes.size() == 1 ? "" : "es",
                                              fmt::join(x.meshes, ", ")));
  for (const geardyn::Hysteresis& h : r.hysteresis)
    fmt::print("  {}up and down differ from {} = {:.6g} to {:.6g}{}\n", row(h.value2), o.axis.key,
               h.from_value, h.to_value, unsettled_note(h.unsettled));
  for (const geardyn::Jump& j : r.jumps)
    fmt::print(
        "  {}{} sweep jumps between {:.6g} and {:.6g}: peak-to-peak delta/b {:.4g} -> "
        "{:.4g}{}\n",
        row(j.value2), geardyn::to_string(j.direction), j.from_value, j.to_value, j.before, j.after,
        unsettled_note(j.unsettled));
  if (r.jumps.empty())
    fmt::print("  no jump found{}\n",
               o.direction == geardyn::SweepDirection::kBoth && r.hysteresis.empty()
                   ? ", and up and down agree"
                   : "");
  fmt::print("  written to {}/ (sweep.csv, strobe.csv, summary.json{}{})\n", out_dir,
             drawn.empty() ? "" : ", ", fmt::join(drawn, ", "));
  if (r.cancelled) return kExitInterrupted;
  return r.failed > 0 ? kExitNumerical : 0;
}

// Harmonics shown in the stiffness figure's DFT panels.
constexpr int kFigureHarmonics = 10;

int cmd_stiffness(const std::string& case_file, const std::vector<std::string>& sets,
                  const std::string& mesh, const std::string& out_dir, bool json) {
  const geardyn::Case of = geardyn::load_case(case_path(case_file), parse_overrides(sets));
  check_command_takes(of, "stiffness");
  const geardyn::MeshStiffnessReport read = geardyn::mesh_stiffness_report(of, mesh);
  const geardyn::Case& c = read.pair;
  check_output_folder(out_dir, "stiffness");
  const geardyn::Geometry& g = read.geometry;
  const geardyn::Iso6336Stiffness& iso = read.iso;
  const geardyn::StiffnessCycle& cycle = read.cycle;
  const geardyn::StiffnessFourier& kept = read.kept;
  const std::string report = geardyn::stiffness_json(c, g, iso, cycle, kept);
  if (!out_dir.empty()) {
    write_output(out_dir, "stiffness", [&](const std::filesystem::path& d) {
      geardyn::write_files_atomically(
          d, {{"stiffness.csv", geardyn::stiffness_csv(g, cycle, kept, read.used)},
              {"harmonics.json", report + "\n"}});
      geardyn::write_stiffness_figure(
          d,
          c.name + (read.internal ? ": mesh stiffness (energy method, internal)"
                                  : ": mesh stiffness (energy method)"),
          cycle, geardyn::fourier_harmonics(cycle, kFigureHarmonics),
          c.mesh.stiffness_source == geardyn::StiffnessSource::kHarmonics ||
                  c.mesh.stiffness_source == geardyn::StiffnessSource::kIso6336
              ? 0
              : c.mesh.harmonics_kept,
          read.used);
    });
  }
  if (json) {
    fmt::print("{}\n", report);
    return 0;
  }
  print_warnings(read.warnings);
  fmt::print("mesh stiffness of {} (normal direction{})\n", c.name,
             read.internal ? "; an internal pair: its pinion, then its ring" : "");
  fmt::print(
      "  ISO 6336-1 Method B   c'_th {:.4f}, c' {:.4f}, c_gamma_alpha {:.4f}, "
      "c_gamma_beta {:.4f} N/(mm um)\n",
      iso.c_prime_th, iso.c_prime, iso.c_gamma_alpha, iso.c_gamma_beta);
  fmt::print("                        c_gamma_alpha b = {:.4g} N/m (load factor {:.3f})\n",
             iso.mesh_stiffness_n_per_m, iso.load_factor);
  fmt::print(
      "  energy method         mean {:.4g} N/m, min {:.4g}, max {:.4g} "
      "({} positions x {} slices)\n",
      cycle.mean_n_per_m(), cycle.min_n_per_m(), cycle.max_n_per_m(), cycle.position.size(),
      c.mesh.stiffness_slices);
  fmt::print(
      "                        pairs in contact {:.4f} on average "
      "(eps_alpha + eps_beta = {:.4f})\n",
      cycle.mean_pairs_in_contact(), g.total_contact_ratio());
  for (std::size_t i = 0; i < kept.harmonics.size(); ++i)
    fmt::print("                        k_a{}/k_m = {:.5f}, phi_{} = {:.2f} deg\n", i + 1,
               kept.harmonics[i].ratio, i + 1, kept.harmonics[i].phase_deg);
  fmt::print("                        series of {} harmonics within {:.2f} % of the curve\n",
             kept.harmonics.size(), 100 * geardyn::truncation_error(cycle, kept));
  fmt::print("  the case's k_m        {:.4g} N/m{}\n", c.mesh.mean_stiffness_n_per_m,
             c.mesh.mean_stiffness_n_per_m == 2.34e8 ? " (Table 1 of Park 2010)" : "");
  if (!out_dir.empty())
    fmt::print("  written to            {}/ (stiffness.csv, harmonics.json, stiffness.png, .svg)\n",
               out_dir);
  return 0;
}

// The region's name in an orbit's report.
const char* contact_name(int region) {
  switch (geardyn::contact_state(region)) {
    case 1:
      return "drive contact";
    case -1:
      return "back contact";
    default:
      return "separated";
  }
}

// An orbit's Floquet multipliers (the four largest) and whether it is stable, as `geardyn orbit`
// prints them for a train (and the coupled pair as its train).
void print_multipliers(const geardyn::PeriodicSolution& r) {
  fmt::print("  multipliers       {}, the largest:\n", r.multipliers.size());
  for (std::size_t k = 0; k < std::min<std::size_t>(r.multipliers.size(), 4); ++k)
    fmt::print("                    {:.9g}{:+.9g}i (|mu| {:.9g})\n", r.multipliers[k].real(),
               r.multipliers[k].imag(), std::abs(r.multipliers[k]));
  fmt::print("  stable            {}\n", r.stable ? "yes" : "no");
}

// A gear train's orbit (train_orbit.hpp), or the coupled pair's as its train form: its period,
// Newton, multipliers, each mesh's impacts per period and each clearance's.
int cmd_train_orbit(const geardyn::Case& c, const geardyn::OrbitOptions& o,
                    const std::vector<double>& state, bool json) {
  std::optional<geardyn::ode::Vector> start;
  if (!state.empty())
    start = Eigen::Map<const geardyn::ode::Vector>(state.data(),
                                                   static_cast<Eigen::Index>(state.size()));
  const geardyn::TrainOrbit r = geardyn::find_train_orbit(c, o, start);
  if (json) {
    fmt::print("{}\n", geardyn::train_orbit_json(r));
    return r.converged ? 0 : kExitNumerical;
  }
  fmt::print("geardyn orbit: {} ({}){}\n", c.name, as_train(c),
             c.description.empty() ? "" : " - " + c.description);
  if (!r.converged) {
    fmt::print(stderr, "geardyn: the orbit was not found: {}\n", r.message);
    return kExitNumerical;
  }
  fmt::print(
      "  period            {:.9g} s = {} x the system period {:.9g} s ({} shooting segment{})\n",
      r.period_s, r.periods, r.system_period_s, r.segments, r.segments == 1 ? "" : "s");
  fmt::print("  Newton            {}\n", r.message);
  fmt::print(
      "  unknowns          {} (the free coordinates and rates{}; --json prints the state)\n",
      r.coordinates.size(),
      r.modulo_rotation ? ", modulo the train's free rotation at its nominal mean speed" : "");
  print_multipliers(r);
  for (std::size_t m = 0; m < r.meshes.size(); ++m) {
    const geardyn::TrainMeshReading& x = r.readings[m];
    fmt::print(
        "  mesh {:<12} {} impacts/period ({} back side), (d - e)/b {:.9g} to {:.9g}, "
        "F {:.9g} to {:.9g} N\n",
        r.meshes[m], r.impacts_per_period[m], r.backside_impacts_per_period[m],
        x.min_deflection_m / x.backlash_m, x.max_deflection_m / x.backlash_m, x.min_force_n,
        x.max_force_n);
  }
  for (std::size_t k = 0; k < r.clearances.size(); ++k)
    fmt::print("  clearance {:<12} {} impacts/period, separations {}\n", r.clearances[k],
               r.clearance_readings[k].impacts, r.clearance_readings[k].separations);
  if (!r.sequence.empty()) {
    fmt::print("  contact sequence  (time from the section)\n");
    for (const geardyn::TrainContactEvent& e : r.sequence) {
      const auto part = static_cast<std::size_t>(e.part);
      fmt::print("    {:.9g} s  {} {}: {}, velocity {:.6g} m/s\n", e.t_s,
                 part < r.meshes.size() ? "mesh" : "clearance",
                 part < r.meshes.size() ? r.meshes[part] : r.clearances[part - r.meshes.size()],
                 geardyn::to_string(e.kind), e.velocity_m_s);
    }
  }
  return 0;
}

int cmd_orbit(const std::string& case_file, const std::vector<std::string>& sets,
              const geardyn::OrbitOptions& o, const std::vector<double>& state, bool json) {
  const geardyn::Case c = load_model_case(case_file, parse_overrides(sets), "orbit");
  if (geardyn::runs_as_train(c)) return cmd_train_orbit(c, o, state, json);
  std::optional<geardyn::ode::State> start;
  if (!state.empty()) {
    if (state.size() != 2)
      throw geardyn::InputError(fmt::format(
          "--state: {} value{} given; it takes two, delta (m) and delta' (m/s) at t = 0",
          state.size(), state.size() == 1 ? "" : "s"));
    start = geardyn::ode::State{0.0, state[0], state[1], 0.0, 0};
  }
  const geardyn::Orbit r = geardyn::find_orbit(c, o, start);
  const bool nd = c.model.form == geardyn::ModelForm::kNondimensional;
  const double b = nd ? 1.0 : c.mesh.backlash_um * 1e-6;
  if (json) {
    fmt::print("{}\n", geardyn::orbit_json(r));
    return r.converged ? 0 : kExitNumerical;
  }
  const char* t_unit = nd ? "" : " s";
  fmt::print("geardyn orbit: {}{}\n", c.name, c.description.empty() ? "" : " - " + c.description);
  if (!r.converged) {
    fmt::print(stderr, "geardyn: the orbit was not found: {}\n", r.message);
    return kExitNumerical;
  }
  fmt::print(
      "  period            {:.9g}{} = {} x the system period {:.9g}{} ({} shooting segment{})\n",
      r.period_s, t_unit, r.periods, r.system_period_s, t_unit, r.segments,
      r.segments == 1 ? "" : "s");
  fmt::print("  Newton            {}\n", r.message);
  fmt::print("  section state     delta_bar {:.12g}, velocity {:.12g}{} ({})\n", r.state.q / b,
             r.state.v, nd ? "" : " m/s", contact_name(r.state.region));
  fmt::print("  multipliers      ");
  for (const auto& m : r.multipliers)
    fmt::print(" {:.9g}{:+.9g}i (|mu| {:.9g})", m.real(), m.imag(), std::abs(m));
  fmt::print("\n  stable            {}\n", r.stable ? "yes" : "no");
  fmt::print("  impacts/period    {} ({} back side), separations {}\n", r.reading.impacts,
             r.reading.backside_impacts, r.reading.separations);
  fmt::print("  delta_bar         min {:.9g}  max {:.9g}\n", r.reading.min_delta_bar,
             r.reading.max_delta_bar);
  fmt::print("  F_bar             min {:.9g}  max {:.9g}\n", r.reading.min_force_bar,
             r.reading.max_force_bar);
  if (!r.sequence.empty()) {
    fmt::print("  contact sequence  (time from the section)\n");
    for (const auto& e : r.sequence)
      fmt::print("    {:.9g}{}  {}, velocity {:.6g}{}\n", e.t_s, t_unit, geardyn::to_string(e.kind),
                 e.velocity_m_s, nd ? "" : " m/s");
  }
  return 0;
}

int cmd_continue(const std::string& case_file, const std::vector<std::string>& sets,
                 geardyn::ContinuationOptions o, const std::string& out_dir, bool figures,
                 const std::string& overlay_dir) {
  const geardyn::Case c = load_model_case(case_file, parse_overrides(sets), "continue");
  check_output_folder(out_dir, "continue");
  if (const std::string e = o.validate(); !e.empty()) throw geardyn::InputError(e);
  std::string sweep_text;
  if (!overlay_dir.empty()) {
    const std::filesystem::path f = std::filesystem::path(overlay_dir) / "sweep.csv";
    std::ifstream in(f);
    if (!in)
      throw geardyn::InputError(fmt::format(
          "--overlay-sweep {}: no readable sweep.csv there (write one with geardyn sweep --out)",
          overlay_dir));
    std::ostringstream text;
    text << in.rdbuf();
    sweep_text = text.str();
  }
  ProgressBar bar("continue");
  o.progress = [&](double p, std::size_t points) {
    bar.show(std::abs(p - o.from) / std::max(std::abs(o.to - o.from), 1e-300),
             fmt::format("{} = {:.6g}, {} points", o.key, p, points));
    return !g_interrupted.load();
  };
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);  // a polite kill stops as Ctrl-C does
  const geardyn::ContinuationResult r = geardyn::continuation(c, o);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  bar.finish();
  if (r.cancelled)
    fmt::print(stderr, "interrupted: writing the {} points computed\n", r.points.size());
  if (!r.points.empty())
    write_output(out_dir, "continue", [&](const std::filesystem::path& d) {
      geardyn::write_continuation(d, r, o.key, figures && !r.cancelled, sweep_text);
    });
  fmt::print("geardyn continue: {} from {} to {}, period {} x the system period\n", o.key, o.from,
             o.to, o.orbit.periods);
  fmt::print("  {} points, {:.2f} s; {}\n", r.points.size(), r.wall_time_s, r.message);
  if (!r.mesh.empty())
    fmt::print(
        "  the branch reads mesh {} (x_a, forces, impacts); every mesh's contacts mark "
        "grazings\n",
        r.mesh);
  std::size_t unstable = 0;
  for (const auto& p : r.points) unstable += !p.orbit.stable;
  fmt::print("  {} stable, {} unstable points\n", r.points.size() - unstable, unstable);
  for (const geardyn::Bifurcation& b : r.bifurcations)
    fmt::print("  {}{:<16} at {} = {:.12g}: {}, x_a {:.6g}\n",
               b.branch > 0 ? fmt::format("[branch {}] ", b.branch) : "",
               geardyn::to_string(b.type), o.key, b.param, b.detail,
               0.5 * (b.orbit.reading.max_delta_bar - b.orbit.reading.min_delta_bar));
  if (!r.points.empty())
    fmt::print("  written to {}/ (branch.csv, bifurcations.json, bifurcations.csv{})\n", out_dir,
               figures && !r.cancelled ? ", branch.png, branch.svg" : "");
  if (r.cancelled) return kExitInterrupted;
  return r.completed ? 0 : kExitNumerical;
}

int cmd_stability(const std::string& case_file, const std::vector<std::string>& sets,
                  geardyn::StabilityOptions o, const std::string& out_dir, bool json,
                  bool figures) {
  const geardyn::Case c = load_model_case(case_file, parse_overrides(sets), "stability");
  check_output_folder(out_dir, "stability");
  if (const std::string e = o.validate(); !e.empty()) throw geardyn::InputError(e);
  ProgressBar bar("stability");
  o.progress = [&](std::size_t done, std::size_t total) {
    bar(static_cast<double>(done) / static_cast<double>(total));
    return !g_interrupted.load();
  };
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);  // a polite kill stops as Ctrl-C does
  const geardyn::StabilityResult r = geardyn::stability(c, o);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  bar.finish();
  if (r.cancelled)
    fmt::print(stderr, "interrupted: writing the {} samples computed\n", r.samples.size());
  if (!out_dir.empty() && !r.samples.empty())
    write_output(out_dir, "stability", [&](const std::filesystem::path& d) {
      geardyn::write_stability(d, r, o, figures && !r.cancelled);
    });
  if (json) {
    fmt::print("{}", geardyn::boundaries_json(r, o.axis2.has_value()));
    return r.cancelled ? kExitInterrupted : 0;
  }
  std::size_t unstable = 0;
  for (const auto& s : r.samples) unstable += !s.stable;
  fmt::print("geardyn stability: {} from {} to {}, {} points{} (permanent contact)\n", o.axis.key,
             o.axis.from, o.axis.to, o.axis.points,
             o.axis2 ? fmt::format(" x {} from {} to {}, {} points", o.axis2->key, o.axis2->from,
                                   o.axis2->to, o.axis2->points)
                     : "");
  fmt::print("  {} samples, {} unstable\n", r.samples.size(), unstable);
  for (const geardyn::StabilityBoundary& b : r.boundaries)
    fmt::print("  {:<16} at {} = {:.15g}{}\n", geardyn::to_string(b.type), o.axis.key, b.param,
               o.axis2 ? fmt::format(" ({} = {:.6g})", o.axis2->key, b.param2) : "");
  if (r.boundaries.empty()) fmt::print("  no boundary: the stability does not change\n");
  if (!out_dir.empty())
    fmt::print("  written to {}/ (stability.csv, boundaries.json{})\n", out_dir,
               figures && !r.cancelled ? ", stability.png, stability.svg" : "");
  return r.cancelled ? kExitInterrupted : 0;
}

int cmd_reproduce(const std::string& study_name, const std::string& case_file,
                  const std::vector<std::string>& sets, const std::string& out_dir,
                  unsigned threads, bool figures) {
  if (study_name != "park2010")
    throw geardyn::InputError(
        fmt::format("reproduce {}: unknown study; available: park2010", study_name));
  const std::vector<geardyn::Override> overrides = parse_overrides(sets);
  const geardyn::Case base = load_model_case(case_file, overrides, "reproduce");
  check_output_folder(out_dir, "reproduce");
  const geardyn::Study study = geardyn::park2010_study(base);
  // The study sets the paper's conditions per case: a --set of the same key does not reach
  // those cases, and the user is told so.
  for (const geardyn::Override& o : overrides)
    for (const char* key : {"speed.shaft_frequency_hz", "mesh.damping_ratio",
                            "load.fluctuation_ratio", "mesh.backlash_um", "solver.duration_s"})
      if (o.key == key)
        fmt::print(stderr,
                   "geardyn: warning: --set {}={}: the study sets {} for its cases (the paper's "
                   "conditions), so this value is not used\n",
                   o.key, o.value, key);
  fmt::print("geardyn reproduce {}: {} cases\n", study.name, study.cases.size());
  ProgressBar bar("cases", "cases");
  const geardyn::StudyResult r = geardyn::run_study(
      study, threads, [&bar](std::size_t done, std::size_t total) { bar(done, total); });
  bar.finish();
  geardyn::write_study(out_dir, r, figures);
  for (const geardyn::CaseOutcome& o : r.outcomes) {
    fmt::print("  {:6} {:<16} {:<10} impacts {:4}  last separation {:>9}  {}\n", o.spec.id,
               o.spec.label, geardyn::to_string(o.run.reading.regime), o.run.reading.impacts,
               o.run.reading.last_separation_s
                   ? fmt::format("{:.2f} ms", *o.run.reading.last_separation_s * 1e3)
                   : "none",
               o.holds ? "as the paper" : "differs: " + o.difference);
  }
  std::size_t holding = 0;
  for (const auto& o : r.outcomes) holding += o.holds;
  fmt::print("{} of {} cases as the paper found; {:.2f} s on {} threads\n{}\n", holding,
             r.outcomes.size(), r.wall_time_s, r.threads, geardyn::study_headline(r));
  fmt::print("report: {}/report.html and report.md{}\n", out_dir,
             figures ? ", figures fig4, fig5, fig6 (.png, .svg)" : "");
  return 0;
}

int cmd_validate(bool quick, bool json, const std::string& out_dir) {
  check_output_folder(out_dir, "validate");
  ProgressBar bar("validate", "checks");
  geardyn::ValidationOptions o;
  o.quick = quick;
  // A test-only switch: Ctrl-C (SIGINT to this process, through its handler) once this many
  // checks are done, where a test's own kill would race a fast machine.
  const char* after = std::getenv("GEARDYN_TEST_SIGINT_AFTER_CHECKS");
  const std::size_t interrupt_after = after ? std::strtoul(after, nullptr, 10) : 0;
  o.progress = [&bar, interrupt_after](std::size_t done, std::size_t total,
                                       const std::string& check) {
    bar.show(static_cast<double>(done) / static_cast<double>(std::max<std::size_t>(total, 1)),
             fmt::format("{}/{} checks{}", done, total, check.empty() ? "" : ", " + check));
    if (interrupt_after > 0 && done >= interrupt_after && !g_interrupted.load()) std::raise(SIGINT);
    return !g_interrupted.load();
  };
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);  // a polite kill stops as Ctrl-C does
  const geardyn::ValidationResult r = geardyn::validate(o);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  bar.finish();
  if (r.cancelled) fmt::print(stderr, "interrupted: reporting the {} checks done\n", r.checks_run);
  if (!out_dir.empty())
    for (const std::string& kept : geardyn::write_validation(out_dir, r))
      fmt::print(stderr,
                 "geardyn: note: {}/{} was written by an earlier `geardyn validate` and changed "
                 "since: kept as it is\n",
                 out_dir, kept);
  if (json) {
    fmt::print("{}", geardyn::validation_json(r));
  } else {
    fmt::print("geardyn validate{}: every check is described in docs/validation.md\n{}",
               quick ? " --quick" : "", geardyn::validation_table(r));
    if (!out_dir.empty())
      fmt::print("written to {}/ (validation.md, validation.html, validation.json)\n", out_dir);
  }
  if (r.cancelled) return kExitInterrupted;
  return r.passed() ? 0 : kExitNumerical;
}

// --param2 and its range: each needs the others (a range without its key would qualify
// nothing, a key without its range would be a map of nothing), so a missing partner is an error
// naming both, exit 2.
void add_second_axis(CLI::App* sub, geardyn::SweepAxis& axis, const std::string& what) {
  CLI::Option* key = sub->add_option("--param2", axis.key, what);
  CLI::Option* from = sub->add_option("--from2", axis.from, "first value of --param2");
  CLI::Option* to = sub->add_option("--to2", axis.to, "last value of --param2");
  CLI::Option* points = sub->add_option("--points2", axis.points, "number of values of --param2");
  CLI::Option* log = sub->add_flag("--log2", axis.log, "geometric spacing of --param2");
  for (CLI::Option* o : {from, to, points, log}) o->needs(key);
  key->needs(from)->needs(to)->needs(points);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"geardyn: nonlinear dynamics of gear pairs and trains with backlash"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "geardyn " GEARDYN_VERSION);

  std::string case_file, out_dir;
  std::vector<std::string> sets;
  bool json = false;
  auto add_case = [&](CLI::App* sub) {
    sub->add_option("case", case_file, "case file (TOML); default: the paper's Table 1 gear");
    sub->add_option("--set", sets, "override a case key: --set key=value (TOML value syntax)")
        ->allow_extra_args(false);
  };

  CLI::App* run = app.add_subcommand("run", "integrate one case and read the run");
  add_case(run);
  run->add_option("--out", out_dir, "directory for summary.json, timeseries.csv, events.csv");
  bool plot = false;
  run->add_flag("--plot", plot, "also draw the run's figures (PNG and SVG) into --out DIR");
  bool physical = false;
  run->add_flag("--physical", physical,
                "draw delta in um and F_G in N, not delta/b and F/(b k_m) (with --plot)");

  CLI::App* geometry = app.add_subcommand("geometry", "print the derived gear geometry");
  add_case(geometry);
  geometry->add_flag("--json", json, "print JSON");
  std::string pair_mesh;
  geometry->add_option("--mesh", pair_mesh,
                       "a gear train's mesh whose gear pair is read (default: the first)");

  CLI::App* describe = app.add_subcommand(
      "describe",
      "print what the case assembles to: speeds, frames, inertias, stiffnesses, damping, loads");
  add_case(describe);
  describe->add_flag("--json", json, "print JSON");

  CLI::App* modes = app.add_subcommand(
      "modes", "natural frequencies, damping and strain energies of a gear train or a pair");
  add_case(modes);
  modes->add_flag("--json", json, "print JSON");
  std::string modes_out;
  modes->add_option("--out", modes_out, "directory for modes.json, campbell.csv and the figure");

  CLI::App* train_form = app.add_subcommand(
      "train-form", "print a gear pair's or coupled case as a gear train of elements (TOML)");
  add_case(train_form);

  CLI::App* keys = app.add_subcommand("keys", "list every case key: unit, default, bounds");
  bool markdown = false;
  keys->add_flag("--markdown", markdown, "the key tables of docs/case-files.md");
  keys->add_flag("--json", json, "print JSON");

  CLI::App* stiffness = app.add_subcommand(
      "stiffness", "mesh stiffness from the gear data: ISO 6336-1 and the energy method");
  add_case(stiffness);
  stiffness->add_option("--out", out_dir, "directory for stiffness.csv, harmonics.json, figure");
  stiffness->add_flag("--json", json, "print JSON");
  stiffness->add_option("--mesh", pair_mesh,
                        "a gear train's mesh whose gear pair is read (default: the first)");

  CLI::App* sweep_cmd =
      app.add_subcommand("sweep", "sweep a case key (a map: two): frequency response, jumps");
  add_case(sweep_cmd);
  geardyn::SweepOptions so;
  geardyn::SweepAxis axis2;
  std::string direction = "both";
  std::string sweep_out = "out/sweep";
  bool sweep_no_figures = false;
  sweep_cmd->add_option("--param", so.axis.key, "the case key swept, e.g. speed.shaft_frequency_hz")
      ->required();
  sweep_cmd->add_option("--from", so.axis.from, "first value")->required();
  sweep_cmd->add_option("--to", so.axis.to, "last value")->required();
  sweep_cmd->add_option("--points", so.axis.points, "number of values")->required();
  sweep_cmd->add_flag("--log", so.axis.log, "geometric spacing");
  sweep_cmd->add_option("--direction", direction, "up, down or both (default both)")
      ->check(CLI::IsMember({"up", "down", "both"}));
  add_second_axis(sweep_cmd, axis2, "a second key: a 2-D map");
  sweep_cmd->add_option("--settle-periods", so.settle_periods,
                        "periods always run before steadiness is judged (0)");
  sweep_cmd->add_option("--measure-periods", so.measure_periods,
                        "periods measured once steady (10; a multiple of the response's period)");
  sweep_cmd->add_option("--max-settle-periods", so.max_settle_periods,
                        "periods before a point is flagged not settled (200)");
  sweep_cmd->add_option("--steady-tolerance", so.steady_tolerance,
                        "predicted distance to the periodic response, in b (1e-6)");
  std::string sweep_start = "static";
  sweep_cmd
      ->add_option("--start", sweep_start,
                   "where each up and down sweep starts: static (contact, the default) or case "
                   "(the case's solver.initial)")
      ->check(CLI::IsMember({"static", "case"}));
  sweep_cmd->add_option("--mesh", so.mesh,
                        "a gear train's mesh that the statistics, jumps and figures read "
                        "(default: the first; every mesh has its own columns)");
  sweep_cmd->add_option("--threads", so.threads, "worker threads (default: all cores)");
  sweep_cmd->add_option("--out", sweep_out, "output directory (default out/sweep)");
  sweep_cmd->add_flag("--no-figures", sweep_no_figures, "write the data without figures");

  CLI::App* reproduce =
      app.add_subcommand("reproduce", "run a paper's study and write its report and figures");
  std::string study_name;
  std::string reproduce_out = "results/park2010";
  unsigned threads = 0;
  bool no_figures = false;
  reproduce->add_option("study", study_name, "the study: park2010")->required();
  reproduce->add_option("--case", case_file, "base case file (default: Table 1 of the paper)");
  reproduce->add_option("--set", sets, "override a key of the base case: --set key=value");
  reproduce->add_option("--out", reproduce_out, "output directory (default results/park2010)");
  reproduce->add_option("--threads", threads, "worker threads (default: all cores)");
  reproduce->add_flag("--no-figures", no_figures, "write the report and data without figures");

  CLI::App* orbit = app.add_subcommand(
      "orbit", "find a periodic motion by shooting: its state, multipliers and stability");
  add_case(orbit);
  geardyn::OrbitOptions oo;
  std::vector<double> orbit_state;
  orbit->add_option("--periods", oo.periods, "period in system periods (default 1)");
  orbit->add_option("--segments", oo.segments, "shooting segments (default: one per period)");
  orbit->add_option("--settle-periods", oo.settle_periods,
                    "system periods simulated for the first guess (default 100)");
  orbit->add_option("--starts", oo.starts,
                    "settled states Newton starts from at most, one orbit period apart "
                    "(default 16)");
  orbit
      ->add_option("--state", orbit_state,
                   "first guess on the section t = 0: delta (m) and delta' (m/s); a gear "
                   "train or coupled case: its unknowns (--json's \"unknowns\", SI)")
      // As many as the case takes (a train's free coordinates and rates: any number); the
      // count is checked against the case, naming what it takes.
      ->expected(1, CLI::detail::expected_max_vector_size);
  orbit->add_option("--tolerance", oo.tolerance, "Newton's tolerance on the scaled residual");
  orbit->add_option("--max-iterations", oo.max_iterations, "Newton iterations at most (40)");
  orbit->add_flag("--json", json, "print JSON");

  CLI::App* cont = app.add_subcommand(
      "continue", "follow a branch of periodic orbits in a case key: stability, bifurcations");
  add_case(cont);
  geardyn::ContinuationOptions co;
  std::string cont_out = "out/continue";
  bool cont_no_figures = false;
  cont->add_option("--param", co.key, "the numeric case key, e.g. model.omega")->required();
  cont->add_option("--from", co.from, "where the branch starts")->required();
  cont->add_option("--to", co.to, "where it should end")->required();
  cont->add_option("--periods", co.orbit.periods, "orbit period in system periods (default 1)");
  cont->add_option("--segments", co.orbit.segments, "shooting segments (default: one a period)");
  cont->add_option("--settle-periods", co.orbit.settle_periods,
                   "system periods simulated for the first orbit (default 100)");
  cont->add_option("--starts", co.orbit.starts,
                   "settled states the first orbit's Newton starts from at most (default 16)");
  cont->add_option("--step", co.initial_step, "first arclength step (default 0.01)");
  cont->add_option("--max-step", co.max_step, "largest arclength step (default 0.02)");
  cont->add_option("--max-points", co.max_points, "points at most (default 5000)");
  cont->add_option("--mesh", co.mesh,
                   "a gear train's mesh whose amplitude, force and impacts the branch reads "
                   "(default: the first; every mesh's contacts mark grazings)");
  cont->add_flag("--follow-period-doubling", co.follow_period_doubling,
                 "switch to the period-doubled branch at each period doubling and follow it");
  cont->add_option("--out", cont_out, "output directory (default out/continue)");
  std::string overlay_dir;
  CLI::Option* no_figures_option =
      cont->add_flag("--no-figures", cont_no_figures, "write the data without the figure");
  cont->add_option("--overlay-sweep", overlay_dir,
                   "a geardyn sweep's output directory along the same key: its points drawn "
                   "over the branch")
      ->excludes(no_figures_option);  // it is drawn in the figure only

  CLI::App* stab = app.add_subcommand(
      "stability", "Floquet stability in permanent contact along a key (a chart: two)");
  add_case(stab);
  geardyn::StabilityOptions sto;
  geardyn::SweepAxis stab_axis2;
  std::string stab_out;
  bool stab_no_figures = false;
  stab->add_option("--param", sto.axis.key, "the case key, e.g. model.omega")->required();
  stab->add_option("--from", sto.axis.from, "first value")->required();
  stab->add_option("--to", sto.axis.to, "last value")->required();
  stab->add_option("--points", sto.axis.points, "number of values")->required();
  stab->add_flag("--log", sto.axis.log, "geometric spacing");
  add_second_axis(stab, stab_axis2, "a second key: a stability chart");
  stab->add_option("--out", stab_out, "directory for stability.csv, boundaries.json, figure");
  stab->add_flag("--json", json, "print the boundaries as JSON");
  stab->add_flag("--no-figures", stab_no_figures, "write the data without the figure");

  CLI::App* validate = app.add_subcommand(
      "validate", "run geardyn's validation: every check against its reference, pass or fail");
  bool quick = false;
  std::string validate_out;
  validate->add_flag("--quick", quick, "the quick set (fewer cases per check)");
  validate->add_flag("--json", json, "print JSON");
  validate->add_option("--out", validate_out,
                       "directory for validation.md, validation.html and validation.json");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitInput;
  }

  // The command the arguments chose.
  const auto dispatch = [&]() -> int {
    if (run->parsed()) return cmd_run(case_file, sets, out_dir, plot, physical);
    if (geometry->parsed()) return cmd_geometry(case_file, sets, pair_mesh, json);
    if (describe->parsed()) return cmd_describe(case_file, sets, json);
    if (keys->parsed()) return cmd_keys(markdown, json);
    if (train_form->parsed()) return cmd_train_form(case_file, sets);
    if (modes->parsed()) return cmd_modes(case_file, sets, json, modes_out);
    if (stiffness->parsed()) return cmd_stiffness(case_file, sets, pair_mesh, out_dir, json);
    if (sweep_cmd->parsed()) {
      so.direction = direction == "up"     ? geardyn::SweepDirection::kUp
                     : direction == "down" ? geardyn::SweepDirection::kDown
                                           : geardyn::SweepDirection::kBoth;
      if (!axis2.key.empty()) so.axis2 = axis2;
      so.start_static = sweep_start == "static";
      return cmd_sweep(case_file, sets, so, sweep_out, !sweep_no_figures);
    }
    if (stab->parsed()) {
      if (!stab_axis2.key.empty()) sto.axis2 = stab_axis2;
      return cmd_stability(case_file, sets, sto, stab_out, json, !stab_no_figures);
    }
    if (cont->parsed())
      return cmd_continue(case_file, sets, co, cont_out, !cont_no_figures, overlay_dir);
    if (orbit->parsed()) {
      // The settling gives the first guesses: with --state, or without settling, its options
      // are not used, and the user is told so.
      for (const char* opt : {"--settle-periods", "--starts"}) {
        const bool unused =
            !orbit_state.empty() || (oo.settle_periods == 0 && std::string(opt) == "--starts");
        if (unused && orbit->count(opt) > 0)
          fmt::print(stderr, "geardyn: warning: {} is not used: {}\n", opt,
                     orbit_state.empty() ? "--settle-periods 0 settles nothing"
                                         : "--state is the first guess");
      }
      return cmd_orbit(case_file, sets, oo, orbit_state, json);
    }
    if (validate->parsed()) return cmd_validate(quick, json, validate_out);
    if (reproduce->parsed())
      return cmd_reproduce(study_name, case_file, sets, reproduce_out, threads, !no_figures);
    return 0;
  };
  int code = kExitInput;
  try {
    // Every output directory is checked before any work (it is created only when written).
    if ((run->parsed() || stiffness->parsed()) && !out_dir.empty()) check_output_directory(out_dir);
    if (sweep_cmd->parsed()) check_output_directory(sweep_out);
    if (reproduce->parsed()) check_output_directory(reproduce_out);
    if (cont->parsed()) check_output_directory(cont_out);
    if (stab->parsed() && !stab_out.empty()) check_output_directory(stab_out);
    if (modes->parsed() && !modes_out.empty()) check_output_directory(modes_out);
    if (validate->parsed() && !validate_out.empty()) check_output_directory(validate_out);
    code = dispatch();
  } catch (const geardyn::InputError& e) {
    print_error("error", e.what());
    return kExitInput;
  } catch (const geardyn::FigureError& e) {
    print_error("figure error", e.what());
    return kExitFigure;
  } catch (const std::exception& e) {
    // Numerical failures inside a study and I/O failures (a failed write to stdout included).
    print_error("error", e.what());
    return kExitNumerical;
  }
  // What was printed must have reached stdout: a full disk or a closed pipe is a failure.
  if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
    print_error("error", "cannot write to standard output");
    return kExitNumerical;
  }
  return code;
}
