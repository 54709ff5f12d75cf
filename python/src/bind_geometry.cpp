#include "bindings.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/output.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_geometry(py::module_& m) {
  m.def(
      "_geometry_json", [](const Case& c) { return geometry_json(compute_geometry(c.gear)); },
      py::arg("case"));
}

}  // namespace geardyn::python
