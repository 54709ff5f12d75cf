#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cstdint>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "geardyn/case.hpp"
#include "geardyn/output.hpp"
#include "geardyn/output_folder.hpp"
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

// A column as a NumPy array that owns a copy (for a pickled state).
template <class T>
py::array owned(const std::vector<T>& v) {
  return py::array_t<T>(static_cast<py::ssize_t>(v.size()), v.data());
}

template <class T>
std::vector<T> to_vector(const py::handle& a) {
  const auto arr = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!arr) throw InputError("a pickled geardyn.RunResult holds a column that is not an array");
  return {arr.data(), arr.data() + arr.size()};
}

py::object optional_float(const std::optional<double>& x) {
  return x ? py::object(py::float_(*x)) : py::object(py::none());
}

std::optional<double> to_optional(const py::handle& x) {
  if (x.is_none()) return std::nullopt;
  return x.cast<double>();
}

py::tuple reading_state(const RunReading& g) {
  return py::make_tuple(static_cast<int>(g.regime), g.double_sided, g.impacts, g.backside_impacts,
                        g.separations, optional_float(g.last_separation_s), g.separated_fraction,
                        g.max_impact_velocity_m_s, g.max_force_bar, g.min_force_bar,
                        g.mean_force_bar, g.rms_force_bar, g.max_delta_bar, g.min_delta_bar,
                        g.mean_delta_bar, g.rms_delta_bar, optional_float(g.dynamic_factor));
}

RunReading reading_from(const py::tuple& g) {
  RunReading a;
  a.regime = static_cast<Regime>(g[0].cast<int>());
  a.double_sided = g[1].cast<bool>();
  a.impacts = g[2].cast<std::int64_t>();
  a.backside_impacts = g[3].cast<std::int64_t>();
  a.separations = g[4].cast<std::int64_t>();
  a.last_separation_s = to_optional(g[5]);
  double* reading[] = {&a.separated_fraction, &a.max_impact_velocity_m_s, &a.max_force_bar,
                       &a.min_force_bar,      &a.mean_force_bar,          &a.rms_force_bar,
                       &a.max_delta_bar,      &a.min_delta_bar,           &a.mean_delta_bar,
                       &a.rms_delta_bar};
  for (std::size_t k = 0; k < std::size(reading); ++k) *reading[k] = g[6 + k].cast<double>();
  a.dynamic_factor = to_optional(g[16]);
  return a;
}

constexpr int kPickleVersion = 4;

std::vector<std::pair<double, double>> error_pairs(const std::vector<ErrorHarmonic>& h) {
  std::vector<std::pair<double, double>> out;
  for (const ErrorHarmonic& x : h) out.emplace_back(x.amplitude, x.phase_deg);
  return out;
}

// Every field of a result but the geometry and the spectra, which are derived again on
// unpickling (from the case and from the samples) with the same code, hence the same digits.
py::tuple pickled(const RunResult& r) {
  const Derived& d = r.derived;
  const ode::IntegrationSummary& i = r.integration;
  std::vector<double> event_t, event_v;
  std::vector<int> event_kind;
  for (const ContactEvent& e : r.events) {
    event_t.push_back(e.t_s);
    event_kind.push_back(static_cast<int>(e.kind));
    event_v.push_back(e.velocity_m_s);
  }
  const Timeseries& s = r.samples;
  return py::make_tuple(
      kPickleVersion, r.input,
      py::make_tuple(d.m_eq_kg, d.natural_frequency_hz, d.damping_n_s_per_m, d.mean_force_n,
                     d.static_delta_bar, d.mesh_frequency_hz, d.base_helix_angle_deg,
                     d.working_pressure_angle_deg, d.transverse_contact_ratio, d.overlap_ratio,
                     d.fastest_period_s, d.time_step_s, d.output_interval_s,
                     d.transmission_error_mean_um, error_pairs(d.transmission_error_um)),
      py::make_tuple(static_cast<int>(i.termination), i.message, i.steps, i.transitions,
                     i.unsplit_steps, i.end_time_s, i.end_state.t, i.end_state.q, i.end_state.v,
                     i.end_state.a, i.end_state.region),
      reading_state(r.reading), py::make_tuple(owned(event_t), owned(event_kind), owned(event_v)),
      py::make_tuple(owned(s.t_s), owned(s.delta_bar), owned(s.velocity_m_s), owned(s.force_bar),
                     owned(s.contact)),
      r.steady_start_s, r.wall_time_s,
      py::make_tuple(static_cast<int>(r.steady.basis), r.steady.from_s, r.steady.period_multiple,
                     r.steady.error, reading_state(r.steady.reading), r.steady.window_s));
}

RunResult unpickled(const py::tuple& t) {
  if (t.size() != 10 || t[0].cast<int>() != kPickleVersion)
    throw InputError("a pickled geardyn.RunResult of another layout (version " +
                     std::to_string(kPickleVersion) + " expected)");
  RunResult r;
  r.input = t[1].cast<Case>();
  build_model(r.input, &r.geometry);
  const auto d = t[2].cast<py::tuple>();
  Derived& v = r.derived;
  double* derived[] = {&v.m_eq_kg,
                       &v.natural_frequency_hz,
                       &v.damping_n_s_per_m,
                       &v.mean_force_n,
                       &v.static_delta_bar,
                       &v.mesh_frequency_hz,
                       &v.base_helix_angle_deg,
                       &v.working_pressure_angle_deg,
                       &v.transverse_contact_ratio,
                       &v.overlap_ratio,
                       &v.fastest_period_s,
                       &v.time_step_s,
                       &v.output_interval_s};
  for (std::size_t k = 0; k < std::size(derived); ++k) *derived[k] = d[k].cast<double>();
  v.transmission_error_mean_um = d[std::size(derived)].cast<double>();
  for (const auto& [amplitude, phase_deg] :
       d[std::size(derived) + 1].cast<std::vector<std::pair<double, double>>>())
    v.transmission_error_um.push_back({amplitude, phase_deg});
  const auto i = t[3].cast<py::tuple>();
  ode::IntegrationSummary& s = r.integration;
  s.termination = static_cast<ode::Termination>(i[0].cast<int>());
  s.message = i[1].cast<std::string>();
  s.steps = i[2].cast<std::int64_t>();
  s.transitions = i[3].cast<std::int64_t>();
  s.unsplit_steps = i[4].cast<std::int64_t>();
  s.end_time_s = i[5].cast<double>();
  s.end_state = {i[6].cast<double>(), i[7].cast<double>(), i[8].cast<double>(), i[9].cast<double>(),
                 i[10].cast<int>()};
  r.reading = reading_from(t[4].cast<py::tuple>());
  const auto e = t[5].cast<py::tuple>();
  const auto et = to_vector<double>(e[0]), ev = to_vector<double>(e[2]);
  const auto ek = to_vector<int>(e[1]);
  for (std::size_t k = 0; k < et.size(); ++k)
    r.events.push_back({et[k], static_cast<EventKind>(ek[k]), ev[k]});
  const auto c = t[6].cast<py::tuple>();
  r.samples = {to_vector<double>(c[0]), to_vector<double>(c[1]), to_vector<double>(c[2]),
               to_vector<double>(c[3]), to_vector<int>(c[4])};
  r.steady_start_s = t[7].cast<double>();
  r.wall_time_s = t[8].cast<double>();
  const auto st = t[9].cast<py::tuple>();
  r.steady.basis = static_cast<SteadyBasis>(st[0].cast<int>());
  r.steady.from_s = st[1].cast<double>();
  r.steady.period_multiple = st[2].cast<int>();
  r.steady.error = st[3].cast<double>();
  r.steady.reading = reading_from(st[4].cast<py::tuple>());
  r.steady.window_s = st[5].cast<double>();
  compute_spectra(r);
  return r;
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
      .def_property_readonly(
          "ok", [](const RunResult& r) { return r.integration.ok(); },
          "True when the integration reached the end of the window (False when a progress "
          "callback stopped it).")
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
      // Pickled field by field: the numbers come back to the last digit.
      .def(py::pickle(&pickled, &unpickled))
      .def(
          "write",
          [](const RunResult& r, const std::string& dir) {
            return write_set(dir, "run", [&](const std::filesystem::path& d) { write_run(d, r); });
          },
          py::arg("directory"),
          "Writes the run's files as `geardyn run --out` does (docs/outputs.md).\n\n"
          "Parameters\n----------\ndirectory : str\n    Created if needed; summary.json, "
          "timeseries.csv, events.csv, case.toml and the rest are written into it. Only these "
          "files are replaced, together; the folder's other files stay (docs/outputs.md).\n\n"
          "Returns\n-------\nlist of str\n    Files of an earlier run written here that were "
          "changed since and so kept.\n\n"
          "Raises\n------\nRuntimeError\n    A file of one of these names is in the folder "
          "but geardyn did not write it there, or it was changed since: nothing is written.");
  // The output folder's rules (output_folder.hpp) for the package's own writers.
  m.def(
      "_write_set",
      [](const std::filesystem::path& dir, const std::string& name,
         const std::function<void(const std::filesystem::path&)>& stage) {
        return write_set(dir, name, stage);
      },
      py::arg("directory"), py::arg("name"), py::arg("stage"),
      "Calls stage(staging_folder), then puts what it wrote into `directory` as the set "
      "`name`, as every command's files are put (docs/outputs.md).");
  m.def("_foreign_files", &foreign_files, py::arg("directory"), py::arg("names"),
        "The names among `names` that are in `directory` and that a set would refuse to "
        "replace: not written by geardyn there, or changed since.");
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
