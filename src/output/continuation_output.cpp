// The files and figures of a continuation (continuation_output.hpp): branch.csv,
// bifurcations.json and .csv, a sweep's points to overlay, and the branch figure.
#include "geardyn/continuation_output.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "geardyn/case_keys.hpp"
#include "geardyn/figures.hpp"
#include "geardyn/output.hpp"

namespace geardyn {

std::string branch_csv(const ContinuationResult& r) {
  std::string s =
      "param,stable,x_a,min_delta_bar,max_delta_bar,max_force_bar,impacts_per_period,"
      "max_multiplier,min_force_bar,backside_impacts_per_period,separations_per_period";
  for (const std::string& name : r.state_names) s += "," + name;
  s += ",mu1_re,mu1_im,mu2_re,mu2_im,branch,periods\n";
  for (const BranchPoint& p : r.points) {
    const BranchOrbit& o = p.orbit;
    const RunReading& x = o.reading;
    fmt::format_to(std::back_inserter(s), "{:.17g},{},{:.17g},{:.17g},{:.17g},{:.17g},{},{:.17g},",
                   p.param, o.stable ? 1 : 0, p.amplitude(), x.min_delta_bar, x.max_delta_bar,
                   x.max_force_bar, x.impacts, o.max_multiplier());
    fmt::format_to(std::back_inserter(s), "{:.17g},{},{}", x.min_force_bar, x.backside_impacts,
                   x.separations);
    for (const double y : o.state) fmt::format_to(std::back_inserter(s), ",{:.17g}", y);
    for (std::size_t i = 0; i < 2; ++i) {
      const std::complex<double> m = i < o.multipliers.size() ? o.multipliers[i] : 0.0;
      fmt::format_to(std::back_inserter(s), ",{:.17g},{:.17g}", m.real(), m.imag());
    }
    fmt::format_to(std::back_inserter(s), ",{},{}\n", p.branch, p.periods);
  }
  return s;
}

std::string bifurcations_json(const ContinuationResult& r) {
  nlohmann::json a = nlohmann::json::array();
  for (const Bifurcation& b : r.bifurcations) {
    nlohmann::json mu = nlohmann::json::array();
    for (const auto& m : b.orbit.multipliers) mu.push_back({m.real(), m.imag()});
    a.push_back({{"type", to_string(b.type)},
                 {"param", b.param},
                 {"branch", b.branch},
                 {"detail", b.detail},
                 {"x_a", 0.5 * (b.orbit.reading.max_delta_bar - b.orbit.reading.min_delta_bar)},
                 {"impacts_per_period", b.orbit.reading.impacts},
                 {"state", std::vector<double>(b.orbit.state.begin(), b.orbit.state.end())},
                 {"floquet_multipliers", mu}});
    if (!r.mesh.empty()) a.back()["mesh"] = r.mesh;  // whose x_a and impacts these are
  }
  return a.dump(2) + "\n";
}

namespace {

// overlay.csv (direction,value,x_a) from a sweep.csv's direction, value and pp_delta_bar.
std::string sweep_overlay(const std::string& sweep_csv) {
  std::istringstream in(sweep_csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  {
    std::istringstream h(line);
    for (std::string cell; std::getline(h, cell, ',');) header.push_back(cell);
  }
  const auto column = [&](const char* name) {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end())
      throw InputError(fmt::format(
          "--overlay-sweep: the sweep file has no column {} (is it a geardyn sweep.csv?)", name));
    return static_cast<std::size_t>(it - header.begin());
  };
  const std::size_t cd = column("direction"), cv = column("value"), cp = column("pp_delta_bar");
  std::string out = "direction,value,x_a\n";
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    if (cells.size() <= std::max({cd, cv, cp})) continue;
    fmt::format_to(std::back_inserter(out), "{},{},{:.10g}\n", cells[cd], cells[cv],
                   0.5 * std::strtod(cells[cp].c_str(), nullptr));
  }
  return out;
}

}  // namespace

void write_continuation(const std::filesystem::path& dir, const ContinuationResult& r,
                        const std::string& key, bool figures, const std::string& sweep_csv) {
  const std::string overlay = sweep_csv.empty() ? std::string{} : sweep_overlay(sweep_csv);
  std::string marks = "param,x_a,type\n";
  for (const Bifurcation& b : r.bifurcations)
    fmt::format_to(std::back_inserter(marks), "{:.17g},{:.17g},{}\n", b.param,
                   0.5 * (b.orbit.reading.max_delta_bar - b.orbit.reading.min_delta_bar),
                   to_string(b.type));
  std::vector<std::pair<std::string, std::string>> files{
      {"branch.csv", branch_csv(r)},
      {"bifurcations.json", bifurcations_json(r)},
      {"bifurcations.csv", marks}};
  if (!overlay.empty()) files.emplace_back("overlay.csv", overlay);
  write_files_atomically(dir, files);
  if (!figures || r.points.empty()) return;
  // Only what happened: a curve per branch and stability found, a mark per type found.
  std::vector<std::string> plots;
  int branches = 0;
  for (const BranchPoint& p : r.points) branches = std::max(branches, p.branch + 1);
  // One curve per branch and stability (each period-doubled branch in another colour). With
  // one branch the key reads stable and unstable; with more, each names its period, once.
  std::vector<std::string> titles;
  // branch.csv's column of the branch (1-based): after the 11 readings, the state and the 4
  // multiplier columns.
  const std::size_t branch_column = 11 + r.state_names.size() + 4 + 1;
  const char* const colours[] = {"#1f3b73", "#4a8f3c", "#b5532b", "#7a1f7a"};
  for (int b = 0; b < branches; ++b) {
    const char* colour = colours[static_cast<std::size_t>(b) % std::size(colours)];
    for (const int stable : {1, 0}) {
      const auto first = std::find_if(r.points.begin(), r.points.end(), [&](const BranchPoint& p) {
        return p.branch == b && p.orbit.stable == (stable == 1);
      });
      if (first == r.points.end()) continue;
      const char* stability = stable ? "stable" : "unstable";
      std::string title = branches == 1 ? std::string(stability)
                                        : fmt::format("period {}, {}", first->periods, stability);
      const bool repeated = std::find(titles.begin(), titles.end(), title) != titles.end();
      titles.push_back(title);
      plots.push_back(fmt::format(
          "'branch.csv' every ::1 using 1:(${5} == {0} && $2 == {1} ? $3 : NaN) with lines lw 2 "
          "{2}lc rgb '{3}' {4}",
          b, stable, stable ? "" : "dt 2 ", colour,
          repeated ? std::string("notitle") : fmt::format("title '{}'", title), branch_column));
    }
  }
  const std::pair<BifurcationType, const char*> styles[] = {
      {BifurcationType::kFold, "pt 5 ps 1.3 lc rgb 'black'"},
      {BifurcationType::kBranchPoint, "pt 4 ps 1.3 lc rgb 'black'"},
      {BifurcationType::kPeriodDoubling, "pt 9 ps 1.5 lc rgb '#7a1f7a'"},
      {BifurcationType::kNeimarkSacker, "pt 11 ps 1.5 lc rgb '#1f7a3b'"},
      {BifurcationType::kGrazing, "pt 7 ps 1.1 lc rgb '#c08a00'"}};
  for (const auto& style : styles) {
    const BifurcationType type = style.first;
    const bool found = std::any_of(r.bifurcations.begin(), r.bifurcations.end(),
                                   [type](const Bifurcation& b) { return b.type == type; });
    if (found)
      plots.push_back(fmt::format(
          "'bifurcations.csv' every ::1 using 1:(strcol(3) eq '{0}' ? $2 : NaN) with points {1} "
          "title '{0}'",
          to_string(type), style.second));
  }
  for (const char* direction : {"up", "down"}) {
    if (overlay.find(std::string("\n") + direction + ",") == std::string::npos) continue;
    plots.push_back(fmt::format(
        "'overlay.csv' every ::1 using 2:(strcol(1) eq '{0}' ? $3 : NaN) with points pt {1} ps "
        "0.9 lc rgb '{2}' title 'sweep {0}'",
        direction, std::string(direction) == "up" ? 6 : 8,
        std::string(direction) == "up" ? "#555555" : "#b5532b"));
  }
  std::string body =
      "reset\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key outside right top font ',9'\n";
  fmt::format_to(std::back_inserter(body),
                 "set title 'periodic orbits: amplitude along {0}'\nset xlabel '{0}'\n"
                 "set ylabel 'x_a = (max - min)/2 of delta / b'\nplot ",
                 key);
  for (std::size_t i = 0; i < plots.size(); ++i) body += (i ? ", \\\n     " : "") + plots[i];
  body += "\n";
  render_figure(dir, "branch", body, 1000, 600);
}

}  // namespace geardyn
