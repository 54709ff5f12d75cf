// The figures of the coupled model: a run's time histories per part (mesh, bearings, axial
// motion) and the Campbell diagram of its modes.
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

// coupled_plot.csv: t_ms, (d - e)/b, F_bar, the line-of-action bearing forces, the axial ones,
// y1, y2, z1, z2 in um and the shaft torques, decimated as decimated_csv does.
std::string coupled_plot_csv(const CoupledRunResult& r) {
  const CoupledSamples& s = r.samples;
  const CoupledParameters& p = r.parameters;
  const auto coordinate = [&](std::size_t k, Coordinate x) {
    const int j = p.index(x);
    return j < 0 ? 0.0 : s.state[k][j] * 1e6;
  };
  const auto columns = [&](std::size_t k) {
    return std::vector<double>{s.deflection_bar[k],
                               s.force_bar[k],
                               s.bearing_force_n[k][0],
                               s.bearing_force_n[k][1],
                               s.axial_force_n[k][0],
                               s.axial_force_n[k][1],
                               coordinate(k, Coordinate::kLine1),
                               coordinate(k, Coordinate::kLine2),
                               coordinate(k, Coordinate::kAxial1),
                               coordinate(k, Coordinate::kAxial2),
                               s.shaft_torque_nm[k][0],
                               s.shaft_torque_nm[k][1]};
  };
  return decimated_csv(
      "t_ms,deflection_bar,force_bar,bearing1_n,bearing2_n,axial1_n,axial2_n,y1_um,y2_um,z1_um,"
      "z2_um,shaft1_nm,shaft2_nm\n",
      s.t_s.size(), [&](std::size_t k) { return s.t_s[k] * 1e3; }, columns);
}

}  // namespace

void write_coupled_run_figures(const fs::path& dir, const CoupledRunResult& r) {
  const Case& c = r.input;
  const CoupledParameters& p = r.parameters;
  write_files_atomically(dir, {{"coupled_plot.csv", coupled_plot_csv(r)}});
  const bool axial = p.index(Coordinate::kAxial1) >= 0 && p.sin_base_helix > 0;
  const bool shafts = p.shaft[0] >= 0 || p.shaft[1] >= 0;
  const int rows = 3 + (axial ? 1 : 0) + (shafts ? 1 : 0);
  std::string s =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key top right font ',9' opaque\n";
  fmt::format_to(std::back_inserter(s),
                 "set multiplot layout {},1 title \"{}: coupled, dof {}, f_1 = {} Hz, b = {} μm "
                 "(mesh {})\"\nset xrange [0:{}]\n",
                 rows, c.name, p.dof, c.speed.shaft_frequency_hz, c.mesh.backlash_um,
                 to_string(r.mesh.regime), c.solver.duration_s * 1e3);
  // (a) The mesh: deflection relative to the transmission error, and the force.
  s += "set ylabel '(d − e) / b,  F / (b k_m)'\nunset xlabel\n"
       "plot 'coupled_plot.csv' using 1:2 skip 1 with lines lw 1.2 lc rgb '#1f4e9c' title "
       "'(d − e) / b', '' using 1:3 skip 1 with lines lw 1.2 lc rgb '#c0392b' title 'F / (b k_m)', "
       "1 with lines dt 2 lc rgb 'gray50' title 'contact edge'\n";
  // (b) The bearing forces along the line of action.
  s += "set ylabel 'bearing force (N)'\n"
       "plot 'coupled_plot.csv' using 1:4 skip 1 with lines lc rgb '#1f4e9c' title 'gear 1', "
       "'' using 1:5 skip 1 with lines lc rgb '#c0392b' title 'gear 2'\n";
  if (axial)
    s += "set ylabel 'axial bearing force (N)'\n"
         "plot 'coupled_plot.csv' using 1:6 skip 1 with lines lc rgb '#1f4e9c' title 'gear 1', "
         "'' using 1:7 skip 1 with lines lc rgb '#c0392b' title 'gear 2'\n";
  // The shaft torques, of the shafts that are there.
  if (shafts) {
    s += "set ylabel 'shaft torque (N m)'\nplot ";
    const char* names[] = {"drive shaft (motor)", "load shaft"};
    const char* colours[] = {"#1f4e9c", "#c0392b"};
    bool first = true;
    for (int i = 0; i < 2; ++i) {
      if (p.shaft[i] < 0) continue;
      fmt::format_to(std::back_inserter(s),
                     "{}'coupled_plot.csv' using 1:{} skip 1 with lines lc "
                     "rgb '{}' title '{}'",
                     first ? "" : ", ", 12 + i, colours[i], names[i]);
      first = false;
    }
    s += "\n";
  }
  // The bodies' translations.
  s += "set xlabel 't (ms)'\nset ylabel 'displacement (μm)'\nplot 'coupled_plot.csv' using 1:8 "
       "skip 1 with lines lc rgb '#1f4e9c' title 'y_1', '' using 1:9 skip 1 with lines lc rgb "
       "'#c0392b' title 'y_2'";
  if (axial)
    s += ", '' using 1:10 skip 1 with lines dt 2 lc rgb '#1f4e9c' title 'z_1', '' using 1:11 "
         "skip 1 with lines dt 2 lc rgb '#c0392b' title 'z_2'";
  s += "\nunset multiplot\n";
  render_figure(dir, "coupled_time", s, 1000, 250 * rows);
}

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
