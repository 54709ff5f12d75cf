#include "geardyn/reproduce.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <stdexcept>

#include "geardyn/figures.hpp"
#include "geardyn/output.hpp"
#include "geardyn/parallel.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {
namespace {

namespace fs = std::filesystem;

// The paper gives no time axis. The contact transient decays with the time constant
// 1 / (xi omega_n) = 3.1 ms at xi = 0.02; 20 ms holds 6.5 of them and 52 contact periods.
constexpr double kWindowS = 0.02;
// Five times longer, to tell a long transient from a steady rattle.
constexpr double kLongWindowS = 0.1;
// The shortest window scanned: a tenth of the long one.
constexpr double kScanFromS = 0.01;

// Sorted, merged intervals.
WindowSet merged(WindowSet v) {
  std::sort(v.begin(), v.end());
  WindowSet out;
  for (const auto& [a, b] : v) {
    if (!(a < b)) continue;
    if (!out.empty() && a <= out.back().second)
      out.back().second = std::max(out.back().second, b);
    else
      out.emplace_back(a, b);
  }
  return out;
}

// [from, to) minus a set.
WindowSet complement(const WindowSet& set, double from, double to) {
  WindowSet out;
  double at = from;
  for (const auto& [a, b] : set) {
    if (b <= at) continue;
    if (a >= to) break;
    if (a > at) out.emplace_back(at, a);
    at = std::max(at, b);
  }
  if (at < to) out.emplace_back(at, to);
  return out;
}

WindowSet intersection(const WindowSet& x, const WindowSet& y) {
  WindowSet out;
  for (const auto& [a, b] : x)
    for (const auto& [c, d] : y)
      if (std::max(a, c) < std::min(b, d)) out.emplace_back(std::max(a, c), std::min(b, d));
  return merged(out);
}

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

std::string regime_words(Regime r) {
  switch (r) {
    case Regime::kNone:
      return "no separation";
    case Regime::kTransient:
      return "separation at first only";
    case Regime::kSustained:
      return "separation over the whole window";
  }
  return "?";
}

}  // namespace

Study park2010_study(const Case& base) {
  Study s;
  s.name = "park2010";
  s.title = "Park (2010), Figs. 4-6: helical gears with backlash under torque fluctuation";
  s.window_s = kWindowS;
  s.long_window_s = kLongWindowS;
  s.scan_from_s = kScanFromS;
  s.window_reason =
      "The paper's time axis is not in its text. Its findings separate rattle that stops "
      "'at first' from rattle 'over the whole time shown'; the contact transient decays with the "
      "time constant 1/(xi omega_n) = 3.1 ms at xi = 0.02, so a 20 ms window (6.5 time constants, "
      "52 contact periods) is where that difference shows. Every case is also run over 0.1 s, to "
      "tell a long transient from a steady rattle; that column is reported beside the paper's.";
  // Long items span lines as adjacent literals, which this check takes for a missing comma.
  // NOLINTBEGIN(bugprone-suspicious-missing-comma)
  s.assumptions = {
      "Gear data: Table 1 (m_n = 2.5 mm, alpha_n = 20 deg, beta = 20 deg, a = 150 mm, z = 56/56, "
      "b_w = 20 mm, x = 0.2075/0.2075, T1 = 49.5 N m, k_m = 2.34e8 N/m).",
      "Inertias (not in Table 1): solid steel cylinders of the reference diameter and the face "
      "width, density 7850 kg/m^3.",
      "Damping: c = 2 xi sqrt(m_eq k_m) / cos(beta_b), acting in contact only (eqs. 3a-3c); "
      "F_G may pull in contact (tension allowed), as the paper writes it.",
      "Torque fluctuation at the shaft frequency (order 1), phase 0; matched load (eq. 7).",
      "Initial conditions (eq. 15): delta = 0, delta' = 0, the middle of the backlash.",
      "Regime: 'sustained' when the teeth are separated at some time in the final 10 % of the "
      "window, 'transient' when they separate only before it.",
      "A finding holds when the regime and the absence of back-side contact agree with the "
      "paper; its remarks on amplitudes are quoted beside them but not tested.",
  };  // NOLINTEND(bugprone-suspicious-missing-comma)

  // The stiffness the runs use, in words, from the same computation the runs make.
  const MeshStiffness k = mesh_stiffness(base, compute_geometry(base.gear));
  std::string h;
  for (std::size_t i = 0; i < k.fourier.harmonics.size(); ++i)
    h += fmt::format("{}k_a{}/k_m = {:.4f}, phi_{} = {:.1f} deg", h.empty() ? "" : "; ", i + 1,
                     k.fourier.harmonics[i].ratio, i + 1, k.fourier.harmonics[i].phase_deg);
  if (h.empty()) h = "no harmonics (constant k_m)";
  const char* source =
      base.mesh.stiffness_source == StiffnessSource::kEnergy
          ? "computed from the gear data by the potential-energy slice method, "
            "its mean scaled to k_m as the paper did"
      : base.mesh.stiffness_source == StiffnessSource::kTable
          ? "from the table mesh.stiffness_table, its mean scaled to k_m"
      : base.mesh.stiffness_source == StiffnessSource::kIso6336
          ? "k_m from ISO 6336-1 Method B (c_gamma_alpha b), the harmonics as given"
          : "as given in the case";
  s.assumptions.push_back(fmt::format(
      "Mesh stiffness: k_m = {:.4g} N/m with {}; {}. The paper kept the mean and two harmonics "
      "of its own program's curve (Fig. 3) but does not print them.",
      k.fourier.mean_n_per_m, h, source));

  // The paper's conditions: b = 100 um, xi = 0.02, F_a/F_m = 0.25 unless a panel sets otherwise.
  Case paper_base = base;
  paper_base.mesh.backlash_um = 100;
  paper_base.mesh.damping_ratio = 0.02;
  paper_base.load.fluctuation_ratio = 0.25;
  constexpr auto kTransient = Regime::kTransient;
  constexpr auto kSustained = Regime::kSustained;
  // One row per panel: figure, panel, what varies, the settings that make it, the finding.
  struct Panel {
    int figure;
    char panel;
    const char* label;
    std::vector<Override> settings;
    Regime paper;
    const char* finding;
  };
  const char* kSettleF5 = "with xi = 0.07, separation at first only";
  const char* kGoOnF5 = "separation over the whole time despite xi = 0.07";
  const Panel panels[] = {
      {4,
       'a',
       "f_1 = 10 Hz",
       {{"speed.shaft_frequency_hz", "10"}},
       kTransient,
       "separation at first, then steady contact"},
      {4,
       'b',
       "f_1 = 100 Hz",
       {{"speed.shaft_frequency_hz", "100"}},
       kTransient,
       "separation at first, then steady contact"},
      {4,
       'c',
       "f_1 = 1000 Hz",
       {{"speed.shaft_frequency_hz", "1000"}},
       kSustained,
       "separation over the whole time, the vibration grows"},
      {4,
       'd',
       "f_1 = 10000 Hz",
       {{"speed.shaft_frequency_hz", "10000"}},
       kTransient,
       "separation at first only, then small vibration in mesh"},
      {5,
       'a',
       "F_a/F_m = 0.1",
       {{"speed.shaft_frequency_hz", "1000"},
        {"mesh.damping_ratio", "0.07"},
        {"load.fluctuation_ratio", "0.1"}},
       kTransient,
       kSettleF5},
      {5,
       'b',
       "F_a/F_m = 0.25",
       {{"speed.shaft_frequency_hz", "1000"},
        {"mesh.damping_ratio", "0.07"},
        {"load.fluctuation_ratio", "0.25"}},
       kTransient,
       kSettleF5},
      {5,
       'c',
       "F_a/F_m = 0.4",
       {{"speed.shaft_frequency_hz", "1000"},
        {"mesh.damping_ratio", "0.07"},
        {"load.fluctuation_ratio", "0.4"}},
       kSustained,
       kGoOnF5},
      {5,
       'd',
       "F_a/F_m = 0.55",
       {{"speed.shaft_frequency_hz", "1000"},
        {"mesh.damping_ratio", "0.07"},
        {"load.fluctuation_ratio", "0.55"}},
       kSustained,
       kGoOnF5},
      {6,
       'a',
       "b = 50 um",
       {{"speed.shaft_frequency_hz", "100"}, {"mesh.backlash_um", "50"}},
       kTransient,
       "separation at first only"},
      {6,
       'b',
       "b = 150 um",
       {{"speed.shaft_frequency_hz", "100"}, {"mesh.backlash_um", "150"}},
       kSustained,
       "separation over the whole time, smaller forces"},
      {6,
       'c',
       "b = 200 um",
       {{"speed.shaft_frequency_hz", "100"}, {"mesh.backlash_um", "200"}},
       kSustained,
       "separation over the whole time, smaller forces"},
  };
  for (const Panel& p : panels) {
    Case c = paper_base;
    for (const Override& o : p.settings) set_case_value(c, o);
    const std::string id = fmt::format("fig{}{}", p.figure, p.panel);
    c.name = id;
    c.solver.duration_s = kWindowS;
    s.cases.push_back({id, fmt::format("Fig. {}", p.figure), fmt::format("({})", p.panel), p.label,
                       std::move(c), p.paper, false, p.finding});
  }
  return s;
}

WindowSet finding_windows(const StudyCase& spec, const RunResult& long_run, double from_s,
                          double to_s) {
  const double kept = 1.0 - spec.input.solver.final_fraction;
  // The separated intervals [start, end) of the long run, from its start state and its events.
  WindowSet sustained;
  std::optional<double> open;
  if (spec.input.solver.initial == InitialCondition::kCenter) open = 0.0;  // mid-backlash
  std::optional<double> backside;
  for (const ContactEvent& e : long_run.events) {
    if (e.kind == EventKind::kSeparation) {
      open = e.t_s;
    } else {
      if (e.kind == EventKind::kBacksideImpact && !backside) backside = e.t_s;
      if (open) sustained.emplace_back(*open, e.t_s / kept);
      open.reset();
    }
  }
  if (open) sustained.emplace_back(*open, std::numeric_limits<double>::infinity());
  sustained = merged(sustained);
  // Regime per window: sustained on `sustained`; otherwise transient when anything separated
  // before the window ends, none when nothing did.
  WindowSet regime_holds;
  if (spec.paper_regime == Regime::kSustained) {
    regime_holds = intersection(sustained, {{from_s, to_s}});
  } else {
    const WindowSet not_sustained = complement(sustained, from_s, to_s);
    const double first =
        sustained.empty() ? std::numeric_limits<double>::infinity() : sustained.front().first;
    // A separation starting at `first` makes a window of length > first at least transient.
    regime_holds = spec.paper_regime == Regime::kTransient
                       ? intersection(not_sustained, {{first, to_s}})
                       : intersection(not_sustained, {{from_s, first}});
  }
  // Back-side contact from its first impact on.
  const double b = backside ? *backside : std::numeric_limits<double>::infinity();
  const WindowSet sides = spec.paper_double_sided ? WindowSet{{b, to_s}} : WindowSet{{from_s, b}};
  return intersection(regime_holds, sides);
}

bool contains(const WindowSet& set, double window_s) {
  return std::any_of(set.begin(), set.end(),
                     [&](const auto& w) { return w.first <= window_s && window_s < w.second; });
}

StudyResult run_study(const Study& study, unsigned threads,
                      const std::function<void(std::size_t, std::size_t)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  StudyResult out;
  out.study = study;
  out.outcomes.resize(study.cases.size());
  const std::function<bool(std::size_t, std::size_t)> report = [&progress](std::size_t done,
                                                                           std::size_t total) {
    if (progress) progress(done, total);
    return true;
  };
  out.threads =
      parallel_for(
          study.cases.size(), threads, study.cases.size(), report,
          [&](std::size_t i, WorkTicker& ticker) {
            const StudyCase& spec = study.cases[i];
            CaseOutcome& o = out.outcomes[i];
            o.spec = spec;
            o.run = run(spec.input);
            if (!o.run.integration.ok())
              throw std::runtime_error(fmt::format("case {}: numerical failure ({}): {}", spec.id,
                                                   ode::to_string(o.run.integration.termination),
                                                   o.run.integration.message));
            Case longer = spec.input;
            longer.solver.duration_s = study.long_window_s;
            RunOptions quiet;
            quiet.keep_samples = false;
            const RunResult lr = run(longer, quiet);
            if (!lr.integration.ok())
              throw std::runtime_error(fmt::format("case {} over {} s: numerical failure: {}",
                                                   spec.id, study.long_window_s,
                                                   lr.integration.message));
            o.long_window = lr.reading;
            o.holds_for = finding_windows(spec, lr, study.scan_from_s, study.long_window_s);
            const RunReading& x = o.run.reading;
            std::vector<std::string> diffs;
            if (x.regime != spec.paper_regime)
              diffs.push_back(fmt::format("{} (the paper: {})", regime_words(x.regime),
                                          regime_words(spec.paper_regime)));
            if (x.double_sided != spec.paper_double_sided)
              diffs.push_back(x.double_sided ? "back-side contact occurs (the paper: none)"
                                             : "no back-side contact (the paper: some)");
            o.holds = diffs.empty();
            for (const std::string& d : diffs)
              o.difference += (o.difference.empty() ? "" : "; ") + d;
            ticker.tick();
          })
          .threads;
  out.all_hold = {{study.scan_from_s, study.long_window_s}};
  for (const CaseOutcome& o : out.outcomes) out.all_hold = intersection(out.all_hold, o.holds_for);
  out.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

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
