#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "geardyn/coupled_run.hpp"

namespace py = pybind11;

namespace geardyn::python {
namespace {

// A copy of n x k values as a NumPy array.
py::array_t<double> matrix(std::size_t rows, std::size_t cols,
                           const std::function<double(std::size_t, std::size_t)>& at) {
  py::array_t<double> a({rows, cols});
  auto v = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < cols; ++j) v(i, j) = at(i, j);
  return a;
}

// The run as (summary.json text, dict of arrays): t, state (samples x 2n), deflection_bar,
// force_bar, mesh_contact, bearing_force, axial_force and shaft_torque (samples x 2 each).
py::tuple coupled_result(const CoupledRunResult& r) {
  const CoupledSamples& s = r.samples;
  const std::size_t n = s.t_s.size();
  const std::size_t width = n ? static_cast<std::size_t>(s.state[0].size()) : 0;
  py::dict arrays;
  arrays["t"] = py::array_t<double>(py::ssize_t(n), s.t_s.data());
  arrays["state"] = matrix(n, width, [&](std::size_t i, std::size_t j) { return s.state[i][j]; });
  arrays["deflection_bar"] = py::array_t<double>(py::ssize_t(n), s.deflection_bar.data());
  arrays["force_bar"] = py::array_t<double>(py::ssize_t(n), s.force_bar.data());
  arrays["mesh_contact"] = py::array_t<int>(py::ssize_t(n), s.mesh_contact.data());
  arrays["bearing_force"] =
      matrix(n, 2, [&](std::size_t i, std::size_t j) { return s.bearing_force_n[i][j]; });
  arrays["axial_force"] =
      matrix(n, 2, [&](std::size_t i, std::size_t j) { return s.axial_force_n[i][j]; });
  arrays["shaft_torque"] =
      matrix(n, 2, [&](std::size_t i, std::size_t j) { return s.shaft_torque_nm[i][j]; });
  return py::make_tuple(coupled_summary_json(r, -1), arrays);
}

}  // namespace

void bind_coupled(py::module_& m) {
  // The coupled run without the GIL; Ctrl-C and progress as for the one-degree run.
  m.def(
      "_run_coupled",
      [](const Case& c, const py::object& progress) {
        return run_from_python<CoupledRunOptions>(
            c, progress,
            [](const Case& x, const CoupledRunOptions& o) { return run_coupled(x, o); },
            coupled_result);
      },
      py::arg("case"), py::arg("progress") = py::none());
  m.def(
      "_modes",
      [](const Case& c) { return modes_json(modes(CoupledModel(coupled_parameters(c))), -1); },
      py::arg("case"));
}

}  // namespace geardyn::python
