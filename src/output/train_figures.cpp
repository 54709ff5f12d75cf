// The figures of a gear train: a run's time histories, one row per mesh, and the Campbell
// diagram of its modes against every mesh's orders.
#include "geardyn/train_figures.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "geardyn/figures.hpp"
#include "geardyn/train_case.hpp"

namespace geardyn {
namespace fs = std::filesystem;

namespace {

// The modes that hold at least this fraction of their strain energy in some mesh are the ones a
// mesh excites: drawn bold, their resonance speeds marked (as the coupled model's diagram).
constexpr double kMeshCritical = 0.05;
constexpr int kMeshOrders = 3;
// The colours of the torques' and prescribed speeds' orders in the Campbell diagram (apart from
// the meshes' palette).
// A Campbell diagram with excitation orders turns logarithmic in frequency when a mode lies below
// this share of its range.
constexpr double kLinearCampbellShare = 0.02;
constexpr std::array<const char*, 4> kOrderColours = {"#8c2d04", "#54278f", "#006d2c", "#7f2704"};
// The speeds at which a Campbell diagram in a turning frame (train.frame_terms) reads the modes.
constexpr int kCampbellSpeeds = 48;
// The Campbell diagram's speeds: from rest to this many times the case's operating speed.
constexpr double kCampbellSpeedSpan = 1.5;
// Samples of each part a phase portrait draws at most, consecutive: a steady orbit of many
// periods drawn once over.
constexpr std::size_t kMaxPhasePoints = 5000;
// Distinct colours for the meshes, in turn.
constexpr const char* kColours[] = {"#1f4e9c", "#c0392b", "#2e8b57",
                                    "#8e44ad", "#d35400", "#16a085"};

const char* colour(std::size_t i) { return kColours[i % std::size(kColours)]; }

// A name inside a gnuplot single-quoted string.
std::string quoted(const std::string& name) {
  std::string out;
  for (char ch : name) out += ch == '\'' ? std::string("''") : std::string(1, ch);
  return out;
}

// Each load-sharing group of a run (a sun and its planets, a ring and its planets) in a row:
// every mesh's force over time, a line per planet, and the group's factor n max F / sum F on
// the right axis, its static value dashed.
void write_load_sharing_figure(const fs::path& dir, const TrainRunResult& r) {
  const TrainSamples& s = r.samples;
  // The meshes of every group (a mesh may be in two: its driving and its driven gear's), then
  // each group's factor.
  std::vector<std::size_t> meshes;
  for (const TrainLoadSharing& g : r.load_sharing)
    for (const std::string& name : g.meshes)
      for (std::size_t m = 0; m < r.meshes.size(); ++m)
        if (r.meshes[m].name == name && std::find(meshes.begin(), meshes.end(), m) == meshes.end())
          meshes.push_back(m);
  const auto column = [&](const std::string& name) {
    for (std::size_t i = 0; i < meshes.size(); ++i)
      if (r.meshes[meshes[i]].name == name) return 2 + i;
    return std::size_t{0};
  };
  std::string header = "t_ms";
  for (const std::size_t m : meshes) header += fmt::format(",{}_force_n", r.meshes[m].name);
  for (const TrainLoadSharing& g : r.load_sharing) header += fmt::format(",{}_factor", g.gear);
  header += "\n";
  constexpr double kUndefined = std::numeric_limits<double>::quiet_NaN();
  write_files_atomically(dir,
                         {{"load_sharing_plot.csv",
                           decimated_csv(
                               header, s.t_s.size(), [&](std::size_t k) { return s.t_s[k] * 1e3; },
                               [&](std::size_t k) {
                                 std::vector<double> v;
                                 v.reserve(meshes.size() + r.load_sharing.size());
                                 for (const std::size_t m : meshes) v.push_back(s.force_n[k][m]);
                                 for (const TrainLoadSharing& g : r.load_sharing) {
                                   std::vector<double> forces;
                                   forces.reserve(g.meshes.size());
                                   for (const std::string& name : g.meshes)
                                     forces.push_back(v[column(name) - 2]);
                                   v.push_back(load_sharing_factor(forces).value_or(kUndefined));
                                 }
                                 return v;
                               })}});
  std::string g =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key outside right top font ',9'\nset ytics nomirror\nset y2tics\n"
      "set ylabel 'mesh force (N)'\nset y2label 'load-sharing factor'\n"
      // A factor of 1 to rounding reads 1.000 on an axis of at least 0.98 to 1.02, not "1 1 1".
      "set format y2 '%.3f'\nset y2range [* < 0.98 : 1.02 < *]\n";
  fmt::format_to(std::back_inserter(g),
                 "set multiplot layout {},1 title \"{}: load sharing\"\nset xrange [0:{}]\n",
                 r.load_sharing.size(), quoted(r.input.name), r.input.solver.duration_s * 1e3);
  for (std::size_t i = 0; i < r.load_sharing.size(); ++i) {
    const TrainLoadSharing& x = r.load_sharing[i];
    std::string plots;
    for (std::size_t k = 0; k < x.meshes.size(); ++k)
      plots += fmt::format(
          "{}'load_sharing_plot.csv' using 1:{} skip 1 axes x1y1 with lines lw 1.2 lc rgb '{}' "
          "title '{}'",
          k ? ", " : "", column(x.meshes[k]), colour(k), quoted(x.meshes[k]));
    // A group whose meshes carry no load (a set written for its modes) has no factor to draw.
    const bool loaded = x.factor_with_startup.has_value();
    if (loaded)
      plots += fmt::format(
          ", '' using 1:{} skip 1 axes x1y2 with lines lw 1.5 lc rgb 'black' title 'factor'",
          2 + meshes.size() + i);
    if (x.static_factor)
      plots += fmt::format(", {} axes x1y2 with lines dt 2 lc rgb 'gray40' title 'at rest'",
                           *x.static_factor);
    const auto worst = x.factor ? x.factor : x.factor_with_startup;
    fmt::format_to(
        std::back_inserter(g), "set title \"gear {}: {} meshes{}{}\" font ',10'\n{}plot {}\n",
        quoted(x.gear), x.meshes.size(),
        worst    ? fmt::format(", factor up to {:.4g}", *worst)
        : loaded ? std::string()
                 : std::string(", no factor: its meshes carry no load"),
        x.lost_contact.empty() ? std::string()
                               : fmt::format(", lost contact: {}", fmt::join(x.lost_contact, " ")),
        i + 1 == r.load_sharing.size() ? "set xlabel 't (ms)'\n" : "unset xlabel\n", plots);
  }
  g += "unset multiplot\n";
  render_figure(dir, "load_sharing", g, 1000,
                300 * static_cast<int>(std::max<std::size_t>(r.load_sharing.size(), 1)));
}

// Each mesh's amplitude spectra over the steady part (mesh_spectra), a row per mesh on log axes
// as the one-degree run's run_spectrum: F / (b k_m) and (d - e) / b, the mesh's own orders
// i f_z dashed and the other meshes' frequencies dotted in their colours, from
// train_spectrum.csv (frequency_hz, then each mesh's <mesh>_force_bar and <mesh>_deflection_bar
// amplitudes). Nothing without a spectrum (fewer than 4 samples in the steady part).
void write_train_spectrum_figure(const fs::path& dir, const TrainRunResult& r, bool physical) {
  std::vector<MeshSpectra> spectra;
  for (std::size_t m = 0; m < r.meshes.size(); ++m) spectra.push_back(mesh_spectra(r, m));
  if (spectra.empty() || spectra[0].force_n.frequency_hz.size() < 2) return;
  const std::vector<double>& f = spectra[0].force_n.frequency_hz;
  std::string header = "frequency_hz";
  for (const TrainMeshReading& m : r.meshes)
    header += physical ? fmt::format(",{0}_force_n,{0}_deflection_um", m.name)
                       : fmt::format(",{0}_force_bar,{0}_deflection_bar", m.name);
  // Each row's columns after the frequency: each mesh's F in N or over b k_m, and its d - e
  // over b or in um.
  const auto columns = [&](std::size_t k) {
    std::vector<double> v;
    for (std::size_t m = 0; m < r.meshes.size(); ++m) {
      const TrainMeshReading& x = r.meshes[m];
      const double force = spectra[m].force_n.amplitude[k],
                   deflection = spectra[m].deflection_bar.amplitude[k];
      v.push_back(physical ? force : force / (x.backlash_m * x.mean_stiffness_n_per_m));
      v.push_back(physical ? deflection * x.backlash_m * 1e6 : deflection);
    }
    return v;
  };
  double top = 0;
  for (const TrainMeshReading& m : r.meshes) top = std::max(top, m.mesh_frequency_hz);
  const double x_min = f[1], x_max = std::min(f.back(), 4.0 * std::max(top, f[1]));
  write_files_atomically(dir, {{"train_spectrum.csv",
                                [&](std::ostream& o) {
                                  o << header;
                                  for (std::size_t k = 0; k < f.size(); ++k) {
                                    o << fmt::format("\n{:.10g}", f[k]);
                                    for (double v : columns(k)) o << fmt::format(",{:.6e}", v);
                                  }
                                  o << "\n";
                                }},
                               {"train_spectrum_plot.csv", [&](std::ostream& o) {
                                  o << log_decimated_csv(header, f, x_min, x_max, columns);
                                }}});
  std::string g =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set logscale xy\nset key bottom left font ',9' opaque\n";
  g += physical ? "set ylabel 'force (N), d − e (um)'\n" : "set ylabel 'amplitude'\n";
  fmt::format_to(std::back_inserter(g),
                 "set multiplot layout {},1 title \"{}: spectra over the steady part, t >= {:.4g} "
                 "ms\"\nset xrange [{}:{}]\n",
                 r.meshes.size(), quoted(r.input.name), r.steady.from_s * 1e3, x_min, x_max);
  for (std::size_t m = 0; m < r.meshes.size(); ++m) {
    const TrainMeshReading& x = r.meshes[m];
    std::string marks;
    for (int i = 1; i <= 20 && i * x.mesh_frequency_hz <= x_max; ++i)
      if (i * x.mesh_frequency_hz >= x_min)
        fmt::format_to(std::back_inserter(marks),
                       "set arrow from {0}, graph 0 to {0}, graph 1 nohead dt 2 lc rgb 'gray40'\n",
                       i * x.mesh_frequency_hz);
    for (std::size_t o = 0; o < r.meshes.size(); ++o) {
      const double fo = r.meshes[o].mesh_frequency_hz;
      if (o != m && fo >= x_min && fo <= x_max)
        fmt::format_to(std::back_inserter(marks),
                       "set arrow from {0}, graph 0 to {0}, graph 1 nohead dt 3 lc rgb '{1}'\n", fo,
                       colour(o));
    }
    // Its columns: the force, then the deflection.
    const std::size_t force = 2 + 2 * m, deflection = force + 1;
    fmt::format_to(std::back_inserter(g),
                   "unset arrow\n{0}set title \"mesh {1} ({2:.6g} Hz)\" font ',10'\n{3}"
                   "plot 'train_spectrum_plot.csv' using 1:((${4}>0)?${4}:NaN) skip 1 with lines "
                   "lw 1.2 lc rgb "
                   "'{6}' title '{7}', '' using 1:((${5}>0)?${5}:NaN) skip 1 with lines lw 1 lc "
                   "rgb 'gray40' title '{8}', NaN with lines dt 2 lc rgb 'gray40' title 'mesh "
                   "orders i f_z'\n",
                   marks, quoted(x.name), x.mesh_frequency_hz,
                   m + 1 == r.meshes.size() ? "set xlabel 'frequency (Hz)'\n" : "unset xlabel\n",
                   force, deflection, colour(m), physical ? "F (N)" : "F / (b k_m)",
                   physical ? "d − e (um)" : "(d − e) / b");
  }
  g += "unset multiplot\n";
  render_figure(dir, "train_spectrum", g, 1000,
                260 * static_cast<int>(std::max<std::size_t>(r.meshes.size(), 1)));
}

// train_phase: each mesh's phase portrait, (d - e) / b against d' - e' (m/s), the start of the
// run light and its steady part in the mesh's colour, the contact edges at +-1 dashed, read
// from train_phase.csv beside it.
void write_train_phase_figure(const fs::path& dir, const TrainRunResult& r) {
  const std::size_t meshes = r.meshes.size();
  const TrainSamples& s = r.samples;
  const std::size_t n = s.t_s.size();
  if (meshes == 0 || n == 0) return;
  std::size_t steady_row = 0;
  while (steady_row < n && s.t_s[steady_row] < r.steady.from_s) ++steady_row;
  // train_phase.csv: the run's first kMaxPhasePoints samples, then (a second block) the steady
  // part's last kMaxPhasePoints, each mesh's (d - e) / b and d' - e' (m/s), consecutive samples
  // as they are: a trajectory thinned out would cut corners off its orbit, and gnuplot drawing
  // every sample of a long run took half a minute.
  const std::size_t start_end = std::min(n, kMaxPhasePoints);
  const std::size_t steady_begin = std::max(steady_row, n - std::min(n, kMaxPhasePoints));
  write_files_atomically(dir, {{"train_phase.csv", [&](std::ostream& o) {
                                  o << "t_s";
                                  for (const TrainMeshReading& m : r.meshes)
                                    o << fmt::format(",{0}_deflection_bar,{0}_deflection_rate_m_s",
                                                     m.name);
                                  const auto rows = [&](std::size_t from, std::size_t to) {
                                    for (std::size_t i = from; i < to; ++i) {
                                      o << fmt::format("\n{:.10g}", s.t_s[i]);
                                      for (std::size_t m = 0; m < meshes; ++m)
                                        o << fmt::format(",{:.10g},{:.10g}", s.deflection_bar[i][m],
                                                         s.deflection_rate_m_s[i][m]);
                                    }
                                  };
                                  rows(0, start_end);
                                  o << "\n\n";
                                  rows(steady_begin, n);
                                  o << "\n";
                                }}});
  const std::size_t columns = std::min<std::size_t>(meshes, 3);
  const std::size_t rows = (meshes + columns - 1) / columns;
  std::string g =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key top right font ',9' opaque\n";
  fmt::format_to(std::back_inserter(g),
                 "set multiplot layout {},{} title \"{}: phase portraits, the steady part from "
                 "t = {:.4g} ms\"\nset xlabel '(d − e) / b'\nset ylabel 'd′ − e′ (m/s)'\n"
                 "set arrow 1 from 1, graph 0 to 1, graph 1 nohead dt 2 lc rgb 'gray40'\n"
                 "set arrow 2 from -1, graph 0 to -1, graph 1 nohead dt 2 lc rgb 'gray40'\n",
                 rows, columns, quoted(r.input.name), r.steady.from_s * 1e3);
  for (std::size_t m = 0; m < meshes; ++m) {
    const std::size_t deflection = 2 + 2 * m, rate = 3 + 2 * m;
    fmt::format_to(std::back_inserter(g),
                   "set title \"mesh {}\" font ',10'\n"
                   "plot 'train_phase.csv' index 0 every ::1 using {}:{} with lines lc rgb "
                   "'#c8c8c8' title 'start of the run', '' index 1 using {}:{} with lines lw 1.2 "
                   "lc rgb '{}' title 'steady part'\n",
                   quoted(r.meshes[m].name), deflection, rate, deflection, rate, colour(m));
  }
  g += "unset multiplot\n";
  render_figure(dir, "train_phase", g, 560 * static_cast<int>(columns),
                480 * static_cast<int>(rows));
}

}  // namespace

void write_train_run_figures(const fs::path& dir, const TrainRunResult& r, bool physical) {
  if (!r.load_sharing.empty()) write_load_sharing_figure(dir, r);
  write_train_spectrum_figure(dir, r, physical);
  write_train_phase_figure(dir, r);
  const TrainSamples& s = r.samples;
  const std::size_t meshes = r.meshes.size(), shafts = r.shafts.size(),
                    bearings = r.bearings.size();
  // A row for the shafts' torques (N m) and one for the bearings' radial forces (N), each on its
  // own axis, when there are any, and a last one for the axial forces of the bearings of bodies
  // that move along their axis.
  // And a row for the forces of the joints read as parts (a clutch damper's torque).
  std::vector<std::size_t> joints;  // their indices among r.joints
  for (std::size_t q = 0; q < r.joints.size(); ++q)
    if (r.joints[q].read) joints.push_back(q);
  const bool parts = shafts + bearings + joints.size() > 0;
  std::vector<std::size_t> axial;  // the bearings with an axial force
  for (std::size_t q = 0; q < bearings; ++q)
    if (r.bearings[q].spatial) axial.push_back(q);
  const std::size_t rows = meshes + (shafts > 0 ? 1 : 0) + (bearings > 0 ? 1 : 0) +
                           (axial.empty() ? 0 : 1) + (joints.empty() ? 0 : 1);
  std::string header = "t_ms";
  for (const TrainMeshReading& m : r.meshes)
    header += fmt::format(",{0}_deflection_bar,{0}_force_n", m.name);
  for (const TrainShaftReading& x : r.shafts) header += fmt::format(",{}_torque_nm", x.name);
  for (const TrainBearingReading& x : r.bearings)
    header += fmt::format(",{}_radial_force_n", x.name);
  for (const std::size_t q : axial) header += fmt::format(",{}_axial_force_n", r.bearings[q].name);
  for (const std::size_t q : joints)
    header += fmt::format(",{}_{}", r.joints[q].name, r.joints[q].force_what);
  header += "\n";
  // Each bearing's x force among the parts (a spatial body's has its axial force and moments
  // after its y).
  std::vector<std::size_t> bearing_part;
  std::size_t first_joint = shafts;  // the first joint's force among the parts
  for (std::size_t q = 0; q < bearings; ++q) {
    bearing_part.push_back(first_joint);
    first_joint += static_cast<std::size_t>(r.bearings[q].part_count());
  }
  write_files_atomically(
      dir, {{"train_plot.csv",
             decimated_csv(
                 header, s.t_s.size(), [&](std::size_t k) { return s.t_s[k] * 1e3; },
                 [&](std::size_t k) {
                   std::vector<double> v;
                   for (std::size_t m = 0; m < meshes; ++m) {
                     v.push_back(s.deflection_bar[k][m]);
                     v.push_back(s.force_n[k][m]);
                   }
                   const auto p = s.parts[k];
                   for (std::size_t q = 0; q < shafts; ++q) v.push_back(p[q]);
                   for (std::size_t q = 0; q < bearings; ++q)
                     v.push_back(std::hypot(p[bearing_part[q]], p[bearing_part[q] + 1]));
                   for (const std::size_t q : axial) v.push_back(p[bearing_part[q] + 2]);
                   for (std::size_t q = 0; q < joints.size(); ++q)
                     v.push_back(p[first_joint + 2 * q]);
                   return v;
                 })}});
  std::string g =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      // The key beside each panel, never over the traces.
      "set key outside right top font ',9'\nset ytics nomirror\nset y2tics\n";
  fmt::format_to(std::back_inserter(g),
                 "set multiplot layout {},1 title \"{}: gear train, {} bodies, {} mesh{}\"\n"
                 "set xrange [0:{}]\n",
                 rows, quoted(r.input.name), r.bodies.size(), meshes, meshes == 1 ? "" : "es",
                 r.input.solver.duration_s * 1e3);
  for (std::size_t m = 0; m < meshes; ++m) {
    const TrainMeshReading& x = r.meshes[m];
    fmt::format_to(
        std::back_inserter(g),
        "set title \"mesh {} ({:.6g} Hz): {}, {} impacts\" font ',10'\n"
        "set ylabel '(d − e) / b'\nset y2label 'force (N)'\n{}"
        "plot 'train_plot.csv' using 1:{} skip 1 axes x1y1 with lines lw 1.2 lc rgb "
        "'{}' title '(d − e) / b', '' using 1:{} skip 1 axes x1y2 with lines lw 1 lc rgb "
        "'gray40' title 'force (N)', 1 axes x1y1 with lines dt 2 lc rgb 'gray60' title "
        "'contact edge'{}\n",
        quoted(x.name), x.mesh_frequency_hz, to_string(x.regime), x.impacts,
        m + 1 == meshes && !parts ? "set xlabel 't (ms)'\n" : "unset xlabel\n", 2 + 2 * m,
        colour(m), 3 + 2 * m,
        // The back side's edge where the mesh left its drive side (in permanent
        // contact it would squeeze the deflection's ripple into a line).
        x.separations > 0 || x.double_sided
            ? ", -1 axes x1y1 with lines dt 2 lc rgb 'gray60' notitle"
            : "");
  }
  // Each shaft's torque, then each bearing's radial force, a panel each in its unit.
  std::size_t column = 2 + 2 * meshes;
  const auto part_panel = [&](const char* title, const char* unit_label, std::size_t count,
                              std::size_t colour_from, const char* kind, const auto& name,
                              const char* suffix, bool last) {
    std::string plots;
    for (std::size_t q = 0; q < count; ++q, ++column)
      plots += fmt::format(
          "{}'train_plot.csv' using 1:{} skip 1 axes x1y1 with lines lw 1.2 lc rgb '{}' title "
          "'{} {}{}'",
          plots.empty() ? "" : ", ", column, colour(colour_from + q), kind, quoted(name(q)),
          suffix);
    fmt::format_to(std::back_inserter(g),
                   "set title \"{}\" font ',10'\nset ylabel '{}'\nset y2label ''\nunset y2tics\n"
                   "{}\nplot {}\nset y2tics\n",
                   title, unit_label, last ? "set xlabel 't (ms)'" : "unset xlabel", plots);
  };
  if (shafts > 0)
    part_panel(
        "shafts", "torque (N m)", shafts, 0, "shaft",
        [&](std::size_t q) { return r.shafts[q].name; }, " (N m)",
        bearings == 0 && axial.empty() && joints.empty());
  if (bearings > 0)
    part_panel(
        "bearings", "radial force |F| (N)", bearings, shafts, "bearing",
        [&](std::size_t q) { return r.bearings[q].name; }, " |F| (N)",
        axial.empty() && joints.empty());
  if (!axial.empty()) {
    // Each axial or spatial body's bearing's axial force (a helical mesh's thrust on it).
    std::string plots;
    for (std::size_t i = 0; i < axial.size(); ++i, ++column)
      plots += fmt::format(
          "{}'train_plot.csv' using 1:{} skip 1 axes x1y1 with lines lw 1.2 lc rgb '{}' title "
          "'bearing {} axial (N)'",
          i == 0 ? "" : ", ", column, colour(shafts + axial[i]), quoted(r.bearings[axial[i]].name));
    fmt::format_to(std::back_inserter(g),
                   "set title \"axial bearing forces\" font ',10'\nset ylabel 'axial force (N)'\n"
                   "set y2label ''\nunset y2tics\n{}\nplot {}\nset y2tics\n",
                   joints.empty() ? "set xlabel 't (ms)'" : "unset xlabel", plots);
  }
  if (!joints.empty())
    part_panel(
        "joints", r.joints[joints[0]].force_what == "torque_nm" ? "torque (N m)" : "force",
        joints.size(), shafts + bearings, "joint",
        [&](std::size_t q) { return r.joints[joints[q]].name; },
        fmt::format(" ({})", r.joints[joints[0]].force_what).c_str(), true);
  g += "unset multiplot\n";
  render_figure(dir, "train_time", g, 1000, 260 * static_cast<int>(std::max<std::size_t>(rows, 1)));
}

void write_train_campbell_figure(const fs::path& dir, const train::Assembled& a,
                                 const std::vector<train::TrainMode>& modes) {
  const train::Train& t = a.train();
  // Each mesh's frequency per hertz of the reference speed.
  std::vector<double> per_hz;
  for (std::size_t m = 0; m < t.meshes.size(); ++m)
    per_hz.push_back(a.mesh_frequency_hz(static_cast<int>(m)) / t.reference_speed_hz);
  const auto largest_mesh_energy = [](const train::TrainMode& x) {
    return x.mesh_energy.empty() ? 0.0
                                 : *std::max_element(x.mesh_energy.begin(), x.mesh_energy.end());
  };
  // The case's speed range, from rest to kCampbellSpeedSpan times its operating speed, and the
  // frequencies its mesh orders reach there (at least the first mode a mesh strains, so that
  // one shows).
  double first = 0;
  for (const train::TrainMode& x : modes)
    if (x.frequency_hz > 0 && largest_mesh_energy(x) >= kMeshCritical) {
      first = x.frequency_hz;
      break;
    }
  const double fastest = *std::max_element(per_hz.begin(), per_hz.end());
  const double x_max = kCampbellSpeedSpan * t.reference_speed_hz;
  const double y_max = 1.05 * std::max(kMeshOrders * fastest * x_max, 1.1 * first);
  // With the frame's rotation terms the frequencies move with the speed: each mode (by rank)
  // over kCampbellSpeeds speeds up to x_max, the train assembled again at each.
  const bool turning = a.frame_rate_rad_s() != 0;
  std::vector<double> speeds;
  std::vector<std::vector<double>> curves;  // per speed, per mode
  if (turning)
    for (int k = 0; k <= kCampbellSpeeds; ++k) {
      train::Train at = t;
      at.frame_terms = k > 0;  // at speed 0 the frame is still: the modes at rest
      if (k > 0) at.reference_speed_hz = x_max * k / kCampbellSpeeds;
      speeds.push_back(x_max * k / kCampbellSpeeds);
      std::vector<double> f;
      for (const train::TrainMode& x : train::modes(train::Assembled(at)))
        f.push_back(x.frequency_hz);
      curves.push_back(std::move(f));
    }
  // Where mode r meets order i of a mesh of per_hz p: f / (i p) at a fixed frequency, else the
  // first crossing of its curve (linear between speeds; NaN when it meets none below x_max).
  const auto resonance = [&](std::size_t r, double line) {
    if (!turning) return modes[r].frequency_hz / line;
    double s0 = 0, g0 = curves[0][r];
    for (std::size_t k = 1; k < speeds.size(); ++k) {
      if (r >= curves[k].size()) break;
      const double g1 = curves[k][r] - line * speeds[k];
      if (g0 > 0 && g1 <= 0) return s0 + (speeds[k] - s0) * g0 / (g0 - g1);
      s0 = speeds[k];
      g0 = g1;
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  std::string csv = "mode,frequency_hz,largest_mesh_energy,mesh,mesh_order,resonance_speed_hz\n";
  for (std::size_t r = 0; r < modes.size(); ++r) {
    const train::TrainMode& x = modes[r];
    for (std::size_t m = 0; m < per_hz.size(); ++m)
      for (int i = 1; i <= kMeshOrders; ++i)
        fmt::format_to(std::back_inserter(csv), "{},{:.10g},{:.6g},{},{},{:.10g}\n", r + 1,
                       x.frequency_hz, largest_mesh_energy(x), t.meshes[m].name, i,
                       resonance(r, i * per_hz[m]));
  }
  std::vector<std::pair<std::string, std::string>> files{{"campbell.csv", csv}};
  // The orders of the torques' and prescribed speeds' harmonics (an engine's firing orders), per
  // hertz of the reference speed (each of its own body's speed), and where each meets each mode:
  // campbell_orders.csv, with a train that has any.
  std::vector<std::pair<std::string, double>> orders;  // (its name, per_hz)
  const auto per_ref_hz = [&](const std::string& body) {
    return a.turning_hz(a.index(body)) / t.reference_speed_hz;
  };
  for (const train::Torque& q : t.torques)
    for (const train::TorqueHarmonic& h : q.harmonics)
      orders.emplace_back(fmt::format("torque '{}' order {:g}", q.name, h.order),
                          h.order * per_ref_hz(q.body));
  for (const train::Speed& v : t.speeds)
    for (const train::SpeedHarmonic& h : v.harmonics)
      orders.emplace_back(fmt::format("speed '{}' order {:g}", v.name, h.order),
                          h.order * per_ref_hz(v.body));
  if (!orders.empty()) {
    std::string o = "mode,frequency_hz,excitation,resonance_speed_hz\n";
    for (std::size_t r = 0; r < modes.size(); ++r)
      for (const auto& [name, ratio] : orders)
        fmt::format_to(std::back_inserter(o), "{},{:.10g},\"{}\",{:.10g}\n", r + 1,
                       modes[r].frequency_hz, name, resonance(r, ratio));
    files.emplace_back("campbell_orders.csv", o);
  }
  std::string table;
  if (turning) {
    table = "speed_hz";
    for (std::size_t r = 0; r < modes.size(); ++r)
      fmt::format_to(std::back_inserter(table), ",mode{}_hz", r + 1);
    table += "\n";
    for (std::size_t k = 0; k < speeds.size(); ++k) {
      fmt::format_to(std::back_inserter(table), "{:.10g}", speeds[k]);
      for (const double f : curves[k]) fmt::format_to(std::back_inserter(table), ",{:.10g}", f);
      table += "\n";
    }
    files.emplace_back("campbell_modes.csv", table);
  }
  write_files_atomically(dir, files);
  std::string g =
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key outside right top font ',9'\n";
  fmt::format_to(std::back_inserter(g),
                 "set title \"gear train: modes in contact{} and {} orders (speed of '{}')\"\n"
                 "set xlabel 'speed of {} (Hz)'\nset ylabel 'frequency (Hz)'\n"
                 "set xrange [0:{}]\n",
                 turning ? ", in the turning frame," : "",
                 orders.empty() ? "mesh" : "mesh and excitation", quoted(t.reference),
                 quoted(t.reference), x_max);
  // With excitation orders (an engine's, low) and a mode far below the mesh orders' range (a
  // clutch damper's), a linear axis would flatten both onto zero: a logarithmic one shows them
  // beside the meshes'.
  double lowest = y_max;
  for (const train::TrainMode& x : modes)
    if (x.frequency_hz > 0) lowest = std::min(lowest, x.frequency_hz);
  if (!orders.empty() && lowest < kLinearCampbellShare * y_max) {
    // Down to a third of the lowest mode and of the slowest order at the operating speed.
    for (const auto& [name, ratio] : orders)
      if (ratio > 0) lowest = std::min(lowest, ratio * t.reference_speed_hz);
    fmt::format_to(std::back_inserter(g), "set logscale y\nset yrange [{}:{}]\n", lowest / 3,
                   y_max);
  } else {
    fmt::format_to(std::back_inserter(g), "set yrange [0:{}]\n", y_max);
  }
  std::vector<std::string> plots;
  std::string points;
  bool critical = false, other = false;
  if (turning) g += "$modes << EOD\n" + table + "EOD\n";
  for (std::size_t r = 0; r < modes.size(); ++r) {
    const train::TrainMode& x = modes[r];
    if (x.frequency_hz <= 0) continue;  // the free rotation
    // Above every mesh order in the speed range: no excitation reaches it (an arrow would be
    // drawn outside the graph).
    if (!turning && x.frequency_hz > y_max) continue;
    const bool excited = largest_mesh_energy(x) >= kMeshCritical;
    (excited ? critical : other) = true;
    const char* style = excited ? "lw 2 lc rgb '#1f4e9c'" : "lw 1 dt 3 lc rgb 'gray60'";
    if (turning)
      plots.push_back(
          fmt::format("$modes every ::1 using 1:{} with lines {} notitle", r + 2, style));
    else
      fmt::format_to(std::back_inserter(g), "set arrow from 0, {0} to {1}, {0} nohead {2}\n",
                     x.frequency_hz, x_max, style);
    for (std::size_t m = 0; excited && m < per_hz.size(); ++m)
      for (int i = 1; i <= kMeshOrders; ++i) {
        const double speed = resonance(r, i * per_hz[m]);
        if (speed <= x_max)
          fmt::format_to(std::back_inserter(points), "{},{}\n", speed,
                         turning ? speed * i * per_hz[m] : x.frequency_hz);
      }
  }
  // One line an order for each mesh frequency, whichever meshes share it (a planetary set's six
  // meshes at one frequency are one line, named by the first and their count).
  std::vector<std::pair<double, std::vector<std::string>>> frequencies;
  for (std::size_t m = 0; m < per_hz.size(); ++m) {
    auto same = std::find_if(frequencies.begin(), frequencies.end(), [&](const auto& f) {
      return std::abs(f.first - per_hz[m]) <= 1e-12 * per_hz[m];
    });
    if (same == frequencies.end())
      frequencies.push_back({per_hz[m], {t.meshes[m].name}});
    else
      same->second.push_back(t.meshes[m].name);
  }
  for (std::size_t k = 0; k < frequencies.size(); ++k) {
    const auto& [ratio, names] = frequencies[k];
    const std::string who = names.size() == 1 ? fmt::format("mesh {}", quoted(names[0]))
                                              : fmt::format("meshes {} and {} more",
                                                            quoted(names[0]), names.size() - 1);
    for (int i = 1; i <= kMeshOrders; ++i)
      plots.push_back(fmt::format("{} * x with lines lw 1.2 dt {} lc rgb '{}' title '{} order {}'",
                                  i * ratio, i, colour(k + 1), who, i));
  }
  // The excitation orders, dash-dotted, and where each meets any mode (each mode but the free
  // rotation: a torque's order strains whatever it reaches).
  std::string order_points;
  for (std::size_t k = 0; k < orders.size(); ++k) {
    plots.push_back(fmt::format("{} * x with lines lw 1.2 dt 4 lc rgb '{}' title '{}'",
                                orders[k].second, kOrderColours[k % kOrderColours.size()],
                                quoted(std::as_const(orders[k].first))));
    for (std::size_t r = 0; r < modes.size(); ++r) {
      if (modes[r].frequency_hz <= 0) continue;
      const double speed = resonance(r, orders[k].second);
      if (speed <= x_max)
        fmt::format_to(std::back_inserter(order_points), "{},{}\n", speed,
                       turning ? speed * orders[k].second : modes[r].frequency_hz);
    }
  }
  if (critical)
    plots.push_back(
        "keyentry with lines lw 2 lc rgb '#1f4e9c' title 'mode with >= 5 % energy in a mesh'");
  if (other) plots.push_back("keyentry with lines lw 1 dt 3 lc rgb 'gray60' title 'other mode'");
  if (!points.empty()) {
    g += "$crossings << EOD\n" + points + "EOD\n";
    plots.push_back(
        "$crossings using 1:2 with points pt 6 ps 1.5 lc rgb 'black' title 'resonance speed'");
  }
  if (!order_points.empty()) {
    g += "$order_crossings << EOD\n" + order_points + "EOD\n";
    plots.push_back(
        "$order_crossings using 1:2 with points pt 8 ps 1.5 lc rgb 'black' title 'resonance speed "
        "of an excitation order'");
  }
  fmt::format_to(std::back_inserter(g),
                 "set arrow from first {0}, graph 0 to first {0}, graph 1 nohead lw 1.5 dt 4 lc "
                 "rgb 'black'\n"
                 "set label 'operating speed' at first {0}, graph 0.97 left offset 0.3,0 font "
                 "',8'\n",
                 t.reference_speed_hz);
  g += "plot ";
  for (std::size_t k = 0; k < plots.size(); ++k) g += (k ? ", " : "") + plots[k];
  g += "\n";
  render_figure(dir, "campbell", g, 1100, 650);
}

}  // namespace geardyn
