// What the commands of the command line share: exit codes, the case a command reads, its output
// folder's checks and writing, and how errors and warnings are printed. No numerics here.
//
// Exit codes: 0 success, 1 numerical failure (reported with its reason) or a failed validation
// check, 2 bad input, 3 a figure could not be drawn (gnuplot missing or failing; the data files
// are written), 130 interrupted.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/sweep.hpp"

namespace geardyn::cli {

constexpr int kExitNumerical = 1;
constexpr int kExitInput = 2;
constexpr int kExitFigure = 3;
constexpr int kExitInterrupted = 130;  // 128 + SIGINT, as shells report it

// A command's case: the file (empty: the paper's Table 1 gear) and its --set overrides.
struct CaseArgs {
  std::string file;
  std::vector<std::string> sets;
};

// Adds the positional case file and --set to a command.
void add_case_args(CLI::App* command, CaseArgs& args);

// The --set overrides parsed (case.hpp's parse_override); bad syntax is an InputError.
std::vector<Override> parse_overrides(const std::vector<std::string>& sets);

// The case as load_case takes it: none for an empty name.
std::optional<std::filesystem::path> case_path(const std::string& file);

// The case as the file and its overrides give it, nothing said of it.
Case read_case(const CaseArgs& args);

// The case a model command works on, every setting it gives that the model does not use said on
// stderr (case_keys.hpp, unused_settings), never dropped silently, and the train's plausibility
// warnings. `command` is the command's name; check_command_takes refuses a form it cannot take.
Case load_model_case(const CaseArgs& args, std::string_view command);

// Every command takes every form but `reproduce park2010`: the paper's study of its dimensional
// gear pair, whose panels set the pair's keys (speed.shaft_frequency_hz, mesh.damping_ratio,
// load.fluctuation_ratio, mesh.backlash_um). The non-dimensional form does not read them, the
// coupled form is another model than the paper's, and a train spreads them over its elements:
// each is refused before any case runs (InputError), naming its form and where it was set.
void check_command_takes(const Case& c, std::string_view command);

// "train", or a pair's form named as the train it runs as ("coupled, dof 12, as a train").
std::string as_train(const Case& c);

// What a form's modes are in when not SI ("a second is a tau, ..."); empty for SI.
const char* modes_units(const Case& c);

// Prints each warning on stderr, one a line.
void print_warnings(const std::vector<std::string>& warnings);

// Prints an error on stderr and never throws (stderr may be closed). A long message keeps its
// head and its tail (the key and what is allowed) and says how much it left out.
void print_error(const char* kind, const std::string& message) noexcept;

// An output directory must be a directory, or not exist yet with a writable directory above it:
// found before any work (InputError, exit 2). Nothing is created here.
void check_output_directory(const std::string& dir);

// Refuses an output folder holding one of `files` (those `command` always writes, its figures
// aside) that geardyn did not write there or that changed since: an InputError before any work,
// nothing written, rather than a refusal after the work, at the commit (output_folder.hpp, which
// checks every file). An empty `out_dir` passes.
void check_output_folder(const std::string& out_dir, std::string_view command,
                         const std::vector<std::string>& files);

// Writes a command's files into `dir` as one named set (output_folder.hpp): the user's files
// stay, the command's earlier files are replaced together. A file of the earlier set that the
// user changed since is kept, and said so.
void write_output(const std::string& dir, const std::string& command,
                  const std::function<void(const std::filesystem::path&)>& stage);

// "none", or the value to 6 significant digits followed by `unit`.
std::string fmt_optional(const std::optional<double>& x, const char* unit);

// --param2 and its range on `command`: each needs the others (a range without its key would
// qualify nothing, a key without its range would be a map of nothing), so a missing partner is
// an error naming both, exit 2.
void add_second_axis(CLI::App* command, SweepAxis& axis, const std::string& what);

}  // namespace geardyn::cli
