#include <pybind11/complex.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <atomic>
#include <memory>

#include "bindings.hpp"
#include "geardyn/continuation.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/stability.hpp"
#include "geardyn/train_orbit.hpp"
#include "geardyn/train_presets.hpp"

namespace py = pybind11;

namespace geardyn::python {
namespace {

template <class T, class F>
py::array_t<double> column(const std::vector<T>& rows, F get) {
  py::array_t<double> a(static_cast<py::ssize_t>(rows.size()));
  auto w = a.mutable_unchecked<1>();
  for (std::size_t i = 0; i < rows.size(); ++i) w(static_cast<py::ssize_t>(i)) = get(rows[i]);
  return a;
}

// The largest `k` multipliers of each row, as an (n, k) complex array (0 where fewer).
template <class T, class F>
py::array_t<std::complex<double>> multipliers(const std::vector<T>& rows, F get, std::size_t k) {
  py::array_t<std::complex<double>> a(
      {static_cast<py::ssize_t>(rows.size()), static_cast<py::ssize_t>(k)});
  auto w = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& mu = get(rows[i]);
    for (std::size_t j = 0; j < k; ++j)
      w(static_cast<py::ssize_t>(i), static_cast<py::ssize_t>(j)) =
          j < mu.size() ? mu[j] : std::complex<double>{};
  }
  return a;
}

}  // namespace

void bind_orbit(py::module_& m) {
  m.def(
      "_orbit",
      [](const Case& c, int periods, int segments, int settle_periods, double tolerance,
         int max_iterations, std::optional<std::vector<double>> state, int starts) {
        OrbitOptions o;
        o.starts = starts;
        o.periods = periods;
        o.segments = segments;
        o.settle_periods = settle_periods;
        o.tolerance = tolerance;
        o.max_iterations = max_iterations;
        std::optional<ode::State> start;
        if (state && state->size() == 2) start = ode::State{0.0, (*state)[0], (*state)[1], 0.0, 0};
        if (c.model.form == ModelForm::kCoupled || c.model.form == ModelForm::kTrain) {
          std::optional<ode::Vector> y0;
          if (state)
            y0 = Eigen::Map<const ode::Vector>(state->data(),
                                               static_cast<Eigen::Index>(state->size()));
          const py::gil_scoped_release release;
          // The coupled pair as its train form (train_form_of): one path.
          return train_orbit_json(find_train_orbit(c, o, y0), -1);
        }
        if (state && state->size() != 2)
          throw InputError("state: takes two values, delta (m) and delta' (m/s) at t = 0");
        Orbit r;
        {
          const py::gil_scoped_release release;
          r = find_orbit(c, o, start);
        }
        return orbit_json(r, -1);
      },
      py::arg("case"), py::arg("periods") = 1, py::arg("segments") = 0,
      py::arg("settle_periods") = 100, py::arg("tolerance") = 1e-10, py::arg("max_iterations") = 40,
      py::arg("state") = py::none(), py::arg("starts") = OrbitOptions{}.starts);

  m.def(
      "_continuation",
      [](const Case& c, const std::string& param, double from, double to, int periods, int segments,
         int settle_periods, double step, double max_step, int max_points,
         bool follow_period_doubling, const py::object& progress, const std::string& mesh,
         int starts) {
        ContinuationOptions o;
        o.mesh = mesh;
        o.key = param;
        o.from = from;
        o.to = to;
        o.orbit.periods = periods;
        o.orbit.segments = segments;
        o.orbit.settle_periods = settle_periods;
        o.orbit.starts = starts;
        o.initial_step = step;
        o.max_step = max_step;
        o.max_points = max_points;
        o.follow_period_doubling = follow_period_doubling;
        Hook hook(progress);
        o.progress = [&hook](double p, std::size_t n) { return hook(p, n); };
        ContinuationResult r;
        run_interruptible(hook, [&] { r = continuation(c, o); });
        const auto& pts = r.points;
        py::dict d;
        d["param"] = column(pts, [](const BranchPoint& p) { return p.param; });
        d["stable"] = column(pts, [](const BranchPoint& p) { return p.orbit.stable ? 1.0 : 0.0; });
        d["x_a"] = column(pts, [](const BranchPoint& p) { return p.amplitude(); });
        d["min_delta_bar"] =
            column(pts, [](const BranchPoint& p) { return p.orbit.reading.min_delta_bar; });
        d["max_delta_bar"] =
            column(pts, [](const BranchPoint& p) { return p.orbit.reading.max_delta_bar; });
        d["max_force_bar"] =
            column(pts, [](const BranchPoint& p) { return p.orbit.reading.max_force_bar; });
        d["impacts_per_period"] = column(
            pts, [](const BranchPoint& p) { return static_cast<double>(p.orbit.reading.impacts); });
        d["max_multiplier"] =
            column(pts, [](const BranchPoint& p) { return p.orbit.max_multiplier(); });
        // The state on the section, a column per entry: delta_m and velocity_m_s, or a train's
        // unknowns (the coupled pair's as its train's).
        for (std::size_t j = 0; j < r.state_names.size(); ++j)
          d[py::str(r.state_names[j])] = column(pts, [j](const BranchPoint& p) {
            return p.orbit.state[static_cast<Eigen::Index>(j)];
          });
        d["branch"] =
            column(pts, [](const BranchPoint& p) { return static_cast<double>(p.branch); });
        d["periods"] =
            column(pts, [](const BranchPoint& p) { return static_cast<double>(p.periods); });
        d["multipliers"] = multipliers(
            pts, [](const BranchPoint& p) -> const auto& { return p.orbit.multipliers; }, 2);
        py::list bif;
        for (const Bifurcation& b : r.bifurcations) {
          bif.append(py::dict(py::arg("type") = to_string(b.type), py::arg("param") = b.param,
                              py::arg("branch") = b.branch, py::arg("detail") = b.detail,
                              py::arg("x_a") = 0.5 * (b.orbit.reading.max_delta_bar -
                                                      b.orbit.reading.min_delta_bar),
                              py::arg("orbit") = py::str(b.orbit_json)));
        }
        d["bifurcations"] = bif;
        d["completed"] = r.completed;
        d["cancelled"] = r.cancelled;
        d["interrupted"] = hook.interrupted();
        d["message"] = r.message;
        d["wall_time_s"] = r.wall_time_s;
        d["mesh"] = r.mesh;
        return d;
      },
      py::arg("case"), py::arg("param"), py::arg("from_"), py::arg("to"), py::arg("periods") = 1,
      py::arg("segments") = 0, py::arg("settle_periods") = 100, py::arg("step") = 0.01,
      py::arg("max_step") = 0.02, py::arg("max_points") = 5000,
      py::arg("follow_period_doubling") = false, py::arg("progress") = py::none(),
      py::arg("mesh") = "", py::arg("starts") = OrbitOptions{}.starts);

  m.def(
      "_stability",
      [](const Case& c, const std::string& param, std::vector<double> values,
         const std::string& param2, std::vector<double> values2, const py::object& progress) {
        StabilityOptions o;
        o.axis.key = param;
        o.axis.explicit_values = std::move(values);
        o.axis.points = static_cast<int>(o.axis.explicit_values.size());
        if (!o.axis.explicit_values.empty()) {
          o.axis.from = o.axis.explicit_values.front();
          o.axis.to = o.axis.explicit_values.back();
        }
        if (!param2.empty()) {
          SweepAxis a2;
          a2.key = param2;
          a2.explicit_values = std::move(values2);
          a2.points = static_cast<int>(a2.explicit_values.size());
          if (!a2.explicit_values.empty()) {
            a2.from = a2.explicit_values.front();
            a2.to = a2.explicit_values.back();
          }
          o.axis2 = a2;
        }
        Hook hook(progress);
        o.progress = [&hook](std::size_t done, std::size_t total) { return hook(done, total); };
        StabilityResult r;
        run_interruptible(hook, [&] { r = stability(c, o); });
        const auto& s = r.samples;
        py::dict d;
        d["param"] = column(s, [](const StabilitySample& x) { return x.param; });
        if (o.axis2) d["param2"] = column(s, [](const StabilitySample& x) { return x.param2; });
        d["stable"] = column(s, [](const StabilitySample& x) { return x.stable ? 1.0 : 0.0; });
        d["max_multiplier"] = column(s, [](const StabilitySample& x) { return x.max_multiplier; });
        d["multipliers"] = multipliers(
            s, [](const StabilitySample& x) -> const auto& { return x.multipliers; }, 2);
        py::list b;
        for (const StabilityBoundary& x : r.boundaries) {
          py::dict e(py::arg("param") = x.param, py::arg("type") = to_string(x.type));
          if (o.axis2) e["param2"] = x.param2;
          b.append(e);
        }
        d["boundaries"] = b;
        d["cancelled"] = r.cancelled;
        d["interrupted"] = hook.interrupted();
        return d;
      },
      py::arg("case"), py::arg("param"), py::arg("values"), py::arg("param2") = "",
      py::arg("values2") = std::vector<double>{}, py::arg("progress") = py::none());
}

}  // namespace geardyn::python
