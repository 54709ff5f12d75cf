// Planetary sets as elements of the train model (train.hpp): Lin and Parker's (1999) natural
// frequencies, multiplicities and mode types (../shared/literature/lin_parker_1999.md, Table 2),
// the pin bearing's and the torsional support's stamps, and the set's rigid motions.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/stability.hpp"
#include "geardyn/sweep.hpp"
#include "geardyn/sweep_output.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_statics.hpp"
#include "test_support.hpp"

namespace geardyn::train {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180;

// Lin and Parker's Table 1: each member's mass, I / r^2 and base radius (the carrier's: its
// planets' centres), every bearing 1e8 N/m, the ring held by 1e9 N/m on u = r theta, meshes
// 5e8 N/m at 24.6 deg. Their u = r theta is our theta scaled by r, so J = (I / r^2) r^2.
struct Member {
  const char* name;
  double mass_kg, i_over_r2_kg, base_radius_m;
};
constexpr Member kSun{"sun", 0.4, 0.39, 0.5 * 77.4e-3};
constexpr Member kRing{"ring", 2.35, 3.00, 0.5 * 275.0e-3};
constexpr Member kCarrier{"carrier", 5.43, 6.29, 0.5 * 176.8e-3};
constexpr Member kPlanet{"planet", 0.66, 0.61, 0.5 * 100.3e-3};
constexpr double kBearing = 1e8, kRingSupport = 1e9, kMeshStiffness = 5e8;
constexpr double kPressureAngle = 24.6 * kDeg;

// A planet p's two meshes at its angle psi: the sun (30 teeth) driving it (39), it driving the
// ring (108, internal), base radii {sun, planet, ring}, stiffness k at alpha.
void add_planet_meshes(Train& t, const std::string& p, double psi, const double (&radii_m)[3],
                       double k, double alpha, double backlash_m) {
  Mesh sp;
  sp.name = "s" + p;
  sp.driving = "sun";
  sp.driven = p;
  sp.teeth_driving = 30;
  sp.teeth_driven = 39;
  sp.base_radius_driving_m = radii_m[0];
  sp.base_radius_driven_m = radii_m[1];
  sp.backlash_m = backlash_m;
  sp.mean_stiffness_n_per_m = k;
  sp.position_angle_rad = psi;
  sp.transverse_pressure_angle_rad = alpha;
  Mesh rp = sp;
  rp.name = "r" + p;
  rp.driving = p;
  rp.driven = "ring";
  rp.internal = true;
  rp.teeth_driving = 39;
  rp.teeth_driven = 108;
  rp.base_radius_driving_m = radii_m[1];
  rp.base_radius_driven_m = radii_m[2];
  rp.position_angle_rad = psi + kPi;  // the ring's centre seen from the planet's
  t.meshes.push_back(sp);
  t.meshes.push_back(rp);
}

// The set with `planets` planets at the angles given (equally spaced when empty). Teeth only set
// the speeds, which the modes do not read.
Train lin_parker(int planets, std::vector<double> angles_rad = {}) {
  if (angles_rad.empty())
    for (int n = 0; n < planets; ++n) angles_rad.push_back(2 * kPi * n / planets);
  Train t;
  const auto body = [&](const Member& m, const std::string& name) {
    t.bodies.push_back({name, m.i_over_r2_kg * m.base_radius_m * m.base_radius_m, true, m.mass_kg});
  };
  body(kSun, "sun");
  body(kRing, "ring");
  body(kCarrier, "carrier");
  for (const char* c : {"sun", "ring", "carrier"})
    t.bearings.push_back({fmt::format("{}_bearing", c), c, kBearing, 0.0});
  t.shafts.push_back({"ring_support", "ring", kGround,
                      kRingSupport * kRing.base_radius_m * kRing.base_radius_m, 0.0});
  for (int n = 0; n < planets; ++n) {
    const std::string p = fmt::format("p{}", n + 1);
    const double psi = angles_rad[static_cast<std::size_t>(n)];
    body(kPlanet, p);
    Bearing pin{p + "_pin", p, kBearing, 0.0, "carrier", kCarrier.base_radius_m, psi};
    t.bearings.push_back(pin);
    add_planet_meshes(t, p, psi, {kSun.base_radius_m, kPlanet.base_radius_m, kRing.base_radius_m},
                      kMeshStiffness, kPressureAngle, 1e-4);
  }
  t.reference = "sun";
  t.reference_speed_hz = 10;
  return t;
}

struct Expected {
  double hz;
  int multiplicity;
  const char* type;
};

// Table 2, each frequency with its multiplicity and type.
std::vector<Expected> table2(int planets) {
  std::vector<double> rotational, translational, planet;
  if (planets == 3) {
    rotational = {0, 1475.7, 1930.3, 2658.3, 7462.8, 11775.3};
    translational = {743.2, 1102.4, 1896.0, 2276.4, 6986.3, 9647.9};
  } else if (planets == 4) {
    rotational = {0, 1536.6, 1970.6, 2625.7, 7773.6, 13071.1};
    translational = {727.0, 1091.0, 1892.8, 2342.5, 7189.9, 10437.6};
    planet = {1808.2, 5963.8, 6981.7};
  } else {
    rotational = {0, 1567.4, 2006.1, 2614.8, 8065.4, 14253.1};
    translational = {710.0, 1072.0, 1888.1, 2425.3, 7382.4, 11172.3};
    planet = {1808.2, 5963.8, 6981.7};
  }
  std::vector<Expected> out;
  out.reserve(rotational.size() + translational.size() + planet.size());
  for (double f : rotational) out.push_back({f, 1, "rotational"});
  for (double f : translational) out.push_back({f, 2, "translational"});
  for (double f : planet) out.push_back({f, planets - 3, "planet"});
  std::sort(out.begin(), out.end(),
            [](const Expected& a, const Expected& b) { return a.hz < b.hz; });
  return out;
}

class LinParker : public ::testing::TestWithParam<int> {};

// Every natural frequency of Table 2 within 0.05 %, with its multiplicity and mode type, and
// nothing else: the modes, listed once per distinct frequency, are the table's.
TEST_P(LinParker, Table2FrequenciesMultiplicitiesAndTypes) {
  const int planets = GetParam();
  const Assembled a(lin_parker(planets));
  const std::vector<TrainMode> modes = train::modes(a);
  ASSERT_EQ(static_cast<int>(modes.size()), 3 * (3 + planets));
  std::vector<const TrainMode*> distinct;
  for (const TrainMode& m : modes)
    if (distinct.empty() || std::abs(m.frequency_hz - distinct.back()->frequency_hz) >
                                kSameModeFrequency * m.frequency_hz)
      distinct.push_back(&m);
  const std::vector<Expected> expected = table2(planets);
  ASSERT_EQ(distinct.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE(fmt::format("N = {}, Table 2's {} Hz", planets, expected[i].hz));
    if (expected[i].hz == 0) {
      EXPECT_EQ(distinct[i]->frequency_hz, 0.0);
    } else {
      // The paper's N = 4 column is printed to 0.3 Hz off its own computation: 0.05 % holds it.
      EXPECT_NEAR(distinct[i]->frequency_hz, expected[i].hz, 5e-4 * expected[i].hz);
    }
    EXPECT_EQ(distinct[i]->multiplicity, expected[i].multiplicity);
    EXPECT_EQ(distinct[i]->type, expected[i].type);
  }
}

INSTANTIATE_TEST_SUITE_P(ThreeFourFivePlanets, LinParker, ::testing::Values(3, 4, 5));

// The pin bearing's and the support's stiffness are Lin and Parker's blocks: K against a finite
// difference of the elastic energy of the deflections written out by hand for one planet, and
// symmetric (the trap of the public port: the planet bearing acts on x and y only).
TEST(Planetary, PinAndSupportStampLinParkersCouplings) {
  const double psi = 0.7;
  const Assembled a(lin_parker(1, {psi}));
  const Eigen::MatrixXd k = a.contact_stiffness();
  EXPECT_LE((k - k.transpose()).cwiseAbs().maxCoeff(), 1e-12 * k.cwiseAbs().maxCoeff());
  // The hand-written energy: bearings of sun, ring, carrier; the ring's support on u_r; the
  // planet on its pin, radial (zeta - x_c cos psi - y_c sin psi) and tangential (eta + x_c sin
  // psi - y_c cos psi - u_c), u_c = r_c theta_c; the two meshes along their lines (Lin and
  // Parker's delta_sn and delta_rn, in our senses of rotation: u_s = r_s theta_s, u_n = -r_p
  // theta_p, u_r = -r_r theta_r).
  const int n = a.size();
  const auto energy = [&](const Eigen::VectorXd& q) {
    const auto th = [&](const char* b) { return q(a.index(b)); };
    const auto xy = [&](const char* b) {
      return Eigen::Vector2d(q(a.translation(a.index(b))), q(a.translation(a.index(b)) + 1));
    };
    double e = 0;
    for (const char* c : {"sun", "ring", "carrier"}) e += 0.5 * kBearing * xy(c).squaredNorm();
    const double ur = -kRing.base_radius_m * th("ring");
    e += 0.5 * kRingSupport * ur * ur;
    const Eigen::Vector2d er(std::cos(psi), std::sin(psi)), et(-std::sin(psi), std::cos(psi));
    const Eigen::Vector2d c = xy("carrier"), p = xy("p1");
    const double zeta = p.dot(er), eta = p.dot(et);
    const double uc = kCarrier.base_radius_m * th("carrier");
    const double radial = zeta - c.dot(er), tangential = eta - c.dot(et) - uc;
    e += 0.5 * kBearing * (radial * radial + tangential * tangential);
    const double us = kSun.base_radius_m * th("sun"), un = -kPlanet.base_radius_m * th("p1");
    const Eigen::Vector2d s = xy("sun"), r = xy("ring");
    const double psn = psi - kPressureAngle, prn = psi + kPressureAngle;
    const double dsn = -s.x() * std::sin(psn) + s.y() * std::cos(psn) -
                       zeta * std::sin(kPressureAngle) - eta * std::cos(kPressureAngle) + us + un;
    const double drn = -r.x() * std::sin(prn) + r.y() * std::cos(prn) +
                       zeta * std::sin(kPressureAngle) - eta * std::cos(kPressureAngle) + ur - un;
    e += 0.5 * kMeshStiffness * (dsn * dsn + drn * drn);
    return e;
  };
  // K_ij = d2E / dq_i dq_j by central differences of the quadratic (exact to rounding).
  const double h = 1e-6;
  Eigen::MatrixXd fd(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd q = Eigen::VectorXd::Zero(n);
      const auto at = [&](double di, double dj) {
        q.setZero();
        q(i) += di;
        q(j) += dj;
        return energy(q);
      };
      fd(i, j) = (at(h, h) - at(h, -h) - at(-h, h) + at(-h, -h)) / (4 * h * h);
    }
  testing::expect_matrix_near(k, fd, 1e-6, 1e-9);
}

// With the ring held and sun and carrier free, one motion is free (Table 2's 0 Hz mode): the set
// turning about its ring, the carrier by theta_c and the sun by 2 r_c cos(alpha) / r_s theta_c
// (Lin and Parker's kinematics: u_s = 2 u_c cos alpha).
TEST(Planetary, RigidMotionsOfTheSet) {
  const Assembled held(lin_parker(3));
  const Eigen::MatrixXd r = held.rigid_motions();
  ASSERT_EQ(r.cols(), 1);
  const Eigen::VectorXd g = r.col(0);
  EXPECT_LE((held.contact_stiffness() * g).norm(), 1e-9 * held.contact_stiffness().norm());
  EXPECT_NEAR(g(held.index("sun")), 1.0, 1e-12);
  EXPECT_NEAR(g(held.index("ring")), 0.0, 1e-9);
  EXPECT_NEAR(g(held.index("carrier")) * 2 * kCarrier.base_radius_m * std::cos(kPressureAngle) /
                  kSun.base_radius_m,
              1.0, 1e-9);
  // Without the support the set's nominal motion is not fixed (a differential): refused.
  Train free = lin_parker(3);
  free.shafts.clear();
  EXPECT_THROW(Assembled{free}, InputError);
}

// The frame's rotation terms on one planar body on an isotropic bearing k, its mesh always in
// its (wide) backlash: in a frame turning at Omega an isotropic oscillator of w0 = sqrt(k / m)
// whirls at w0 - Omega and w0 + Omega exactly (its two circular motions, +-w0 in the absolute);
// released at x0 at rest in the frame, its centre is the absolute motion x0 cos(w0 t) e_x +
// (Omega x0 / w0) sin(w0 t) e_y turned back by -Omega t. The frame is a carrier's: the pinion
// (20 teeth) rides on a pin at the centre of an arm (pin radius 0: no centrifugal load), the
// arm, the reference, turning at 50 Hz (its rotation held to the nominal by a prescribed
// speed) about the wheel (40) a shaft holds to the ground: the pinion turns at 150 Hz, 100 Hz
// relative to the arm.
Train whirling_centre() {
  Train t;
  t.bodies.push_back({"pinion", 1e-3, true, 2.0});
  t.bodies.push_back({"wheel", 4e-3});
  t.bodies.push_back({"arm", 1.0});
  t.bearings.push_back({"bearing", "pinion", 8e7, 0.0, "arm", 0.0, 0.0});
  t.shafts.push_back({"held", "wheel", kGround, 1e3, 0.0});
  t.speeds.push_back({"arm_speed", "arm", {}});
  Mesh m = geardyn::testing::mesh("mesh", "pinion", "wheel", {20, 40}, {0.02, 0.04}, 1.0, 1e8);
  m.transverse_pressure_angle_rad = 20 * kDeg;
  t.meshes.push_back(m);
  t.reference = "arm";
  t.reference_speed_hz = 50;
  t.frame_terms = true;
  return t;
}

TEST(FrameTerms, AnIsotropicCentreWhirlsAtItsFrequencyPlusAndMinusTheFrames) {
  const Assembled a(whirling_centre());
  const double omega = 2 * kPi * 50, w0 = std::sqrt(8e7 / 2.0);
  EXPECT_NEAR(a.frame_rate_rad_s() / omega, 1.0, 1e-15);
  // The mesh in drive contact (modes read it so) couples the centre to the gears' turning: the
  // two modes nearest w0 -+ Omega, each within 1e-12 once that coupling is taken out.
  Train loose = whirling_centre();
  loose.meshes[0].mean_stiffness_n_per_m = 1e-6;
  const std::vector<TrainMode> m = modes(Assembled(loose));
  std::vector<double> hz;
  for (const TrainMode& x : m) hz.push_back(x.frequency_hz);
  for (const double expected : {(w0 - omega) / (2 * kPi), (w0 + omega) / (2 * kPi)}) {
    const auto nearest = std::min_element(hz.begin(), hz.end(), [&](double x, double y) {
      return std::abs(x - expected) < std::abs(y - expected);
    });
    EXPECT_NEAR(*nearest / expected, 1.0, 1e-12) << expected;
    // A whirl: x and y a quarter period apart, of equal amplitude.
    const TrainMode& whirl = m[static_cast<std::size_t>(nearest - hz.begin())];
    const int x = a.translation(0);
    EXPECT_NEAR(std::hypot(whirl.shape(x), whirl.shape_imag(x)) /
                    std::hypot(whirl.shape(x + 1), whirl.shape_imag(x + 1)),
                1.0, 1e-9);
  }
  // Without the frame's terms the two are one, twice.
  loose.frame_terms = false;
  const std::vector<TrainMode> still = modes(Assembled(loose));
  EXPECT_EQ(std::count_if(still.begin(), still.end(),
                          [&](const TrainMode& x) {
                            return std::abs(x.frequency_hz * 2 * kPi / w0 - 1) < 1e-12 &&
                                   x.multiplicity == 2;
                          }),
            2);
  // The engine's flow in the frame against the turned absolute motion.
  ode::EngineOptions o;
  o.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), o);
  constexpr double kX0 = 1e-5;
  ode::Vector y0 = ode::Vector::Zero(2 * a.size());
  const int x = a.translation(0);
  y0(x) = kX0;
  ode::FlowObserver nothing;
  for (const double t : {1e-4, 7.3e-4, 3.1e-3, 1.2e-2}) {
    const ode::FlowResult r = engine.flow(0.0, y0, a.classify(0.0, y0), t, {}, nothing);
    ASSERT_TRUE(r.ok()) << r.message;
    const Eigen::Vector2d absolute(kX0 * std::cos(w0 * t), omega * kX0 / w0 * std::sin(w0 * t));
    const Eigen::Vector2d turned = Eigen::Rotation2Dd(-omega * t) * absolute;
    EXPECT_LE((r.state.segment(x, 2) - turned).norm(), 1e-9 * kX0) << t;
  }
}

// Lin and Parker's set in its turning carrier frame keeps its rigid turn free (K's null space,
// the same motion as without the terms), and the planets' centrifugal load does no work on it;
// the frame splits each degenerate translational pair by Omega |phi_1^T G phi_2| to first order
// (G the Coriolis matrix over Omega, phi_1, phi_2 the pair's mass-normalised shapes at rest: the
// gyroscopic perturbation of a double eigenvalue), and moves the rotational modes only to second
// order.
TEST(FrameTerms, TheSetKeepsItsRigidTurnAndSplitsItsTranslationalPairs) {
  Train t = lin_parker(3);
  t.frame_terms = true;
  const Assembled turning(t);
  const Assembled still(lin_parker(3));
  // The sun (30 teeth) turns at 10 Hz, the ring (108) is held: the carrier, and its frame,
  // at 10 x 30 / 138 = 2.17 Hz (Willis).
  const double omega = 2 * kPi * 10 * 30 / 138.0;
  ASSERT_NEAR(turning.frame_rate_rad_s() / omega, 1.0, 1e-15);
  const Eigen::MatrixXd r = turning.rigid_motions();
  ASSERT_EQ(r.cols(), 1);
  const Eigen::MatrixXd k = turning.contact_stiffness();
  EXPECT_LE((k * r).norm(), 1e-12 * k.norm() * r.norm());
  EXPECT_LE((r - still.rigid_motions()).norm(), 1e-9 * r.norm());
  EXPECT_LE((k - k.transpose()).norm(), 1e-15 * k.norm());
  const Eigen::VectorXd load = turning.frame_load();
  ASSERT_GT(load.norm(), 0);
  EXPECT_LE(std::abs(r.col(0).dot(load)), 1e-12 * r.norm() * load.norm());
  // Lin and Parker's term alone (on the planets' translations u, not v = u - theta_c d_c)
  // gives the rigid turn the stiffness -Omega^2 sum m R^2.
  Eigen::MatrixXd lp = still.contact_stiffness();
  for (int i = 0; i < turning.body_count(); ++i)
    if (const int x = turning.translation(i); x >= 0)
      lp.block(x, x, 2, 2) -= omega * omega * turning.mass()(x, x) * Eigen::Matrix2d::Identity();
  EXPECT_NEAR(r.col(0).dot(lp * r.col(0)) /
                  (-omega * omega * 3 * kPlanet.mass_kg * kCarrier.base_radius_m *
                   kCarrier.base_radius_m * std::pow(r(turning.index("carrier"), 0), 2)),
              1.0, 1e-8);  // r from the eigensolver, to some 1e-9

  // The frame's speed needs the set's motion fixed: a member held, and no more than one.
  Train unheld = t;
  unheld.shafts.clear();
  EXPECT_NE(geardyn::testing::error_of([&] {
              const Assembled x(unheld);
            }).find("the train: the reference's speed leaves the speeds of 'ring', 'carrier'"),
            std::string::npos);
  Train twice = t;
  twice.shafts.push_back({"sun_held", "sun", kGround, 1e3, 0.0});
  EXPECT_NE(geardyn::testing::error_of([&] { const Assembled x(twice); })
                .find("shaft 'sun_held': holds body 'sun' to the ground (a support: it cannot "
                      "turn), but the train turns it at 1 times the reference's speed"),
            std::string::npos);
  // At rest in the frame the centrifugal load moves each planet outward on its pin.
  const std::optional<Eigen::VectorXd> rest = geardyn::static_state(turning);
  ASSERT_TRUE(rest);
  for (int n = 0; n < 3; ++n) {
    const int p = turning.index(fmt::format("p{}", n + 1));
    const double psi = 2 * kPi * n / 3;
    EXPECT_GT(
        rest->segment(turning.translation(p), 2).dot(Eigen::Vector2d(std::cos(psi), std::sin(psi))),
        0.1 * kPlanet.mass_kg * omega * omega * kCarrier.base_radius_m / kBearing)
        << n;
  }
  const Eigen::MatrixXd g = turning.frame_damping() / omega;
  t.reference_speed_hz *= 2;
  const std::vector<TrainMode> at_rest = modes(still), whirling = modes(turning),
                               faster = modes(Assembled(t));
  ASSERT_EQ(at_rest.size(), whirling.size());
  int pairs = 0;
  for (std::size_t i = 1; i < at_rest.size(); ++i) {
    const TrainMode& m = at_rest[i];
    if (m.type == "rotational") {
      // Second order: twice the speed, four times the shift.
      const double shift = whirling[i].frequency_hz - m.frequency_hz;
      EXPECT_NEAR((faster[i].frequency_hz - m.frequency_hz) / shift, 4.0, 0.02) << m.frequency_hz;
      EXPECT_EQ(whirling[i].type, "rotational");
    } else if (m.type == "translational" && i + 1 < at_rest.size() &&
               at_rest[i + 1].type == "translational" &&
               std::abs(at_rest[i + 1].frequency_hz / m.frequency_hz - 1) < 1e-9) {
      const double split_hz = omega * std::abs(m.shape.dot(g * at_rest[i + 1].shape)) / (2 * kPi);
      EXPECT_NEAR((whirling[i + 1].frequency_hz - whirling[i].frequency_hz) / split_hz, 1.0, 1e-3)
          << m.frequency_hz;
      EXPECT_GT(split_hz, 0.05 * omega / (2 * kPi));
      EXPECT_EQ(whirling[i].type, "translational");
      EXPECT_EQ(whirling[i].multiplicity, 1);
      ++pairs;
    }
  }
  EXPECT_EQ(pairs, 6);
}

// An undamped set in its turning frame keeps its Jacobi integral, 1/2 q'^T M q' + 1/2 q^T K_e q
// - Q^T q plus each mesh's 1/2 k (d -+ b)^2 in contact (K_e the bearings', supports' and frame's
// K, Q the centrifugal load): the Coriolis forces do no work. Read from the exact engine's flow
// through the meshes' contact changes, from the set at rest knocked on a planet's centre.
TEST(FrameTerms, AnUndampedSetKeepsItsJacobiIntegral) {
  Train t = lin_parker(3);
  t.frame_terms = true;
  t.reference_speed_hz = 200;
  const Assembled a(t);
  const int n = a.size();
  Eigen::MatrixXd k_e = a.contact_stiffness();
  for (int m = 0; m < static_cast<int>(t.meshes.size()); ++m)
    k_e -= kMeshStiffness * a.mesh_vector(m).transpose() * a.mesh_vector(m);
  const Eigen::VectorXd load = a.frame_load();
  const auto jacobi = [&](const ode::Vector& y) {
    const Eigen::VectorXd q = y.head(n), v = y.tail(n);
    double e = 0.5 * v.dot(a.mass() * v) + 0.5 * q.dot(k_e * q) - load.dot(q);
    for (int m = 0; m < static_cast<int>(t.meshes.size()); ++m) {
      const double d = a.mesh_vector(m).dot(q),
                   b = t.meshes[static_cast<std::size_t>(m)].backlash_m;
      if (std::abs(d) > b) e += 0.5 * kMeshStiffness * (std::abs(d) - b) * (std::abs(d) - b);
    }
    return e;
  };
  ode::Vector y0 = ode::Vector::Zero(2 * n);
  y0(n + a.translation(a.index("p1"))) = 0.05;  // m/s
  ode::EngineOptions o;
  o.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), o);
  ode::FlowObserver nothing;
  const double e0 = jacobi(y0);
  std::int64_t events = 0;
  for (const double t1 : {2e-3, 7e-3, 2e-2}) {
    const ode::FlowResult r = engine.flow(0.0, y0, a.classify(0.0, y0), t1, {}, nothing);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_NEAR(jacobi(r.state) / e0, 1.0, 1e-9) << t1;
    events = r.events;
  }
  EXPECT_GT(events, 10);  // through contacts made and lost
}

// A bearing with a radial clearance c acts in x and y each as a dead zone (Kahraman and Singh):
// the centre of the isolated body above (its mesh in its wide backlash, no frame terms),
// released at x0 > c at rest, swings a quarter cycle of w = sqrt(k / m) to +c, crosses the
// clearance at w (x0 - c), swings half a cycle on -c and back: period 2 pi / w + 4 c / (w (x0 -
// c)), at its half -x0; each crossing ends in an impact, two a period, and y, never touched,
// stays inside. The exact engine's flow, and the run's reading.
TEST(BearingClearance, AnIsolatedCentreRattlesInItsClearanceAsTheClosedFormSays) {
  Train t = whirling_centre();
  t.frame_terms = false;
  constexpr double kGap = 2e-5, kX0 = 5e-5;
  t.bearings[0].clearance_m = kGap;
  const Assembled a(t);
  ASSERT_EQ(a.clearances().size(), 2U);
  EXPECT_EQ(a.region_count(), 27);
  const double w = std::sqrt(8e7 / 2.0);
  const double period = 2 * kPi / w + 4 * kGap / (w * (kX0 - kGap));
  ode::EngineOptions o;
  o.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), o);
  ode::Vector y0 = ode::Vector::Zero(2 * a.size());
  const int x = a.translation(0);
  y0(x) = kX0;
  EXPECT_EQ(a.joint_states(a.classify(0.0, y0)), (std::vector<int>{1, 0}));
  ode::FlowObserver nothing;
  for (const auto& [t1, expected] :
       {std::pair{0.5 * period, -kX0}, std::pair{period, kX0}, std::pair{3 * period, kX0}}) {
    const ode::FlowResult r = engine.flow(0.0, y0, a.classify(0.0, y0), t1, {}, nothing);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_NEAR(r.state(x), expected, 1e-9 * kX0) << t1;
    EXPECT_NEAR(r.state(a.size() + x), 0.0, 1e-9 * w * kX0) << t1;
    EXPECT_EQ(r.state(x + 1), 0.0);
    EXPECT_EQ(r.events, static_cast<std::int64_t>(std::round(4 * t1 / period)));
  }
  // Without the clearance the same release swings at w alone.
  Train tight = t;
  tight.bearings[0].clearance_m = 0;
  const Assembled b(tight);
  const ode::ExactEngine plain(b.linear_system(), o);
  const ode::FlowResult r = plain.flow(0.0, y0, b.classify(0.0, y0), kPi / w, {}, nothing);
  EXPECT_NEAR(r.state(x), -kX0, 1e-9 * kX0);
}

// A planet moved off its equal spacing: the types no longer separate (the paper's structure needs
// equally spaced planets), and the reading says "mixed" rather than a wrong type.
TEST(Planetary, UnequalSpacingMixesTheTypes) {
  const Assembled a(lin_parker(3, {0.0, 2 * kPi / 3 + 0.2, 4 * kPi / 3}));
  int mixed = 0;
  for (const TrainMode& m : train::modes(a)) mixed += m.type == "mixed";
  EXPECT_GT(mixed, 0);
}

// Refused, naming the element: a planet on a pin of a gear it meshes with, a pin on its own
// body, a body named "ground".
TEST(Planetary, PinsAndSupportsAreChecked) {
  Train t = lin_parker(3);
  t.bearings.back().on = "sun";
  EXPECT_THROW(
      {
        try {
          Assembled{t};
        } catch (const InputError& e) {
          EXPECT_NE(std::string(e.what()).find("body 'sun' carries bodies on pins"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      InputError);
  t = lin_parker(3);
  t.bearings.back().on = t.bearings.back().body;
  EXPECT_THROW(Assembled{t}, InputError);
  t = lin_parker(3);
  t.bodies[0].name = kGround;
  EXPECT_THROW(Assembled{t}, InputError);
}

}  // namespace
}  // namespace geardyn::train

namespace geardyn::train {
namespace {

// A star set (the carrier held: each planet on a bearing k_p on the ground at its angle), sun
// and ring on rigid bearings, meshes of stiffness k at alpha, spur: the sun's torque T shared by
// N planets. A planet's pin moved by e_n across its radius (counterclockwise) unloads it: each
// planet's two mesh forces are equal (it has no torsional support), their radial parts cancel,
// and its pin carries 2 F cos(alpha) across; so F_n (2 / k + 4 cos^2(alpha) / k_p) = U - 2
// cos(alpha) e_n with U the same for all, and sum F_n = T / R_s:
//   F_n = T / (N R_s) + 2 cos(alpha) (mean(e) - e_n) / c,  c = 2 / k + 4 cos^2(alpha) / k_p.
// A radial error moves the planet along its radius and changes no force.
struct StarSet {
  static constexpr int kPlanets = 4;
  static constexpr double kModule = 2e-3, kAlpha = 20 * kDeg, kK = 4e8, kKp = 2e8, kT = 120;
  static double base_radius(int teeth) { return 0.5 * teeth * kModule * std::cos(kAlpha); }
  static double compliance() { return 2 / kK + 4 * std::cos(kAlpha) * std::cos(kAlpha) / kKp; }
  static double mean_force() { return kT / (kPlanets * base_radius(30)); }
  // The train with tangential and radial pin errors per planet (m).
  static Train train(const std::vector<double>& tangential, const std::vector<double>& radial) {
    Train t;
    t.bodies.push_back({"sun", 2e-3, false, 0});
    t.bodies.push_back({"ring", 5e-2, false, 0});
    for (int n = 0; n < kPlanets; ++n) {
      const std::string p = fmt::format("p{}", n + 1);
      const double psi = 2 * kPi * n / kPlanets;
      t.bodies.push_back({p, 3e-4, true, 0.5});
      Bearing pin{p + "_pin", p, kKp, 0.0, "", 0.0, psi};
      pin.pin_error_tangential_m = tangential[static_cast<std::size_t>(n)];
      pin.pin_error_radial_m = radial[static_cast<std::size_t>(n)];
      t.bearings.push_back(pin);
      add_planet_meshes(t, p, psi, {base_radius(30), base_radius(39), base_radius(108)}, kK, kAlpha,
                        5e-5);
    }
    t.torques.push_back({"drive", "sun", kT, {}});
    t.torques.push_back({"load", "ring", -kT * 108.0 / 30.0, {}});
    t.reference = "sun";
    t.reference_speed_hz = 20;
    return t;
  }
  // The static sun-planet mesh forces.
  static std::vector<double> sun_forces(const Train& t) {
    const Assembled a(t);
    std::string why;
    const std::optional<Eigen::VectorXd> rest = static_state(a, &why);
    EXPECT_TRUE(rest) << why;
    const std::vector<double> all = static_mesh_forces_n(a, rest.value_or(Eigen::VectorXd()));
    std::vector<double> out;
    out.reserve(kPlanets);
    for (std::size_t n = 0; n < kPlanets; ++n) out.push_back(all[2 * n]);
    return out;
  }
};

TEST(PlanetaryLoadSharing, OnePinErrorAgainstItsClosedForm) {
  const std::vector<double> none(StarSet::kPlanets, 0.0);
  const double f = StarSet::mean_force(), c = StarSet::compliance();
  const double ca = std::cos(StarSet::kAlpha);
  // Without errors every planet carries T / (N R_s).
  for (double x : StarSet::sun_forces(StarSet::train(none, none))) EXPECT_NEAR(x / f, 1.0, 1e-9);
  // One tangential error: the closed form, each planet, to 1e-6.
  std::vector<double> e = none;
  e[0] = 20e-6;
  const std::vector<double> forces = StarSet::sun_forces(StarSet::train(e, none));
  const double mean = e[0] / StarSet::kPlanets;
  for (int n = 0; n < StarSet::kPlanets; ++n) {
    const double expected = f + 2 * ca * (mean - e[static_cast<std::size_t>(n)]) / c;
    EXPECT_NEAR(forces[static_cast<std::size_t>(n)] / expected, 1.0, 1e-6) << n;
  }
  // A radial error changes no force.
  std::vector<double> radial = none;
  radial[1] = 50e-6;
  for (double x : StarSet::sun_forces(StarSet::train(none, radial))) EXPECT_NEAR(x / f, 1.0, 1e-9);
  // The planet unloads at e* = N c F / (2 cos(alpha) (N - 1)).
  e[0] = StarSet::kPlanets * c * f / (2 * ca * (StarSet::kPlanets - 1));
  EXPECT_NEAR(StarSet::sun_forces(StarSet::train(e, none))[0] / f, 0.0, 1e-9);
}

}  // namespace
}  // namespace geardyn::train

namespace geardyn {
namespace {

// cases/planetary_set.toml (which starts from its static state) with the keys set as given.
Case shipped_stage(const std::vector<std::pair<std::string, std::string>>& sets) {
  Case c = load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "planetary_set.toml");
  for (const auto& [key, value] : sets) set_case_value(c, {key, value});
  return c;
}

// The shipped set's run reads its load sharing: with constant mesh stiffness and no
// fluctuation, a run from the static state stays there (the pin errors' loads enter the run as
// they enter the static state), so the steady factor is the static one; one planet's pin 20 um
// off loads the others; 300 um (six backlashes) unloads it: the static state says so, and the
// run shows it off its drive flank (it ends on its back flank).
TEST(PlanetaryLoadSharing, TheShippedSetsRunReadsItsLoadSharing) {
  Case c = shipped_stage({{"train.mesh[0].stiffness_harmonics", "[]"},
                          {"train.mesh[1].stiffness_harmonics", "[]"},
                          {"solver.duration_s", "0.005"}});
  const TrainRunResult even = run_train(c);
  ASSERT_TRUE(even.ok()) << even.message;
  ASSERT_EQ(even.load_sharing.size(), 2U);  // the sun's planets and the ring's
  EXPECT_EQ(even.load_sharing[0].gear, "sun");
  EXPECT_EQ(even.load_sharing[0].meshes,
            (std::vector<std::string>{"sun_planet1", "sun_planet2", "sun_planet3"}));
  EXPECT_NEAR(*even.load_sharing[0].static_factor, 1.0, 1e-12);
  set_case_value(c, {"train.planet_pin_errors_um", "[[0, 20], [0, 0], [0, 0]]"});
  const TrainRunResult off = run_train(c);
  ASSERT_TRUE(off.ok()) << off.message;
  const TrainLoadSharing& sun = off.load_sharing[0];
  ASSERT_TRUE(sun.static_factor && sun.factor && sun.factor_with_startup);
  EXPECT_GT(*sun.static_factor, 1.05);
  EXPECT_NEAR(*sun.factor / *sun.static_factor, 1.0, 1e-9);
  EXPECT_NEAR(*sun.factor_with_startup / *sun.static_factor, 1.0, 1e-9);
  // The factor is the other planets' share: 3 F_2 / sum F, from the meshes' static forces.
  const double f1 = *off.meshes[0].static_force_n, f2 = *off.meshes[1].static_force_n;
  EXPECT_LT(f1, f2);
  EXPECT_NEAR(*sun.static_factor, 3 * f2 / (f1 + 2 * f2), 1e-12);
  EXPECT_TRUE(sun.lost_contact.empty() && sun.unloaded_at_rest.empty());
  set_case_value(c, {"train.planet_pin_errors_um", "[[0, 300], [0, 0], [0, 0]]"});
  const TrainRunResult lost = run_train(c);
  ASSERT_TRUE(lost.ok()) << lost.message;
  EXPECT_EQ(lost.load_sharing[0].unloaded_at_rest, std::vector<std::string>{"sun_planet1"});
  EXPECT_NE(std::find(lost.load_sharing[0].lost_contact.begin(),
                      lost.load_sharing[0].lost_contact.end(), "sun_planet1"),
            lost.load_sharing[0].lost_contact.end());
}

// A sweep reads each load-sharing group per point: the shipped set with constant stiffness
// settles at every speed on its static state, so each point's factor is the run's static one
// (to the settling tolerance, 1e-6 b); with one pin 300 um off, planet 1 leaves its drive flank
// at every speed (its lightly damped start has not settled in 200 periods), and the point counts
// that one mesh in each group, the more loaded of the other two carrying over half the load.
TEST(PlanetaryLoadSharing, ASweepReadsEachGroupPerPoint) {
  Case c = shipped_stage({{"train.mesh[0].stiffness_harmonics", "[]"},
                          {"train.mesh[1].stiffness_harmonics", "[]"},
                          {"train.planet_pin_errors_um", "[[0, 20], [0, 0], [0, 0]]"},
                          {"solver.duration_s", "0.01"}});
  SweepOptions o;
  o.axis = {"train.reference_speed_hz", 10, 30, 2};
  o.direction = SweepDirection::kUp;
  o.measure_periods = 2;
  o.threads = 1;
  const auto swept = [&] {
    const SweepResult r = sweep(c, o);
    EXPECT_EQ(r.failed, 0U);
    return r;
  };
  const SweepResult off = swept();
  ASSERT_EQ(off.load_sharing.size(), 2U);
  EXPECT_EQ(off.load_sharing[0].label, "sun");
  EXPECT_EQ(off.load_sharing[1].label, "ring");
  EXPECT_EQ(off.load_sharing[0].meshes, (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(off.load_sharing[1].meshes, (std::vector<std::size_t>{3, 4, 5}));
  const TrainRunResult at_rest = run_train(c);
  ASSERT_TRUE(at_rest.ok()) << at_rest.message;
  for (const SweepPoint& p : off.points) {
    ASSERT_EQ(p.load_sharing.size(), 2U);
    for (std::size_t g = 0; g < 2; ++g) {
      EXPECT_NEAR(p.load_sharing[g].factor / *at_rest.load_sharing[g].static_factor, 1.0, 1e-6)
          << p.value;
      EXPECT_EQ(p.load_sharing[g].lost_contact, 0.0);
    }
    EXPECT_GT(p.load_sharing[0].factor, 1.05);
  }
  const std::string csv = sweep_csv(off);
  EXPECT_NE(csv.find(",sun_load_sharing_factor,sun_lost_contact,ring_load_sharing_factor,"
                     "ring_lost_contact,"),
            std::string::npos);

  // The shipped varying stiffness with the sun at 40 Hz relative to its carrier (40 x 102 / 78
  // Hz its own, by Willis's equation with the ring held): a point reads the factor the run reads
  // in its steady part (the same periodic response at the same phases: the run samples 64 times
  // a system period, one mesh cycle at 24 x 40 Hz, as the point does), above the static one.
  const double mesh_hz = 24 * 40, sun_hz = 40 * 102 / 78.0;
  Case varying = shipped_stage({{"train.planet_pin_errors_um", "[[0, 20], [0, 0], [0, 0]]"},
                                {"train.reference_speed_hz", fmt::format("{}", sun_hz)},
                                {"solver.duration_s", "0.05"},
                                {"solver.output_interval_s", fmt::format("{}", 1 / mesh_hz / 64)}});
  const TrainRunResult run = run_train(varying);
  ASSERT_TRUE(run.ok() && run.steady.marked) << run.message;
  o.axis = {"train.reference_speed_hz", sun_hz, sun_hz, 1};
  const SweepResult dynamic = sweep(varying, o);
  ASSERT_TRUE(dynamic.points[0].settled);
  for (std::size_t g = 0; g < 2; ++g) {
    const double factor = dynamic.points[0].load_sharing[g].factor;
    EXPECT_NEAR(factor / *run.load_sharing[g].factor, 1.0, 1e-6);
    EXPECT_GT(factor, *run.load_sharing[g].static_factor + 2e-3);
  }

  set_case_value(c, {"train.planet_pin_errors_um", "[[0, 300], [0, 0], [0, 0]]"});
  o.axis = {"train.reference_speed_hz", 10, 30, 2};
  const SweepResult lost = swept();
  for (const SweepPoint& p : lost.points)
    for (std::size_t g = 0; g < 2; ++g) {
      // Planet 1's mesh of the group, and it alone, off its drive flank (d - e < 0).
      for (std::size_t i = 0; i < 3; ++i)
        EXPECT_EQ(p.meshes[off.load_sharing[g].meshes[i]].min_delta_bar < 0, i == 0) << p.value;
      EXPECT_EQ(p.load_sharing[g].lost_contact, 1.0) << p.value;
      EXPECT_GT(p.load_sharing[g].factor, 1.5);  // planet 1 pushed back: the others carry more
      EXPECT_LT(p.load_sharing[g].factor, 3.0);
    }
}

}  // namespace
}  // namespace geardyn

namespace geardyn::train {
namespace {

// Planet mesh phasing (docs/model.md, "Mesh phasing of planets"): with N equally spaced
// planets phased from the layout, sun-planet mesh n lags the first by z_s psi_n / 2 pi cycles,
// so harmonic l of the sun meshes' transmission error puts on the sun a net torque sum_n
// e^(i l z_s psi_n), zero unless l z_s / N is whole, and a net transverse force sum_n
// e^(i (l z_s +- 1) psi_n), zero unless l z_s / N +- 1 is. Read from the computed forced
// response, not asserted: the sun's rotation and its centre's motion at l times the mesh
// frequency, against the planets' (which always move).
struct PhasingResponse {
  double sun_rotation, sun_translation, planet_rotation;  // amplitudes, rad and m
};

PhasingResponse phasing_response(int z_sun, int z_planet, int planets, int harmonic,
                                 double moved_rad = 0) {
  constexpr double kModule = 2e-3, kAlpha = 20 * kDeg;
  const int z_ring = z_sun + 2 * z_planet;
  const auto radius = [&](int z) { return 0.5 * z * kModule * std::cos(kAlpha); };
  Train t;
  t.mesh_phase_from_layout = true;
  t.bodies.push_back({"sun", 5e-4, true, 0.5});
  t.bodies.push_back({"ring", 5e-2, true, 2.0});
  t.bodies.push_back({"carrier", 2e-2, true, 3.0});
  for (const char* c : {"sun", "ring", "carrier"})
    t.bearings.push_back({fmt::format("{}_bearing", c), c, 1e8, 200.0});
  t.shafts.push_back({"ring_support", "ring", kGround, 1e6, 10.0});
  for (int n = 0; n < planets; ++n) {
    const std::string p = fmt::format("p{}", n + 1);
    const double psi = 2 * kPi * n / planets + (n == 1 ? moved_rad : 0.0);
    t.bodies.push_back({p, 3e-4, true, 0.4});
    t.bearings.push_back(
        {p + "_pin", p, 2e8, 200.0, "carrier", 0.5 * kModule * (z_sun + z_planet), psi});
    add_planet_meshes(t, p, psi, {radius(z_sun), radius(z_planet), radius(z_ring)}, 4e8, kAlpha,
                      5e-5);
    for (Mesh* m : {&t.meshes[t.meshes.size() - 2], &t.meshes.back()}) {
      m->teeth_driving = m == &t.meshes.back() ? z_planet : z_sun;
      m->teeth_driven = m == &t.meshes.back() ? z_ring : z_planet;
      m->damping_n_s_per_m = 500;
    }
    // The sun mesh's transmission error: harmonic `harmonic` alone, phase 0 at its pitch point.
    std::vector<MeshHarmonic>& te = t.meshes[t.meshes.size() - 2].transmission_error;
    te.assign(static_cast<std::size_t>(harmonic), {0.0, 0.0});
    te.back().value = 1e-6;
  }
  t.reference = "sun";
  t.reference_speed_hz = 30;
  const Assembled a(t);
  const Eigen::MatrixXd k = a.contact_stiffness(), c = a.contact_damping();
  const Eigen::MatrixXd& m = a.mass();
  const double w = harmonic * 2 * kPi * a.mesh_frequency_hz(0);
  using Cd = std::complex<double>;
  const Eigen::MatrixXcd d = k.cast<Cd>() - w * w * m.cast<Cd>() + Cd(0, w) * c.cast<Cd>();
  Eigen::VectorXcd rhs = Eigen::VectorXcd::Zero(a.size());
  for (int j = 0; j < a.train().meshes.size(); ++j) {
    const Mesh& x = a.train().meshes[static_cast<std::size_t>(j)];
    if (x.transmission_error.empty()) continue;
    // The phase the layout gave it (Assembled::place_teeth delays each harmonic).
    const Cd e =
        std::polar(x.transmission_error.back().value, x.transmission_error.back().phase_rad);
    rhs += a.mesh_vector(j).transpose().cast<Cd>() *
           (Cd(x.mean_stiffness_n_per_m, w * x.damping_n_s_per_m) * e);
  }
  const Eigen::VectorXcd theta = d.partialPivLu().solve(rhs);
  const int sun = a.index("sun"), xs = a.translation(sun);
  return {std::abs(theta(sun)), theta.segment(xs, 2).norm(), std::abs(theta(a.index("p1")))};
}

TEST(PlanetaryPhasing, TheSunFeelsAHarmonicAsTheToothCountsSay) {
  // Four planets: 24 + 76 teeth, l = 1: l z_s / N = 6, a torque and no force; 25 + 75: 24 / 4
  // = 6 whole, a force and no torque; 26 + 74: 26, 25, 27 over 4 none whole, the sun still.
  // l = 2 with 26 teeth: 52 / 4 = 13, a torque.
  constexpr double kStill = 1e-9;  // of the planets' motion, in its units
  const PhasingResponse torque = phasing_response(24, 26, 4, 1);
  EXPECT_GT(torque.sun_rotation, 1e-3 * torque.planet_rotation);
  EXPECT_LT(torque.sun_translation, kStill * torque.planet_rotation * 0.03);
  const PhasingResponse force = phasing_response(25, 25, 4, 1);
  EXPECT_LT(force.sun_rotation, kStill * force.planet_rotation);
  EXPECT_GT(force.sun_translation, 1e-3 * force.planet_rotation * 0.03);
  const PhasingResponse still = phasing_response(26, 24, 4, 1);
  EXPECT_LT(still.sun_rotation, kStill * still.planet_rotation);
  EXPECT_LT(still.sun_translation, kStill * still.planet_rotation * 0.03);
  const PhasingResponse second = phasing_response(26, 24, 4, 2);
  EXPECT_GT(second.sun_rotation, 1e-3 * second.planet_rotation);
  // Three planets (25 + 77 teeth): 25 / 3 is not whole, 24 / 3 is: a force, no torque.
  const PhasingResponse three = phasing_response(25, 26, 3, 1);
  EXPECT_LT(three.sun_rotation, kStill * three.planet_rotation);
  EXPECT_GT(three.sun_translation, 1e-3 * three.planet_rotation * 0.03);
  // A planet moved off equal spacing by 7.2 deg, two of the angles 360 / (z_s + z_r) at which
  // it still assembles: the cancellation breaks, and the still sun turns and moves.
  const PhasingResponse moved = phasing_response(26, 24, 4, 1, 2 * 2 * kPi / 100);
  EXPECT_GT(moved.sun_rotation, 1e-4 * moved.planet_rotation);
  EXPECT_GT(moved.sun_translation, 1e-4 * moved.planet_rotation * 0.03);
}

}  // namespace
}  // namespace geardyn::train

namespace geardyn::train {
namespace {

// The rigid-bearing limit: sun, ring and carrier on rigid bearings (torsion only), each planet on
// a pin of stiffness k_pin, is Lin and Parker's purely rotational model as k_pin grows. That
// model, written by hand with u = r theta: planet modes (the central members still, the planets
// turning against one another) at w^2 = (k_s + k_r) / (I_p / r_p^2), N - 1 times; and the modes
// where every planet moves alike, from the four coordinates (u_s, u_r, u_c, u_p) with the
// planets' centres carried by the carrier (eta = u_c):
//   delta_s = u_s + u_p - u_c cos(alpha), delta_r = u_r - u_p - u_c cos(alpha),
//   2 V = N (k_s delta_s^2 + k_r delta_r^2) + k_ru u_r^2,
//   M = diag(I_s / r_s^2, I_r / r_r^2, I_c / r_c^2 + N m_p, N I_p / r_p^2).
std::vector<double> rotational_model_hz(int planets) {
  const double ca = std::cos(kPressureAngle), k = kMeshStiffness;
  Eigen::Matrix4d stiffness = Eigen::Matrix4d::Zero();
  const Eigen::RowVector4d ds(1, 0, -ca, 1), dr(0, 1, -ca, -1);
  stiffness += planets * k * (ds.transpose() * ds + dr.transpose() * dr);
  stiffness(1, 1) += kRingSupport;
  const Eigen::Vector4d mass(kSun.i_over_r2_kg, kRing.i_over_r2_kg,
                             kCarrier.i_over_r2_kg + planets * kPlanet.mass_kg,
                             planets * kPlanet.i_over_r2_kg);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix4d> solver(
      stiffness, Eigen::Matrix4d(mass.asDiagonal()));
  std::vector<double> hz;
  hz.reserve(3 + static_cast<std::size_t>(planets));
  // The set turning about its held ring: a zero eigenvalue, to rounding.
  for (int i = 0; i < 4; ++i)
    hz.push_back(solver.eigenvalues()(i) > 1e-12 * solver.eigenvalues()(3)
                     ? std::sqrt(solver.eigenvalues()(i)) / (2 * kPi)
                     : 0.0);
  const double planet = std::sqrt(2 * k / kPlanet.i_over_r2_kg) / (2 * kPi);
  for (int n = 1; n < planets; ++n) hz.push_back(planet);
  std::sort(hz.begin(), hz.end());
  return hz;
}

// The lowest 3 + N frequencies of the set with rigid central bearings and pins of stiffness
// k_pin (the other 2 N are the planets on their pins, far above).
std::vector<double> rigid_bearing_set_hz(int planets, double pin_stiffness) {
  Train t = lin_parker(planets);
  for (Body& b : t.bodies)
    if (b.name == "sun" || b.name == "ring" || b.name == "carrier") b.planar = false;
  std::vector<Bearing> pins;
  for (Bearing& b : t.bearings)
    if (!b.on.empty()) {
      b.stiffness_n_per_m = pin_stiffness;
      pins.push_back(b);
    }
  t.bearings = pins;
  std::vector<double> hz;
  for (const TrainMode& m : modes(Assembled(t))) hz.push_back(m.frequency_hz);
  hz.resize(3 + static_cast<std::size_t>(planets));
  return hz;
}

TEST(Planetary, RigidBearingsAndPinsGiveTheRotationalModel) {
  for (const int planets : {3, 4}) {
    SCOPED_TRACE(planets);
    const std::vector<double> exact = rotational_model_hz(planets);
    double error[2] = {0, 0};
    for (int i = 0; i < 2; ++i) {
      const std::vector<double> hz = rigid_bearing_set_hz(planets, i == 0 ? 1e12 : 1e13);
      ASSERT_EQ(hz.size(), exact.size());
      EXPECT_EQ(hz[0], 0.0);
      EXPECT_EQ(exact[0], 0.0);
      for (std::size_t j = 1; j < hz.size(); ++j)
        error[i] = std::max(error[i], std::abs(hz[j] / exact[j] - 1));
    }
    // Within k_mesh / k_pin, and shrinking with it (first order).
    EXPECT_LT(error[0], 2e-4);
    EXPECT_LT(error[1], 2e-5);
    EXPECT_NEAR(error[0] / error[1], 10.0, 2.0);
  }
}

}  // namespace
}  // namespace geardyn::train

namespace geardyn {
namespace {

// Five planets: 3^10 = 59049 contact regions, built as the flow enters them. The shipped stage with
// five planets (their phases as given: 24 + 78 teeth do not assemble five equally spaced, and the
// meshes in phase keep the planets alike) runs from its static state, its planets sharing equally
// throughout; with one pin off the others carry more, and more still as the meshes' stiffness
// varies.
TEST(PlanetaryLoadSharing, FivePlanetsRunWithTheirRegionsBuiltOnDemand) {
  Case c =
      shipped_stage({{"train.planets", "5"},
                     {"train.mesh_phase", "\"given\""},
                     {"train.planet_pin_errors_um", "[[0, 0], [0, 0], [0, 0], [0, 0], [0, 0]]"},
                     {"solver.duration_s", "0.002"}});
  ASSERT_TRUE(assembled_train(c).linear_system().lazy());
  const TrainRunResult even = run_train(c);
  ASSERT_TRUE(even.ok()) << even.message;
  ASSERT_EQ(even.meshes.size(), 10U);
  EXPECT_NEAR(*even.load_sharing[0].static_factor, 1.0, 1e-12);
  EXPECT_NEAR(*even.load_sharing[0].factor_with_startup, 1.0, 1e-9);
  set_case_value(c, {"train.planet_pin_errors_um", "[[0, 10], [0, 0], [0, 0], [0, 0], [0, 0]]"});
  const TrainRunResult off = run_train(c);
  ASSERT_TRUE(off.ok()) << off.message;
  EXPECT_GT(*off.load_sharing[0].static_factor, 1.01);
  EXPECT_GT(*off.load_sharing[0].factor_with_startup, *off.load_sharing[0].static_factor);
}

}  // namespace
}  // namespace geardyn

namespace geardyn {
namespace {

// A least-squares fit of x(t) ~ x0 + Re[X e^(i w t)] over the samples from `from_s` on: X.
std::complex<double> harmonic_of(const std::vector<double>& t_s, const std::vector<double>& x,
                                 double w, double from_s) {
  Eigen::MatrixXd a(0, 3);
  Eigen::VectorXd b(0);
  for (std::size_t k = 0; k < t_s.size(); ++k) {
    if (t_s[k] < from_s) continue;
    a.conservativeResize(a.rows() + 1, 3);
    b.conservativeResize(b.size() + 1);
    a.row(a.rows() - 1) << 1.0, std::cos(w * t_s[k]), std::sin(w * t_s[k]);
    b(b.size() - 1) = x[k];
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(b);
  return {c(1), -c(2)};
}

// A gear's runout (train.hpp, "Eccentricity") forces its mesh once a turn of that gear. With the
// mesh in contact at constant stiffness k and damping c, the pair's reduced mass m_e (1 / m_e =
// V M^-1 V^T) and p(t) = cos(beta_b) n . epsilon_a(t) the runout's share of the deflection,
// m_e d'' = -F + const, F = k (d + p - b) + c (d' + p'), so the force's part at the gear's speed
// w is F = -m_e w^2 P (k + i c w) / (k - m_e w^2 + i c w), P = cos(beta_b) e e^(i (phi - angle
// n)) for the pinion (turning counterclockwise) and -cos(beta_b) e e^(i (angle n - phi)) for the
// wheel (turning clockwise, and on the other side of d). Read from a run, amplitude and phase.
TEST(Eccentricity, ARunoutForcesItsMeshAsTheClosedFormSays) {
  const std::string text = R"(
[model]
form = "train"
[train]
reference = "pinion"
reference_speed_hz = 300
[[train.body]]
name = "pinion"
teeth = 20
normal_module_mm = 2
helix_angle_deg = 15
face_width_mm = 20
[[train.body]]
name = "wheel"
teeth = 36
normal_module_mm = 2
helix_angle_deg = 15
face_width_mm = 20
[[train.mesh]]
driving = "pinion"
driven = "wheel"
mean_stiffness_n_per_m = 2e8
damping_ratio = 0.1
backlash_um = 50
position_angle_deg = 40
[[train.torque]]
body = "pinion"
mean_nm = 50
[[train.torque]]
body = "wheel"
mean_nm = -90
[solver]
duration_s = 0.05
output_interval_s = 2e-5
tolerance = 1e-10
initial = "static"
)";
  for (const bool on_pinion : {true, false}) {
    Case c = parse_case(text, "pair.toml");
    const std::string body = on_pinion ? "train.body[0]" : "train.body[1]";
    constexpr double kE = 5e-6, kPhi = 30 * std::numbers::pi / 180;
    set_case_value(c, {body + ".eccentricity_um", "5"});
    set_case_value(c, {body + ".eccentricity_angle_deg", "30"});
    // The layout is read: it directs the runout along the line of action.
    EXPECT_TRUE(unused_settings(c).empty()) << unused_settings(c).front();
    const train::Assembled a = assembled_train(c);
    const TrainRunResult r = run_train(c);
    ASSERT_TRUE(r.ok()) << r.message;
    const double cb = std::cos(a.train().meshes[0].base_helix_angle_rad);
    const double k = a.train().meshes[0].mean_stiffness_n_per_m,
                 damping = a.train().meshes[0].damping_n_s_per_m;
    const Eigen::RowVectorXd v = a.mesh_vector(0);
    const double me = 1.0 / (v * a.mass().inverse() * v.transpose())(0, 0);
    const Eigen::Vector2d n = a.line_of_action(0);
    const double angle_n = std::atan2(n.y(), n.x());
    const double w = 2 * std::numbers::pi * (on_pinion ? 300.0 : 300.0 * 20 / 36);
    using Cd = std::complex<double>;
    const Cd p = on_pinion ? cb * kE * std::polar(1.0, kPhi - angle_n)
                           : -cb * kE * std::polar(1.0, angle_n - kPhi);
    const Cd expected = -me * w * w * p * Cd(k, damping * w) / Cd(k - me * w * w, damping * w);
    std::vector<double> force;
    for (const auto& f : r.samples.force_n) force.push_back(f[0]);
    const Cd got = harmonic_of(r.samples.t_s, force, w, 0.02);
    EXPECT_NEAR(std::abs(got) / std::abs(expected), 1.0, 1e-6) << on_pinion;
    EXPECT_NEAR(std::arg(got / expected), 0.0, 1e-6) << on_pinion;
    EXPECT_LT(r.meshes[0].min_force_n, r.meshes[0].max_force_n);
    EXPECT_GT(r.meshes[0].min_force_n, 0.0);  // in contact throughout
  }
}

// A carrier's eccentricity shifts every pin alike: the same as pin errors of its projections on
// each planet's radial and tangential directions, to rounding, in the static state and the run.
TEST(Eccentricity, ACarriersEccentricityIsItsPinsErrors) {
  Case eccentric = shipped_stage({{"train.body[3].eccentricity_um", "20"},
                                  {"train.body[3].eccentricity_angle_deg", "30"},
                                  {"solver.duration_s", "0.003"}});
  std::vector<std::string> pairs;
  for (int n = 0; n < 3; ++n) {
    const double psi = 2 * std::numbers::pi * n / 3, phi = 30 * std::numbers::pi / 180;
    pairs.push_back(
        fmt::format("[{:.17g}, {:.17g}]", 20 * std::cos(phi - psi), 20 * std::sin(phi - psi)));
  }
  Case errors =
      shipped_stage({{"train.planet_pin_errors_um", fmt::format("[{}]", fmt::join(pairs, ", "))},
                     {"solver.duration_s", "0.003"}});
  const TrainRunResult x = run_train(eccentric), y = run_train(errors);
  ASSERT_TRUE(x.ok() && y.ok()) << x.message << y.message;
  ASSERT_TRUE(x.load_sharing[0].static_factor && y.load_sharing[0].static_factor);
  EXPECT_GT(*x.load_sharing[0].static_factor, 1.001);  // it unloads a planet
  EXPECT_TRUE(unused_settings(eccentric).empty());
  // An angle with no eccentricity to direct is reported, not dropped.
  const std::vector<std::string> unused =
      unused_settings(shipped_stage({{"train.body[3].eccentricity_angle_deg", "30"}}));
  ASSERT_EQ(unused.size(), 1U);
  EXPECT_NE(unused[0].find("train.body[3].eccentricity_angle_deg = 30"), std::string::npos)
      << unused[0];
  EXPECT_NEAR(*x.load_sharing[0].static_factor, *y.load_sharing[0].static_factor, 1e-12);
  for (std::size_t m = 0; m < x.meshes.size(); ++m) {
    EXPECT_NEAR(*x.meshes[m].static_force_n, *y.meshes[m].static_force_n,
                1e-9 * std::abs(*y.meshes[m].static_force_n));
    EXPECT_NEAR(x.meshes[m].max_force_n, y.meshes[m].max_force_n,
                1e-8 * std::abs(y.meshes[m].max_force_n));
  }
}

// A sun's runout, read quasi-statically: turning slowly (2 Hz against the floating sun's
// lowest mode), the sun's meshes at each instant carry what they carry at rest with the sun's
// bearing seat moved by its runout there, epsilon(t) = e (cos w t, sin w t) (its centre of
// teeth and its seat play the same part at rest), up to the inertia's share (f / f_n)^2, from
// the first sample on; w the sun's speed relative to its carrier, in whose frame the set's
// translations are read (2 x 78 / 102 Hz with the ring held).
TEST(Eccentricity, ASunsRunoutIsQuasiStaticallyAMovedSeat) {
  constexpr double kSpeedHz = 2, kE = 20e-6;
  Case c = shipped_stage({{"train.mesh[0].stiffness_harmonics", "[]"},
                          {"train.mesh[1].stiffness_harmonics", "[]"},
                          {"train.reference_speed_hz", "2"},
                          {"train.body[0].eccentricity_um", "20"},
                          {"solver.duration_s", "1"},
                          {"solver.output_interval_s", "0.01"}});
  const TrainRunResult r = run_train(c);
  ASSERT_TRUE(r.ok()) << r.message;
  const train::Assembled a = assembled_train(c);
  int sun_bearing = -1;
  for (std::size_t b = 0; b < a.train().bearings.size(); ++b)
    if (a.train().bearings[b].body == "sun") sun_bearing = static_cast<int>(b);
  ASSERT_GE(sun_bearing, 0);
  double largest_swing = 0, largest_miss = 0, start_miss = 0;
  for (std::size_t k = 0; k < r.samples.t_s.size(); k += 7) {
    const double t = r.samples.t_s[k];
    train::Train moved = a.train();
    for (train::Body& b : moved.bodies) b.eccentricity_m = 0;
    moved.bearings[static_cast<std::size_t>(sun_bearing)].pin_error_radial_m = kE;
    moved.bearings[static_cast<std::size_t>(sun_bearing)].pin_angle_rad =
        2 * std::numbers::pi * kSpeedHz * 78 / 102 * t;
    const train::Assembled b(moved);
    const std::optional<Eigen::VectorXd> rest = static_state(b);
    ASSERT_TRUE(rest);
    const std::vector<double> f = static_mesh_forces_n(b, *rest);
    for (std::size_t m = 0; m < f.size(); ++m) {
      const double miss = std::abs(r.samples.force_n[k][m] - f[m]);
      // The start (static at t0 with the runout's value and rate) against the rest.
      (t < 0.5 ? start_miss : largest_miss) = std::max(t < 0.5 ? start_miss : largest_miss, miss);
      largest_swing = std::max(largest_swing, std::abs(f[m] - *r.meshes[m].static_force_n));
    }
  }
  EXPECT_GT(largest_swing, 10.0);  // N: the runout moves the loads
  EXPECT_LT(largest_miss, 1e-3 * largest_swing);
  // From the start too: the static state at t0 takes the runout's value and rate (static_state
  // with at_s), so no transient is released (0.011 N in the first half second as after it; a
  // start that left the runout out missed by 6300 N there).
  EXPECT_LT(start_miss, 1e-3 * largest_swing);
}

}  // namespace
}  // namespace geardyn

namespace geardyn {
namespace {

// The many-mesh Mathieu-Hill problem (docs/model.md, "Phasing and parametric instability"):
// Lin and Parker's set, each mesh's stiffness varying by 20 % at the mesh frequency, its
// Floquet multipliers in permanent contact. Harmonic l couples modes i and j through
// sum_n e^(i l z_s psi_n) times what planet n's shapes hold: for two rotational modes nothing
// that depends on n, so sum_n e^(i l z_s psi_n), zero unless l z_s / N is whole; for a
// rotational and a translational one e^(+-i psi_n), so sum_n e^(i (l z_s +- 1) psi_n). With the
// meshes in phase ("given": every phase 0) the first sum is N and the second 0; phased from the
// layout with 85 teeth and three planets (85 / 3 not whole, 84 / 3 whole) the reverse. So the
// rotational sun mode (11775 Hz, 99 % of its energy in the sun meshes) goes unstable at a mesh
// frequency of twice its own only in phase, and its combination with the translational pair at
// 9648 Hz (sum 21423 Hz) only phased from the layout.
TEST(PlanetaryPhasing, PhasingSuppressesTheInstabilitiesItsRulesSay) {
  const auto largest_multiplier = [](const std::string& phase, double speed_hz) {
    Case c =
        load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "lin_parker_1999.toml");
    set_case_value(c, {"train.planetary[0].mesh_stiffness_harmonics", "[[0.2, 0]]"});
    set_case_value(c, {"train.mesh_phase", "\"" + phase + "\""});
    set_case_value(c, {"train.reference_speed_hz", fmt::format("{}", speed_hz)});
    return contact_monodromy(c).eigenvalues().cwiseAbs().maxCoeff();
  };
  // Mesh frequencies 2 x 11775.3 Hz and 11775.3 + 9647.9 Hz, over the sun's 85 teeth and its
  // speed relative to the carrier, 305 / 390 of its own with the ring held (Willis).
  const double relative = 305.0 / 390;
  const double primary_hz = 2 * 11775.3 / 85 / relative,
               combination_hz = (11775.3 + 9647.9) / 85 / relative;
  constexpr double kNeutral = 1e-9;  // the rigid rotation's rate keeps a multiplier of 1
  EXPECT_GT(largest_multiplier("given", primary_hz), 1.04);
  EXPECT_LT(largest_multiplier("layout", primary_hz), 1 + kNeutral);
  EXPECT_LT(largest_multiplier("given", combination_hz), 1 + kNeutral);
  EXPECT_GT(largest_multiplier("layout", combination_hz), 1.04);
}

}  // namespace
}  // namespace geardyn
