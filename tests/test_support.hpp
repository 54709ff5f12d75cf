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

// The default case (Park 2010's Table 1 pair) as the coupled model with `dof` kept.
inline Case coupled(int dof) {
  Case c;
  c.model.form = ModelForm::kCoupled;
  c.model.dof = dof;
  return c;
}

}  // namespace geardyn::testing
