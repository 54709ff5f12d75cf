// The commands of the command line, one file each (commands/<name>.cpp): each adds its
// subcommand to the application, with its options, and returns what it does once the arguments
// chose it. main.cpp lists them in the order `geardyn --help` shows them.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace geardyn::cli {

// One command: its subcommand (options bound to storage the action owns) and its action, which
// returns the exit code (cli.hpp) and throws InputError for bad input, FigureError for a figure
// that could not be drawn and any other exception for a numerical or I/O failure.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> act;
};

Command add_run(CLI::App& geardyn);         // commands/run.cpp
Command add_geometry(CLI::App& geardyn);    // commands/geometry.cpp
Command add_describe(CLI::App& geardyn);    // commands/describe.cpp
Command add_modes(CLI::App& geardyn);       // commands/modes.cpp
Command add_train_form(CLI::App& geardyn);  // commands/train_form.cpp
Command add_keys(CLI::App& geardyn);        // commands/keys.cpp
Command add_stiffness(CLI::App& geardyn);   // commands/stiffness.cpp
Command add_sweep(CLI::App& geardyn);       // commands/sweep.cpp
Command add_reproduce(CLI::App& geardyn);   // commands/reproduce.cpp
Command add_orbit(CLI::App& geardyn);       // commands/orbit.cpp
Command add_continue(CLI::App& geardyn);    // commands/continue.cpp
Command add_stability(CLI::App& geardyn);   // commands/stability.cpp
Command add_validate(CLI::App& geardyn);    // commands/validate.cpp

}  // namespace geardyn::cli
