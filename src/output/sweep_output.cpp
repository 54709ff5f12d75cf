// The files and figures of a sweep (sweep_output.hpp): sweep.csv, strobe.csv, summary.json,
// the frequency response, the bifurcation diagram, the regime map and the per-part responses.
#include "geardyn/sweep_output.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "geardyn/case_keys.hpp"
#include "geardyn/figures.hpp"
#include "geardyn/output.hpp"

namespace geardyn {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

namespace {
// The units a key's name ends with (geardyn names every quantity with its unit), longest first,
// as an axis shows them.
constexpr std::array<std::pair<std::string_view, std::string_view>, 17> kUnitSuffixes{{
    {"_n_m_s_per_rad", "N m s/rad"},
    {"_n_m_per_rad", "N m/rad"},
    {"_n_s_per_m", "N s/m"},
    {"_n_per_m", "N/m"},
    {"_kg_m2", "kg m²"},
    {"_kg_m3", "kg/m³"},
    {"_gpa", "GPa"},
    {"_hz", "Hz"},
    {"_um", "µm"},
    {"_mm", "mm"},
    {"_deg", "deg"},
    {"_rad", "rad"},
    {"_nm", "N m"},
    {"_kg", "kg"},
    {"_w", "W"},
    {"_s", "s"},
    {"_n", "N"},
}};

// A swept key as an axis names it: with its unit when its name ends with one
// ("train.reference_speed_hz (Hz)"), else as it is (a ratio, a count, a harmonic's entry).
std::string key_label(const std::string& key) {
  for (const auto& [suffix, unit] : kUnitSuffixes)
    if (key.ends_with(suffix)) return fmt::format("{} ({})", key, unit);
  return key;
}

// A text cell: quoted when it holds a comma or a quote (RFC 4180).
std::string csv_text(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char ch : s) {
    if (ch == '"') q += '"';
    q += ch == '\n' ? ' ' : ch;
  }
  return q + "\"";
}

// sweep.csv's header (no newline); before `failure` a train's (or a coupled pair's) meshes add
// ten columns each, its load-sharing groups two each, its bearing clearance directions two each,
// its shaft and bearing quantities two each.
std::string sweep_csv_header(const SweepResult& r) {
  std::string out =
      "direction,param,value,param2,value2,settled,settle_periods,mean_delta_bar,rms_delta_bar,"
      "pp_delta_bar,min_delta_bar,mean_force_bar,rms_force_bar,pp_force_bar,max_force_bar,"
      "dynamic_factor,separated_fraction,impacts_per_period,regime,double_sided,period_multiple,"
      "steady_error,";
  for (const std::string& mesh : r.meshes) {
    for (const MeshColumn& col : kMeshColumns)
      fmt::format_to(std::back_inserter(out), "{}_{},", mesh, col.name);
    fmt::format_to(std::back_inserter(out), "{}_regime,", mesh);
  }
  for (const LoadSharingGroup& g : r.load_sharing)
    fmt::format_to(std::back_inserter(out), "{0}_load_sharing_factor,{0}_lost_contact,", g.label);
  for (const std::string& c : r.clearances)
    fmt::format_to(std::back_inserter(out), "{0}_impacts_per_period,{0}_inside_fraction,", c);
  for (const SweepPart& q : r.parts)
    fmt::format_to(std::back_inserter(out), "{},{},", q.peak_column(), q.factor_column());
  return out + "failure";
}

// The 1-based column of `name` in sweep.csv (gnuplot's $N); 0 when there is none.
int sweep_csv_column(const SweepResult& r, const std::string& name) {
  std::istringstream header(sweep_csv_header(r));
  int k = 0;
  for (std::string cell; std::getline(header, cell, ',');) {
    ++k;
    if (cell == name) return k;
  }
  return 0;
}

}  // namespace

std::string sweep_csv(const SweepResult& r) {
  const SweepOptions& o = r.options;
  std::string out = sweep_csv_header(r) + "\n";
  for (const SweepPoint& p : r.points) {
    fmt::format_to(
        std::back_inserter(out),
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},",
        to_string(p.direction), o.axis.key, p.value, o.axis2 ? o.axis2->key : "", p.value2,
        p.settled ? 1 : 0, p.settle_periods, p.mean_delta_bar, p.rms_delta_bar, p.pp_delta_bar,
        p.min_delta_bar, p.mean_force_bar, p.rms_force_bar, p.pp_force_bar, p.max_force_bar,
        p.dynamic_factor ? fmt::format("{}", *p.dynamic_factor) : "", p.separated_fraction,
        p.impacts_per_period, p.failure.empty() ? to_string(p.regime) : "failed",
        p.double_sided ? 1 : 0, p.period_multiple, p.steady_error);
    for (std::size_t i = 0; i < r.meshes.size(); ++i) {
      const bool read = i < p.meshes.size() && p.failure.empty();
      for (const MeshColumn& col : kMeshColumns)
        fmt::format_to(std::back_inserter(out), "{},", read ? p.meshes[i].*col.member : kNaN);
      fmt::format_to(std::back_inserter(out), "{},",
                     read ? to_string(p.meshes[i].regime) : "failed");
    }
    for (std::size_t i = 0; i < r.load_sharing.size(); ++i) {
      const bool read = i < p.load_sharing.size() && p.failure.empty();
      fmt::format_to(std::back_inserter(out), "{},{},", read ? p.load_sharing[i].factor : kNaN,
                     read ? p.load_sharing[i].lost_contact : kNaN);
    }
    for (std::size_t i = 0; i < r.clearances.size(); ++i) {
      const bool read = i < p.clearances.size() && p.failure.empty();
      fmt::format_to(std::back_inserter(out), "{},{},", read ? p.clearances[i][0] : kNaN,
                     read ? p.clearances[i][1] : kNaN);
    }
    for (std::size_t i = 0; i < r.parts.size(); ++i) {
      const bool read = i < p.parts.size() && p.failure.empty();
      fmt::format_to(std::back_inserter(out), "{},{},", read ? p.parts[i].peak : kNaN,
                     read ? p.parts[i].factor : kNaN);
    }
    out += csv_text(p.failure) + "\n";
  }
  return out;
}

namespace {

std::string strobe_csv(const SweepResult& r, ModelForm form) {
  std::string out = fmt::format("direction,value,value2,period,delta_bar,{},force_bar\n",
                                form_key("velocity_m_s", form));
  for (const SweepPoint& p : r.points)
    for (std::size_t k = 0; k < p.strobe_delta_bar.size(); ++k)
      fmt::format_to(std::back_inserter(out), "{},{},{},{},{},{},{}\n", to_string(p.direction),
                     p.value, p.value2, k, p.strobe_delta_bar[k], p.strobe_velocity_m_s[k],
                     p.strobe_force_bar[k]);
  return out;
}

std::string summary(const SweepResult& r) {
  const SweepOptions& o = r.options;
  nlohmann::json j;
  j["param"] = o.axis.key;
  j["from"] = o.axis.from;
  j["to"] = o.axis.to;
  j["points"] = o.axis.points;
  j["log"] = o.axis.log;
  if (o.axis2) {
    j["param2"] = o.axis2->key;
    j["from2"] = o.axis2->from;
    j["to2"] = o.axis2->to;
    j["points2"] = o.axis2->points;
  }
  j["direction"] = to_string(o.direction);
  if (!r.meshes.empty()) {
    j["meshes"] = r.meshes;
    j["mesh"] = r.mesh;
  }
  if (!r.load_sharing.empty()) {
    nlohmann::json groups = nlohmann::json::array();
    for (const LoadSharingGroup& g : r.load_sharing) {
      std::vector<std::string> names;
      for (const std::size_t m : g.meshes) names.push_back(r.meshes[m]);
      groups.push_back({{"label", g.label}, {"gear", g.gear}, {"meshes", names}});
    }
    j["load_sharing"] = groups;
  }
  if (!r.clearances.empty()) j["clearances"] = r.clearances;
  if (!r.parts.empty()) {
    nlohmann::json parts = nlohmann::json::array();
    for (const SweepPart& q : r.parts) parts.push_back({{"part", q.part}, {"quantity", q.what}});
    j["parts"] = parts;
  }
  j["steadiness"] = r.steadiness;
  if (!r.period_note.empty()) j["period_note"] = r.period_note;
  j["settle_periods"] = o.settle_periods;
  j["measure_periods"] = o.measure_periods;
  j["max_settle_periods"] = o.max_settle_periods;
  j["steady_tolerance"] = o.steady_tolerance;
  j["start"] = o.start_static ? "static" : "case";
  j[form_key("period_s", r.form)] = r.period_s;
  j["points_computed"] = r.points.size();
  j["unsettled"] = r.unsettled;
  j["failed"] = r.failed;
  j["cancelled"] = r.cancelled;
  j["wall_time_s"] = r.wall_time_s;
  j["threads"] = r.threads;
  j["unused_settings"] = r.unused_settings;
  j["hysteresis"] = nlohmann::json::array();
  for (const Hysteresis& h : r.hysteresis) {
    nlohmann::json x = {
        {"from_value", h.from_value}, {"to_value", h.to_value}, {"unsettled", h.unsettled}};
    if (o.axis2) x["value2"] = h.value2;
    j["hysteresis"].push_back(x);
  }
  j["unsettled_ranges"] = nlohmann::json::array();
  for (const UnsettledRange& u : r.unsettled_ranges) {
    nlohmann::json x = {{"direction", to_string(u.direction)},
                        {"from_value", u.from_value},
                        {"to_value", u.to_value},
                        {"points", u.points}};
    if (o.axis2) x["value2"] = u.value2;
    j["unsettled_ranges"].push_back(x);
  }
  j["impact_onsets"] = nlohmann::json::array();
  for (const ImpactOnset& x : r.impact_onsets) {
    nlohmann::json y = {
        {"direction", to_string(x.direction)}, {"value", x.value}, {"meshes", x.meshes}};
    if (o.axis2) y["value2"] = x.value2;
    j["impact_onsets"].push_back(y);
  }
  j["jumps"] = nlohmann::json::array();
  for (const Jump& x : r.jumps) {
    nlohmann::json y = {{"direction", to_string(x.direction)},
                        {"from_value", x.from_value},
                        {"to_value", x.to_value},
                        {"pp_delta_bar_before", x.before},
                        {"pp_delta_bar_after", x.after},
                        {"unsettled", x.unsettled}};
    if (o.axis2) y["value2"] = x.value2;
    j["jumps"].push_back(y);
  }
  return j.dump(2) + "\n";
}

// The cell edges of a grid: midway between neighbours (geometrically on a log axis), the
// end cells as wide as their neighbours.
std::vector<double> cell_edges(const std::vector<double>& v, bool log) {
  std::vector<double> e(v.size() + 1);
  const auto mid = [log](double a, double b) { return log ? std::sqrt(a * b) : 0.5 * (a + b); };
  if (v.size() == 1) {
    e = log ? std::vector<double>{v[0] / 1.1, v[0] * 1.1}
            : std::vector<double>{v[0] - 0.5, v[0] + 0.5};
    return e;
  }
  for (std::size_t i = 1; i < v.size(); ++i) e[i] = mid(v[i - 1], v[i]);
  e.front() = log ? v.front() * v.front() / e[1] : 2 * v.front() - e[1];
  e.back() = log ? v.back() * v.back() / e[v.size() - 1] : 2 * v.back() - e[v.size() - 1];
  return e;
}

// The regime map of a 2-D sweep: one panel per direction swept, each point a filled cell
// coloured by what happened there (only what occurred is in the legend), and the cells where
// the up and the down sweep differ (coexisting branches) marked in both.
std::string regime_map_body(const SweepResult& r) {
  const SweepOptions& o = r.options;
  const std::vector<double> xs = o.axis.values(), ys = o.axis2->values();
  const std::vector<double> xe = cell_edges(xs, o.axis.log), ye = cell_edges(ys, o.axis2->log);
  const auto index = [](const std::vector<double>& v, double x) {
    return static_cast<std::size_t>(std::lower_bound(v.begin(), v.end(), x) - v.begin());
  };
  struct Class {
    const char* name;
    const char* colour;
  };
  static constexpr std::array<Class, 5> kClasses{{{"none", "#d9efd9"},
                                                  {"transient", "#f7e3a1"},
                                                  {"sustained", "#f4a6a6"},
                                                  {"double-sided", "#7b3294"},
                                                  {"failed", "#9a9a9a"}}};
  const auto class_of = [](const SweepPoint& p) -> std::size_t {
    if (!p.failure.empty()) return 4;
    if (p.double_sided) return 3;
    return static_cast<std::size_t>(p.regime);  // none, transient, sustained
  };
  // Data blocks: cells per direction and class, and the coexistence marks.
  std::string data, body;
  std::map<std::pair<double, double>, std::pair<const SweepPoint*, const SweepPoint*>> at;
  for (const SweepPoint& p : r.points)
    (p.direction == SweepDirection::kUp ? at[{p.value, p.value2}].first
                                        : at[{p.value, p.value2}].second) = &p;
  std::string coexist;
  for (const auto& [xy, pair] : at) {
    const auto [up, down] = pair;
    if (up && down && up->failure.empty() && down->failure.empty() &&
        std::abs(up->pp_delta_bar - down->pp_delta_bar) >
            kHysteresisFraction *
                std::max(std::abs(up->pp_delta_bar), std::abs(down->pp_delta_bar)))
      fmt::format_to(std::back_inserter(coexist), "{},{}\n", xy.first, xy.second);
  }
  if (!coexist.empty()) data += "$coexist << EOD\n" + coexist + "EOD\n";
  std::vector<SweepDirection> panels;
  for (SweepDirection d : {SweepDirection::kUp, SweepDirection::kDown})
    if (std::any_of(r.points.begin(), r.points.end(),
                    [&](const SweepPoint& p) { return p.direction == d; }))
      panels.push_back(d);
  for (SweepDirection d : panels) {
    std::string plot;
    for (std::size_t k = 0; k < kClasses.size(); ++k) {
      std::string cells;
      for (const SweepPoint& p : r.points) {
        if (p.direction != d || class_of(p) != k) continue;
        const std::size_t i = index(xs, p.value), j = index(ys, p.value2);
        fmt::format_to(std::back_inserter(cells), "{},{},{},{},{},{}\n", p.value, p.value2, xe[i],
                       xe[i + 1], ye[j], ye[j + 1]);
      }
      if (cells.empty()) continue;
      const std::string block = fmt::format("${}_{}", to_string(d), k);
      fmt::format_to(std::back_inserter(data), "{} << EOD\n{}EOD\n", block, cells);
      fmt::format_to(std::back_inserter(plot),
                     "{}{} using 1:2:3:4:5:6 with boxxyerror fs solid 1.0 noborder fc rgb '{}' "
                     "title '{}'",
                     plot.empty() ? "plot " : ", \\\n     ", block, kClasses[k].colour,
                     kClasses[k].name);
    }
    if (!coexist.empty())
      plot +=
          ", \\\n     $coexist using 1:2 with points pt 6 ps 1.0 lc rgb 'black' title "
          "'up ≠ down (branches coexist)'";
    fmt::format_to(std::back_inserter(body), "set title '{} sweeps'\n{}\n", to_string(d), plot);
  }
  std::string s = "reset\nset encoding utf8\nset datafile separator ','\n" + data;
  if (o.axis.log) s += "set logscale x\n";
  if (o.axis2->log) s += "set logscale y\n";
  fmt::format_to(std::back_inserter(s),
                 "set xlabel '{}'\nset ylabel '{}'\nset xrange [{}:{}]\nset yrange [{}:{}]\n"
                 "set key below font ',9'\nset multiplot layout 1,{} title 'regime map'\n{}"
                 "unset multiplot\n",
                 key_label(o.axis.key), key_label(o.axis2->key), xe.front(), xe.back(), ye.front(),
                 ye.back(), panels.size(), body);
  return s;
}

// A figure of panels along the key, each drawing its series (sweep.csv's column and its legend)
// up and down.
struct SeriesPanel {
  std::string ylabel;
  std::vector<std::pair<std::string, std::string>> series;
  // Per series, its group (empty: every series its own): the series of one group (a set's
  // identical planets' meshes) share a colour and one legend entry, the group's label.
  std::vector<std::string> groups;
  std::string settings;  // gnuplot lines before the panel's plot (its axis' range and format)
};
// A panel with more legend entries per direction than this has its legend beside it.
constexpr std::size_t kLegendInside = 4;
std::string series_body(const SweepResult& r, const std::string& title,
                        const std::vector<SeriesPanel>& panels) {
  static constexpr std::array<const char*, 6> kColours{"#1f3b73", "#b5532b", "#2e7d32",
                                                       "#6a1b9a", "#00838f", "#5d4037"};
  std::string s = fmt::format(
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key top left font ',9'\n{}set multiplot layout {},1 title \"{} along {}\"\n",
      r.options.axis.log ? "set logscale x\n" : "", panels.size(), title, r.options.axis.key);
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const SeriesPanel& panel = panels[k];
    // Each series' colour and legend: its group's (the first series of a group carries the
    // title), else its own.
    std::vector<std::string> keys;
    std::vector<std::size_t> colour(panel.series.size());
    std::vector<bool> titled(panel.series.size());
    for (std::size_t m = 0; m < panel.series.size(); ++m) {
      const std::string key = m < panel.groups.size() && !panel.groups[m].empty()
                                  ? panel.groups[m]
                                  : "\x01" + panel.series[m].first;
      const auto at = std::find(keys.begin(), keys.end(), key);
      colour[m] = static_cast<std::size_t>(at - keys.begin());
      titled[m] = at == keys.end();
      if (titled[m]) keys.push_back(key);
    }
    // A long legend beside the graph, not over its curves.
    fmt::format_to(std::back_inserter(s),
                   "set key {} font ',9'\nset autoscale y\nset format y '% h'\n{}set xlabel "
                   "'{}'\nset ylabel '{}'\nplot ",
                   keys.size() > kLegendInside ? "outside right top" : "top left", panel.settings,
                   k + 1 == panels.size() ? key_label(r.options.axis.key) : "", panel.ylabel);
    bool first = true;
    for (SweepDirection d : {SweepDirection::kUp, SweepDirection::kDown}) {
      if (std::none_of(r.points.begin(), r.points.end(),
                       [&](const SweepPoint& p) { return p.direction == d; }))
        continue;
      const bool up = d == SweepDirection::kUp;
      for (std::size_t m = 0; m < panel.series.size(); ++m) {
        const auto& [column, label] = panel.series[m];
        const std::string& shown =
            m < panel.groups.size() && !panel.groups[m].empty() ? panel.groups[m] : label;
        fmt::format_to(std::back_inserter(s),
                       "{}'sweep.csv' every ::1 using {}:(strcol({}) eq '{}' ? ${} : NaN) with "
                       "linespoints dt {} pt {} ps 0.4 lc rgb '{}' {}",
                       first ? "" : ", \\\n     ", sweep_csv_column(r, "value"),
                       sweep_csv_column(r, "direction"), to_string(d), sweep_csv_column(r, column),
                       up ? 1 : 2, up ? 7 : 6, kColours[colour[m] % kColours.size()],
                       titled[m] ? fmt::format("title '{}: {}'", to_string(d), shown) : "notitle");
        first = false;
      }
    }
    s += "\n";
  }
  return s + "unset multiplot\n";
}

// A train's meshes along the key, each a curve, up and down: the peak-to-peak (d - e) / b, the
// dynamic factor, and in a third panel the impacts per system period where any occurred.
std::string mesh_responses_body(const SweepResult& r) {
  // A load-sharing group's meshes (a set's identical planets') are one legend entry.
  std::vector<std::string> group(r.meshes.size());
  for (const LoadSharingGroup& g : r.load_sharing)
    for (const std::size_t m : g.meshes)
      if (m < group.size() && group[m].empty())
        group[m] = fmt::format("{} meshes of {}", g.meshes.size(), g.gear);
  const auto per_mesh = [&](const char* ylabel, const char* column) {
    SeriesPanel p{ylabel, {}, group, {}};
    for (const std::string& m : r.meshes) p.series.emplace_back(m + "_" + column, m);
    return p;
  };
  std::vector<SeriesPanel> panels{per_mesh("peak-to-peak (d - e) / b", "pp_delta_bar"),
                                  per_mesh("dynamic factor", "dynamic_factor")};
  const bool impacts = std::any_of(r.points.begin(), r.points.end(), [](const SweepPoint& p) {
    return std::any_of(p.meshes.begin(), p.meshes.end(),
                       [](const MeshReading& m) { return m.impacts_per_period > 0; });
  });
  if (impacts) panels.push_back(per_mesh("impacts per system period", "impacts_per_period"));
  if (!r.load_sharing.empty()) {
    // A factor is 1 when the meshes share equally: its axis from 1 to at least 1.01, with the
    // digits that tell its values apart (near 1, autoscaling read rounding noise, "1 1 1 1").
    double most = 1;
    for (const SweepPoint& p : r.points)
      for (const LoadSharingReading& x : p.load_sharing)
        if (std::isfinite(x.factor)) most = std::max(most, x.factor);
    const double top = std::max(1.01, 1 + 1.1 * (most - 1));
    SeriesPanel p{"load-sharing factor",
                  {},
                  {},
                  fmt::format("set yrange [0.999:{}]\nset format y '%.3f'\n", top)};
    for (const LoadSharingGroup& g : r.load_sharing)
      p.series.emplace_back(g.label + "_load_sharing_factor", g.label);
    panels.push_back(std::move(p));
  }
  return series_body(r, "each mesh", panels);
}

// A train's shafts and bearings along the key, up and down, one panel per kind of quantity that
// some point loads (a quantity's largest magnitude; one that stays 0, as a spur pair's axial
// force, is left out): the bearings' forces in the plane (x, y), their axial forces, their
// moments, the shafts' torques; and the impacts per system period in each bearing clearance.
std::string part_forces_body(const SweepResult& r) {
  const auto loaded = [&](std::size_t i) {
    return std::any_of(r.points.begin(), r.points.end(), [&](const SweepPoint& p) {
      return i < p.parts.size() && std::isfinite(p.parts[i].peak) && p.parts[i].peak > 0;
    });
  };
  struct Kind {
    const char* ylabel;
    std::vector<const char*> whats;
  };
  static const std::array<Kind, 4> kKinds{
      {{"largest bearing force (N)", {"force_x_n", "force_y_n"}},
       {"largest axial force (N)", {"axial_force_n"}},
       {"largest moment (N m)", {"moment_x_nm", "moment_y_nm"}},
       {"largest shaft torque (N m)", {"torque_nm"}}}};
  // A planet's copies of an element (its name and 1 to N, N the planets of a load-sharing
  // group, as the set writes them) are one legend entry, as the planets' meshes are: the stem,
  // or "" for a part that is no such copy.
  std::size_t planets = 0;
  for (const LoadSharingGroup& g : r.load_sharing) planets = std::max(planets, g.meshes.size());
  const auto stem_of = [&](const std::string& part) {
    const std::size_t end = part.find_last_not_of("0123456789");
    if (planets < 2 || end == std::string::npos || end + 1 == part.size()) return std::string();
    std::string stem = part.substr(0, end + 1);
    for (std::size_t k = 1; k <= planets; ++k)
      if (std::none_of(r.parts.begin(), r.parts.end(),
                       [&](const SweepPart& q) { return q.part == stem + std::to_string(k); }))
        return std::string();
    return stem;
  };
  std::vector<SeriesPanel> panels;
  for (const Kind& kind : kKinds) {
    SeriesPanel p{kind.ylabel, {}, {}, {}};
    for (std::size_t i = 0; i < r.parts.size(); ++i) {
      const SweepPart& q = r.parts[i];
      if (std::find_if(kind.whats.begin(), kind.whats.end(),
                       [&](const char* w) { return q.what == w; }) == kind.whats.end() ||
          !loaded(i))
        continue;
      p.series.emplace_back(q.peak_column(), q.label());
      const std::string stem = stem_of(q.part);
      p.groups.push_back(stem.empty() ? std::string()
                                      : fmt::format("{}1-{}_{}", stem, planets, q.what));
    }
    if (!p.series.empty()) panels.push_back(std::move(p));
  }
  if (!r.clearances.empty()) {
    SeriesPanel p{"impacts per period in the clearance", {}, {}, {}};
    for (const std::string& c : r.clearances) p.series.emplace_back(c + "_impacts_per_period", c);
    panels.push_back(std::move(p));
  }
  return series_body(r, "bearings and shafts", panels);
}

}  // namespace

std::vector<std::string> write_sweep(const std::filesystem::path& dir, const SweepResult& r,
                                     bool figures) {
  write_files_atomically(dir, {{"sweep.csv", sweep_csv(r)},
                               {"strobe.csv", strobe_csv(r, r.form)},
                               {"summary.json", summary(r)}});
  if (!figures || r.points.empty()) return {};
  std::vector<std::string> drawn{"frequency_response", "bifurcation"};
  const SweepOptions& o = r.options;
  const std::string xlog = o.axis.log ? "set logscale x\n" : "";
  const std::string preamble = "reset\nset encoding utf8\nset datafile separator ','\n";
  // Frequency response: rms F_bar and peak-to-peak delta_bar, up and down overlaid; the
  // unsettled points, the jumps and the hysteresis intervals marked where they occur.
  std::string fr = preamble + "set grid lc rgb '#dddddd'\nset key top left font ',9'\n" + xlog;
  fmt::format_to(std::back_inserter(fr), "set multiplot layout 2,1 title \"sweep of {}{}\"\n",
                 o.axis.key, r.mesh.empty() ? "" : ", mesh " + r.mesh);
  if (!o.axis2) {
    for (const Hysteresis& h : r.hysteresis)
      fmt::format_to(std::back_inserter(fr),
                     "set object rect from {}, graph 0 to {}, graph 1 behind fc rgb '#ececec' "
                     "fs solid 1.0 noborder\n",
                     h.from_value, h.to_value);
  }
  const auto col = [&](const char* name) { return sweep_csv_column(r, name); };
  const int c_direction = col("direction"), c_value = col("value"), c_settled = col("settled"),
            c_regime = col("regime");
  const auto curves = [&](int column, const char* label, bool arrows) {
    std::string out;
    if (arrows && !o.axis2)
      for (const Jump& j : r.jumps)
        fmt::format_to(std::back_inserter(out),
                       "set arrow from {}, {} to {}, {} head filled size screen 0.012,20 lw 1.5 "
                       "lc rgb '{}'\n",
                       j.from_value, j.before, j.to_value, j.after,
                       j.direction == SweepDirection::kUp ? "#1f3b73" : "#b5532b");
    out += "plot ";
    std::vector<std::string> parts;
    for (const char* d : {"up", "down"}) {
      const bool present = std::any_of(r.points.begin(), r.points.end(), [&](const SweepPoint& p) {
        return std::string(to_string(p.direction)) == d;
      });
      if (!present) continue;
      const bool up = std::string(d) == "up";
      parts.push_back(fmt::format(
          "'sweep.csv' every ::1 using {6}:(strcol({7}) eq '{0}' ? ${1} : NaN) with linespoints "
          "pt {2} ps {3} lc rgb '{4}' title '{0}: {5}'",
          d, column, up ? 7 : 6, up ? 0.4 : 0.5, up ? "#1f3b73" : "#b5532b", label, c_value,
          c_direction));
    }
    if (r.unsettled > 0)
      parts.push_back(fmt::format(
          "'sweep.csv' every ::1 using {}:(${} == 0 && strcol({}) ne 'failed' ? ${} : NaN) with "
          "points pt 2 ps 1.2 lc rgb 'black' title 'not settled'",
          c_value, c_settled, c_regime, column));
    if (arrows && !o.axis2 && !r.hysteresis.empty())
      parts.emplace_back(
          "NaN with boxes fs solid 1.0 fc rgb '#ececec' title 'up and down differ "
          "(hysteresis)'");
    if (arrows && !o.axis2 && !r.jumps.empty())
      parts.emplace_back("NaN with vectors lc rgb 'gray30' title 'jump'");
    for (std::size_t k = 0; k < parts.size(); ++k) out += (k ? ", \\\n     " : "") + parts[k];
    return out + "\nunset arrow\n";
  };
  fmt::format_to(std::back_inserter(fr), "set xlabel ''\nset ylabel 'F / (b·k_m)'\n{}",
                 curves(col("rms_force_bar"), "rms F/(b·k_m)", false));
  fmt::format_to(std::back_inserter(fr), "set xlabel '{}'\nset ylabel 'δ / b'\n{}",
                 key_label(o.axis.key), curves(col("pp_delta_bar"), "peak-to-peak δ/b", true));
  fr += "unset multiplot\n";
  render_figure(dir, "frequency_response", fr, 1000, 750);

  // Bifurcation diagram: the stroboscopic delta_bar at every point.
  std::string bi = preamble + "set grid lc rgb '#dddddd'\nset key top left font ',9'\n" + xlog;
  fmt::format_to(std::back_inserter(bi),
                 "set title 'bifurcation diagram: δ/b once per system period'\nset xlabel '{}'\n"
                 "set ylabel 'δ / b'\nplot ",
                 key_label(o.axis.key));
  bool first = true;
  for (SweepDirection d : {SweepDirection::kUp, SweepDirection::kDown}) {
    if (std::none_of(r.points.begin(), r.points.end(),
                     [&](const SweepPoint& p) { return p.direction == d; }))
      continue;
    fmt::format_to(std::back_inserter(bi),
                   "{}'strobe.csv' every ::1 using 2:(strcol(1) eq '{}' ? $5 : NaN) with points "
                   "pt 7 ps 0.3 lc rgb '{}' title '{}'",
                   first ? "" : ", \\\n     ", to_string(d),
                   d == SweepDirection::kUp ? "#1f3b73" : "#b5532b", to_string(d));
    first = false;
  }
  bi += "\n";
  render_figure(dir, "bifurcation", bi, 1000, 600);

  if (o.axis2) {
    render_figure(dir, "regime_map", regime_map_body(r), 1000, 600);
    drawn.emplace_back("regime_map");
  }
  if (!r.meshes.empty() && !o.axis2) {
    render_figure(dir, "mesh_responses", mesh_responses_body(r), 1000, 900);
    drawn.emplace_back("mesh_responses");
  }
  if (!r.parts.empty() && !o.axis2) {
    render_figure(dir, "part_forces", part_forces_body(r), 1000, 900);
    drawn.emplace_back("part_forces");
  }
  return drawn;
}

}  // namespace geardyn
