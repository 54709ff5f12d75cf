// geardyn: writing a run's results (summary.json, timeseries.csv, events.csv, case.toml).
//
// Files are written atomically as a set: each to a temporary name in the output directory
// first, then all renamed into place, so a failure leaves no half-written output.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "geardyn/run.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {

// The derived geometry in case-file units (mm, deg), as `geardyn geometry --json` prints it.
std::string geometry_json(const Geometry& g);

// summary.json of a run, as text (every key of docs/outputs.md).
std::string summary_json(const RunResult& r, int indent = 2);

// timeseries.csv: header t_s,delta_bar,velocity_m_s,force_bar,contact.
std::string timeseries_csv(const Timeseries& s);

// spectrum.csv: header frequency_hz,force_bar_amplitude,delta_bar_amplitude (steady part).
std::string spectrum_csv(const RunResult& r);

// events.csv: header t_s,kind,velocity_m_s.
std::string events_csv(const std::vector<ContactEvent>& events);

// The mesh stiffness of a case from its gear data, as `geardyn stiffness --json` prints it:
// {"iso6336": {q_prime, c_prime_th, c_prime, c_gamma_alpha, c_gamma_beta (N/(mm um)), ...},
//  "energy": {mean_n_per_m, min_n_per_m, max_n_per_m, harmonics: [[ratio, phase_deg]...],
//             mean_pairs_in_contact, truncation_error, ...}, "geometry": {...}}.
// `fourier` holds the kept harmonics of `cycle`.
std::string stiffness_json(const Case& c, const Geometry& g, const Iso6336Stiffness& iso,
                           const StiffnessCycle& cycle, const StiffnessFourier& fourier);

// stiffness.csv: position (fraction of the mesh cycle), position_mm (along the line of action),
// total_n_per_m, series_n_per_m (the kept harmonics), pairs_in_contact, contact_length_mm and
// pair_<j>_n_per_m for each tooth pair.
std::string stiffness_csv(const Geometry& g, const StiffnessCycle& cycle,
                          const StiffnessFourier& fourier);

// Writes the named files into `dir` (created if missing) all or nothing.
// Throws std::runtime_error naming the path on an I/O failure.
void write_files_atomically(const std::filesystem::path& dir,
                            const std::vector<std::pair<std::string, std::string>>& files);

// The run's files: summary.json, timeseries.csv, events.csv and case.toml.
void write_run(const std::filesystem::path& dir, const RunResult& r);

}  // namespace geardyn
