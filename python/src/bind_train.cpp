#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/output_folder.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_run.hpp"

namespace py = pybind11;

namespace geardyn::python {
namespace {

// rows x cols values as a NumPy array.
template <class T, class At>
py::array_t<T> table(std::size_t rows, std::size_t cols, const At& at) {
  py::array_t<T> a({rows, cols});
  auto v = a.template mutable_unchecked<2>();
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t j = 0; j < cols; ++j) v(i, j) = at(i, j);
  return a;
}

// The run as (summary.json text, dict of arrays): t, state (samples x 2 coordinates),
// deflection_bar, force (N), contact and deflection_rate (m/s) (samples x meshes), parts, the
// events, and "write": write(directory), the run's files as `geardyn run --out` writes them
// (write_train_run, in the output set "run"), the run moved into it.
py::tuple train_result(TrainRunResult& r) {
  const TrainSamples& s = r.samples;
  const std::size_t n = s.t_s.size(), meshes = r.meshes.size();
  const std::size_t width = 2 * r.coordinates.size();
  py::dict arrays;
  arrays["t"] = py::array_t<double>(py::ssize_t(n), s.t_s.data());
  arrays["state"] =
      table<double>(n, width, [&](std::size_t i, std::size_t j) { return s.state[i](j); });
  arrays["deflection_bar"] = table<double>(
      n, meshes, [&](std::size_t i, std::size_t m) { return s.deflection_bar[i][m]; });
  arrays["force"] =
      table<double>(n, meshes, [&](std::size_t i, std::size_t m) { return s.force_n[i][m]; });
  arrays["contact"] =
      table<int>(n, meshes, [&](std::size_t i, std::size_t m) { return s.contact[i][m]; });
  arrays["deflection_rate"] = table<double>(
      n, meshes, [&](std::size_t i, std::size_t m) { return s.deflection_rate_m_s[i][m]; });
  // Each part's quantities (part_quantities): each shaft's torque (N m), then each bearing's
  // force in x and y (N), a spatial body's followed by its axial force (N) and, when it tilts,
  // its moments about x and y (N m), then each joint's read as a part, its force and its x.
  const std::size_t parts = part_quantities(r).size();
  arrays["parts"] =
      table<double>(n, parts, [&](std::size_t i, std::size_t k) { return s.parts[i][k]; });
  // The located contact changes as the one-degree run's events: t_s, part (its name), kind and
  // velocity_m_s (the part's rate there).
  const auto events = static_cast<py::ssize_t>(r.contact_events.size());
  py::array_t<double> t(events), v(events);
  py::list part, kind;
  for (py::ssize_t i = 0; i < events; ++i) {
    const TrainContactEvent& e = r.contact_events[static_cast<std::size_t>(i)];
    t.mutable_at(i) = e.t_s;
    v.mutable_at(i) = e.velocity_m_s;
    part.append(r.contact_parts[static_cast<std::size_t>(e.part)]);
    kind.append(to_string(e.kind));
  }
  arrays["events"] = py::dict(py::arg("t_s") = t, py::arg("part") = part, py::arg("kind") = kind,
                              py::arg("velocity_m_s") = v);
  std::vector<std::string> unused = unused_settings(r.input);
  std::string summary = train_summary_json(r, unused, -1);
  auto run = std::make_shared<const TrainRunResult>(std::move(r));
  arrays["write"] = py::cpp_function(
      [run, unused](const std::filesystem::path& dir) {
        return write_set(dir, "run",
                         [&](const std::filesystem::path& d) { write_train_run(d, *run, unused); });
      },
      py::arg("directory"));
  return py::make_tuple(summary, arrays);
}

}  // namespace

void bind_train(py::module_& m) {
  // The train's run without the GIL; Ctrl-C and progress as for the one-degree run.
  m.def(
      "_run_train",
      [](const Case& c, const py::object& progress) {
        return run_from_python<TrainRunOptions>(
            c, progress, [](const Case& x, const TrainRunOptions& o) { return run_train(x, o); },
            train_result);
      },
      py::arg("case"), py::arg("progress") = py::none());
  m.def(
      "_train_modes",
      [](const Case& c) {
        const train::Assembled a = assembled_train(c);
        return train_modes_json(a, train::modes(a), -1);
      },
      py::arg("case"));
}

}  // namespace geardyn::python
