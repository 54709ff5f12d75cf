// `geardyn train-form`: a gear pair's or coupled case printed as the gear train of elements it
// runs as (a case file).
#include <fmt/format.h>

#include <memory>

#include "../cli.hpp"
#include "../commands.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn::cli {
namespace {

// Prints the train form of a gear pair's case (train_form_of) as a case file.
int cmd_train_form(const CaseArgs& input) {
  const geardyn::Case c = read_case(input);
  const geardyn::Case t = geardyn::train_form_of(c);
  // Assembled before it is printed: a train that cannot be built (a mesh to no body, a body
  // named twice) is refused as every command refuses it, never printed as if it were one.
  (void)geardyn::assembled_train(t);
  fmt::print("{}", geardyn::to_toml(t));
  return 0;
}

}  // namespace

Command add_train_form(CLI::App& geardyn) {
  auto input = std::make_shared<CaseArgs>();
  CLI::App* train_form = geardyn.add_subcommand(
      "train-form", "print a gear pair's or coupled case as a gear train of elements (TOML)");
  add_case_args(train_form, *input);
  return {train_form, [input] { return cmd_train_form(*input); }};
}

}  // namespace geardyn::cli
