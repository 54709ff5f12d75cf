// geardyn: figures, the last pipeline stage (analysis -> figures).
//
// Figures are drawn by gnuplot (Debian's gnuplot-nox) from data files and scripts written beside
// them, so that a user can restyle a figure by editing its `*_body.gp` and running
// `gnuplot NAME.gp` in the directory. Each figure is written as NAME.png and NAME.svg.
#pragma once

#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "geardyn/output_folder.hpp"
#include "geardyn/run.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {

// Separation and back-side contact intervals of a run, from its located events:
// intervals.csv with header t_start_s,t_end_s,contact (0 separated, -1 back side).
std::string contact_intervals_csv(const RunResult& r);

// Points of a time-history plot at most: far more than a panel has pixel columns.
constexpr std::size_t kMaxPlotPoints = 4000;

// plot.csv, the samples a time-history figure draws: t_s,delta_bar,force_bar. Up to
// kMaxPlotPoints samples as they are; beyond, min/max decimation: each bucket of consecutive
// samples gives its minimum and its maximum (of each signal), so the drawn envelope is exact.
std::string plot_csv(const Timeseries& s);

// A time-history CSV for a figure: `header`, then one row per sample k of n, its time t_ms(k)
// and its columns(k). Up to kMaxPlotPoints samples as they are; beyond, each bucket of
// consecutive samples gives the minima and the maxima of every column (the drawn envelope is
// exact).
std::string decimated_csv(const std::string& header, std::size_t n,
                          const std::function<double(std::size_t)>& t_ms,
                          const std::function<std::vector<double>(std::size_t)>& columns);

// Equal bins of log f a spectrum figure's axis is cut into, beyond which its rows are reduced
// to each bin's minima and maxima: about a bin per pixel column of a 1000-pixel panel.
constexpr double kSpectrumPlotBins = 1000;

// The rows a log-frequency figure draws, `header` first: those of f (ascending) in
// [x_min, x_max] (0 < x_min < x_max), each f[k] with its columns(k); where more than two fall
// in one of kSpectrumPlotBins equal bins of log f, the bin's minima and its maxima column by
// column instead, at its first and last frequency, so that the drawn envelope (every peak) is
// the full spectrum's.
std::string log_decimated_csv(const std::string& header, const std::vector<double>& f, double x_min,
                              double x_max,
                              const std::function<std::vector<double>(std::size_t)>& columns);

// One panel row of a time-history figure: delta_bar and F_bar of one run.
struct TimeHistoryPanel {
  std::string title;     // e.g. "(a) f_1 = 10 Hz"
  std::string data_dir;  // relative to the figure's directory ("" for the same)
  double window_s = 0;   // x range [0, window]
  // What occurred in the run, so that only that is in the legend.
  bool separated = true, back_side = false;
  // Physical units: delta in um (delta_bar times b) and F_G in N (F_bar times b k_m); 0 for
  // the normalised delta / b and F / (b k_m).
  double backlash_um = 0, force_scale_n = 0;
  // The time axis: ms for the gear pair, tau for the non-dimensional form.
  bool time_in_tau = false;
};

// A panel of a run: its title, its data directory and what occurred in it.
TimeHistoryPanel run_panel(const RunResult& r, std::string title, std::string data_dir);

// The gnuplot body of a time-history figure: each panel's delta_bar and F_bar, with the
// separation (and back-side) intervals shaded and the backlash band |delta_bar| < 1 marked.
// `stacked`: delta_bar above F_bar (one run); otherwise side by side, one row per panel.
std::string time_history_body(const std::vector<TimeHistoryPanel>& panels, bool stacked,
                              const std::string& title);

// Writes NAME.gp (PNG and SVG terminals around `load 'NAME_body.gp'`) and NAME_body.gp into
// dir, and runs gnuplot there. Throws FigureError.
void render_figure(const std::filesystem::path& dir, const std::string& name,
                   const std::string& body, int width_px, int height_px);

// The mesh stiffness figure, like the paper's Fig. 3: (a) k over one mesh cycle with its
// truncated series, each tooth pair's contribution, and the stiffness a run uses (`used`: the
// case's source, kept harmonics and mean scaling), (b) the DFT: harmonic ratios k_ai/k_m, the
// `kept` ones marked, and (c) phases. Needs stiffness.csv and harmonics.csv (written here).
void write_stiffness_figure(const std::filesystem::path& dir, const std::string& name,
                            const StiffnessCycle& cycle, const StiffnessFourier& spectrum, int kept,
                            const StiffnessFourier& used);

// The figures of one run, into a directory that already holds its timeseries.csv:
// run_time (delta_bar and F_bar over time), run_spectrum (spectrum of F_bar over the steady part
// with the mesh and torque harmonics marked), run_phase (phase portrait), with intervals.csv and
// spectrum.csv beside them.
// `physical`: delta in um and F_G in N (the gear-pair form) in place of delta / b and
// F / (b k_m).
void write_run_figures(const std::filesystem::path& dir, const RunResult& r, bool physical = false);

}  // namespace geardyn
