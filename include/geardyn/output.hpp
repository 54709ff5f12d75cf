// geardyn: writing a run's results (summary.json, timeseries.csv, events.csv, case.toml).
//
// Files are written as a set into a folder the user may share with us (output_folder.hpp): only
// our files are replaced, each atomically, and a failure leaves the folder as it was.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "geardyn/output_folder.hpp"
#include "geardyn/run.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {

// `s` escaped for HTML text and attribute values (&, <, >, ").
std::string html_escape(const std::string& s);

// The derived geometry in case-file units (mm, deg), as `geardyn geometry --json` prints it.
std::string geometry_json(const Geometry& g);

// summary.json of a run, as text (every key of docs/outputs.md, named by form_key).
std::string summary_json(const RunResult& r, int indent = 2);

// timeseries.csv: header t_s,delta_bar,velocity_m_s,force_bar,contact (named by form_key).
std::string timeseries_csv(const Timeseries& s, ModelForm form = ModelForm::kGearPair);

// spectrum.csv: header frequency_hz,force_bar_amplitude,delta_bar_amplitude (steady part).
std::string spectrum_csv(const RunResult& r);

// events.csv: header t_s,kind,velocity_m_s (named by form_key).
std::string events_csv(const std::vector<ContactEvent>& events,
                       ModelForm form = ModelForm::kGearPair);

// The mesh stiffness of a case from its gear data, as `geardyn stiffness --json` prints it:
// {"iso6336": {q_prime, c_prime_th, c_prime, c_gamma_alpha, c_gamma_beta (N/(mm um)), ...},
//  "energy": {mean_n_per_m, min_n_per_m, max_n_per_m, harmonics: [[ratio, phase_deg]...],
//             mean_pairs_in_contact, truncation_error, ...}, "geometry": {...}}.
// `fourier` holds the kept harmonics of `cycle`.
std::string stiffness_json(const Case& c, const Geometry& g, const Iso6336Stiffness& iso,
                           const StiffnessCycle& cycle, const StiffnessFourier& fourier);

// stiffness.csv: position (fraction of the mesh cycle), position_mm (along the line of action),
// total_n_per_m (the computed curve), series_n_per_m (its kept harmonics), used_n_per_m (the
// stiffness a run of the case uses: its source, kept harmonics and mean scaling),
// pairs_in_contact, contact_length_mm and pair_<j>_n_per_m for each tooth pair.
std::string stiffness_csv(const Geometry& g, const StiffnessCycle& cycle,
                          const StiffnessFourier& fourier, const StiffnessFourier& used);

// timeseries.csv into a stream, row by row (timeseries_csv's text).
void write_timeseries_csv(std::ostream& out, const Timeseries& s,
                          ModelForm form = ModelForm::kGearPair);

// The run's files: summary.json, timeseries.csv, events.csv and case.toml.
void write_run(const std::filesystem::path& dir, const RunResult& r);

}  // namespace geardyn
