#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "geardyn/sweep.hpp"

namespace py = pybind11;

namespace geardyn::python {

void bind_sweep(py::module_& m) {
  m.def(
      "_sweep",
      [](const Case& c, const std::string& param, std::vector<double> values,
         const std::string& direction, int settle_periods, int measure_periods,
         int max_settle_periods, double steady_tolerance, const std::string& start,
         unsigned threads, const py::object& progress, const std::string& param2,
         std::vector<double> values2, const std::string& mesh) {
        SweepOptions o;
        o.axis.key = param;
        o.axis.explicit_values = std::move(values);
        o.axis.points = static_cast<int>(o.axis.explicit_values.size());
        if (!param2.empty()) {
          SweepAxis a2;
          a2.key = param2;
          a2.explicit_values = std::move(values2);
          a2.points = static_cast<int>(a2.explicit_values.size());
          o.axis2 = a2;
        }
        if (direction == "up") {
          o.direction = SweepDirection::kUp;
        } else if (direction == "down") {
          o.direction = SweepDirection::kDown;
        } else if (direction == "both") {
          o.direction = SweepDirection::kBoth;
        } else {
          throw InputError("direction = \"" + direction +
                           "\": must be \"up\", \"down\" or \"both\"");
        }
        o.settle_periods = settle_periods;
        o.measure_periods = measure_periods;
        o.max_settle_periods = max_settle_periods;
        o.steady_tolerance = steady_tolerance;
        if (start != "static" && start != "case")
          throw InputError("start = \"" + start + "\": must be \"static\" or \"case\"");
        o.start_static = start == "static";
        o.threads = threads;
        o.mesh = mesh;
        Hook hook(progress);
        // Python hears whole points (a bar's update per point); the shares of points under way
        // only give it the chance to stop.
        std::size_t heard = 0;
        o.progress = [&hook, &heard](double done, std::size_t total) {
          const auto whole = static_cast<std::size_t>(done);
          if (whole == heard) return hook.going();
          heard = whole;
          return hook(whole, total);
        };
        SweepResult r;
        run_interruptible(hook, [&] { r = sweep(c, o); });
        const std::size_t n = r.points.size();
        auto col = [&](auto get) {
          py::array_t<double> a(n);
          auto w = a.mutable_unchecked<1>();
          for (std::size_t i = 0; i < n; ++i) w(i) = get(r.points[i]);
          return a;
        };
        py::dict out;
        py::list dirs, regimes, failures;
        for (const SweepPoint& p : r.points) {
          dirs.append(to_string(p.direction));
          regimes.append(p.failure.empty() ? to_string(p.regime) : "failed");
          failures.append(p.failure);
        }
        out["failure"] = failures;
        out["direction"] = dirs;
        out["regime"] = regimes;
        out["value"] = col([](const SweepPoint& p) { return p.value; });
        if (o.axis2) out["value2"] = col([](const SweepPoint& p) { return p.value2; });
        out["settled"] = col([](const SweepPoint& p) { return p.settled ? 1.0 : 0.0; });
        out["mean_delta_bar"] = col([](const SweepPoint& p) { return p.mean_delta_bar; });
        out["rms_delta_bar"] = col([](const SweepPoint& p) { return p.rms_delta_bar; });
        out["pp_delta_bar"] = col([](const SweepPoint& p) { return p.pp_delta_bar; });
        out["min_delta_bar"] = col([](const SweepPoint& p) { return p.min_delta_bar; });
        out["mean_force_bar"] = col([](const SweepPoint& p) { return p.mean_force_bar; });
        out["rms_force_bar"] = col([](const SweepPoint& p) { return p.rms_force_bar; });
        out["pp_force_bar"] = col([](const SweepPoint& p) { return p.pp_force_bar; });
        out["max_force_bar"] = col([](const SweepPoint& p) { return p.max_force_bar; });
        out["separated_fraction"] = col([](const SweepPoint& p) { return p.separated_fraction; });
        out["impacts_per_period"] = col([](const SweepPoint& p) { return p.impacts_per_period; });
        out["double_sided"] = col([](const SweepPoint& p) { return p.double_sided ? 1.0 : 0.0; });
        out["dynamic_factor"] = col([](const SweepPoint& p) {
          return p.dynamic_factor.value_or(std::numeric_limits<double>::quiet_NaN());
        });
        out["settle_periods"] = col([](const SweepPoint& p) { return p.settle_periods; });
        out["period_multiple"] = col([](const SweepPoint& p) { return p.period_multiple; });
        out["steady_error"] = col([](const SweepPoint& p) { return p.steady_error; });
        // A (points, k) array of get(point, j): NaN for a failed point and past the point's
        // own columns.
        const auto per_point = [&](std::size_t k, const auto& items, auto get) {
          py::array_t<double> a({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(k)});
          auto w = a.mutable_unchecked<2>();
          for (std::size_t i = 0; i < n; ++i) {
            const SweepPoint& p = r.points[i];
            for (std::size_t j = 0; j < k; ++j)
              w(i, j) = j < (p.*items).size() && p.failure.empty()
                            ? get((p.*items)[j])
                            : std::numeric_limits<double>::quiet_NaN();
          }
          return a;
        };
        // A train's meshes (a coupled pair's too): each column as a (points, meshes) array,
        // mesh_<name>.
        if (!r.meshes.empty()) {
          out["meshes"] = r.meshes;
          out["mesh"] = r.mesh;
          const std::size_t k = r.meshes.size();
          for (const MeshColumn& c : kMeshColumns)
            out[py::str(std::string("mesh_") + c.name)] = per_point(
                k, &SweepPoint::meshes, [&](const MeshReading& x) { return x.*c.member; });
          py::list regimes_per_mesh;
          for (const SweepPoint& p : r.points) {
            py::list row;
            for (std::size_t j = 0; j < k; ++j)
              row.append(j < p.meshes.size() && p.failure.empty() ? to_string(p.meshes[j].regime)
                                                                  : "failed");
            regimes_per_mesh.append(row);
          }
          out["mesh_regime"] = regimes_per_mesh;
        }
        // A train's load-sharing groups: (points, groups) arrays under sweep.csv's names.
        if (!r.load_sharing.empty()) {
          py::list labels;
          for (const LoadSharingGroup& g : r.load_sharing) labels.append(g.label);
          out["load_sharing"] = labels;
          for (const auto& [name, member] :
               {std::pair{"load_sharing_factor", &LoadSharingReading::factor},
                std::pair{"lost_contact", &LoadSharingReading::lost_contact}})
            out[name] = per_point(r.load_sharing.size(), &SweepPoint::load_sharing,
                                  [m = member](const LoadSharingReading& x) { return x.*m; });
        }
        // A train's bearing clearance directions: (points, clearances) arrays.
        if (!r.clearances.empty()) {
          out["clearances"] = r.clearances;
          for (const auto& [name, at] : {std::pair{"clearance_impacts_per_period", 0},
                                         std::pair{"clearance_inside_fraction", 1}})
            out[name] = per_point(r.clearances.size(), &SweepPoint::clearances,
                                  [at = static_cast<std::size_t>(at)](
                                      const std::array<double, 2>& x) { return x[at]; });
        }
        // A train's shaft and bearing quantities (<part>_<quantity>): (points, parts) arrays of
        // the largest magnitude and the dynamic factor.
        if (!r.parts.empty()) {
          py::list labels;
          for (const SweepPart& q : r.parts) labels.append(q.label());
          out["parts"] = labels;
          out["part_peak"] = per_point(r.parts.size(), &SweepPoint::parts,
                                       [](const PartReading& x) { return x.peak; });
          out["part_factor"] = per_point(r.parts.size(), &SweepPoint::parts,
                                         [](const PartReading& x) { return x.factor; });
        }
        if (!r.period_note.empty()) out["period_note"] = r.period_note;
        out["steadiness"] = r.steadiness;
        py::list onsets;
        for (const ImpactOnset& x : r.impact_onsets) {
          py::dict d(py::arg("direction") = to_string(x.direction), py::arg("value") = x.value,
                     py::arg("meshes") = x.meshes);
          if (o.axis2) d["value2"] = x.value2;
          onsets.append(d);
        }
        out["impact_onsets"] = onsets;
        // The strobe (one sample per system period of each point's measurement), flat:
        // sample i belongs to point strobe["point"][i].
        std::vector<std::int64_t> owner;
        std::vector<double> sd, sv, sf;
        for (std::size_t i = 0; i < n; ++i) {
          const SweepPoint& p = r.points[i];
          owner.insert(owner.end(), p.strobe_delta_bar.size(), static_cast<std::int64_t>(i));
          sd.insert(sd.end(), p.strobe_delta_bar.begin(), p.strobe_delta_bar.end());
          sv.insert(sv.end(), p.strobe_velocity_m_s.begin(), p.strobe_velocity_m_s.end());
          sf.insert(sf.end(), p.strobe_force_bar.begin(), p.strobe_force_bar.end());
        }
        out["strobe"] =
            py::dict(py::arg("point") = py::array_t<std::int64_t>(
                         static_cast<py::ssize_t>(owner.size()), owner.data()),
                     py::arg("delta_bar") =
                         py::array_t<double>(static_cast<py::ssize_t>(sd.size()), sd.data()),
                     py::arg("velocity_m_s") =
                         py::array_t<double>(static_cast<py::ssize_t>(sv.size()), sv.data()),
                     py::arg("force_bar") =
                         py::array_t<double>(static_cast<py::ssize_t>(sf.size()), sf.data()));
        out["period_s"] = r.period_s;
        // Python keeps the SI names in either form; the form tells their units (tau, b w_n).
        out["form"] = to_string(r.form);
        py::list jumps, hysteresis;
        for (const Jump& j : r.jumps) {
          py::dict d(py::arg("direction") = to_string(j.direction),
                     py::arg("from_value") = j.from_value, py::arg("to_value") = j.to_value,
                     py::arg("pp_delta_bar_before") = j.before,
                     py::arg("pp_delta_bar_after") = j.after, py::arg("unsettled") = j.unsettled);
          if (o.axis2) d["value2"] = j.value2;
          jumps.append(d);
        }
        for (const Hysteresis& h : r.hysteresis) {
          py::dict d(py::arg("from_value") = h.from_value, py::arg("to_value") = h.to_value,
                     py::arg("unsettled") = h.unsettled);
          if (o.axis2) d["value2"] = h.value2;
          hysteresis.append(d);
        }
        py::list unsettled_ranges;
        for (const UnsettledRange& u : r.unsettled_ranges) {
          py::dict d(py::arg("direction") = to_string(u.direction),
                     py::arg("from_value") = u.from_value, py::arg("to_value") = u.to_value,
                     py::arg("points") = u.points);
          if (o.axis2) d["value2"] = u.value2;
          unsettled_ranges.append(d);
        }
        out["jumps"] = jumps;
        out["hysteresis"] = hysteresis;
        out["unsettled_ranges"] = unsettled_ranges;
        out["cancelled"] = r.cancelled;
        out["interrupted"] = hook.interrupted();
        return out;
      },
      py::arg("case"), py::arg("param"), py::arg("values"), py::arg("direction") = "both",
      py::arg("settle_periods") = 0, py::arg("measure_periods") = 10,
      py::arg("max_settle_periods") = 200, py::arg("steady_tolerance") = 1e-6,
      py::arg("start") = "static", py::arg("threads") = 0, py::arg("progress") = py::none(),
      py::arg("param2") = "", py::arg("values2") = std::vector<double>{}, py::arg("mesh") = "");
}

}  // namespace geardyn::python
