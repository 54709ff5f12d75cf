#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.hpp"
#include "geardyn/case.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_case(py::module_& m) {
  py::class_<Case>(m, "Case", "A case: everything a run needs (docs/case-files.md).")
      .def_static(
          "from_toml", [](const std::filesystem::path& path) { return load_case(path); },
          py::arg("path"), "Reads a case file; raises InputError on bad input.")
      .def_static(
          "default", [] { return load_case(std::nullopt); },
          "The paper's gear: Table 1 at the conditions of Fig. 4(c).")
      .def(
          "set_toml",
          [](Case& c, const std::string& key, const std::string& toml_value) {
            set_case_value(c, {key, toml_value});
          },
          py::arg("key"), py::arg("toml_value"),
          "Sets a key from a value in TOML syntax, as --set key=value does.")
      .def("to_toml", [](const Case& c) { return to_toml(c); })
      .def_readwrite("name", &Case::name)
      .def("copy", [](const Case& c) { return Case(c); })
      .def("__repr__", [](const Case& c) { return "<geardyn.Case " + c.name + ">"; });
}

}  // namespace geardyn::python
