#include "bindings.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/output.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_geometry(py::module_& m) {
  m.def(
      "_geometry_json",
      [](const Case& c, const std::string& mesh) {
        // A train's mesh's gear pair, its warnings in the train's keys (gear_pair_to_read).
        const GearPairToRead read = gear_pair_to_read(c, mesh);
        Geometry g = compute_geometry(read.pair.gear);
        g.warnings = read.warnings;
        return geometry_json(g);
      },
      py::arg("case"), py::arg("mesh") = "");
}

}  // namespace geardyn::python
