#include <pybind11/stl.h>

#include <string>

#include "bindings.hpp"
#include "geardyn/coupled_run.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_coupled(py::module_& m) {
  // A coupled case runs as its train form (geardyn._run_train); its modes are the coupled
  // model's.
  m.def(
      "_modes",
      [](const Case& c) { return modes_json(modes(CoupledModel(coupled_parameters(c))), -1); },
      py::arg("case"));
}

}  // namespace geardyn::python
