#include <pybind11/numpy.h>

#include "bindings.hpp"
#include "geardyn/mesh_stiffness_report.hpp"
#include "geardyn/output.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train_case.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_stiffness(py::module_& m) {
  m.def(
      "_stiffness",
      [](const Case& of, const std::string& mesh) {
        // A train's: its mesh's gear pair, external or internal.
        const MeshStiffnessReport r = mesh_stiffness_report(of, mesh);
        const Case& c = r.pair;
        const Geometry& g = r.geometry;
        const Iso6336Stiffness& iso = r.iso;
        const StiffnessCycle& cycle = r.cycle;
        const StiffnessFourier& kept = r.kept;
        py::dict arrays;
        arrays["position"] = py::array_t<double>(cycle.position.size(), cycle.position.data());
        arrays["total_n_per_m"] =
            py::array_t<double>(cycle.total_n_per_m.size(), cycle.total_n_per_m.data());
        return py::make_tuple(stiffness_json(c, g, iso, cycle, kept), arrays);
      },
      py::arg("case"), py::arg("mesh") = "");
}

}  // namespace geardyn::python
