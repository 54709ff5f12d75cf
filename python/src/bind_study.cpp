#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "geardyn/run.hpp"
#include "geardyn/study_sample.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_study(py::module_& m) {
  // A batch of a study's run samples, of any form (studies.py): the base case with each row's
  // keys set (to 17 digits, as Case.set gives them), run by run_sample (study_sample.hpp: no
  // samples or events kept, a pair form's mesh stiffness computed once when no key changes
  // it). Without the GIL; between samples progress(done, total) is called, and Ctrl-C stops
  // the sample running, which is not counted. Returns (outputs as a dict of arrays, named as
  // run_sample names them, in its order; failures as a list of str (empty: ok); samples done;
  // whether Ctrl-C stopped it).
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
        std::vector<std::string> names;
        std::vector<std::vector<double>> out;  // per sample, in `names` order
        std::vector<std::string> failures;
        Hook hook(progress);
        run_interruptible(hook, [&] {
          const std::optional<MeshStiffness> shared = shared_stiffness(base, keys);
          const auto going_on = [&hook](double) { return !hook.interrupted(); };
          while (out.size() < n && hook(out.size(), n)) {
            const std::size_t i = out.size();
            Case c = base;
            for (std::size_t j = 0; j < keys.size(); ++j)
              set_case_value(c, {keys[j], fmt::format("{:.17g}", values[i * keys.size() + j])});
            SampleReadings x = run_sample(c, shared ? &*shared : nullptr, going_on);
            if (x.cancelled) break;
            if (i == 0) names = x.names;
            if (x.names != names)  // a base case's samples differ in numbers only
              throw std::logic_error(
                  fmt::format("_run_batch: sample {} reads other outputs than sample 0", i));
            out.push_back(std::move(x.values));
            failures.push_back(std::move(x.failure));
          }
        });
        py::dict arrays;
        for (std::size_t k = 0; k < names.size(); ++k) {
          py::array_t<double> a(static_cast<py::ssize_t>(out.size()));
          auto v = a.mutable_unchecked<1>();
          for (std::size_t i = 0; i < out.size(); ++i) v(static_cast<py::ssize_t>(i)) = out[i][k];
          arrays[names[k].c_str()] = a;
        }
        return py::make_tuple(arrays, failures, out.size(), hook.interrupted());
      },
      py::arg("case"), py::arg("keys"), py::arg("rows"), py::arg("progress") = py::none());
}

}  // namespace geardyn::python
