// geardyn: the figures of a gear train (train_figures.cpp): a run's time histories, spectra and
// phase portraits per mesh, its load sharing, and the Campbell diagram of its modes. Drawn as
// every figure is (figures.hpp: gnuplot, from data files written beside them).
#pragma once

#include <filesystem>
#include <vector>

#include "geardyn/train.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {

// The figures of a gear train's run, into a directory that already holds its timeseries.csv
// (write_train_timeseries_csv): train_time, one row per mesh with its deflection (d - e) / b
// and its force (N), with train_plot.csv beside it; train_spectrum (train_spectrum.csv);
// train_phase, each mesh's phase portrait ((d - e) / b against d' - e', from timeseries.csv);
// with load-sharing groups (a planetary set), load_sharing too: a row per group with each
// planet's mesh force and the factor over time, with load_sharing_plot.csv. `physical`: the
// spectra of each mesh's force in N and its deflection d - e in um (train_spectrum.csv's
// <mesh>_force_n and <mesh>_deflection_um) in place of F / (b k_m) and (d - e) / b.
void write_train_run_figures(const std::filesystem::path& dir, const TrainRunResult& r,
                             bool physical = false);

// The Campbell diagram of a train (campbell .png .svg .gp, campbell.csv): its modes in contact
// against the reference body's speed, from rest to 1.5 times the case's operating speed and up
// to the frequencies the mesh orders reach there, with the first three orders of every mesh's
// frequency (one line an order for meshes of one frequency);
// the modes that hold at least 5 % of their strain energy in some mesh bold, and where a mesh
// order crosses one of them marked.
void write_train_campbell_figure(const std::filesystem::path& dir, const train::Assembled& a,
                                 const std::vector<train::TrainMode>& modes);

}  // namespace geardyn
