// geardyn: the nominal motion of a train of gears, its frames and its speeds, solved exactly in
// ratios of whole numbers. Below the train's assembler (train.hpp), which reads every speed, mesh
// frequency and frame from here; it knows bodies, meshes, shafts and pins by index only.
//
// Frames. A drivetrain has one frame per carrier, and the ground's. A carrier is a body that
// carries others on pins (a planetary set's planets); it may turn, be driven, be held or be the
// reference. A mesh belongs to the frame of the carrier whose pin holds one of its gears (a sun's
// or a ring's mesh with a planet, a planet's with another planet on the same carrier), or to the
// ground's when neither gear rides on a pin (a fixed-axis stage). A body's translations are read
// in one frame: a carrier's in its own, a planet's in its carrier's, a body that meshes only in
// one carrier's frame (a sun, a ring) in that carrier's, every other body in the ground's; a body
// that meshes in two frames has none (kMixedFrame), and keeps its rotation only.
//
// Nominal motion. Every body's absolute angular speed w_i (counterclockwise positive) follows
// from
//   - each mesh between gears a and b in the frame of carrier c (w_c = 0 for the ground's),
//     Willis's equation: the mesh turns as a fixed-axis pair seen from its carrier,
//       z_a (w_a - w_c) = -z_b (w_b - w_c)  (external),   z_a (w_a - w_c) = z_b (w_b - w_c)
//       (internal);
//   - each shaft joining a and b: w_a = w_b; each shaft holding a to the ground (a torsional
//     support: a ring or a sun held in its housing, a carrier held by a brake): w_a = 0;
//   - the reference: w_ref = its given speed (counterclockwise).
// The constraints are solved by exact elimination: a train whose constraints disagree cannot turn
// (refused naming the element that closes the disagreeing loop, or the support that holds a body
// the train turns); a train that leaves a speed free (a planetary set with no member held) is
// refused naming the bodies. A mesh's frequency is z_a |w_a - w_c|, and an order of a body's
// speed is of its |w_i|.
//
// Senses. Each body's rotation coordinate is counted positive in a sense s_i = +-1 that an
// external mesh reverses and an internal mesh or a shaft keeps, so that one sign rule, the mesh
// deflection R_a theta_a - R_b theta_b, serves every mesh. The reference's sense is
// counterclockwise; each part of the train that meshes and shafts do not join to the reference
// (a planetary set joined to it through its carrier's pins only) takes the sense in which its
// first gear turns forward relative to its mesh's frame. A body's speed is reported in its sense:
// s_i w_i / w_ref, negative where it turns against it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace geardyn::train {

// A ratio of whole numbers, for speeds and mesh frequencies over the reference speed: trains
// are made of teeth counts, so their frequencies are commensurate exactly. den > 0.
struct Ratio {
  std::int64_t num = 0, den = 1;
};

// The graph the nominal motion is solved on: bodies by index, each element named as messages
// name it ("mesh 'first'").
struct KinematicGraph {
  struct Mesh {
    std::string element;
    int a = 0, b = 0;  // the driving and the driven gear
    int teeth_a = 0, teeth_b = 0;
    bool internal = false;
  };
  struct Shaft {
    std::string element;
    int a = 0, b = 0;  // b = kToGround: a support holding a
  };
  struct Pin {
    std::string element;
    int body = 0, carrier = 0;
  };
  static constexpr int kToGround = -1;
  std::vector<std::string> bodies;
  int reference = 0;
  std::vector<Mesh> meshes;
  std::vector<Shaft> shafts;
  std::vector<Pin> pins;
};

// The ground's frame, and a body that meshes in two frames.
inline constexpr int kGroundFrame = -1;
inline constexpr int kMixedFrame = -2;

struct NominalMotion {
  std::vector<int> sense;        // s_i
  std::vector<Ratio> speed;      // s_i w_i / w_ref
  std::vector<int> frame;        // each body's: its carrier's index, kGroundFrame or kMixedFrame
  std::vector<int> mesh_frame;   // each mesh's: its carrier's index or kGroundFrame
  std::vector<bool> is_carrier;  // each body's: it carries others on pins
  // Body i's speed relative to frame f (a carrier's index or kGroundFrame) over w_ref, in i's
  // sense: s_i (w_i - w_f) / w_ref.
  Ratio relative(int body, int frame) const;
  // z_a |w_a - w_c| / w_ref of mesh m (teeth z_a of its driving gear a).
  Ratio mesh_frequency(int mesh, const KinematicGraph& g) const;
};

// Throws InputError (case.hpp) naming the element: a body joined to the reference by no mesh,
// shaft or pin, a loop whose senses or speeds disagree, a support holding a body the train turns,
// a speed left free, a body on pins of two carriers, a mesh whose gears ride on two carriers or
// whose carrier is one of its gears, ratios past 18 digits.
NominalMotion solve_nominal_motion(const KinematicGraph& g);

// Arithmetic on ratios, exact; throws InputError past 18 digits.
Ratio reduced(std::int64_t num, std::int64_t den);
Ratio times(Ratio a, std::int64_t num, std::int64_t den);
Ratio plus(Ratio a, Ratio b);
Ratio minus(Ratio a, Ratio b);
Ratio absolute(Ratio a);
bool same(Ratio a, Ratio b);
double value(Ratio r);

}  // namespace geardyn::train
