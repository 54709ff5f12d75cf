// geardyn: a continuation's files and figures (continuation_output.cpp), output layer.
#pragma once

#include <filesystem>
#include <string>

#include "geardyn/continuation.hpp"

namespace geardyn {

// branch.csv: one row per point, header
// param,stable,x_a,min_delta_bar,max_delta_bar,max_force_bar,impacts_per_period,max_multiplier,
// min_force_bar,backside_impacts_per_period,separations_per_period, the state on the section
// t = 0 (state_names: delta_m,velocity_m_s for the one-degree model), mu1_re,mu1_im,mu2_re,
// mu2_im,branch,periods (x_a = (max - min) / 2 of delta_bar; multipliers largest first),
// numbers to 17 significant digits.
std::string branch_csv(const ContinuationResult& r);

// bifurcations.json: [{"type", "param", "branch", "detail", "x_a", "impacts_per_period",
// "state", "floquet_multipliers"}, ...].
std::string bifurcations_json(const ContinuationResult& r);

// Writes branch.csv, bifurcations.json and bifurcations.csv (param,x_a,type) into dir, all or
// nothing, and with `figures` the figure `branch` (x_a against the key: stable solid, unstable
// dashed, bifurcations marked). `sweep_csv`, when not empty, is the text of a `geardyn sweep`
// sweep.csv along the same key: its up and down points ((max - min)/2 of delta_bar) are
// written to overlay.csv and drawn over the branch. Throws InputError on a sweep.csv that is
// not one, std::runtime_error on I/O, FigureError on gnuplot.
void write_continuation(const std::filesystem::path& dir, const ContinuationResult& r,
                        const std::string& key, bool figures = true,
                        const std::string& sweep_csv = {});

}  // namespace geardyn
