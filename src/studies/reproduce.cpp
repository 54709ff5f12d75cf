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

}  // namespace geardyn
