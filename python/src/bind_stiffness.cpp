#include <pybind11/numpy.h>

#include "bindings.hpp"
#include "geardyn/output.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train_case.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_stiffness(py::module_& m) {
  m.def(
      "_stiffness",
      [](const Case& of, const std::string& mesh) {
        const Case c = gear_pair_to_read(of, mesh).pair;  // a train's: its mesh's gear pair
        const Geometry g = compute_geometry(c.gear);
        const Iso6336Stiffness iso = iso6336_stiffness(c, g);
        StiffnessCycle cycle = energy_method_cycle(c, g);
        const StiffnessFourier kept = fourier_harmonics(cycle, c.mesh.harmonics_kept);
        py::dict arrays;
        arrays["position"] = py::array_t<double>(cycle.position.size(), cycle.position.data());
        arrays["total_n_per_m"] =
            py::array_t<double>(cycle.total_n_per_m.size(), cycle.total_n_per_m.data());
        return py::make_tuple(stiffness_json(c, g, iso, cycle, kept), arrays);
      },
      py::arg("case"), py::arg("mesh") = "");
}

}  // namespace geardyn::python
