// Helpers shared by the tests.
#pragma once

#include <string>

#include "geardyn/case.hpp"

namespace geardyn::testing {

// The message of the InputError that `f` throws, or "" if it throws none.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace geardyn::testing
