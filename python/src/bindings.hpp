// The Python bindings: one bind_<area>.cpp per library area, registered by module.cpp.
#pragma once

#include <pybind11/pybind11.h>

namespace geardyn::python {

void bind_case(pybind11::module_& m);
void bind_geometry(pybind11::module_& m);
void bind_stiffness(pybind11::module_& m);
void bind_run(pybind11::module_& m);
void bind_sweep(pybind11::module_& m);
void bind_orbit(pybind11::module_& m);

}  // namespace geardyn::python
