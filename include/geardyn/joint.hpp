// geardyn: the joint, a piecewise-linear force along one deformation of a train, and the
// element interface through which a kind of element gives the assembler its joints without the
// assembler knowing the kind (elements layer, beside train.hpp).
//
// A joint acts along x = row q - offset (m or rad), row a row over the train's coordinates q. Its
// characteristic is piecewise linear in x: the edges e_0 < e_1 < ... cut the line into stages
// s = 0 .. edges.size(), and in stage s its force is
//
//   f = k_s x + f_s + c_s x',
//
// which acts on the bodies as the generalised force -row^T f (f pushes x back). A bearing's
// clearance in one direction is a joint of three stages (k (x + c), nothing, k (x - c)); a clutch
// damper's free play, stages and stops one of five or more. The exact engine integrates each
// stage as one region and locates x crossing an edge as a guard: the joint is exact, no
// smoothing.
//
// A joint of one stage that is not read (a drag) is a link (train.hpp, Assembled::links()): it
// acts alike in every region, so it has no contact states and is no contact part of a study.
//
// Contact states. A joint's state is its stage less its rest stage (the stage x = 0 lies in):
// 0 at rest, > 0 beyond it in +x (the drive side), < 0 in -x. A joint of three stages has the
// states -1, 0, 1, as a mesh's back side, backlash and drive side.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace geardyn::train {

class Assembled;  // train.hpp

// One stage: f = stiffness x + force_at_zero + damping x' (units of the joint's force per unit
// of x: N/m or N m/rad; N or N m; per unit rate).
struct JointStage {
  double stiffness = 0;
  double force_at_zero = 0;
  double damping = 0;
};

struct Joint {
  // Its name among the train's contact parts and readings ("<bearing>_x", "<damper>").
  std::string name;
  Eigen::RowVectorXd row;  // x = row q - offset
  double offset = 0;
  std::vector<double> edges;       // ascending
  std::vector<JointStage> stages;  // edges.size() + 1
  // The stage x = 0 lies in: its state 0.
  int rest = 0;
  // The guards' scale (the size of x that counts, m or rad): a crossing is located to the
  // engine's tolerance times it.
  double scale = 1;
  // Whether the joint is read as a part of the train (its force and x in every run's readings,
  // named `force_what` and `deformation_what`: "torque_nm", "twist_rad"); a bearing's clearance
  // direction is read as its bearing's force instead.
  bool read = false;
  std::string force_what, deformation_what;
  // Whether the linearisation (modes, the static state) takes the joint at its operating stage
  // (Assembled::operating_stages: the stage of the static state); false: its owner stamps its
  // own linearisation (a bearing's clearance: the bearing as if it had none).
  bool linearised = true;
  // The stage the linearisation takes until the static state places the joint
  // (settle_joints, train_statics.hpp): the stage the element expects to carry the load.
  int operating = 0;
  // Whether its outermost stages on either side are stops (a clutch damper's): a static load
  // resting on one is more than the element carries before it, which the case's plausibility
  // warnings say (plausibility.hpp).
  bool stops = false;
  // How messages name the element it belongs to ("damper 'clutch'"), set by the assembler.
  std::string label;

  int stage_count() const { return static_cast<int>(stages.size()); }
  // The stage x lies in (an edge belongs to the stage above it).
  int stage_at(double x) const;
  double force(int stage, double x, double rate) const {
    const JointStage& s = stages[static_cast<std::size_t>(stage)];
    return s.stiffness * x + s.force_at_zero + s.damping * rate;
  }
  // The strain energy stored at x, the integral of the spring force (k_s x + f_s) from 0 to x
  // along the stages it crosses (J).
  double energy(double x) const;
};

// A kind of element the assembler takes without knowing it (a clutch damper): it names the
// bodies it joins, what it holds at one nominal speed, and gives its joints over the assembled
// train's coordinates. The assembler checks the names, adds the couplings to the train's
// kinematics and the joints to its regions, guards, readings and linearisation.
class Element {
 public:
  virtual ~Element() = default;
  // How messages name it: "damper 'clutch'".
  virtual std::string label() const = 0;
  // Each body it joins, as (key, name): ("from", "engine").
  virtual std::vector<std::array<std::string, 2>> bodies() const = 0;
  // Each pair of bodies it turns at one nominal speed, as a shaft does (b may be kGround: held).
  virtual std::vector<std::array<std::string, 2>> couplings() const { return {}; }
  // Its joints over a's coordinates (a's bodies and coordinates are set; its joints are not).
  // Throws InputError naming the element and the key for values it cannot take.
  virtual std::vector<Joint> joints(const Assembled& a) const = 0;
};

}  // namespace geardyn::train
