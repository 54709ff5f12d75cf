// The files and figures of a stability study (stability_output.hpp): stability.csv,
// boundaries.json and the figure of the largest multiplier or the chart of unstable regions.
#include "geardyn/stability_output.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "geardyn/case_keys.hpp"
#include "geardyn/figures.hpp"
#include "geardyn/output.hpp"

namespace geardyn {

std::string boundaries_json(const StabilityResult& r, bool chart) {
  nlohmann::json a = nlohmann::json::array();
  for (const StabilityBoundary& b : r.boundaries) {
    nlohmann::json j{{"param", b.param}, {"type", to_string(b.type)}};
    if (chart) j["param2"] = b.param2;
    a.push_back(j);
  }
  return nlohmann::json{{"boundaries", a}}.dump(2) + "\n";
}

void write_stability(const std::filesystem::path& dir, const StabilityResult& r,
                     const StabilityOptions& o, bool figures) {
  const bool chart = o.axis2.has_value();
  std::string csv = chart ? "param,param2," : "param,";
  csv += "stable,max_multiplier,mu1_re,mu1_im,mu2_re,mu2_im\n";
  for (const StabilitySample& s : r.samples) {
    fmt::format_to(std::back_inserter(csv), "{:.17g},", s.param);
    if (chart) fmt::format_to(std::back_inserter(csv), "{:.17g},", s.param2);
    fmt::format_to(std::back_inserter(csv), "{},{:.17g}", s.stable ? 1 : 0, s.max_multiplier);
    for (std::size_t i = 0; i < 2; ++i) {
      const std::complex<double> m = i < s.multipliers.size() ? s.multipliers[i] : 0.0;
      fmt::format_to(std::back_inserter(csv), ",{:.17g},{:.17g}", m.real(), m.imag());
    }
    csv += "\n";
  }
  std::string marks = chart ? "param,param2,type\n" : "param,type\n";
  for (const StabilityBoundary& b : r.boundaries) {
    if (chart)
      fmt::format_to(std::back_inserter(marks), "{:.17g},{:.17g},{}\n", b.param, b.param2,
                     to_string(b.type));
    else
      fmt::format_to(std::back_inserter(marks), "{:.17g},{}\n", b.param, to_string(b.type));
  }
  write_files_atomically(dir, {{"stability.csv", csv},
                               {"boundaries.json", boundaries_json(r, chart)},
                               {"boundaries.csv", marks}});
  if (!figures || r.samples.empty()) return;
  std::string body =
      "reset\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key top left font ',9' opaque box\n";
  if (o.axis.log) body += "set logscale x\n";
  const bool any_boundary = !r.boundaries.empty();
  if (!chart) {
    fmt::format_to(std::back_inserter(body),
                   "set title 'Floquet stability in permanent contact'\nset xlabel '{}'\n"
                   "set ylabel 'largest |multiplier|'\n"
                   "plot 'stability.csv' every ::1 using 1:3 with lines lw 2 lc rgb '#1f3b73' "
                   "title 'max |mu|', 1 with lines dt 2 lc rgb 'gray' notitle",
                   o.axis.key);
    if (any_boundary)
      body +=
          ", \\\n     'boundaries.csv' every ::1 using 1:(1) with points pt 7 ps 1.1 lc rgb "
          "'#b5532b' title 'boundary'";
    body += "\n";
  } else {
    if (o.axis2->log) body += "set logscale y\n";
    fmt::format_to(std::back_inserter(body),
                   "set title 'instability regions in permanent contact (colour: log10 max "
                   "|mu| where above 1)'\nset xlabel '{}'\nset ylabel '{}'\n"
                   "set palette defined (0 'white', 1 '#f2b8a0', 2 '#b5532b')\nset cbrange [0:*]\n"
                   "plot 'stability.csv' every ::1 using 1:2:($3 == 1 ? 0 : log10($4)) with "
                   "points pt 5 ps 0.6 lc palette notitle",
                   o.axis.key, o.axis2->key);
    if (any_boundary)
      body +=
          ", \\\n     'boundaries.csv' every ::1 using 1:2 with points pt 7 ps 0.4 lc rgb "
          "'black' title 'boundary'";
    body += "\n";
  }
  render_figure(dir, "stability", body, 1000, 600);
}

}  // namespace geardyn
