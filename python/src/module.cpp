#include "bindings.hpp"
#include "geardyn/case.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_geardyn, m) {
  m.doc() = "geardyn: nonlinear dynamics of gear pairs and trains with backlash (C++ core)";
  // Bad input, with the command line's message (file and line or key, value, what is allowed).
  static py::exception<geardyn::InputError> input_error(m, "InputError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const geardyn::InputError& e) {
      input_error(e.what());
    }
  });
  geardyn::python::bind_case(m);
  geardyn::python::bind_geometry(m);
  geardyn::python::bind_stiffness(m);
  geardyn::python::bind_run(m);
  geardyn::python::bind_sweep(m);
  geardyn::python::bind_orbit(m);
  geardyn::python::bind_train(m);
  geardyn::python::bind_validation(m);
  geardyn::python::bind_study(m);
}
