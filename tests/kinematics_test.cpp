// A train's nominal motion (kinematics.hpp): every body's speed and every mesh's frequency
// against Willis's equation for carrier-, ring- and sun-driven sets, a stepped-planet compound
// set and two sets in series, a planetary stage followed by fixed-axis stages (the wind-turbine
// gearbox, whose parallel stages turn at the ground's speeds, not the carrier's), the frames'
// assignment, and the trains whose motion is locked or left free, refused naming the element.
// The speeds are checked against the stiffness too: a set's free rigid motion (the null space
// of its assembled K, from the base radii and the pin radius) turns each body at its speed.
#include "geardyn/kinematics.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/train.hpp"
#include "test_support.hpp"

namespace geardyn::train {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kAlpha = 20 * kPi / 180;
constexpr double kModuleM = 0.002;

// A gear's base radius from its teeth, module 2 mm at 20 deg: radii in the teeth's ratio, so
// that the stiffness's kinematics are the teeth's.
double base_radius(int teeth) { return 0.5 * kModuleM * teeth * std::cos(kAlpha); }

Mesh gear_mesh(const std::string& name, const std::string& a, const std::string& b, int za, int zb,
               double psi_rad, bool internal = false) {
  Mesh m =
      geardyn::testing::mesh(name, a, b, {za, zb}, {base_radius(za), base_radius(zb)}, 5e-5, 5e8);
  m.internal = internal;
  m.position_angle_rad = psi_rad;
  m.transverse_pressure_angle_rad = kAlpha;
  return m;
}

struct Stage {
  int sun = 21, planet = 39, ring = 99, planets = 3;
};

// One planetary stage, its members named <prefix>sun, <prefix>ring, <prefix>carrier and
// <prefix>p1...: planar, on bearings, the planets on pins of the carrier at the centre distance.
void add_stage(Train& t, const std::string& prefix, const Stage& s) {
  const std::string sun = prefix + "sun", ring = prefix + "ring", carrier = prefix + "carrier";
  t.bodies.push_back({sun, 0.01, true, 1.0});
  t.bodies.push_back({ring, 0.5, true, 5.0});
  t.bodies.push_back({carrier, 0.8, true, 8.0});
  for (const std::string& b : {sun, ring, carrier})
    t.bearings.push_back({b + "_bearing", b, 1e8, 0});
  const double pin_m = 0.5 * kModuleM * (s.sun + s.planet);
  for (int n = 0; n < s.planets; ++n) {
    const std::string p = prefix + "p" + std::to_string(n + 1);
    const double psi = 2 * kPi * n / s.planets;
    t.bodies.push_back({p, 0.02, true, 2.0});
    t.bearings.push_back({p + "_pin", p, 1e8, 0.0, carrier, pin_m, psi});
    const std::string n1 = std::to_string(n + 1);
    t.meshes.push_back(gear_mesh(prefix + "sp" + n1, sun, p, s.sun, s.planet, psi));
    t.meshes.push_back(gear_mesh(prefix + "rp" + n1, p, ring, s.planet, s.ring, psi + kPi, true));
  }
}

void hold(Train& t, const std::string& body) {
  t.shafts.push_back({body + "_held", body, kGround, 1e8, 0.0});
}

double speed(const Assembled& a, const std::string& body) { return a.body_speed_hz(a.index(body)); }

double mesh_hz(const Assembled& a, const std::string& name) {
  for (std::size_t m = 0; m < a.train().meshes.size(); ++m)
    if (a.train().meshes[m].name == name) return a.mesh_frequency_hz(static_cast<int>(m));
  ADD_FAILURE() << "no mesh " << name;
  return 0;
}

// The set's free rigid motion, from K, turns each body at its speed over the reference's.
void expect_rigid_motion_is_the_speeds(const Assembled& a) {
  const Eigen::MatrixXd r = a.rigid_motions();
  ASSERT_EQ(r.cols(), 1);
  for (int i = 0; i < a.body_count(); ++i)
    EXPECT_NEAR(r(i, 0), value(a.speed_ratios()[static_cast<std::size_t>(i)]), 1e-9)
        << a.train().bodies[static_cast<std::size_t>(i)].name;
}

// Carrier driven (the rotor), ring held, sun the output: w_s = w_c (1 + z_r / z_s); every mesh
// at z_r w_c; a planet at -w_c z_r / z_p relative to its carrier.
TEST(Kinematics, ACarrierDrivenSetWithItsRingHeldIsWillis) {
  Train t;
  add_stage(t, "", {});
  hold(t, "ring");
  t.reference = "carrier";
  t.reference_speed_hz = 0.3;
  const Assembled a(t);
  const double wc = 0.3;
  EXPECT_NEAR(speed(a, "sun") / (wc * (1 + 99.0 / 21)), 1.0, 1e-15);
  EXPECT_EQ(speed(a, "ring"), 0.0);
  EXPECT_NEAR(speed(a, "carrier"), wc, 1e-15);
  EXPECT_NEAR(speed(a, "p1") / (wc * (1 - 99.0 / 39)), 1.0, 1e-14);
  for (const char* m : {"sp1", "rp1", "sp3", "rp3"})
    EXPECT_NEAR(mesh_hz(a, m) / (99 * wc), 1.0, 1e-15) << m;
  EXPECT_EQ(a.frame(a.index("p1")), a.index("carrier"));
  EXPECT_EQ(a.frame(a.index("sun")), a.index("carrier"));
  EXPECT_EQ(a.mesh_frame(0), a.index("carrier"));
  expect_rigid_motion_is_the_speeds(a);
}

// Ring driven, sun held, carrier the output: w_c = w_r z_r / (z_r + z_s); sun driven, ring held:
// w_c = w_s z_s / (z_s + z_r); sun driven, carrier held (a star): w_r = -w_s z_s / z_r, the
// meshes at z_s w_s as a fixed-axis train's.
// The stage with one member held and another turned at its speed, its rigid motion checked.
Assembled held_stage(const std::string& held, const std::string& reference, double speed_hz) {
  Train t;
  add_stage(t, "", {});
  hold(t, held);
  t.reference = reference;
  t.reference_speed_hz = speed_hz;
  Assembled a(t);
  expect_rigid_motion_is_the_speeds(a);
  return a;
}

TEST(Kinematics, RingDrivenSunDrivenAndStarSetsAreWillis) {
  const Assembled ring_driven = held_stage("sun", "ring", 10);
  EXPECT_NEAR(speed(ring_driven, "carrier") / (10 * 99.0 / 120), 1.0, 1e-15);
  EXPECT_NEAR(mesh_hz(ring_driven, "sp2") / (21 * 10 * 99.0 / 120), 1.0, 1e-15);
  const Assembled sun_driven = held_stage("ring", "sun", 40);
  EXPECT_NEAR(speed(sun_driven, "carrier") / (40 * 21.0 / 120), 1.0, 1e-15);
  // Relative to the carrier the sun turns at 40 (1 - 21 / 120): the mesh frequency.
  EXPECT_NEAR(mesh_hz(sun_driven, "sp1") / (21 * 40 * 99.0 / 120), 1.0, 1e-15);
  const Assembled star = held_stage("carrier", "sun", 40);
  EXPECT_NEAR(speed(star, "ring") / (-40 * 21.0 / 99), 1.0, 1e-15);
  EXPECT_EQ(speed(star, "carrier"), 0.0);
  EXPECT_NEAR(mesh_hz(star, "rp1") / (21 * 40.0), 1.0, 1e-15);
}

// Stepped planets (a compound set: each planet one body with a gear of z_p1 on the sun and
// another of z_p2 in the ring), ring held, carrier driven: w_s = w_c (1 + z_p1 z_r / (z_s z_p2)).
TEST(Kinematics, ASteppedPlanetSetIsWillis) {
  Train t;
  t.bodies.push_back({"sun", 0.01});
  t.bodies.push_back({"ring", 0.5});
  t.bodies.push_back({"carrier", 0.8, true, 8.0});
  t.bearings.push_back({"carrier_bearing", "carrier", 1e8, 0});
  for (int n = 0; n < 3; ++n) {
    const std::string p = "p" + std::to_string(n + 1);
    t.bodies.push_back({p, 0.02, true, 2.0});
    t.bearings.push_back({p + "_pin", p, 1e8, 0.0, "carrier", 0.05, 2 * kPi * n / 3});
    t.meshes.push_back(gear_mesh("s" + p, "sun", p, 18, 36, 2 * kPi * n / 3));
    t.meshes.push_back(gear_mesh("r" + p, p, "ring", 24, 78, 2 * kPi * n / 3 + kPi, true));
  }
  hold(t, "ring");
  t.reference = "carrier";
  t.reference_speed_hz = 2;
  const Assembled a(t);
  EXPECT_NEAR(speed(a, "sun") / (2 * (1 + 36.0 * 78 / (18.0 * 24))), 1.0, 1e-15);
  EXPECT_NEAR(mesh_hz(a, "rp1") / (78 * 2.0), 1.0, 1e-15);
  // Relative to the carrier the planet turns at -w_c z_r / z_p2, so the sun mesh at z_p1 times it.
  EXPECT_NEAR(mesh_hz(a, "sp1") / (36 * 2 * 78.0 / 24), 1.0, 1e-15);
}

// Two sets in series, the first's sun driving the second's carrier, both rings held:
// w_s2 = w_c1 (1 + z_r1 / z_s1) (1 + z_r2 / z_s2); each set's meshes at its own z_r w_c.
TEST(Kinematics, TwoSetsInSeriesMultiplyTheirRatios) {
  Train t;
  add_stage(t, "a_", {});
  add_stage(t, "b_", {24, 27, 78, 3});
  hold(t, "a_ring");
  hold(t, "b_ring");
  t.shafts.push_back({"between", "a_sun", "b_carrier", 1e7, 0.0});
  t.reference = "a_carrier";
  t.reference_speed_hz = 0.25;
  const Assembled a(t);
  const double wc2 = 0.25 * (1 + 99.0 / 21);
  EXPECT_NEAR(speed(a, "b_carrier") / wc2, 1.0, 1e-15);
  EXPECT_NEAR(speed(a, "b_sun") / (wc2 * (1 + 78.0 / 24)), 1.0, 1e-15);
  EXPECT_NEAR(mesh_hz(a, "a_rp1") / (99 * 0.25), 1.0, 1e-15);
  EXPECT_NEAR(mesh_hz(a, "b_sp2") / (78 * wc2), 1.0, 1e-15);
  EXPECT_EQ(a.frame(a.index("b_p1")), a.index("b_carrier"));
  EXPECT_EQ(a.frame(a.index("a_p1")), a.index("a_carrier"));
}

// The wind-turbine gearbox: the rotor drives the carrier through a shaft, the ring is held, the
// sun drives two fixed-axis parallel stages to the generator. The parallel meshes turn at the
// ground's speeds (the sun's absolute speed times the teeth), not the carrier-relative ones, and
// the rotor's torque may fluctuate at its own orders (3P).
TEST(Kinematics, AFixedAxisStageBehindATurningCarrierTurnsAtItsAbsoluteSpeed) {
  Train t;
  add_stage(t, "", {});
  hold(t, "ring");
  t.bodies.push_back({"rotor", 1e6});
  t.bodies.push_back({"wheel1", 2.0});
  t.bodies.push_back({"pinion1", 0.05});
  t.bodies.push_back({"wheel2", 1.0});
  t.bodies.push_back({"pinion2", 0.02});
  t.bodies.push_back({"generator", 20.0});
  t.shafts.push_back({"main_shaft", "rotor", "carrier", 1e8, 0.0});
  t.shafts.push_back({"sun_shaft", "sun", "wheel1", 1e7, 0.0});
  t.shafts.push_back({"intermediate", "pinion1", "wheel2", 1e7, 0.0});
  t.shafts.push_back({"hss", "pinion2", "generator", 1e6, 0.0});
  t.meshes.push_back(gear_mesh("stage2", "wheel1", "pinion1", 82, 23, 0));
  t.meshes.push_back(gear_mesh("stage3", "wheel2", "pinion2", 88, 22, 0));
  t.torques.push_back({"rotor", "rotor", 3e5, {{3e4, 3.0, 0.0}}});
  t.reference = "rotor";
  t.reference_speed_hz = 0.3;
  const Assembled a(t);
  const double sun = 0.3 * (1 + 99.0 / 21), generator = sun * 82 / 23 * 88 / 22;
  EXPECT_NEAR(std::abs(speed(a, "generator")) / generator, 1.0, 1e-15);
  EXPECT_NEAR(mesh_hz(a, "stage2") / (82 * sun), 1.0, 1e-15);
  EXPECT_NEAR(mesh_hz(a, "stage3") / (88 * sun * 82 / 23), 1.0, 1e-15);
  // The carrier-relative speed of the sun would give the parallel stage 99/120 of this.
  EXPECT_GT(mesh_hz(a, "stage2") / (82 * sun * 99 / 120), 1.2);
  EXPECT_EQ(a.frame(a.index("wheel1")), kGroundFrame);
  EXPECT_EQ(a.frame(a.index("rotor")), kGroundFrame);
  // The rotor's 3P at three times its own 0.3 Hz.
  const HarmonicSeries rotor = a.torque_series(0);
  ASSERT_EQ(rotor.terms.size(), 1U);
  EXPECT_NEAR(rotor.terms[0].angular_frequency_rad_s / (2 * kPi * 0.9), 1.0, 1e-15);
  // Senses: the sun and the fixed-axis wheel on its shaft are counted alike.
  EXPECT_EQ(a.sense(a.index("sun")), a.sense(a.index("wheel1")));
  EXPECT_EQ(a.sense(a.index("pinion1")), -a.sense(a.index("wheel1")));
}

// Refused, naming the element: a support on a body the train turns, a set that no member holds
// (a differential), a mesh between gears on two carriers, a carrier meshing with its own
// planet, a planar body meshing in two frames.
TEST(Kinematics, ALockedOrFreeMotionIsRefusedNamingTheElement) {
  const auto refused = [](const Train& t, const std::string& piece) {
    try {
      const Assembled a(t);
      ADD_FAILURE() << "accepted; expected: " << piece;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(piece), std::string::npos) << e.what();
    }
  };
  Train t;
  add_stage(t, "", {});
  t.reference = "sun";
  t.reference_speed_hz = 10;
  refused(t, "the reference's speed leaves the speeds of 'ring', 'carrier'");
  Train both = t;
  hold(both, "ring");
  hold(both, "carrier");
  refused(both,
          "shaft 'carrier_held': holds body 'carrier' to the ground (a support: it cannot "
          "turn), but the train turns it at 0.175 times the reference's speed");
  Train fixed;
  fixed.bodies = {{"pinion", 0.01}, {"wheel", 0.1}};
  fixed.meshes.push_back(gear_mesh("m", "pinion", "wheel", 20, 40, 0));
  fixed.reference = "pinion";
  fixed.reference_speed_hz = 50;
  hold(fixed, "wheel");
  refused(fixed, "shaft 'wheel_held': holds body 'wheel' to the ground");
  Train own = t;
  hold(own, "ring");
  own.bearings[3].on = "sun";  // p1 on a pin of the sun, with which it meshes
  refused(own, "body 'sun' carries bodies on pins and meshes with one of them");
  Train two;
  add_stage(two, "a_", {});
  add_stage(two, "b_", {});
  two.meshes.push_back(gear_mesh("across", "a_p1", "b_p1", 39, 39, 0));
  two.reference = "a_sun";
  two.reference_speed_hz = 10;
  refused(two, "mesh 'across': its gears ride on pins of two carriers");
  Train mixed = t;
  hold(mixed, "ring");
  mixed.bodies.push_back({"layshaft", 0.01});
  mixed.meshes.push_back(gear_mesh("out", "sun", "layshaft", 21, 30, 0));
  refused(mixed, "body 'sun': is planar but meshes in two frames");
}

// A fixed-axis train's speeds are the teeth's ratios, with senses reversed by each external
// mesh, and exact: a hunting-tooth chain's ratios in whole numbers.
TEST(Kinematics, AFixedAxisChainIsTheRatioOfItsTeethExactly) {
  KinematicGraph g;
  g.bodies = {"a", "b", "c", "d"};
  g.reference = 0;
  g.meshes.push_back({"mesh 'ab'", 0, 1, 97, 23, false});
  g.shafts.push_back({"shaft 'bc'", 1, 2});
  g.meshes.push_back({"mesh 'cd'", 2, 3, 89, 19, false});
  const NominalMotion m = solve_nominal_motion(g);
  EXPECT_EQ(m.speed[3].num, 97 * 89);
  EXPECT_EQ(m.speed[3].den, 23 * 19);
  EXPECT_EQ(m.sense[3], 1);
  EXPECT_EQ(m.sense[1], -1);
  EXPECT_EQ(m.mesh_frequency(1, g).num, 97 * 89);
  EXPECT_EQ(m.mesh_frequency(1, g).den, 23);
}

}  // namespace
}  // namespace geardyn::train
