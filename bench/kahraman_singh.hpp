// The benchmarks' Kahraman-Singh oscillator: the non-dimensional gear of bench/ks_sweep (zeta
// 0.05, F_m 0.1, F_a 0.02) at excitation frequency Omega.
#pragma once

#include "geardyn/case.hpp"

namespace bench {

inline geardyn::Case kahraman_singh(double omega) {
  geardyn::Case c;
  c.model.form = geardyn::ModelForm::kNondimensional;
  c.model.zeta = 0.05;
  c.model.force_mean = 0.1;
  c.model.force_alternating = 0.02;
  c.model.omega = omega;
  return c;
}

}  // namespace bench
