// `geardyn stability`: Floquet stability in permanent contact along a case key (a chart: two),
// with the boundaries located, its files and figure.
#include "geardyn/stability.hpp"

#include <fmt/format.h>

#include <memory>
#include <optional>

#include "../cli.hpp"
#include "../commands.hpp"
#include "../progress.hpp"
#include "geardyn/stability_output.hpp"

namespace geardyn::cli {
namespace {

// The files stability always writes with --out, its figure aside.
const std::vector<std::string> kStabilityFiles = {"stability.csv", "boundaries.json"};

int cmd_stability(const CaseArgs& input, geardyn::StabilityOptions o, const std::string& out_dir,
                  bool json, bool figures) {
  const geardyn::Case c = load_model_case(input, "stability");
  check_output_folder(out_dir, "stability", kStabilityFiles);
  if (const std::string e = o.validate(); !e.empty()) throw geardyn::InputError(e);
  ProgressBar bar("stability");
  o.progress = [&](std::size_t done, std::size_t total) {
    bar(static_cast<double>(done) / static_cast<double>(total));
    return !cli::interrupted();
  };
  const geardyn::StabilityResult r = interruptible(bar, [&] { return geardyn::stability(c, o); });
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

}  // namespace

Command add_stability(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    StabilityOptions stability;
    SweepAxis axis2;
    std::string out_dir;
    bool json = false;
    bool no_figures = false;
  };
  auto o = std::make_shared<Options>();
  StabilityOptions& sto = o->stability;
  CLI::App* stab = geardyn.add_subcommand(
      "stability", "Floquet stability in permanent contact along a key (a chart: two)");
  add_case_args(stab, o->input);
  stab->add_option("--param", sto.axis.key, "the case key, e.g. model.omega")->required();
  stab->add_option("--from", sto.axis.from, "first value")->required();
  stab->add_option("--to", sto.axis.to, "last value")->required();
  stab->add_option("--points", sto.axis.points, "number of values")->required();
  stab->add_flag("--log", sto.axis.log, "geometric spacing");
  add_second_axis(stab, o->axis2, "a second key: a stability chart");
  stab->add_option("--out", o->out_dir, "directory for stability.csv, boundaries.json, figure");
  stab->add_flag("--json", o->json, "print the boundaries as JSON");
  stab->add_flag("--no-figures", o->no_figures, "write the data without the figure");
  return {stab, [o] {
            if (!o->out_dir.empty()) check_output_directory(o->out_dir);
            StabilityOptions chosen = o->stability;
            if (!o->axis2.key.empty()) chosen.axis2 = o->axis2;
            return cmd_stability(o->input, chosen, o->out_dir, o->json, !o->no_figures);
          }};
}

}  // namespace geardyn::cli
