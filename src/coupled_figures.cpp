// The figures of the coupled model: the Campbell diagram of its modes (a coupled run is drawn
// as its train form's, train_figures.cpp).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "geardyn/figures.hpp"
#include "geardyn/output.hpp"

namespace geardyn {
namespace fs = std::filesystem;

namespace {

// The modes that hold at least this fraction of their strain energy in the mesh are the ones
// the mesh excites: drawn bold in the Campbell diagram, their resonance speeds marked.
constexpr double kMeshCritical = 0.05;
constexpr int kMeshOrders = 3;

}  // namespace

std::string campbell_csv(const Case& c, const ModeSet& m) {
  std::string out = "mode,frequency_hz,mesh_energy,mesh_order,resonance_shaft_hz\n";
  const int z1 = c.gear.teeth[0];
  for (std::size_t r = 0; r < m.modes.size(); ++r) {
    const Mode& x = m.modes[r];
    for (int i = 1; i <= kMeshOrders; ++i)
      fmt::format_to(std::back_inserter(out), "{},{:.10g},{:.6g},{},{:.10g}\n", r + 1,
                     x.frequency_hz, x.mesh_energy, i, x.frequency_hz / (i * z1));
  }
  return out;
}

void write_campbell_figure(const fs::path& dir, const Case& c, const ModeSet& m) {
  write_files_atomically(
      dir, {{"campbell.csv", campbell_csv(c, m)}, {"modes.json", modes_json(m) + "\n"}});
  const int z1 = c.gear.teeth[0];
  double top = 0;
  for (const Mode& x : m.modes)
    if (x.mesh_energy >= kMeshCritical) top = std::max(top, x.frequency_hz);
  if (top == 0 && !m.modes.empty()) top = m.modes.back().frequency_hz;
  const double x_max = 1.5 * top / z1;  // the first mesh order past every mesh-critical mode
  const double y_max = 1.15 * std::max(top, m.modes.empty() ? 1.0 : m.modes.back().frequency_hz);
  std::string s =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key top left font ',9' opaque\n";
  const double f1 = c.speed.shaft_frequency_hz;
  fmt::format_to(std::back_inserter(s),
                 "set title \"{}: modes in contact and mesh orders (z_1 = {}){}\"\n"
                 "set xlabel 'shaft frequency f_1 (Hz)'\nset ylabel 'frequency (Hz)'\n"
                 "set xrange [0:{}]\nset yrange [0:{}]\n",
                 c.name, z1,
                 f1 > x_max ? fmt::format(", operating f_1 = {} Hz beyond the range", f1) : "",
                 x_max, y_max);
  std::vector<std::string> plots;
  bool critical = false, other = false, marked = false;
  std::string points;
  for (const Mode& x : m.modes) {
    const bool excited = x.mesh_energy >= kMeshCritical;
    (excited ? critical : other) = true;
    fmt::format_to(std::back_inserter(s), "set arrow from 0, {0} to {1}, {0} nohead {2}\n",
                   x.frequency_hz, x_max,
                   excited ? "lw 2 lc rgb '#1f4e9c'" : "lw 1 dt 3 lc rgb 'gray60'");
    for (int i = 1; excited && i <= kMeshOrders; ++i) {
      const double speed = x.frequency_hz / (i * z1);
      if (speed > x_max) continue;
      fmt::format_to(std::back_inserter(points), "{},{}\n", speed, x.frequency_hz);
      marked = true;
    }
  }
  for (int i = 1; i <= kMeshOrders; ++i)
    plots.push_back(fmt::format("{} * x with lines lw 1.2 dt {} lc rgb '#c0392b' title '{}'",
                                i * z1, i,
                                i == 1 ? "mesh order 1 (f_z)" : fmt::format("mesh order {}", i)));
  // Keys for the horizontal lines (drawn as arrows), only for the kinds that occur.
  if (critical)
    plots.push_back(
        "keyentry with lines lw 2 lc rgb '#1f4e9c' title 'mode with >= 5 % mesh energy'");
  if (other) plots.push_back("keyentry with lines lw 1 dt 3 lc rgb 'gray60' title 'other mode'");
  if (marked)
    plots.push_back(
        "$crossings using 1:2 with points pt 6 ps 1.5 lc rgb 'black' title 'resonance speed'");
  if (f1 <= x_max) {
    fmt::format_to(std::back_inserter(s),
                   "set arrow from {0}, 0 to {0}, {1} nohead lw 1.5 lc rgb '#2e8b57'\n"
                   "set label 'operating f_1' at {0}, {1} * 0.97 left offset 0.3,0 font ',8'\n",
                   f1, y_max);
  }
  if (marked) s += "$crossings << EOD\n" + points + "EOD\n";
  s += "plot ";
  for (std::size_t k = 0; k < plots.size(); ++k) s += (k ? ", " : "") + plots[k];
  s += "\n";
  render_figure(dir, "campbell", s, 900, 650);
}

}  // namespace geardyn
