// `geardyn validate`: every check of geardyn's validation against its reference, pass or fail,
// with its report.
#include <fmt/format.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <memory>
#include <optional>

#include "../cli.hpp"
#include "../commands.hpp"
#include "../progress.hpp"
#include "geardyn/validation.hpp"
#include "geardyn/validation_output.hpp"

namespace geardyn::cli {
namespace {

// The files validate always writes with --out.
const std::vector<std::string> kValidateFiles = {"validation.md", "validation.html",
                                                 "validation.json"};

int cmd_validate(bool quick, bool json, const std::string& out_dir) {
  check_output_folder(out_dir, "validate", kValidateFiles);
  ProgressBar bar("validate", "checks");
  geardyn::ValidationOptions o;
  o.quick = quick;
  // A test-only switch: Ctrl-C (SIGINT to this process, through its handler) once this many
  // checks are done, where a test's own kill would race a fast machine.
  const char* after = std::getenv("GEARDYN_TEST_SIGINT_AFTER_CHECKS");
  const std::size_t interrupt_after = after ? std::strtoul(after, nullptr, 10) : 0;
  o.progress = [&bar, interrupt_after](std::size_t done, std::size_t total,
                                       const std::string& check) {
    bar.show(static_cast<double>(done) / static_cast<double>(std::max<std::size_t>(total, 1)),
             fmt::format("{}/{} checks{}", done, total, check.empty() ? "" : ", " + check));
    if (interrupt_after > 0 && done >= interrupt_after && !cli::interrupted()) std::raise(SIGINT);
    return !cli::interrupted();
  };
  const geardyn::ValidationResult r = interruptible(bar, [&] { return geardyn::validate(o); });
  if (r.cancelled) fmt::print(stderr, "interrupted: reporting the {} checks done\n", r.checks_run);
  if (!out_dir.empty())
    for (const std::string& kept : geardyn::write_validation(out_dir, r))
      fmt::print(stderr,
                 "geardyn: note: {}/{} was written by an earlier `geardyn validate` and changed "
                 "since: kept as it is\n",
                 out_dir, kept);
  if (json) {
    fmt::print("{}", geardyn::validation_json(r));
  } else {
    fmt::print("geardyn validate{}: every check is described in docs/validation.md\n{}",
               quick ? " --quick" : "", geardyn::validation_table(r));
    if (!out_dir.empty())
      fmt::print("written to {}/ (validation.md, validation.html, validation.json)\n", out_dir);
  }
  if (r.cancelled) return kExitInterrupted;
  return r.passed() ? 0 : kExitNumerical;
}

}  // namespace

Command add_validate(CLI::App& geardyn) {
  struct Options {
    bool quick = false;
    bool json = false;
    std::string out_dir;
  };
  auto o = std::make_shared<Options>();
  CLI::App* validate = geardyn.add_subcommand(
      "validate", "run geardyn's validation: every check against its reference, pass or fail");
  validate->add_flag("--quick", o->quick, "the quick set (fewer cases per check)");
  validate->add_flag("--json", o->json, "print JSON");
  validate->add_option("--out", o->out_dir,
                       "directory for validation.md, validation.html and validation.json");
  return {validate, [o] {
            if (!o->out_dir.empty()) check_output_directory(o->out_dir);
            return cmd_validate(o->quick, o->json, o->out_dir);
          }};
}

}  // namespace geardyn::cli
