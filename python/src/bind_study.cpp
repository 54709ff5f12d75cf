#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "geardyn/run.hpp"

namespace py = pybind11;

namespace geardyn::python {
namespace {

// The readings a study keeps of a one-degree run, named as summary.json names them
// (docs/outputs.md) and as studies.py's _RUN_OUTPUTS lists them.
constexpr std::array<const char*, 11> kOutputs = {"impacts",
                                                  "backside_impacts",
                                                  "separations",
                                                  "separated_fraction",
                                                  "max_force_bar",
                                                  "max_delta_bar",
                                                  "max_impact_velocity_m_s",
                                                  "dynamic_factor",
                                                  "dynamic_factor_with_startup",
                                                  "rattle",
                                                  "natural_frequency_hz"};

std::array<double, kOutputs.size()> readings(const RunResult& r) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const RunReading& x = r.reading;
  return {static_cast<double>(x.impacts),
          static_cast<double>(x.backside_impacts),
          static_cast<double>(x.separations),
          x.separated_fraction,
          x.max_force_bar,
          x.max_delta_bar,
          x.max_impact_velocity_m_s,
          r.steady.reading.dynamic_factor.value_or(kNaN),
          x.dynamic_factor.value_or(kNaN),
          x.regime == Regime::kSustained ? 1.0 : 0.0,
          r.derived.natural_frequency_hz};
}

}  // namespace

void bind_study(py::module_& m) {
  // A batch of a study's samples of the gear pair (studies.py): the base case with each row's
  // keys set (to 17 digits, as Case.set gives them), run without keeping samples or events,
  // with the mesh stiffness computed once when no key changes it. Without the GIL; between
  // samples progress(done, total) is called and Ctrl-C stops. Returns (outputs as a dict of
  // arrays, failures as a list of str (empty: ok), samples done, whether Ctrl-C stopped it).
  m.def(
      "_run_batch",
      [](const Case& base, const std::vector<std::string>& keys,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& rows,
         const py::object& progress) {
        const auto r = rows.unchecked<2>();
        const auto n = static_cast<std::size_t>(r.shape(0));
        if (static_cast<std::size_t>(r.shape(1)) != keys.size())
          throw InputError(
              fmt::format("_run_batch: {} keys for rows of {} values", keys.size(), r.shape(1)));
        std::vector<double> values(r.data(0, 0), r.data(0, 0) + n * keys.size());
        std::vector<std::array<double, kOutputs.size()>> out(n);
        std::vector<std::string> failures(n);
        std::size_t done = 0;
        Hook hook(progress);
        run_interruptible(hook, [&] {
          const std::optional<MeshStiffness> shared = shared_stiffness(base, keys);
          for (; done < n; ++done) {
            if (!hook(done, n)) break;
            Case c = base;
            for (std::size_t j = 0; j < keys.size(); ++j)
              set_case_value(c, {keys[j], fmt::format("{:.17g}", values[done * keys.size() + j])});
            RunOptions o;
            o.keep_samples = false;
            o.keep_events = false;
            o.stiffness = shared ? &*shared : nullptr;
            const RunResult x = run(c, o);
            if (x.integration.ok()) {
              out[done] = readings(x);
            } else {
              out[done].fill(std::numeric_limits<double>::quiet_NaN());
              failures[done] =
                  fmt::format("numerical failure ({}): {}",
                              ode::to_string(x.integration.termination), x.integration.message);
            }
          }
        });
        py::dict arrays;
        for (std::size_t k = 0; k < kOutputs.size(); ++k) {
          py::array_t<double> a(static_cast<py::ssize_t>(done));
          auto v = a.mutable_unchecked<1>();
          for (std::size_t i = 0; i < done; ++i) v(static_cast<py::ssize_t>(i)) = out[i][k];
          arrays[kOutputs[k]] = a;
        }
        failures.resize(done);
        return py::make_tuple(arrays, failures, done, hook.interrupted());
      },
      py::arg("case"), py::arg("keys"), py::arg("rows"), py::arg("progress") = py::none());
}

}  // namespace geardyn::python
