// geardyn: the static transmission error e(t), the mesh's other excitation beside its stiffness
// (pipeline stage 3: case -> geometry -> mesh stiffness and transmission error -> model).
//
// e(t) enters the mesh deflection, F_G = k(t) (delta - e - b) + c (delta' - e'): the teeth touch
// when delta - e reaches the backlash. Given as harmonics of the mesh frequency or as a table
// over one mesh cycle (a loaded tooth contact program's output) of which a number of harmonics
// is kept, it is a finite Fourier series whose i-th term is at i times the mesh frequency, with
// position 0 of the cycle at t = 0 (the stiffness's convention).
#pragma once

#include "geardyn/case.hpp"
#include "geardyn/harmonic_series.hpp"

namespace geardyn {

// e(t) in m for the gear pair (the harmonics of mesh.transmission_error_um, or the kept
// harmonics and mean of mesh.transmission_error_table), or in units of b in the non-dimensional
// form (model.transmission_error at i Omega); term i - 1 is the i-th harmonic (zero amplitudes
// kept, so the index is the order); no terms and offset 0 when the case has none.
// Throws InputError for a table that cannot be read, naming the key, the file and the line.
HarmonicSeries transmission_error_series(const Case& c);

}  // namespace geardyn
