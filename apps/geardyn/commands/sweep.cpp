// `geardyn sweep`: a case key swept (a map: two) with each point's steady response read, its
// cost said before the work, its progress shown, and Ctrl-C keeping the points done.
#include "geardyn/sweep.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>

#include "../cli.hpp"
#include "../commands.hpp"
#include "../progress.hpp"
#include "geardyn/sweep_output.hpp"

namespace geardyn::cli {
namespace {

// The files a sweep always writes, its figures aside.
const std::vector<std::string> kSweepFiles = {"sweep.csv", "strobe.csv", "summary.json"};

// A wall time as a reader takes it in: seconds, minutes or hours.
std::string duration_text(double seconds) {
  constexpr double kMinute = 60, kHour = 3600;
  if (seconds < 2 * kMinute) return fmt::format("{:.2g} s", seconds);
  if (seconds < 2 * kHour) return fmt::format("{:.2g} min", seconds / kMinute);
  return fmt::format("{:.2g} h", seconds / kHour);
}

int cmd_sweep(const CaseArgs& input, geardyn::SweepOptions o, const std::string& out_dir,
              bool figures) {
  const geardyn::Case base = load_model_case(input, "sweep");
  check_output_folder(out_dir, "sweep", kSweepFiles);
  if (const std::string e = o.validate(); !e.empty()) throw geardyn::InputError(e);
  std::optional<InterruptWatch> watch(std::in_place);  // Ctrl-C and a polite kill
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
    return !cli::interrupted();
  };
  const geardyn::SweepResult r = geardyn::sweep(base, o);
  watch.reset();
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

}  // namespace

Command add_sweep(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    SweepOptions sweep;
    SweepAxis axis2;
    std::string direction = "both";
    std::string start = "static";
    std::string out_dir = "out/sweep";
    bool no_figures = false;
  };
  auto o = std::make_shared<Options>();
  SweepOptions& so = o->sweep;
  CLI::App* sweep_cmd =
      geardyn.add_subcommand("sweep", "sweep a case key (a map: two): frequency response, jumps");
  add_case_args(sweep_cmd, o->input);
  sweep_cmd->add_option("--param", so.axis.key, "the case key swept, e.g. speed.shaft_frequency_hz")
      ->required();
  sweep_cmd->add_option("--from", so.axis.from, "first value")->required();
  sweep_cmd->add_option("--to", so.axis.to, "last value")->required();
  sweep_cmd->add_option("--points", so.axis.points, "number of values")->required();
  sweep_cmd->add_flag("--log", so.axis.log, "geometric spacing");
  sweep_cmd->add_option("--direction", o->direction, "up, down or both (default both)")
      ->check(CLI::IsMember({"up", "down", "both"}));
  add_second_axis(sweep_cmd, o->axis2, "a second key: a 2-D map");
  sweep_cmd->add_option("--settle-periods", so.settle_periods,
                        "periods always run before steadiness is judged (0)");
  sweep_cmd->add_option("--measure-periods", so.measure_periods,
                        "periods measured once steady (10; a multiple of the response's period)");
  sweep_cmd->add_option("--max-settle-periods", so.max_settle_periods,
                        "periods before a point is flagged not settled (200)");
  sweep_cmd->add_option("--steady-tolerance", so.steady_tolerance,
                        "predicted distance to the periodic response, in b (1e-6)");
  sweep_cmd
      ->add_option("--start", o->start,
                   "where each up and down sweep starts: static (contact, the default) or case "
                   "(the case's solver.initial)")
      ->check(CLI::IsMember({"static", "case"}));
  sweep_cmd->add_option("--mesh", so.mesh,
                        "a gear train's mesh that the statistics, jumps and figures read "
                        "(default: the first; every mesh has its own columns)");
  sweep_cmd->add_option("--threads", so.threads, "worker threads (default: all cores)");
  sweep_cmd->add_option("--out", o->out_dir, "output directory (default out/sweep)");
  sweep_cmd->add_flag("--no-figures", o->no_figures, "write the data without figures");
  return {sweep_cmd, [o] {
            check_output_directory(o->out_dir);
            SweepOptions chosen = o->sweep;
            chosen.direction = o->direction == "up"     ? SweepDirection::kUp
                               : o->direction == "down" ? SweepDirection::kDown
                                                        : SweepDirection::kBoth;
            if (!o->axis2.key.empty()) chosen.axis2 = o->axis2;
            chosen.start_static = o->start == "static";
            return cmd_sweep(o->input, chosen, o->out_dir, !o->no_figures);
          }};
}

}  // namespace geardyn::cli
