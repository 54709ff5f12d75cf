// Planetary sets as elements of the train model (train.hpp): Lin and Parker's (1999) natural
// frequencies, multiplicities and mode types (../shared/literature/lin_parker_1999.md, Table 2),
// the pin bearing's and the torsional support's stamps, and the set's rigid motions.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_run.hpp"
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
    Mesh sp;
    sp.name = "s" + p;
    sp.driving = "sun";
    sp.driven = p;
    sp.teeth_driving = 30;
    sp.teeth_driven = 39;
    sp.base_radius_driving_m = kSun.base_radius_m;
    sp.base_radius_driven_m = kPlanet.base_radius_m;
    sp.backlash_m = 1e-4;
    sp.mean_stiffness_n_per_m = kMeshStiffness;
    sp.position_angle_rad = psi;
    sp.transverse_pressure_angle_rad = kPressureAngle;
    Mesh rp = sp;
    rp.name = "r" + p;
    rp.driving = p;
    rp.driven = "ring";
    rp.internal = true;
    rp.teeth_driving = 39;
    rp.teeth_driven = 108;
    rp.base_radius_driving_m = kPlanet.base_radius_m;
    rp.base_radius_driven_m = kRing.base_radius_m;
    rp.position_angle_rad = psi + kPi;  // the ring's centre seen from the planet's
    t.meshes.push_back(sp);
    t.meshes.push_back(rp);
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
// (Lin and Parker's kinematics: u_s = 2 u_c cos alpha); without the support, two.
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
  Train free = lin_parker(3);
  free.shafts.clear();
  EXPECT_EQ(Assembled(free).rigid_motions().cols(), 2);
}

// A planet moved off its equal spacing: the types no longer separate (the paper's structure needs
// equally spaced planets), and the reading says "mixed" rather than a wrong type.
TEST(Planetary, UnequalSpacingMixesTheTypes) {
  const Assembled a(lin_parker(3, {0.0, 2 * kPi / 3 + 0.2, 4 * kPi / 3}));
  int mixed = 0;
  for (const TrainMode& m : train::modes(a)) mixed += m.type == "mixed";
  EXPECT_GT(mixed, 0);
}

// Refused, naming the element: a pin on a body that meshes (a carrier is at rest in the train's
// frame), a pin on its own body, a body named "ground".
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
