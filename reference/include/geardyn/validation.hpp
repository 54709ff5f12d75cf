// geardyn: its validation, shipped with it (`geardyn validate`, `geardyn.validate()`).
//
// Each check computes quantities with the library as a user runs it (a Case through run(),
// find_orbit(), continuation() ...) and compares each with a reference that is either computed
// independently of the code it checks (a closed form from the case's own data, another
// integrator at a tight tolerance, Hill's determinant, central differences, long simulations,
// another of geardyn's models in the limit where the two must agree) or cited (a published
// example, the paper's findings). A reference is never a stored output of geardyn. Every check
// is described, with its equations, in docs/validation.md under the anchor it names.
//
// Contract: validate() throws nothing a check throws; a check that cannot run is a failed row
// saying why. A row passes when its error is finite and at most its tolerance.
//
// In the geardyn_reference library (reference/), beside the reference implementations it uses,
// linked by the command line and the Python package for `validate`, and by the tests; the
// library never calls it.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "geardyn/case.hpp"

namespace geardyn {

// One compared quantity.
struct ValidationRow {
  std::string check;      // the check's id, e.g. "free_flight" (docs/validation.md#free_flight)
  std::string quantity;   // what is compared, e.g. "first impact time"
  std::string value;      // geardyn's value, with its unit
  std::string reference;  // the reference value, with its unit
  std::string source;     // how the reference was had: "closed form", "dopri5 at 1e-13" ...
  bool cited = false;     // the reference is cited (a publication), not computed
  double error = 0;       // |value - reference| in the measure below
  std::string measure;    // "relative", "in b", "count", ...
  double tolerance = 0;
  bool passed = false;
};

// A check: a group of rows about one claim.
struct ValidationCheck {
  std::string id;     // also the anchor in docs/validation.md
  std::string title;  // "Free flight to the first impact"
  bool quick = true;  // run by --quick (a quick check may compare fewer cases than the full one)
};

// Every check, in the order they run.
const std::vector<ValidationCheck>& validation_checks();

struct ValidationOptions {
  bool quick = false;
  // Called before each check with (checks done, checks in all, the check about to run);
  // returning false stops: the rows done are kept and the result says it was cancelled.
  std::function<bool(std::size_t, std::size_t, const std::string&)> progress;
};

struct ValidationResult {
  bool quick = false;
  bool cancelled = false;
  std::size_t checks_run = 0, checks_total = 0;
  double wall_time_s = 0;
  std::vector<ValidationRow> rows;

  std::size_t failures() const;
  // Every check ran and every row passed.
  bool passed() const { return !cancelled && !rows.empty() && failures() == 0; }
};

ValidationResult validate(const ValidationOptions& options = {});

// Cases the validation and the unit tests share, one definition each.
// ISO/TR 6336-30:2017, example 1 (iso6336_example), with standard tip diameters.
Case iso_tr_6336_30_example_1();
// The paper's gear with a constant stiffness, a steady 100 N m, f1 = 33 Hz (mesh at 0.71 of
// the contact natural frequency) and a transmission error of 1 um at the mesh frequency and
// 0.3 um at 40 deg at twice it, from static contact, 80 ms at tolerance 1e-12 (te_response).
Case gear_with_transmission_error();
// Park 2010's helical pair (Table 1) with the stiffness as harmonics (0.1 at 20 deg, 0.03 at
// -40 deg), f1 = 100 Hz, 20 ms at tolerance 1e-13, samples every 20 us (train_pair) ...
Case park2010_pair_case();
// The Kahraman-Singh oscillator (the non-dimensional gear: zeta 0.05, F_m 0.1, F_a 0.02) at
// excitation frequency omega: the ks_continuation check's, the continuation tests' and the
// sweep benchmarks' case.
Case kahraman_singh_case(double omega);
// ... and the same pair written as a train of two gears, read from its case-file text.
Case park2010_pair_as_train();

}  // namespace geardyn
