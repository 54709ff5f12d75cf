#include <pybind11/numpy.h>

#include "bindings.hpp"
#include "geardyn/case.hpp"
#include "geardyn/output.hpp"
#include "geardyn/run.hpp"

namespace py = pybind11;

namespace geardyn::python {
namespace {

// A column of the result as a NumPy array that points into the result (no copy); the array
// keeps the result alive.
template <class T>
py::array column(const py::object& owner, const std::vector<T>& v) {
  return py::array_t<T>({v.size()}, {sizeof(T)}, v.data(), owner);
}

// The getter of one Timeseries column as such a view.
template <class T>
auto samples_view(std::vector<T> Timeseries::*member) {
  return [member](const py::object& self) {
    return column(self, self.cast<const RunResult&>().samples.*member);
  };
}

}  // namespace

void bind_run(py::module_& m) {
  py::class_<RunResult>(m, "RunResult", "One run: its samples and its reading.")
      .def_property_readonly(
          "t", samples_view(&Timeseries::t_s),
          "Sample times, s (tau in the non-dimensional form); a view into the result.")
      .def_property_readonly("delta_bar", samples_view(&Timeseries::delta_bar),
                             "delta / b at the sample times; a view into the result.")
      .def_property_readonly(
          "force_bar", samples_view(&Timeseries::force_bar),
          "F / (b k_m), the mesh force over backlash times mean stiffness; a view.")
      .def_property_readonly("velocity", samples_view(&Timeseries::velocity_m_s),
                             "delta', m/s (dimensionless in the non-dimensional form); a view.")
      .def_property_readonly(
          "contact", samples_view(&Timeseries::contact),
          "1 drive-side contact, 0 separated, -1 back-side contact (int32); a view.")
      .def_property_readonly("_summary_json", [](const RunResult& r) { return summary_json(r); })
      .def_property_readonly("ok", [](const RunResult& r) { return r.integration.ok(); })
      .def_property_readonly(
          "events",
          [](const RunResult& r) {
            const auto n = static_cast<py::ssize_t>(r.events.size());
            py::array_t<double> t(n), v(n);
            py::list kind;
            for (py::ssize_t i = 0; i < n; ++i) {
              const ContactEvent& e = r.events[static_cast<std::size_t>(i)];
              t.mutable_at(i) = e.t_s;
              v.mutable_at(i) = e.velocity_m_s;
              kind.append(to_string(e.kind));
            }
            return py::dict(py::arg("t_s") = t, py::arg("kind") = kind,
                            py::arg("velocity_m_s") = v);
          },
          "The located contact events as arrays: t_s (s), kind (impact, backside_impact, "
          "separation), velocity_m_s (delta' at the event, m/s).")
      .def_property_readonly(
          "case_toml", [](const RunResult& r) { return to_toml(r.input); },
          "The case that was run, as TOML.")
      .def_property_readonly("_failure",
                             [](const RunResult& r) {
                               return std::string(ode::to_string(r.integration.termination)) +
                                      ": " + r.integration.message;
                             })
      .def(
          "write", [](const RunResult& r, const std::string& dir) { write_run(dir, r); },
          py::arg("directory"), "Writes summary.json, timeseries.csv, events.csv, case.toml.");
  // The integration runs without the GIL: other Python threads go on meanwhile.
  // Ctrl-C and `progress(fraction)` are looked at now and then (every few thousand cells).
  m.def(
      "_run",
      [](const Case& c, const py::object& progress) {
        Hook hook(progress);
        RunOptions o;
        o.progress = [&hook](double fraction) { return hook(fraction); };
        RunResult r;
        run_interruptible(hook, [&] { r = run(c, o); });
        return py::make_tuple(std::move(r), hook.interrupted());
      },
      py::arg("case"), py::arg("progress") = py::none());
}

}  // namespace geardyn::python
