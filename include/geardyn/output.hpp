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

namespace geardyn {

// summary.json of a run, as text (every key of docs/outputs.md).
std::string summary_json(const RunResult& r, int indent = 2);

// timeseries.csv: header t_s,delta_bar,velocity_m_s,force_bar,contact.
std::string timeseries_csv(const Timeseries& s);

// spectrum.csv: header frequency_hz,force_bar_amplitude,delta_bar_amplitude (steady part).
std::string spectrum_csv(const RunResult& r);

// events.csv: header t_s,kind,velocity_m_s.
std::string events_csv(const std::vector<ContactEvent>& events);

// Writes the named files into `dir` (created if missing) all or nothing.
// Throws std::runtime_error naming the path on an I/O failure.
void write_files_atomically(const std::filesystem::path& dir,
                            const std::vector<std::pair<std::string, std::string>>& files);

// The run's files: summary.json, timeseries.csv, events.csv and case.toml.
void write_run(const std::filesystem::path& dir, const RunResult& r);

}  // namespace geardyn
