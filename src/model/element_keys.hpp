// geardyn: one key of a train element's table (the case reader's rows, train_case.cpp), private
// to the library: each kind of element declares its keys with it, in its own file, and the
// reader, its messages, the writer, `--set`, the sweepable keys and the docs' key tables read
// them (model layer).
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/train_case.hpp"

namespace geardyn::element_keys {

// A key's bounds, as its table writes them.
inline Range above(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, true}; }
inline Range at_least(double lo) {
  return {lo, std::numeric_limits<double>::infinity(), true, true};
}
inline Range closed_open(double lo, double hi) { return {lo, hi, true, false}; }
inline Range open(double lo, double hi) { return {lo, hi, false, false}; }
inline Range closed(double lo, double hi) { return {lo, hi, true, true}; }

}  // namespace geardyn::element_keys

namespace geardyn {

// One key of an element: the member it sets, its unit and bounds (of a number, or of each
// harmonic's first entry), whether it must be given, and its meaning.
template <class E>
struct ElementKey {
  std::string_view leaf;
  std::variant<std::string E::*, double E::*, std::optional<double> E::*, int E::*, bool E::*,
               std::vector<StiffnessHarmonic> E::*, std::vector<ErrorHarmonic> E::*,
               std::vector<OrderHarmonic> E::*, BodyDof E::*, MeshKind E::*>
      field;
  std::string_view unit;
  Range range;
  bool required;
  std::string_view doc;
  // Of a name that is one of a few words, "contact always"; an enumeration's are its own
  // (words_of_enum).
  std::string_view choices = "";
  bool file = false;  // of a name that is a file's path
};

}  // namespace geardyn
