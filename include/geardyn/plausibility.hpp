// geardyn: what a train case implies that is likely a mistake, said before any work.
//
// Each warning names the element, the key as written, where it was written and its value, and
// says what the case more likely meant. A warning is no refusal: the case runs as written.
#pragma once

#include <string>
#include <vector>

#include "geardyn/case.hpp"

namespace geardyn {

// The warnings of a train case (empty for a case of another form):
// - a mesh loaded on its back flank at rest (its driving and driven gears the wrong way round,
//   or a torque's sign);
// - a planet pin's radius off its gears' centre distance by more than kPinRadiusTolerance
//   (train_case.hpp), or a
//   planet whose meshes (with its sun and its ring) put it at centre distances that differ by
//   more (profile shifts that make no planetary set, or a ring's shift of the other sign);
// - a backlash below kLeastBacklashShare of the least a gear pair of its module and centre
//   distance is cut with (a value in millimetres read as micrometres);
// - a module below kFinestModuleMm (a value in metres read as millimetres);
// - a pitch-line speed above kFastestPitchLineSpeedMPerS (a speed in rpm read as Hz);
// - a nominal contact stress at rest above kMostContactStressMpa (a torque in N mm read as N m);
// - a joint with stops (a clutch damper's) resting on one at the static load (a stage too soft
//   or too short for the torque), and a joint whose static load lies in another stage than the
//   one modes and the static state take (settle_joints did not settle it).
// Where the train does not assemble or has no static state, the checks that need it are left
// to the run, which says why.
std::vector<std::string> train_plausibility(const Case& c);

// The least backlash of a gear pair (the normal backlash j_bn of AGMA's recommendation, (2/3)
// (0.06 + 0.0005 a + 0.03 m_n) mm, for a centre distance a and module m_n in mm; a mesh's b is
// half of it): a backlash under this share of it is no gear's.
constexpr double kLeastBacklashShare = 0.01;
// The finest module gears are cut with (watch and instrument gears), mm.
constexpr double kFinestModuleMm = 0.05;
// Above the fastest turbo gears' pitch-line speeds (about 200 m/s).
constexpr double kFastestPitchLineSpeedMPerS = 250;
// Three times the contact stress case-hardened steel bears (about 1500 MPa, ISO 6336-5).
constexpr double kMostContactStressMpa = 4500;

}  // namespace geardyn
