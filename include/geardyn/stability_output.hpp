// geardyn: a stability study's files and figures (stability_output.cpp), output layer.
#pragma once

#include <filesystem>
#include <string>

#include "geardyn/stability.hpp"

namespace geardyn {

// stability.csv (param[,param2],stable,max_multiplier,mu1_re,mu1_im,mu2_re,mu2_im) and
// boundaries.json ({"boundaries": [{"param", ["param2",] "type"}]}), all or nothing; with
// `figures`, the figure `stability` (max |mu| along the key with the boundaries marked, or the
// chart of the unstable regions over the two keys).
void write_stability(const std::filesystem::path& dir, const StabilityResult& r,
                     const StabilityOptions& o, bool figures = true);

// boundaries.json's text.
std::string boundaries_json(const StabilityResult& r, bool chart);

}  // namespace geardyn
