// geardyn: the table of case keys. Every key a case file may hold is declared here once: its
// dotted name, the member of Case it sets, its unit, its bounds, what it means, whether a study
// may vary it and whether it changes the mesh stiffness curve. The table drives the reader and
// its messages (case.cpp), the range checks, the TOML writer, the `--set` overrides (which go
// through the reader), the keys a sweep, a continuation or a stability chart accepts, and the
// key tables of docs/case-files.md (`geardyn keys --markdown`; a test keeps the two equal).
//
// Rules that tie two keys together (a Newmark step below the window, kept harmonics below half
// the positions, ...) are checked beside the table, in case.cpp's check_relations; rules on
// derived quantities (the base radii, the contact ratios) with the geometry.
#pragma once

#include <array>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/harmonic_series.hpp"

namespace geardyn {

// The bounds of a number, each end closed or open; an infinite end is no bound. Every number
// must also be finite; NaN is outside every range.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_closed = true;
  bool hi_closed = true;

  bool contains(double x) const;
  // "in (0, 100]", "> 0", ">= 0.001", "from 5 to 10000" (integers), "" (no bound).
  std::string text(bool integer) const;
};

// How a key reaches its member of a Case, one accessor type per kind of value.
using NumberField = double& (*)(Case&);
using OptionalNumberField = std::optional<double>& (*)(Case&);
using IntegerField = int& (*)(Case&);
using PairField = std::array<double, 2>& (*)(Case&);
using OptionalPairField = std::optional<std::array<double, 2>>& (*)(Case&);
using IntegerPairField = std::array<int, 2>& (*)(Case&);
using HarmonicsField = std::vector<StiffnessHarmonic>& (*)(Case&);
using ErrorHarmonicsField = std::vector<ErrorHarmonic>& (*)(Case&);
using TextField = std::string& (*)(Case&);
// An enumeration, through its underlying int, and its names in a case file.
struct ChoiceField {
  int (*get)(const Case&);
  void (*set)(Case&, int);
  std::vector<std::pair<std::string_view, int>> options;
};
using Field =
    std::variant<NumberField, OptionalNumberField, IntegerField, PairField, OptionalPairField,
                 IntegerPairField, HarmonicsField, ErrorHarmonicsField, TextField, ChoiceField>;

struct CaseKey {
  std::string_view name;  // dotted, "gear.normal_module_mm"; top-level keys have no dot
  Field field;
  std::string_view unit;  // printed after a bound: "mm", "Hz"; empty for ratios and counts
  Range range;  // numbers, integers, each element of a pair, a harmonic's ratio or amplitude
  std::string_view what;  // the noun of "must be a <what> in <range> <unit>": "module"
  std::string_view note;  // appended to the bound in messages and docs: "(0 is a spur gear)"
  std::string_view doc;   // the meaning, for docs/case-files.md
  // A study (sweep, continuation, stability chart) may vary it: a real number the model reads
  // (solver settings, counts and choices are not).
  bool sweepable = false;
  // Its change changes the mesh stiffness curve of the gear pair (a sweep then recomputes it).
  bool changes_stiffness = false;

  std::string_view section() const;  // "gear"; "" at the top level
  std::string_view leaf() const;     // "normal_module_mm"
  bool optional() const;             // may be absent: it has no default value
  bool integer() const;              // whole numbers
  // What a value must be: "a module in (0, 100] mm", "one of \"allow\" | \"clip\"".
  std::string allowed() const;
  // The value in a case as TOML text (the shortest digits that read back exactly), or "absent".
  std::string value_text(const Case& c) const;
};

// The most transmission error harmonics (the force series keeps two more terms, for the
// fluctuations of T1 and T2).
constexpr int kMaxErrorHarmonics = HarmonicSeries::kMaxTerms - 2;

// Every key, in the order of the case file (sections as in docs/case-files.md).
const std::vector<CaseKey>& case_keys();

// The key of a dotted name, with or without an element index ("model.stiffness_harmonics[0][0]"
// is model.stiffness_harmonics); nullptr when there is none.
const CaseKey* find_case_key(std::string_view dotted);

// Whether changing `dotted` (with an optional element index) changes the mesh stiffness curve
// (CaseKey::changes_stiffness); true for a name that is no key.
bool changes_stiffness(std::string_view dotted);

// Empty when `dotted` (with an optional element index) names a key a study may vary; otherwise
// why not, naming the key and the keys that may be varied.
std::string check_sweepable(std::string_view dotted);

// Why the value of key `k` in case `c` does nothing there (the chosen form or method does not
// read it: a Newmark step under the exact engine, [bearings] in the one-degree model, [gear] in
// the non-dimensional form, a load fluctuation order with no load fluctuation); empty when it
// is used, or when it holds the value that means "none" (solver.time_step_s = 0).
std::string unused_reason(const CaseKey& k, const Case& c);

// A study's varied key, checked before any work: `corners` are the combinations of the values
// the study sets (each varied key at each end of its values, with its origin, the key checked
// first in each). Its line of unused_settings when every corner leaves it unused (the study
// would vary nothing: speed.shaft_frequency_hz on a train, which turns at
// train.reference_speed_hz; mesh.backlash_um in the non-dimensional form), else empty.
std::string unread_study_key(const Case& c, const std::vector<std::vector<Override>>& corners);

// What integrates a command's motion: the case's solver.method (a run, a sweep, a study's
// samples), or the exact engine whatever the method (a periodic orbit, its continuation, a
// stability chart: their Jacobians need its saltation at every impact).
enum class Integration { kCaseMethod, kExactEngine };

// One line per key the user gave (Case::origins: a file or a --set), at a value other than its
// default (which changes nothing either way), that the case does not use:
// "solver.time_step_s = 1e-06 (--set solver.time_step_s=1e-6): not used: ...". With
// kExactEngine, also solver.method and a Newmark step (kExactEngineOnly). The command line
// prints them as warnings and summary.json lists them ("unused_settings"): a setting is never
// dropped silently.
std::vector<std::string> unused_settings(const Case& c,
                                         Integration integration = Integration::kCaseMethod);
// Why solver.method and solver.time_step_s do nothing under Integration::kExactEngine.
constexpr std::string_view kExactEngineOnly =
    "periodic orbits, their continuation and stability charts are computed with the exact "
    "engine whatever solver.method says (their Jacobians need its saltation at every impact)";

// The key tables of docs/case-files.md: one "## [section]" table per section, columns key, unit,
// default, allowed, meaning.
std::string case_keys_markdown();

// A key or column name in the units of a model form. As written (SI suffixes) for the gear
// pair; in the non-dimensional form, where time is tau and lengths, masses and forces are in
// units of b, m and b k_m: times in tau ("t_s" -> "tau", "_s" -> "_tau"), frequencies in cycles
// per tau ("_hz" -> "_per_tau"), the suffixes of velocities, masses, forces and damping
// dropped ("velocity_m_s" -> "velocity", "mean_force_n" -> "mean_force"). "wall_time_s" is
// real time in either form.
std::string form_key(const std::string& key, ModelForm form);

}  // namespace geardyn
