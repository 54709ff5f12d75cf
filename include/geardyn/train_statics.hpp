// geardyn: a train's static state (train_statics.cpp), where its runs start and from which its
// readings' static values, the ISO 6336 meshes' loads and the plausibility checks are read:
// model layer, below every study.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/train.hpp"

namespace geardyn {

// The static state (theta, theta') of the train in drive contact at every mesh's mean
// stiffness under the mean torques and constant drags. The bodies with a prescribed speed are
// held at their nominal place, or with `at_s` at their prescription's place and rate at that
// time, the free bodies following them quasi-statically (their rates too: a start at t0 without
// a jolt). With `at_s` each mesh's error (transmission error and runouts) at that time loads it
// too, as the one-degree model starts at rest relative to its error: d - e(t0) in place of d,
// the rates following e'(t0) quasi-statically (a start without the jolt of an error that turns
// on); without it the state is the mean one the readings' static values use, each mesh's error
// there its constant part (Mesh::transmission_error_mean_m). The motions no
// element resists (Assembled::rigid_motions(): with no prescribed body and no support, the
// train's rigid rotation, r the speed ratios) are left out (R^T theta = 0, R^T theta' = 0).
// Absent, with `why`, when the mean torques do work on such a motion (the train would speed up
// or slow down: there is no static state), or when a prescribed speed leaves one.

std::optional<Eigen::VectorXd> static_state(const train::Assembled& a, std::string* why = nullptr,
                                            std::optional<double> at_s = std::nullopt);
// Places each joint's operating stage (train::Assembled::operating_stages) where the static
// state puts its x: the static state solved with the joints at their stages, each moved to the
// stage its x lies in, until none moves (at most kJointSettlingPasses solves; a joint's
// characteristic that stiffens as it turns settles in a few). Left as assembled where the train
// has no static state.
constexpr int kJointSettlingPasses = 20;
void settle_joints(train::Assembled& a);
// solver.initial = "center" at t: at rest in the middle of every backlash relative to its mesh's
// error, as the one-degree model's x = delta - e = 0, x' = 0: the quasi-static state under the
// errors alone at t (no torque, no backlash), each mesh's d = e(t) and d' = e'(t) where the
// train lets them be, the prescribed bodies as prescribed; 0 (and the prescriptions) without an
// error, or where the train has no such state (a prescribed speed leaving a part free).
Eigen::VectorXd rest_state(const train::Assembled& a, double at_s);
// Each mesh's force k_m (V theta - e_mean - b) in such a state (e_mean the error's constant
// part).
std::vector<double> static_mesh_forces_n(const train::Assembled& a, const Eigen::VectorXd& y);

}  // namespace geardyn
