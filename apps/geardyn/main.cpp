// geardyn command-line tool: parses arguments, runs the command they chose (commands/, one file
// a command) and turns its failures into exit codes (cli.hpp). No numerics here.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <array>
#include <cstdio>
#include <exception>

#include "cli.hpp"
#include "commands.hpp"
#include "geardyn/input_error.hpp"
#include "geardyn/output_folder.hpp"

namespace {

using geardyn::cli::Command;

// The commands in the order `geardyn --help` lists them.
constexpr std::array<Command (*)(CLI::App&), 13> kCommands = {
    geardyn::cli::add_run,       geardyn::cli::add_geometry,   geardyn::cli::add_describe,
    geardyn::cli::add_modes,     geardyn::cli::add_train_form, geardyn::cli::add_keys,
    geardyn::cli::add_stiffness, geardyn::cli::add_sweep,      geardyn::cli::add_reproduce,
    geardyn::cli::add_orbit,     geardyn::cli::add_continue,   geardyn::cli::add_stability,
    geardyn::cli::add_validate};

}  // namespace

int main(int argc, char** argv) {
  using namespace geardyn::cli;
  CLI::App app{"geardyn: nonlinear dynamics of gear pairs and trains with backlash"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "geardyn " GEARDYN_VERSION);
  std::vector<Command> commands;
  commands.reserve(kCommands.size());
  for (const auto add : kCommands) commands.push_back(add(app));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitInput;
  }

  int code = kExitInput;
  try {
    // Each command checks its output directory before any work (it is created only when
    // written).
    for (const Command& c : commands)
      if (c.app->parsed()) code = c.act();
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
