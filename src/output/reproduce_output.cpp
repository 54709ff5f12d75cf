// The report of a reproduced study (reproduce_output.hpp): its headline, Markdown and HTML, and
// the output set of its files, runs and figures.
#include "geardyn/reproduce_output.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/figures.hpp"
#include "geardyn/output.hpp"
#include "geardyn/output_folder.hpp"
#include "geardyn/parallel.hpp"

namespace geardyn {
namespace {

namespace fs = std::filesystem;

std::string windows_ms(const WindowSet& set) {
  if (set.empty()) return "no window";
  std::string out;
  for (const auto& [a, b] : set)
    out += fmt::format("{}{:.2f}-{:.2f} ms", out.empty() ? "" : ", ", a * 1e3, b * 1e3);
  return out;
}

std::string ms(const std::optional<double>& t_s) {
  return t_s ? fmt::format("{:.2f}", *t_s * 1e3) : std::string("none");
}

}  // namespace

namespace {

struct Row {
  std::string id, conditions, regime, impacts, backside, last_sep, separated, peak_force, paper,
      holds, long_window, windows;
};

std::vector<Row> table_rows(const StudyResult& r) {
  std::vector<Row> rows;
  for (const CaseOutcome& o : r.outcomes) {
    const Case& c = o.spec.input;
    const RunReading& x = o.run.reading;
    Row row;
    row.id = fmt::format("{} {}", o.spec.figure, o.spec.panel);
    row.conditions =
        fmt::format("f_1 = {} Hz, b = {} um, xi = {}, F_a/F_m = {}", c.speed.shaft_frequency_hz,
                    c.mesh.backlash_um, c.mesh.damping_ratio, c.load.fluctuation_ratio);
    row.regime = to_string(x.regime);
    row.impacts = std::to_string(x.impacts);
    row.backside = std::to_string(x.backside_impacts);
    row.last_sep = ms(x.last_separation_s);
    row.separated = fmt::format("{:.1f} %", 100 * x.separated_fraction);
    row.peak_force = fmt::format("{:.3f}", x.max_force_bar);
    row.paper = fmt::format("{}; no back-side contact", o.spec.paper_finding);
    row.holds = o.holds ? "yes" : "no: " + o.difference;
    row.long_window = fmt::format("{}, last separation {} ms", to_string(o.long_window.regime),
                                  ms(o.long_window.last_separation_s));
    row.windows = windows_ms(o.holds_for);
    rows.push_back(std::move(row));
  }
  return rows;
}

std::map<std::string, std::vector<const CaseOutcome*>> by_figure(const StudyResult& r) {
  std::map<std::string, std::vector<const CaseOutcome*>> m;
  for (const CaseOutcome& o : r.outcomes) m[o.spec.figure].push_back(&o);
  return m;
}

std::string figure_file(const std::string& figure) {
  std::string f;
  for (char ch : figure)
    if (std::isalnum(static_cast<unsigned char>(ch))) f += static_cast<char>(std::tolower(ch));
  return f;  // "Fig. 4" -> "fig4"
}

// Sentences on the cases whose regime differs between the window and the long window.
std::vector<std::string> window_notes(const StudyResult& r) {
  std::vector<std::string> notes;
  for (const CaseOutcome& o : r.outcomes) {
    const Regime a = o.run.reading.regime, b = o.long_window.regime;
    if (a == b) continue;
    if (a == Regime::kSustained && b == Regime::kTransient) {
      notes.push_back(fmt::format(
          "{} {} ({}): the teeth still separate in the final part of the {} ms window but settle "
          "within {} ms (last separation at {} ms): under these assumptions its rattle is a long "
          "transient.",
          o.spec.figure, o.spec.panel, o.spec.label, r.study.window_s * 1e3,
          r.study.long_window_s * 1e3, ms(o.long_window.last_separation_s)));
    } else {
      notes.push_back(fmt::format("{} {} ({}): {} over {} ms, {} over {} ms.", o.spec.figure,
                                  o.spec.panel, o.spec.label, to_string(a), r.study.window_s * 1e3,
                                  to_string(b), r.study.long_window_s * 1e3));
    }
  }
  return notes;
}

std::size_t holding(const StudyResult& r) {
  std::size_t n = 0;
  for (const CaseOutcome& o : r.outcomes) n += o.holds;
  return n;
}

// The windows at which the report says how many findings hold.
std::vector<double> report_windows(const Study& s) {
  std::vector<double> w;
  for (double x : {0.01, 0.015, 0.02, 0.025, 0.03, 0.05, 0.075})
    if (x >= s.scan_from_s && x < s.long_window_s) w.push_back(x);
  return w;
}

}  // namespace

std::size_t holding_at(const StudyResult& r, double window_s) {
  std::size_t n = 0;
  for (const CaseOutcome& o : r.outcomes) n += contains(o.holds_for, window_s);
  return n;
}

std::string study_headline(const StudyResult& r) {
  const Study& s = r.study;
  std::string counts;
  for (double w : report_windows(s))
    counts += fmt::format("{}{} at {:g} ms", counts.empty() ? "" : ", ", holding_at(r, w), w * 1e3);
  return fmt::format(
      "{} of the {} findings hold over the {:g} ms window used. How that depends on the window "
      "(every window from {:g} to {:g} ms scanned): all {} hold together for {}; {} of {}.",
      holding(r), r.outcomes.size(), s.window_s * 1e3, s.scan_from_s * 1e3, s.long_window_s * 1e3,
      r.outcomes.size(), windows_ms(r.all_hold), counts, r.outcomes.size());
}

namespace {}  // namespace

std::string report_markdown(const StudyResult& r) {
  const Study& s = r.study;
  std::string md;
  fmt::format_to(std::back_inserter(md), "# {}\n\n", s.title);
  fmt::format_to(std::back_inserter(md),
                 "Computed by `geardyn reproduce {}` in {:.2f} s on {} threads. {}\n\n", s.name,
                 r.wall_time_s, r.threads, study_headline(r));
  md += "## Assumptions\n\n";
  for (const std::string& a : s.assumptions) md += "- " + a + "\n";
  fmt::format_to(std::back_inserter(md), "- Window: {} ms. {}\n\n", s.window_s * 1e3,
                 s.window_reason);
  md += "## Results\n\n";
  fmt::format_to(std::back_inserter(md),
                 "| case | conditions | regime | impacts | back-side impacts | last separation "
                 "(ms) | separated | max F/(b k_m) | the paper | holds | over {} ms | holds "
                 "for windows |\n"
                 "|---|---|---|---|---|---|---|---|---|---|---|---|\n",
                 s.long_window_s * 1e3);
  for (const Row& x : table_rows(r))
    fmt::format_to(std::back_inserter(md),
                   "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", x.id,
                   x.conditions, x.regime, x.impacts, x.backside, x.last_sep, x.separated,
                   x.peak_force, x.paper, x.holds, x.long_window, x.windows);
  const std::vector<std::string> notes = window_notes(r);
  if (!notes.empty()) {
    md += "\nWhere the two windows disagree:\n\n";
    for (const std::string& n : notes) md += "- " + n + "\n";
  }
  md +=
      "\n## Figures\n\nEach panel: delta/b (left) and F/(b k_m) (right) over the window; "
      "separation shaded red, back-side contact blue, the backlash band |delta/b| < 1 grey "
      "between dashed contact surfaces.\n\n";
  for (const auto& [figure, cases] : by_figure(r))
    fmt::format_to(std::back_inserter(md), "### {}\n\n![{}]({}.png)\n\n", figure, figure,
                   figure_file(figure));
  return md;
}

std::string report_html(const StudyResult& r) {
  const Study& s = r.study;
  std::string h =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>" +
      html_escape(s.title) +
      "</title>\n<style>body{font-family:sans-serif;max-width:1250px;margin:2em auto;color:#222}"
      "table{border-collapse:collapse;font-size:90%}td,th{border:1px solid #bbb;padding:4px 6px;"
      "vertical-align:top}th{background:#eef1f7}.no{background:#fbe3e3}.yes{background:#e6f4e6}"
      "img{max-width:100%}</style></head><body>\n";
  fmt::format_to(std::back_inserter(h), "<h1>{}</h1>\n", html_escape(s.title));
  fmt::format_to(std::back_inserter(h),
                 "<p>Computed by <code>geardyn reproduce {}</code> in {:.2f} s on {} threads. "
                 "{}</p>\n",
                 s.name, r.wall_time_s, r.threads, html_escape(study_headline(r)));
  h += "<h2>Assumptions</h2>\n<ul>\n";
  for (const std::string& a : s.assumptions) h += "<li>" + html_escape(a) + "</li>\n";
  fmt::format_to(std::back_inserter(h), "<li>Window: {} ms. {}</li>\n</ul>\n", s.window_s * 1e3,
                 html_escape(s.window_reason));
  fmt::format_to(std::back_inserter(h),
                 "<h2>Results</h2>\n<table>\n<tr><th>case</th><th>conditions</th><th>regime</th>"
                 "<th>impacts</th><th>back-side impacts</th><th>last separation (ms)</th>"
                 "<th>separated</th><th>max F/(b k<sub>m</sub>)</th><th>the paper</th>"
                 "<th>holds</th><th>over {} ms</th><th>holds for windows</th></tr>\n",
                 s.long_window_s * 1e3);
  for (const Row& x : table_rows(r)) {
    const bool ok = x.holds == "yes";
    fmt::format_to(std::back_inserter(h),
                   "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
                   "<td>{}</td><td>{}</td><td>{}</td><td class=\"{}\">{}</td><td>{}</td>"
                   "<td>{}</td></tr>\n",
                   html_escape(x.id), html_escape(x.conditions), x.regime, x.impacts, x.backside,
                   x.last_sep, html_escape(x.separated), x.peak_force, html_escape(x.paper),
                   ok ? "yes" : "no", html_escape(x.holds), html_escape(x.long_window),
                   html_escape(x.windows));
  }
  h += "</table>\n";
  const std::vector<std::string> notes = window_notes(r);
  if (!notes.empty()) {
    h += "<p>Where the two windows disagree:</p>\n<ul>\n";
    for (const std::string& n : notes) h += "<li>" + html_escape(n) + "</li>\n";
    h += "</ul>\n";
  }
  h += "<h2>Figures</h2>\n<p>Each panel: &delta;/b (left) and F/(b k<sub>m</sub>) "
       "(right); separation shaded red, back-side contact blue, the backlash band grey.</p>\n";
  for (const auto& [figure, cases] : by_figure(r))
    fmt::format_to(std::back_inserter(h), "<h3>{0}</h3>\n<img src=\"{1}.png\" alt=\"{0}\">\n",
                   html_escape(figure), figure_file(figure));
  h += "</body></html>\n";
  return h;
}

namespace {

void write_study_files(const fs::path& dir, const StudyResult& r, bool figures);

}  // namespace

void write_study(const fs::path& dir, const StudyResult& r, bool figures) {
  // One named set: only the study's own files are replaced, together; a figure that cannot be
  // drawn still lets the data in (exit 3 says so).
  write_set(dir, "reproduce " + r.study.name,
            [&](const fs::path& staging) { write_study_files(staging, r, figures); });
}

namespace {

void write_study_files(const fs::path& dir, const StudyResult& r, bool figures) {
  for (const CaseOutcome& o : r.outcomes) {
    const fs::path case_dir = dir / "cases" / o.spec.id;
    write_run(case_dir, o.run);
    write_files_atomically(case_dir, {{"intervals.csv", contact_intervals_csv(o.run)},
                                      {"plot.csv", plot_csv(o.run.samples)}});
  }
  nlohmann::json j;
  j["study"] = r.study.name;
  j["window_s"] = r.study.window_s;
  j["long_window_s"] = r.study.long_window_s;
  const auto windows = [](const WindowSet& set) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& [from, to] : set) a.push_back({from, to});
    return a;
  };
  j["window_scan_s"] = {r.study.scan_from_s, r.study.long_window_s};
  j["holding"] = holding(r);
  j["all_hold_windows_s"] = windows(r.all_hold);
  for (double w : report_windows(r.study))
    j["holding_at"].push_back({{"window_s", w}, {"holding", holding_at(r, w)}});
  j["wall_time_s"] = r.wall_time_s;
  j["threads"] = r.threads;
  for (const CaseOutcome& o : r.outcomes) {
    const RunReading& x = o.run.reading;
    j["cases"].push_back({
        {"id", o.spec.id},
        {"label", o.spec.label},
        {"regime", to_string(x.regime)},
        {"double_sided", x.double_sided},
        {"impacts", x.impacts},
        {"backside_impacts", x.backside_impacts},
        {"last_separation_s", x.last_separation_s ? nlohmann::json(*x.last_separation_s) : nullptr},
        {"separated_fraction", x.separated_fraction},
        {"max_force_bar", x.max_force_bar},
        {"paper_regime", to_string(o.spec.paper_regime)},
        {"paper_finding", o.spec.paper_finding},
        {"holds", o.holds},
        {"difference", o.difference},
        {"holds_for_windows_s", windows(o.holds_for)},
        {"long_window_regime", to_string(o.long_window.regime)},
        {"long_window_last_separation_s", o.long_window.last_separation_s
                                              ? nlohmann::json(*o.long_window.last_separation_s)
                                              : nullptr},
    });
  }
  write_files_atomically(dir, {{"report.md", report_markdown(r)},
                               {"report.html", report_html(r)},
                               {"study.json", j.dump(2) + "\n"}});
  if (!figures) return;
  // One gnuplot per paper figure, drawn concurrently.
  struct Drawing {
    std::string file, body;
    int height;
  };
  std::vector<Drawing> drawings;
  for (const auto& [figure, cases] : by_figure(r)) {
    std::vector<TimeHistoryPanel> panels;
    for (const CaseOutcome* o : cases)
      panels.push_back(run_panel(o->run, fmt::format("{} {}", o->spec.panel, o->spec.label),
                                 "cases/" + o->spec.id));
    const std::string title = fmt::format("{} ({})", figure, r.study.name);
    drawings.push_back({figure_file(figure), time_history_body(panels, false, title),
                        70 + 230 * static_cast<int>(panels.size())});
  }
  parallel_for(drawings.size(), 0, drawings.size(), {}, [&](std::size_t i, WorkTicker&) {
    render_figure(dir, drawings[i].file, drawings[i].body, 1200, drawings[i].height);
  });
}

}  // namespace

}  // namespace geardyn
