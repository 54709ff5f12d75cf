// `geardyn reproduce`: a paper's study run case by case (park2010: Park 2010's gear pair), with
// its report and figures.
#include "geardyn/reproduce.hpp"

#include <fmt/format.h>

#include <memory>

#include "../cli.hpp"
#include "../commands.hpp"
#include "../progress.hpp"
#include "geardyn/reproduce_output.hpp"

namespace geardyn::cli {
namespace {

// The files reproduce always writes, its figures aside.
const std::vector<std::string> kReproduceFiles = {"report.md", "report.html", "study.json"};

int cmd_reproduce(const std::string& study_name, const CaseArgs& input, const std::string& out_dir,
                  unsigned threads, bool figures) {
  if (study_name != "park2010")
    throw geardyn::InputError(
        fmt::format("reproduce {}: unknown study; available: park2010", study_name));
  const std::vector<geardyn::Override> overrides = parse_overrides(input.sets);
  const geardyn::Case base = load_model_case(input, "reproduce");
  check_output_folder(out_dir, "reproduce", kReproduceFiles);
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

}  // namespace

Command add_reproduce(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    std::string study;
    std::string out_dir = "results/park2010";
    unsigned threads = 0;
    bool no_figures = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* reproduce =
      geardyn.add_subcommand("reproduce", "run a paper's study and write its report and figures");
  reproduce->add_option("study", o->study, "the study: park2010")->required();
  reproduce->add_option("--case", o->input.file, "base case file (default: Table 1 of the paper)");
  reproduce->add_option("--set", o->input.sets, "override a key of the base case: --set key=value");
  reproduce->add_option("--out", o->out_dir, "output directory (default results/park2010)");
  reproduce->add_option("--threads", o->threads, "worker threads (default: all cores)");
  reproduce->add_flag("--no-figures", o->no_figures, "write the report and data without figures");
  return {reproduce, [o] {
            check_output_directory(o->out_dir);
            return cmd_reproduce(o->study, o->input, o->out_dir, o->threads, !o->no_figures);
          }};
}

}  // namespace geardyn::cli
