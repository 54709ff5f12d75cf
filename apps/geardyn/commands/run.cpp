// `geardyn run`: integrates one case and reads the run (a train's, or a pair's form as its
// train's), prints it and writes its files and figures.
#include "geardyn/run.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <map>
#include <memory>
#include <optional>

#include "../cli.hpp"
#include "../commands.hpp"
#include "../progress.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/figures.hpp"
#include "geardyn/output.hpp"
#include "geardyn/train_figures.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_steadiness.hpp"

namespace geardyn::cli {
namespace {

constexpr double kUmPerM = 1e6;

// The files a run always writes with --out, its figures aside.
const std::vector<std::string> kRunFiles = {"summary.json", "timeseries.csv", "events.csv",
                                            "case.toml"};

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
  opts.progress = [&](double fraction) { return bar(fraction) && !cli::interrupted(); };
  auto r = interruptible(bar, [&] { return run(c, opts); });
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

int cmd_run(const CaseArgs& input, const std::string& out_dir, bool plot, bool physical) {
  if (plot && out_dir.empty())
    throw geardyn::InputError("--plot: needs --out DIR, the directory the figures go to");
  if (physical && !plot) throw geardyn::InputError("--physical: needs --plot (it sets its units)");
  geardyn::Case c = load_model_case(input, "run");
  check_output_folder(out_dir, "run", kRunFiles);
  if (geardyn::runs_as_train(c)) return cmd_run_train(c, out_dir, plot, physical);
  ProgressBar bar("run " + c.name);
  geardyn::RunOptions opts;
  opts.progress = [&](double fraction) { return bar(fraction) && !cli::interrupted(); };
  geardyn::RunResult r = interruptible(bar, [&] { return geardyn::run(c, opts); });
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

}  // namespace

Command add_run(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    std::string out_dir;
    bool plot = false;
    bool physical = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* run = geardyn.add_subcommand("run", "integrate one case and read the run");
  add_case_args(run, o->input);
  run->add_option("--out", o->out_dir, "directory for summary.json, timeseries.csv, events.csv");
  run->add_flag("--plot", o->plot, "also draw the run's figures (PNG and SVG) into --out DIR");
  run->add_flag("--physical", o->physical,
                "draw delta in um and F_G in N, not delta/b and F/(b k_m) (with --plot)");
  return {run, [o] {
            if (!o->out_dir.empty()) check_output_directory(o->out_dir);
            return cmd_run(o->input, o->out_dir, o->plot, o->physical);
          }};
}

}  // namespace geardyn::cli
