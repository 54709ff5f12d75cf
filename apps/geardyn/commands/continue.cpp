// `geardyn continue`: a branch of periodic orbits followed in a case key by pseudo-arclength
// continuation, with its stability and bifurcations, its files and figure.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>

#include "../cli.hpp"
#include "../commands.hpp"
#include "../progress.hpp"
#include "geardyn/continuation.hpp"
#include "geardyn/continuation_output.hpp"

namespace geardyn::cli {
namespace {

// The files continue always writes, its figure aside.
const std::vector<std::string> kContinueFiles = {"branch.csv", "bifurcations.json",
                                                 "bifurcations.csv"};

int cmd_continue(const CaseArgs& input, geardyn::ContinuationOptions o, const std::string& out_dir,
                 bool figures, const std::string& overlay_dir) {
  const geardyn::Case c = load_model_case(input, "continue");
  check_output_folder(out_dir, "continue", kContinueFiles);
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
    return !cli::interrupted();
  };
  const geardyn::ContinuationResult r =
      interruptible(bar, [&] { return geardyn::continuation(c, o); });
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

}  // namespace

Command add_continue(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    ContinuationOptions continuation;
    std::string out_dir = "out/continue";
    bool no_figures = false;
    std::string overlay_dir;
  };
  auto o = std::make_shared<Options>();
  ContinuationOptions& co = o->continuation;
  CLI::App* cont = geardyn.add_subcommand(
      "continue", "follow a branch of periodic orbits in a case key: stability, bifurcations");
  add_case_args(cont, o->input);
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
  cont->add_option("--out", o->out_dir, "output directory (default out/continue)");
  CLI::Option* no_figures_option =
      cont->add_flag("--no-figures", o->no_figures, "write the data without the figure");
  cont->add_option("--overlay-sweep", o->overlay_dir,
                   "a geardyn sweep's output directory along the same key: its points drawn "
                   "over the branch")
      ->excludes(no_figures_option);  // it is drawn in the figure only
  return {cont, [o] {
            check_output_directory(o->out_dir);
            return cmd_continue(o->input, o->continuation, o->out_dir, !o->no_figures,
                                o->overlay_dir);
          }};
}

}  // namespace geardyn::cli
