#include "cli.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <stdexcept>

#include "geardyn/case_keys.hpp"
#include "geardyn/output_folder.hpp"
#include "geardyn/plausibility.hpp"

namespace geardyn::cli {
namespace {

// What the command line says of each model form, one row a form: its name as the train it
// runs as (`{dof}` the coupled form's degrees of freedom; empty for a train itself), what its
// modes' units are when they are not SI, and why `geardyn reproduce park2010` refuses it
// (empty: it takes it).
struct FormWords {
  ModelForm form;
  const char* name;
  const char* units;
  const char* reproduce_refused;
};
constexpr std::array<FormWords, 4> kFormWords = {{
    {ModelForm::kGearPair, "gear pair", "", ""},
    {ModelForm::kNondimensional, "non-dimensional", "a second is a tau, Hz are cycles per tau",
     "this form reads none of them, so every case would be the same"},
    {ModelForm::kCoupled, "coupled, dof {dof}", "",
     "this form is the pair on its bearings, another model than the paper's"},
    {ModelForm::kTrain, "", "",
     "a train spreads them over its elements (its reference speed, each mesh, each torque)"},
}};

const FormWords& form_words(ModelForm form) {
  for (const FormWords& w : kFormWords)
    if (w.form == form) return w;
  throw std::logic_error("a model form without its row in kFormWords");
}

}  // namespace

void add_case_args(CLI::App* command, CaseArgs& args) {
  command->add_option("case", args.file, "case file (TOML); default: the paper's Table 1 gear");
  command
      ->add_option("--set", args.sets, "override a case key: --set key=value (TOML value syntax)")
      ->allow_extra_args(false);
}

std::vector<Override> parse_overrides(const std::vector<std::string>& sets) {
  std::vector<Override> out;
  out.reserve(sets.size());
  for (const std::string& s : sets) out.push_back(parse_override(s));
  return out;
}

std::optional<std::filesystem::path> case_path(const std::string& file) {
  if (file.empty()) return std::nullopt;
  return std::filesystem::path(file);
}

void check_command_takes(const Case& c, std::string_view command) {
  const char* why = form_words(c.model.form).reproduce_refused;
  if (command != "reproduce" || *why == '\0') return;
  throw InputError(with_origins(
      c, fmt::format("model.form = \"{}\": `geardyn reproduce park2010` is the paper's study of "
                     "its gear pair, whose panels set the pair's shaft speed, damping ratio, "
                     "torque fluctuation and backlash; {}. It "
                     "takes a case of model.form = \"gear_pair\" (each of its cases runs on the "
                     "pair's train); `geardyn sweep` and `continue` study any form",
                     to_string(c.model.form), why)));
}

Case read_case(const CaseArgs& args) {
  return load_case(case_path(args.file), parse_overrides(args.sets));
}

Case load_model_case(const CaseArgs& args, std::string_view command) {
  Case c = read_case(args);
  check_command_takes(c, command);
  const bool exact = command == "orbit" || command == "continue" || command == "stability";
  for (const std::string& w :
       unused_settings(c, exact ? Integration::kExactEngine : Integration::kCaseMethod))
    fmt::print(stderr, "geardyn: warning: {}\n", w);
  for (const std::string& w : train_plausibility(c))
    fmt::print(stderr, "geardyn: warning: {}\n", w);
  return c;
}

std::string as_train(const Case& c) {
  const FormWords& w = form_words(c.model.form);
  if (*w.name == '\0') return "train";
  return fmt::format(fmt::runtime(w.name), fmt::arg("dof", c.model.dof)) + ", as a train";
}

const char* modes_units(const Case& c) { return form_words(c.model.form).units; }

void print_warnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) fmt::print(stderr, "warning: {}\n", w);
}

void print_error(const char* kind, const std::string& message) noexcept {
  constexpr std::size_t kKept = 400;
  std::string shown = message;
  try {
    if (message.size() > 2 * kKept + 100)
      shown = message.substr(0, kKept) +
              fmt::format(" [... {} characters left out ...] ", message.size() - 2 * kKept) +
              message.substr(message.size() - kKept);
  } catch (...) {
    shown.clear();
  }
  std::fprintf(stderr, "geardyn: %s: %s\n", kind, shown.c_str());
}

void check_output_directory(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path p = fs::absolute(dir, ec);
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw InputError(fmt::format("--out {}: exists and is not a directory", dir));
  while (!p.empty() && !fs::exists(p, ec)) p = p.parent_path();
  if (!fs::is_directory(p, ec))
    throw InputError(fmt::format("--out {}: {} is not a directory", dir, p.string()));
  if (access(p.c_str(), W_OK) != 0)
    throw InputError(fmt::format("--out {}: {} is not writable", dir, p.string()));
}

void check_output_folder(const std::string& out_dir, std::string_view command,
                         const std::vector<std::string>& files) {
  if (out_dir.empty()) return;
  const std::vector<std::string> foreign = foreign_files(out_dir, files);
  if (!foreign.empty())
    throw InputError(fmt::format(
        "--out {}: {} there {} not written by geardyn, or changed since it was: `geardyn {}` "
        "writes under {} and never replaces a file it did not write; move {} away, or give "
        "another folder",
        out_dir, fmt::join(foreign, ", "), foreign.size() == 1 ? "was" : "were", command,
        foreign.size() == 1 ? "that name" : "those names", foreign.size() == 1 ? "it" : "them"));
}

void write_output(const std::string& dir, const std::string& command,
                  const std::function<void(const std::filesystem::path&)>& stage) {
  for (const std::string& kept : write_set(dir, command, stage))
    fmt::print(stderr,
               "geardyn: note: {}/{} was written by an earlier `geardyn {}` and changed since: "
               "kept as it is\n",
               dir, kept, command);
}

std::string fmt_optional(const std::optional<double>& x, const char* unit) {
  if (!x) return "none";
  return fmt::format("{:.6g}{}", *x, unit);
}

void add_second_axis(CLI::App* command, SweepAxis& axis, const std::string& what) {
  CLI::Option* key = command->add_option("--param2", axis.key, what);
  CLI::Option* from = command->add_option("--from2", axis.from, "first value of --param2");
  CLI::Option* to = command->add_option("--to2", axis.to, "last value of --param2");
  CLI::Option* points =
      command->add_option("--points2", axis.points, "number of values of --param2");
  CLI::Option* log = command->add_flag("--log2", axis.log, "geometric spacing of --param2");
  for (CLI::Option* o : {from, to, points, log}) o->needs(key);
  key->needs(from)->needs(to)->needs(points);
}

}  // namespace geardyn::cli
