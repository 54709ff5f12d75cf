#include <pybind11/stl.h>

#include <string>

#include "bindings.hpp"
#include "geardyn/validation.hpp"
#include "geardyn/validation_output.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_validation(py::module_& m) {
  // The validation without the GIL, progress(done, total) between checks, Ctrl-C stopping it
  // after the check under way. Returns (validation.json text, the terminal table, the HTML
  // report, whether Ctrl-C interrupted it); `out` (not empty) receives the three reports.
  m.def(
      "_validate",
      [](bool quick, const py::object& progress, const std::string& out) {
        Hook hook(progress);
        ValidationOptions o;
        o.quick = quick;
        o.progress = [&hook](std::size_t done, std::size_t total, const std::string&) {
          return hook(done, total);
        };
        ValidationResult r;
        run_interruptible(hook, [&] {
          r = validate(o);
          if (!out.empty()) write_validation(out, r);
        });
        return py::make_tuple(validation_json(r), validation_table(r), validation_html(r),
                              hook.interrupted());
      },
      py::arg("quick") = false, py::arg("progress") = py::none(), py::arg("out") = "");
}

}  // namespace geardyn::python
