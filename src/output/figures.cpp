#include "geardyn/figures.hpp"

#include <fmt/format.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "geardyn/output.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {
namespace {

namespace fs = std::filesystem;

// Colours shared by every figure.
constexpr const char* kSeparatedColour = "#f4a6a6";
constexpr const char* kBackColour = "#9cc3f0";
// Neutral: the backlash band is neither contact side.
constexpr const char* kBandColour = "#f0f0f0";
constexpr const char* kLineColour = "#1f3b73";
constexpr const char* kSecondColour = "#b5532b";

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string panel_plot(const TimeHistoryPanel& p, int column, const std::string& ylabel,
                       bool show_xlabel) {
  const bool physical = p.backlash_um > 0;
  // The column as plotted, and the contact surfaces delta = +-b in the same units.
  const double scale = !physical ? 1.0 : column == 2 ? p.backlash_um : p.force_scale_n;
  const double edge = physical ? p.backlash_um : 1.0;
  const std::string y = fmt::format("(${}*{})", column, scale);
  const std::string dir = p.data_dir.empty() ? "" : p.data_dir + "/";
  const std::string ts = dir + "plot.csv", iv = dir + "intervals.csv";
  std::string s;
  fmt::format_to(std::back_inserter(s), "set title \"{}\"\n", p.title);
  // Times on the axis: ms, or tau as it is in the non-dimensional form.
  const double to_axis = p.time_in_tau ? 1.0 : 1e3;
  fmt::format_to(std::back_inserter(s), "set xrange [0:{}]\n", p.window_s * to_axis);
  fmt::format_to(std::back_inserter(s), "set xlabel \"{}\"\n",
                 show_xlabel ? (p.time_in_tau ? "τ" : "t (ms)") : "");
  fmt::format_to(std::back_inserter(s), "set ylabel \"{}\"\n", ylabel);
  fmt::format_to(std::back_inserter(s),
                 "set autoscale y\n"
                 "stats '{0}' every ::1 using {1} name 'S' nooutput\n"
                 "pad = 0.08 * (S_max - S_min) + 1e-9\n"
                 "ylo = S_min - pad; yhi = S_max + pad\n"
                 "set yrange [ylo:yhi]\n",
                 ts, y);
  if (column == 2) {
    // The backlash band |delta / b| < 1 (its edges, the contact surfaces, are plotted below).
    fmt::format_to(std::back_inserter(s),
                   "set object 1 rect from graph 0, first {1} to graph 1, first {2} back "
                   "fc rgb '{0}' fs solid 1.0 noborder\n",
                   kBandColour, -edge, edge);
  }
  fmt::format_to(
      std::back_inserter(s),
      "plot '{0}' every ::1 using (($1+$2)*{9}/2):(0):($1*{9}):($2*{9}):(($3==0)?ylo:NaN):"
      "(($3==0)?yhi:NaN) with boxxyerror fs solid 0.5 noborder lc rgb '{2}' {7}, \\\n"
      "     '{0}' every ::1 using (($1+$2)*{9}/2):(0):($1*{9}):($2*{9}):(($3==-1)?ylo:NaN):"
      "(($3==-1)?yhi:NaN) with boxxyerror fs solid 0.5 noborder lc rgb '{3}' {8}, "
      "\\\n"
      "     '{1}' every ::1 using ($1*{9}):{4} with lines lw 1.1 lc rgb '{5}' notitle{6}\n",
      iv, ts, kSeparatedColour, kBackColour, y, kLineColour,
      column == 2 ? fmt::format(", \\\n     {0} with lines dt 2 lc rgb 'gray30' notitle, {1} "
                                "with lines dt 2 lc rgb 'gray30' notitle",
                                edge, -edge)
                  : std::string(),
      p.separated ? "title 'separated'" : "notitle",
      p.back_side ? "title 'back-side contact'" : "notitle", to_axis);
  if (column == 2) s += "unset object 1\n";
  return s;
}

}  // namespace

std::string plot_csv(const Timeseries& s) {
  std::string out = "t_s,delta_bar,force_bar\n";
  const std::size_t n = s.size();
  if (n <= kMaxPlotPoints) {
    for (std::size_t i = 0; i < n; ++i)
      fmt::format_to(std::back_inserter(out), "{:.10g},{:.8g},{:.8g}\n", s.t_s[i], s.delta_bar[i],
                     s.force_bar[i]);
    return out;
  }
  const std::size_t buckets = kMaxPlotPoints / 2;
  for (std::size_t b = 0; b < buckets; ++b) {
    const std::size_t lo = b * n / buckets, hi = (b + 1) * n / buckets;
    const auto [dmin, dmax] =
        std::minmax_element(s.delta_bar.begin() + lo, s.delta_bar.begin() + hi);
    const auto [fmin, fmax] =
        std::minmax_element(s.force_bar.begin() + lo, s.force_bar.begin() + hi);
    const double t_mid = s.t_s[(lo + hi) / 2];
    fmt::format_to(std::back_inserter(out), "{:.10g},{:.8g},{:.8g}\n{:.10g},{:.8g},{:.8g}\n",
                   s.t_s[lo], *dmin, *fmin, t_mid, *dmax, *fmax);
  }
  return out;
}

namespace {
// The minima and the maxima, column by column, of columns(k) for k in [from, to) (to > from).
std::pair<std::vector<double>, std::vector<double>> envelope(
    const std::function<std::vector<double>(std::size_t)>& columns, std::size_t from,
    std::size_t to) {
  std::vector<double> low = columns(from), high = low;
  for (std::size_t k = from + 1; k < to; ++k) {
    const std::vector<double> v = columns(k);
    for (std::size_t c = 0; c < v.size(); ++c) {
      low[c] = std::min(low[c], v[c]);
      high[c] = std::max(high[c], v[c]);
    }
  }
  return {low, high};
}
}  // namespace

std::string decimated_csv(const std::string& header, std::size_t n,
                          const std::function<double(std::size_t)>& t_ms,
                          const std::function<std::vector<double>(std::size_t)>& columns) {
  std::string out = header;
  const auto row = [&](double t, const std::vector<double>& v) {
    fmt::format_to(std::back_inserter(out), "{:.10g}", t);
    for (double x : v) fmt::format_to(std::back_inserter(out), ",{:.8g}", x);
    out += "\n";
  };
  if (n <= kMaxPlotPoints) {
    for (std::size_t k = 0; k < n; ++k) row(t_ms(k), columns(k));
    return out;
  }
  const std::size_t buckets = kMaxPlotPoints / 2;
  for (std::size_t b = 0; b < buckets; ++b) {
    const std::size_t lo = b * n / buckets, hi = (b + 1) * n / buckets;
    const auto [low, high] = envelope(columns, lo, hi);
    row(t_ms(lo), low);
    row(t_ms((lo + hi) / 2), high);
  }
  return out;
}

std::string log_decimated_csv(const std::string& header, const std::vector<double>& f, double x_min,
                              double x_max,
                              const std::function<std::vector<double>(std::size_t)>& columns) {
  std::string out = header + "\n";
  const auto row = [&](double x, const std::vector<double>& v) {
    fmt::format_to(std::back_inserter(out), "{:.10g}", x);
    for (double y : v) fmt::format_to(std::back_inserter(out), ",{:.6e}", y);
    out += "\n";
  };
  const double span = std::log(x_max / x_min);
  const auto bin = [&](double x) {
    return static_cast<long>(std::floor(kSpectrumPlotBins * std::log(x / x_min) / span));
  };
  std::size_t k = 0;
  while (k < f.size() && f[k] < x_min) ++k;
  while (k < f.size() && f[k] <= x_max) {
    std::size_t end = k + 1;
    while (end < f.size() && f[end] <= x_max && bin(f[end]) == bin(f[k])) ++end;
    if (end - k <= 2) {
      for (; k < end; ++k) row(f[k], columns(k));
      continue;
    }
    const auto [low, high] = envelope(columns, k, end);
    row(f[k], low);
    row(f[end - 1], high);
    k = end;
  }
  return out;
}

std::string contact_intervals_csv(const RunResult& r) {
  std::string out = "t_start_s,t_end_s,contact\n";
  if (r.samples.size() == 0) return out;
  int state = r.samples.contact.front();
  double start = r.samples.t_s.front();
  const double end = r.input.solver.duration_s;
  auto close = [&](double t) {
    if (state != 1 && t > start)
      fmt::format_to(std::back_inserter(out), "{:.15g},{:.15g},{}\n", start, t, state);
  };
  for (const ContactEvent& e : r.events) {
    close(e.t_s);
    start = e.t_s;
    state = e.kind == EventKind::kImpact ? 1 : e.kind == EventKind::kBacksideImpact ? -1 : 0;
  }
  close(end);
  return out;
}

TimeHistoryPanel run_panel(const RunResult& r, std::string title, std::string data_dir) {
  TimeHistoryPanel p{std::move(title), std::move(data_dir), r.input.solver.duration_s};
  p.time_in_tau = r.input.model.form == ModelForm::kNondimensional;
  p.separated = r.reading.separated_fraction > 0;
  p.back_side = r.reading.double_sided;
  return p;
}

std::string time_history_body(const std::vector<TimeHistoryPanel>& panels, bool stacked,
                              const std::string& title) {
  std::string s =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key top right opaque font ',8'\nset tics font ',8'\n";
  const std::size_t rows = stacked ? 2 * panels.size() : panels.size();
  fmt::format_to(std::back_inserter(s), "set multiplot layout {},{} title \"{}\"\n", rows,
                 stacked ? 1 : 2, title);
  for (std::size_t i = 0; i < panels.size(); ++i) {
    const bool last = i + 1 == panels.size();
    TimeHistoryPanel p = panels[i];
    const bool physical = p.backlash_um > 0;
    s += panel_plot(p, 2, physical ? "δ (μm)" : "δ / b", stacked ? false : last);
    p.title = "";  // the title goes over the panel's first plot only
    s += panel_plot(p, 3, physical ? "F_G (N)" : "F / (b·k_m)", last);
  }
  s += "unset multiplot\n";
  return s;
}

void render_figure(const fs::path& dir, const std::string& name, const std::string& body,
                   int width_px, int height_px) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0)
    throw FigureError(
        "gnuplot is not installed: the figures need Debian's gnuplot-nox (scripts/setup.sh "
        "installs it)");
  // The figure's four files are one set: drawn in its staging folder (gnuplot runs in `dir`,
  // where the data are), and put in place together only when gnuplot succeeded.
  OutputSet set(dir);
  // The script a user runs draws both formats; here each format is drawn by its own gnuplot,
  // the two at once (the SVG takes as long as the PNG).
  const auto terminal = [&](const std::string& format, const std::string& prefix) {
    return fmt::format(
        "set terminal {4} size {1},{2} font 'DejaVu Sans,10' noenhanced\n"
        "set output '{3}{0}.{5}'\nload '{3}{0}_body.gp'\nset output\n",
        name, width_px, height_px, prefix, format == "png" ? "pngcairo" : "svg", format);
  };
  set.write(name + "_body.gp", body);
  set.write(name + ".gp", fmt::format("# Draws {0}.png and {0}.svg; the figure itself is in "
                                      "{0}_body.gp.\n{1}{2}",
                                      name, terminal("png", ""), terminal("svg", "")));
  const std::string drawing = set.staging().filename().string() + "/";
  std::vector<fs::path> scripts;
  for (const std::string format : {"png", "svg"}) {
    scripts.push_back(set.staging() / (".draw_" + format + ".gp"));
    std::ofstream out(scripts.back(), std::ios::binary);
    out << terminal(format, drawing);
    if (!out) throw FigureError(fmt::format("{}: cannot write", scripts.back().string()));
  }
  std::vector<std::pair<FILE*, fs::path>> runs;
  for (const fs::path& draw_script : scripts) {
    const std::string cmd = fmt::format("cd {} && gnuplot {} 2>&1", shell_quote(dir.string()),
                                        shell_quote(drawing + draw_script.filename().string()));
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) {
      for (auto& [started, unused] : runs) pclose(started);
      throw FigureError("cannot start gnuplot");
    }
    runs.emplace_back(pipe, draw_script);
  }
  std::string failures;
  for (auto& [pipe, draw_script] : runs) {
    std::string output;
    char buffer[512];
    while (std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
    const int status = pclose(pipe);
    if (status != 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) failures += output;
    std::error_code ec;
    fs::remove(draw_script, ec);
  }
  if (!failures.empty())
    throw FigureError(
        fmt::format("gnuplot failed on {}: {}", (dir / (name + ".gp")).string(), failures));
  set.commit();
}

void write_stiffness_figure(const fs::path& dir, const std::string& name,
                            const StiffnessCycle& cycle, const StiffnessFourier& spectrum, int kept,
                            const StiffnessFourier& used) {
  std::string h = "harmonic,ratio,phase_deg\n";
  for (std::size_t i = 0; i < spectrum.harmonics.size(); ++i)
    fmt::format_to(std::back_inserter(h), "{},{:.8e},{:.6f}\n", i + 1, spectrum.harmonics[i].ratio,
                   spectrum.harmonics[i].phase_deg);
  write_files_atomically(dir, {{"harmonics.csv", h}});
  std::string s =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key below font ',8'\n";
  fmt::format_to(std::back_inserter(s), "set multiplot layout 3,1 title \"{}\"\n", name);
  s += "set title '(a) mesh stiffness over one mesh cycle'\n"
       "set xlabel 'position in the mesh cycle'\nset ylabel 'k (N/m)'\nset xrange [0:1]\n"
       "plot";
  for (std::size_t j = 0; j < cycle.pair_n_per_m.size(); ++j)
    fmt::format_to(std::back_inserter(s),
                   " 'stiffness.csv' every ::1 using 1:(${0}>0?${0}:NaN) with lines dt 3 lc rgb "
                   "'gray50' {1},",
                   8 + j, j == 0 ? "title 'each tooth pair'" : "notitle");
  fmt::format_to(std::back_inserter(s),
                 " 'stiffness.csv' every ::1 using 1:3 with lines lw 1.5 lc rgb '{}' title "
                 "'energy method', 'stiffness.csv' every ::1 using 1:4 with lines lw 1.2 dt 2 lc "
                 "rgb '{}' title 'its mean + {} harmonics', 'stiffness.csv' every ::1 using 1:5 "
                 "with lines lw 2 lc rgb '#2e8b57' title 'used by the run (mean {:.4g} N/m, {} "
                 "harmonics)'\n",
                 kLineColour, kSecondColour, kept, used.mean_n_per_m, used.harmonics.size());
  fmt::format_to(std::back_inserter(s), "set xrange [0.5:{}.5]\n", spectrum.harmonics.size());
  s += "set title '(b) DFT of the energy method curve: k_ai / k_m'\n"
       "set xlabel 'harmonic of the mesh frequency'\n"
       "set ylabel 'k_ai / k_m'\nset logscale y\nset boxwidth 0.6\n"
       "set style fill solid 0.7 noborder\nset key inside top right\n";
  // The kept harmonics and the others, each in the legend only when there are any.
  std::vector<std::string> bars;
  if (kept > 0)
    bars.push_back(fmt::format(
        "'harmonics.csv' every ::1 using 1:($1 <= {0} ? $2 : NaN) with boxes lc rgb '#1f3b73' "
        "title 'kept ({0})'",
        kept));
  if (static_cast<std::size_t>(kept) < spectrum.harmonics.size())
    bars.push_back(fmt::format(
        "'harmonics.csv' every ::1 using 1:($1 > {} ? $2 : NaN) with boxes lc rgb '#c8c8c8' "
        "title 'not kept'",
        kept));
  s += "plot ";
  for (std::size_t k = 0; k < bars.size(); ++k) s += (k ? ", " : "") + bars[k];
  s += "\nunset logscale y\n"
       "set title '(c) DFT: phases'\nset ylabel 'phase (deg)'\nset yrange [-180:180]\n"
       "plot 'harmonics.csv' every ::1 using 1:3 with points pt 7 lc rgb '#b5532b' notitle\n"
       "unset multiplot\n";
  render_figure(dir, "stiffness", s, 1000, 950);
}

void write_run_figures(const fs::path& dir, const RunResult& r, bool physical) {
  const Case& c = r.input;
  write_files_atomically(dir, {{"intervals.csv", contact_intervals_csv(r)},
                               {"plot.csv", plot_csv(r.samples)},
                               {"spectrum.csv", spectrum_csv(r)}});
  const std::string title =
      c.model.form == ModelForm::kNondimensional
          ? fmt::format("{}: Ω = {}, ζ = {}, F_m = {}, F_a = {} ({})", c.name, c.model.omega,
                        c.model.zeta, c.model.force_mean, c.model.force_alternating,
                        to_string(r.reading.regime))
          : fmt::format("{}: f_1 = {} Hz, b = {} μm, ξ = {}, F_a/F_m = {} ({})", c.name,
                        c.speed.shaft_frequency_hz, c.mesh.backlash_um, c.mesh.damping_ratio,
                        c.load.fluctuation_ratio, to_string(r.reading.regime));
  TimeHistoryPanel time_panel = run_panel(r, "", "");
  if (physical) {
    if (c.model.form == ModelForm::kNondimensional)
      throw InputError("--physical: the non-dimensional form has no physical units");
    const GearPairParameters p = build_model(c).parameters();
    time_panel.backlash_um = c.mesh.backlash_um;
    time_panel.force_scale_n = p.backlash_m * p.mean_stiffness_n_per_m();
  }
  render_figure(dir, "run_time", time_history_body({time_panel}, /*stacked=*/true, title), 1000,
                700);

  // Spectrum of the steady part on a log frequency axis, with the contact natural frequency,
  // the mesh orders and the torque harmonics marked.
  const Derived& d = r.derived;
  const double f_mesh = d.mesh_frequency_hz;
  const double f_torque =
      c.load.fluctuation_ratio > 0 ? c.load.fluctuation_order * c.speed.shaft_frequency_hz : 0.0;
  const double f_n = d.natural_frequency_hz;
  const double nyquist = 0.5 / d.output_interval_s;
  const double df = 1.0 / std::max(c.solver.duration_s - r.steady_start_s, d.output_interval_s);
  const double x_max = std::min(nyquist, 4.0 * std::max({f_mesh, f_n, f_torque}));
  const double x_min =
      std::max(df, 0.25 * std::min({f_mesh, f_n, f_torque > 0 ? f_torque : f_mesh}));
  const bool nd = c.model.form == ModelForm::kNondimensional;
  const char* f_unit = nd ? "cycles per tau" : "Hz";
  std::string s =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set logscale xy\nset key bottom left font ',9' opaque\n";
  fmt::format_to(std::back_inserter(s),
                 "set title \"{} - spectrum over the steady part, t >= {:.4g}{}\"\n"
                 "set xlabel 'frequency ({})'\nset ylabel 'amplitude'\nset xrange [{}:{}]\n",
                 c.name, nd ? r.steady_start_s : r.steady_start_s * 1e3, nd ? " (tau)" : " ms",
                 f_unit, x_min, x_max);
  const auto mark = [&](double f, const char* style, const std::string& label) {
    if (f < x_min || f > x_max) return;
    fmt::format_to(std::back_inserter(s),
                   "set arrow from {0}, graph 0 to {0}, graph 1 nohead {1}\n"
                   "set label '{2}' at {0}, graph 0.97 left offset 0.3,0 font ',8'\n",
                   f, style, label);
  };
  mark(f_n, "lw 1.5 lc rgb '#2e8b57'", "f_n");
  for (int i = 1; i * f_mesh <= x_max && i <= 20; ++i)
    mark(i * f_mesh, "dt 2 lc rgb 'gray40'", i == 1 ? "f_z" : fmt::format("{} f_z", i));
  bool torque_marked = false;
  for (int j = 1; f_torque > 0 && j * f_torque <= x_max && j <= 20; ++j)
    if (j * f_torque >= x_min && std::abs(j * f_torque - f_mesh) > 1e-9 * f_mesh) {
      fmt::format_to(std::back_inserter(s),
                     "set arrow from {0}, graph 0 to {0}, graph 1 nohead dt 3 lc rgb '#d08020'\n",
                     j * f_torque);
      torque_marked = true;
    }
  fmt::format_to(std::back_inserter(s),
                 "plot 'spectrum.csv' every ::1 using 1:(($2>0)?$2:NaN) with lines lw 1.2 "
                 "lc rgb '{}' title 'F/(b·k_m)', \\\n"
                 "     'spectrum.csv' every ::1 using 1:(($3>0)?$3:NaN) with lines lw 1 "
                 "lc rgb '{}' title 'δ/b', \\\n"
                 "     NaN with lines lw 1.5 lc rgb '#2e8b57' title 'contact natural frequency "
                 "f_n', \\\n"
                 "     NaN with lines dt 2 lc rgb 'gray40' title 'mesh orders i z_1 f_1'{}\n",
                 kLineColour, kSecondColour,
                 torque_marked ? ", \\\n     NaN with lines dt 3 lc rgb '#d08020' title 'torque "
                                 "harmonics'"
                               : "");
  render_figure(dir, "run_spectrum", s, 1000, 500);

  // Phase portrait, the steady part drawn over the whole run.
  std::size_t steady_row = 0;
  while (steady_row < r.samples.size() && r.samples.t_s[steady_row] < r.steady_start_s)
    ++steady_row;
  std::string p = "reset\nset datafile separator ','\nset grid lc rgb '#dddddd'\n";
  fmt::format_to(std::back_inserter(p),
                 "set encoding utf8\nset title \"{} - phase portrait\"\nset xlabel 'δ / b'\n"
                 "set ylabel '{}'\n"
                 "set arrow from 1, graph 0 to 1, graph 1 nohead dt 2 lc rgb 'gray40'\n"
                 "set arrow from -1, graph 0 to -1, graph 1 nohead dt 2 lc rgb 'gray40'\n"
                 "plot 'timeseries.csv' every ::1 using 2:3 with lines lc rgb '#c8c8c8' title "
                 "'whole run', \\\n     'timeseries.csv' every ::{} using 2:3 with lines lw 1.2 "
                 "lc rgb '{}' title 'steady part'\n",
                 c.name,
                 c.model.form == ModelForm::kNondimensional ? "dδ/dτ (b ω_n)" : "dδ/dt (m/s)",
                 steady_row + 1, kLineColour);
  render_figure(dir, "run_phase", p, 800, 650);
}

}  // namespace geardyn
