// `geardyn describe`: what the case assembles to before any run (describe.hpp): speeds, frames,
// inertias, stiffnesses, damping, loads and the warnings.
#include "geardyn/describe.hpp"

#include <fmt/format.h>

#include <memory>

#include "../cli.hpp"
#include "../commands.hpp"

namespace geardyn::cli {
namespace {

int cmd_describe(const CaseArgs& input, bool json) {
  const geardyn::Case c = read_case(input);
  fmt::print("{}", json ? geardyn::describe_json(c) + "\n" : geardyn::describe_text(c));
  return 0;
}

}  // namespace

Command add_describe(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* describe = geardyn.add_subcommand(
      "describe",
      "print what the case assembles to: speeds, frames, inertias, stiffnesses, damping, loads");
  add_case_args(describe, o->input);
  describe->add_flag("--json", o->json, "print JSON");
  return {describe, [o] { return cmd_describe(o->input, o->json); }};
}

}  // namespace geardyn::cli
