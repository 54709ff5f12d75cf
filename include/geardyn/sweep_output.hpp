// geardyn: a sweep's files and figures (sweep_output.cpp), output layer.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "geardyn/sweep.hpp"

namespace geardyn {

// sweep.csv (one row per point and direction), strobe.csv, summary.json, and with `figures` the
// frequency-response curve, the bifurcation diagram, (2-D) the regime map and (a 1-D sweep of a
// train or a coupled pair) each mesh's response and the bearings' and shafts' loads
// (mesh_responses, part_forces), PNG and SVG. Returns the names of the figures drawn.
std::vector<std::string> write_sweep(const std::filesystem::path& dir, const SweepResult& r,
                                     bool figures = true);

std::string sweep_csv(const SweepResult& r);

}  // namespace geardyn
