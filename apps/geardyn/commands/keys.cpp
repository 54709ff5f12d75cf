// `geardyn keys`: every case key with its unit, default, bounds and meaning: a listing, the
// tables of docs/case-files.md (--markdown), or JSON.
#include <fmt/format.h>

#include <memory>
#include <nlohmann/json.hpp>

#include "../commands.hpp"
#include "geardyn/case.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/train_case.hpp"

namespace geardyn::cli {
namespace {

int cmd_keys(bool markdown, bool json) {
  if (markdown) {
    fmt::print("{}{}", geardyn::case_keys_markdown(), geardyn::train_keys_markdown());
    return 0;
  }
  const geardyn::Case defaults;
  nlohmann::json all = nlohmann::json::array();
  for (const geardyn::CaseKey& k : geardyn::case_keys()) {
    if (json) {
      all.push_back({{"key", k.name},
                     {"unit", k.unit},
                     {"default", k.value_text(defaults)},
                     {"allowed", k.allowed()},
                     {"sweepable", k.sweepable},
                     {"changes_stiffness", k.changes_stiffness},
                     {"meaning", k.doc}});
    } else {
      fmt::print("{:<34} {:<8} {}\n{:<43} default {}; must be {}\n", k.name, k.unit,
                 k.sweepable ? "(a study may vary it)" : "", "", k.value_text(defaults),
                 k.allowed());
    }
  }
  if (json) {
    for (const geardyn::TrainKeyInfo& k : geardyn::train_key_list())
      all.push_back({{"key", k.dotted()},
                     {"unit", k.unit},
                     {"default", k.default_text},
                     {"allowed", k.allowed},
                     {"sweepable", false},
                     {"changes_stiffness", false},
                     {"meaning", k.meaning}});
    fmt::print("{}\n", all.dump(2));
  }
  if (!json)
    fmt::print("\nthe elements of a gear train (model.form = \"train\"):\n{}",
               geardyn::train_keys_listing());
  return 0;
}

}  // namespace

Command add_keys(CLI::App& geardyn) {
  struct Options {
    bool markdown = false;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* keys = geardyn.add_subcommand("keys", "list every case key: unit, default, bounds");
  keys->add_flag("--markdown", o->markdown, "the key tables of docs/case-files.md");
  keys->add_flag("--json", o->json, "print JSON");
  return {keys, [o] { return cmd_keys(o->markdown, o->json); }};
}

}  // namespace geardyn::cli
