// geardyn: what a case assembles to before any run, for the user to check against their own
// numbers: every body's absolute speed, frame, inertia and mass (given or derived from its gear
// data), every mesh's frame, frequency, stiffness, damping coefficient, backlash and static
// force, every shaft's and bearing's stiffness and damping coefficient (as derived from its
// damping ratio), every torque as applied (a reaction's as computed), and the case's
// plausibility warnings (train_plausibility). Any form: a pair's as its train of elements.
#pragma once

#include <string>

#include "geardyn/case.hpp"

namespace geardyn {

// The description as JSON (an object: reference, bodies, meshes, shafts, bearings, torques,
// warnings; SI units in every name), or as the aligned text `geardyn describe` prints. Throws
// InputError as assembling the train does.
std::string describe_json(const Case& c);
std::string describe_text(const Case& c);

}  // namespace geardyn
