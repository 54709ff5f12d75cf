// `geardyn modes`: the natural frequencies, damping and strain energies of a train, or of a
// pair's form as its train, with the Campbell diagram's data and figure.
#include <fmt/format.h>

#include <memory>

#include "../cli.hpp"
#include "../commands.hpp"
#include "geardyn/output.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_figures.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn::cli {
namespace {

// The files modes always writes with --out, its figure aside.
const std::vector<std::string> kModesFiles = {"modes.json", "campbell.csv"};

// The modes of a train, or of a pair's form as its train (train_form_of: the one-degree pair's
// are its rigid rotation and its contact mode), linearised with every mesh in contact at its
// mean stiffness.
int cmd_modes(const CaseArgs& input, bool json, const std::string& out_dir) {
  geardyn::Case c = load_model_case(input, "modes");
  check_output_folder(out_dir, "modes", kModesFiles);
  const geardyn::train::Assembled a = geardyn::assembled_train(c);
  const std::vector<geardyn::train::TrainMode> m = geardyn::train::modes(a);
  if (json) {
    fmt::print("{}\n", geardyn::train_modes_json(a, m));
  } else {
    const char* units = modes_units(c);
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

}  // namespace

Command add_modes(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    bool json = false;
    std::string out_dir;
  };
  auto o = std::make_shared<Options>();
  CLI::App* modes = geardyn.add_subcommand(
      "modes", "natural frequencies, damping and strain energies of a gear train or a pair");
  add_case_args(modes, o->input);
  modes->add_flag("--json", o->json, "print JSON");
  modes->add_option("--out", o->out_dir, "directory for modes.json, campbell.csv and the figure");
  return {modes, [o] {
            if (!o->out_dir.empty()) check_output_directory(o->out_dir);
            return cmd_modes(o->input, o->json, o->out_dir);
          }};
}

}  // namespace geardyn::cli
