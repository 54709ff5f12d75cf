// A free rigid motion split off a piecewise-linear system (rigid_split.hpp): the reduced flow
// lifted is the whole system's flow through its contact changes, its Jacobian the whole
// flow's, and a direction some term acts on or some guard reads is refused.
#include "geardyn/rigid_split.hpp"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "geardyn/engine.hpp"

namespace geardyn::ode {
namespace {

constexpr double kPi = std::numbers::pi;

// Three inertias on a line (n = 3): body 0 and 1 touch through a one-sided contact of stiffness
// k(t) = k (1 + 0.2 cos(w t)) beyond a gap b (region 1; region 0 apart), bodies 1 and 2 joined
// by a spring and damper; a torque T0 + T1 cos(w_f t) + T2 sin(w_f t) on body 0 and -T0 on body
// 2 (their mean balanced, so that the free rotation r = (1, 1, 1) is forced by the fluctuation
// alone), and the mean `imbalance` on body 1. A ground spring of `ground` on body 2 (0: none)
// makes r not free; `read_body` >= 0 adds an observable of that body's coordinate alone.
struct Line {
  double ground = 0, imbalance = 0;
  int read_body = -1;
  double stiffness_ratio = 0.2;  // of k(t)'s cosine
  bool balanced = false;         // body 2 takes the fluctuation's opposite too
  double fluctuation = 1;        // of the torque's fluctuation T1, T2
};

LinearSwitchedSystem line_system(const Line& x) {
  const Matrix m = Eigen::Vector3d(2.0, 1.0, 3.0).asDiagonal();
  const double k = 4e4, c = 8.0, ks = 2.5e4, cs = 6.0, b = 1e-3;
  const double w = 2 * kPi * 30.0, wf = 2 * kPi * 11.0;
  const double t0 = 40.0, t1 = 25.0 * x.fluctuation, t2 = -15.0 * x.fluctuation;
  LinearSwitchedSystem s;
  s.dimension = 6;
  s.frequencies_rad_s = {w, wf};
  s.coefficient_period_s = 2 * kPi / w;
  const Matrix minv = m.inverse();
  for (int region = 0; region < 2; ++region) {
    const bool contact = region == 1;
    // K = K_c (contact, constant part; its cos part 0.2 K_c), K_s, the ground's.
    Matrix kc = Matrix::Zero(3, 3), cc = Matrix::Zero(3, 3);
    if (contact) {
      kc << k, -k, 0, -k, k, 0, 0, 0, 0;
      cc << c, -c, 0, -c, c, 0, 0, 0, 0;
    }
    Matrix kk = kc, cm = cc;
    kk.bottomRightCorner(2, 2) += ks * Matrix{{1, -1}, {-1, 1}};
    cm.bottomRightCorner(2, 2) += cs * Matrix{{1, -1}, {-1, 1}};
    kk(2, 2) += x.ground;
    LinearRegion r;
    r.a.constant = Matrix::Zero(6, 6);
    r.a.constant.topRightCorner(3, 3).setIdentity();
    r.a.constant.bottomLeftCorner(3, 3) = -minv * kk;
    r.a.constant.bottomRightCorner(3, 3) = -minv * cm;
    Matrix a_cos = Matrix::Zero(6, 6);
    a_cos.bottomLeftCorner(3, 3) = -minv * (x.stiffness_ratio * kc);
    r.a.cos = {a_cos, Matrix::Zero(6, 6)};
    r.a.sin = {Matrix::Zero(6, 6), Matrix::Zero(6, 6)};
    // Q: the torques, and the contact's k(t) b pushing 0 and 1 apart in contact.
    Vector q0 = Vector::Zero(3), qc_w = Vector::Zero(3), qc_f = Vector::Zero(3),
           qs_f = Vector::Zero(3);
    q0 << t0, x.imbalance, -t0;
    qc_f(0) = t1;
    qs_f(0) = t2;
    if (x.balanced) {
      qc_f(2) = -t1;
      qs_f(2) = -t2;
    }
    if (contact) {
      q0(0) += k * b;
      q0(1) -= k * b;
      qc_w(0) = x.stiffness_ratio * k * b;
      qc_w(1) = -x.stiffness_ratio * k * b;
    }
    const auto lower = [&](const Vector& q) {
      Vector u = Vector::Zero(6);
      u.tail(3) = minv * q;
      return u;
    };
    r.u.constant = lower(q0);
    r.u.cos = {lower(qc_w), lower(qc_f)};
    r.u.sin = {Vector::Zero(6), lower(qs_f)};
    // The gap d = q0 - q1 against b: apart while b - d > 0, in contact while d - b > 0.
    LinearGuard g;
    g.row.constant = RowVector::Zero(6);
    g.row.constant(0) = contact ? 1 : -1;
    g.row.constant(1) = contact ? -1 : 1;
    g.offset.constant = contact ? -b : b;
    g.target = contact ? 0 : 1;
    g.scale = b;
    r.guards = {g};
    LinearGuard d = g;  // observables: the gap, the spring's force, and a body's coordinate
    d.row.constant(0) = 1;
    d.row.constant(1) = -1;
    d.offset.constant = 0;
    LinearGuard f;
    f.row.constant = RowVector::Zero(6);
    f.row.constant(1) = ks;
    f.row.constant(2) = -ks;
    f.row.constant(4) = cs;
    f.row.constant(5) = -cs;
    r.observables = {d, f};
    if (x.read_body >= 0) {
      LinearGuard o;
      o.row.constant = RowVector::Zero(6);
      o.row.constant(x.read_body) = 1;
      r.observables.push_back(o);
    }
    drop_zero_terms(r);
    s.regions.push_back(r);
  }
  return s;
}

const Vector kFree = Vector::Ones(3);
const Matrix kMass = Eigen::Vector3d(2.0, 1.0, 3.0).asDiagonal();

// Keeps the samples.
struct Samples : FlowObserver {
  std::vector<double> t;
  std::vector<Vector> y;
  std::vector<double> ev;  // the events' times
  void on_event(double t_s, const Vector& /*y*/, int /*from*/, int /*to*/) override {
    ev.push_back(t_s);
  }
  void on_sample(double t_s, const Vector& at, int /*region*/) override {
    t.push_back(t_s);
    y.push_back(at);
  }
};

// The whole system and its complement, lifted, from a state that turns (phi' = 3 rad/s) and sits
// in the gap: through the contact changes both flows have the same events and states to 1e-10
// of their size; the rotation's quadrature (a mean imbalance, the fluctuation's cosine and sine)
// is the whole flow's rho q. A sign of a quadrature term or a column of L or P wrong moves the
// lifted state by far more.
TEST(RigidSplit, TheComplementsFlowLiftedIsTheWholeFlow) {
  for (const double imbalance : {0.0, 7.0}) {
    Line x;
    x.imbalance = imbalance;
    const LinearSwitchedSystem full = line_system(x);
    const RigidSplit split(full, kFree, kMass);
    ASSERT_EQ(split.reduced().dimension, 4);
    EngineOptions eo;
    eo.tolerance = 1e-13;
    const ExactEngine whole(full, eo), part(split.reduced(), eo);
    const Vector y0{{0.0, 0.0005, -0.0002, 3.0, 3.2, 2.9}};
    const double t0 = 0.013, t1 = 0.613;
    const OutputGrid grid = make_output_grid(t0, t1, 1e-3);
    Samples a, b;
    const FlowResult fa = whole.flow(t0, y0, 0, t1, grid, a);
    const FlowResult fb = part.flow(t0, split.reduce(y0), 0, t1, grid, b);
    ASSERT_TRUE(fa.ok() && fb.ok()) << fa.message << fb.message;
    // The same contact changes at the same times. The whole flow may cross a guard back and
    // forth at one instant where the contact grazes: its guard, q0 - q1 ~ 1e-3 read off two
    // coordinates that turn by radians, holds their rounding; the complement's does not.
    const auto distinct = [](const std::vector<double>& t) {
      std::vector<double> d;
      for (const double x : t)
        if (d.empty() || x - d.back() > 1e-12) d.push_back(x);
      return d;
    };
    const std::vector<double> ea = distinct(a.ev), eb = distinct(b.ev);
    EXPECT_GT(ea.size(), 10U);
    ASSERT_EQ(eb.size(), ea.size());
    for (std::size_t i = 0; i < ea.size(); ++i) EXPECT_NEAR(eb[i], ea[i], 1e-10) << i;
    ASSERT_EQ(b.y.size(), a.y.size());
    const Eigen::Vector2d rigid0 = split.rigid(y0);
    double worst_q = 0, worst_v = 0, size_q = 0, size_v = 0;
    for (std::size_t i = 0; i < a.y.size(); ++i) {
      const Vector lifted = split.lift(t0, rigid0, b.t[i], b.y[i]);
      worst_q = std::max(worst_q, (lifted.head(3) - a.y[i].head(3)).cwiseAbs().maxCoeff());
      worst_v = std::max(worst_v, (lifted.tail(3) - a.y[i].tail(3)).cwiseAbs().maxCoeff());
      size_q = std::max(size_q, a.y[i].head(3).cwiseAbs().maxCoeff());
      size_v = std::max(size_v, a.y[i].tail(3).cwiseAbs().maxCoeff());
    }
    EXPECT_LT(worst_q, 1e-10 * size_q) << imbalance;
    EXPECT_LT(worst_v, 1e-10 * size_v) << imbalance;
    const Vector end = split.lift(t0, rigid0, fb.end_time_s, fb.state);
    EXPECT_LT((end - fa.state).cwiseAbs().maxCoeff(), 1e-10 * size_v);
    // The lifted state splits back into the same parts.
    EXPECT_LT((split.reduce(end) - fb.state).norm(), 1e-12 * fb.state.norm());
    EXPECT_LT((split.rigid(end) - split.rigid_at(t0, rigid0, fb.end_time_s)).norm(),
              1e-12 * split.rigid(end).norm());
  }
}

// A Motion's reading at t takes the phases phases_at has just computed there (a sample's
// observables asked them first) and is then the same to the bit as computing its own; it takes
// no phases kept for another time, nor values a GivenPhases gave (a stepper's rotated ones). A
// mutant that reads any kept phases, or kept phases of another time, fails.
TEST(RigidSplit, AMotionReadsTheKeptPhasesOnlyWhereTheyAreItsOwn) {
  const LinearSwitchedSystem full = line_system(Line{});
  const RigidSplit split(full, kFree, kMass);
  const Eigen::Vector2d rigid0(0.25, 3.0);
  const double t0 = 0.013;
  const RigidSplit::Motion motion(split, t0, rigid0);
  const Vector y_r{{0.0004, -0.0001, 0.2, -0.3}};
  const std::vector<double> unrelated = {1.0};
  for (const double t : {0.013, 0.2371, 1.9}) {
    (void)phases_at(unrelated, t);  // nothing kept for this table
    const Eigen::Vector2d own = motion.at(t);
    const Vector lifted_own = split.lift(t0, rigid0, t, y_r);
    EXPECT_EQ(own, split.rigid_at(t0, rigid0, t));
    (void)phases_at(full.frequencies_rad_s, t);  // a sample's observables, first
    EXPECT_EQ(motion.at(t), own) << t;
    Vector lifted(6);
    motion.lift_into(t, y_r, lifted.data());
    EXPECT_EQ(lifted, lifted_own) << t;
    (void)phases_at(full.frequencies_rad_s, t + 1e-3);
    EXPECT_EQ(motion.at(t), own) << t;
    const std::vector<double> wrong(full.frequencies_rad_s.size(), 0.5);
    const geardyn::ode::Phases wrong_phases{wrong, wrong};
    geardyn::ode::GivenPhases given;
    given.give(full.frequencies_rad_s, t, wrong_phases);
    EXPECT_EQ(motion.at(t), own) << t;
  }
}

// With constant coefficients in contact, the complement's A0 is invertible: once the start-up
// has passed, the engine jumps whole forcing periods around its forced response. The whole
// system's A0 is singular (the free rotation) and its rotation, at rest or turning, does not
// decay onto a periodic response: it steps every cell. Both end in the same state, to rounding
// of the cells the complement stepped.
TEST(RigidSplit, TheComplementJumpsWhereTheWholeSystemCannot) {
  Line x;
  x.stiffness_ratio = 0;
  x.balanced = true;  // the fluctuation does not turn the train
  x.fluctuation = 0.2;
  const LinearSwitchedSystem full = line_system(x);
  const RigidSplit split(full, kFree, kMass);
  const ExactEngine whole(full), part(split.reduced());
  FlowObserver nothing;
  const double t1 = 5.0;
  for (const double rate : {0.0, 3.0}) {
    const Vector y0{{0.002, 0.0, 0.0, rate, rate, rate}};  // in contact, 1 mm into it
    const FlowResult fa = whole.flow(0, y0, 1, t1, {}, nothing);
    const FlowResult fb = part.flow(0, split.reduce(y0), 1, t1, {}, nothing);
    ASSERT_TRUE(fa.ok() && fb.ok()) << fa.message << fb.message;
    EXPECT_GT(fb.periods, 10) << rate;
    EXPECT_EQ(fa.periods, 0) << rate;
    EXPECT_EQ(fa.events, fb.events) << rate;
    const Vector end = split.lift(0, split.rigid(y0), t1, fb.state);
    EXPECT_LT((end.head(3) - fa.state.head(3)).cwiseAbs().maxCoeff(), 1e-9) << rate;
    EXPECT_LT((end.tail(3) - fa.state.tail(3)).cwiseAbs().maxCoeff(), 1e-7) << rate;
  }
}

// The lifted Jacobian of the complement's flow is the whole flow's (saltation at each event
// included), and central differences of the lifted flow's agree.
TEST(RigidSplit, TheLiftedJacobianIsTheWholeFlows) {
  const LinearSwitchedSystem full = line_system(Line{});
  const RigidSplit split(full, kFree, kMass);
  EngineOptions eo;
  eo.tolerance = 1e-13;
  const ExactEngine whole(full, eo), part(split.reduced(), eo);
  const Vector y0{{0.0, 0.0005, -0.0002, 3.0, 3.2, 2.9}};
  const double t0 = 0.013, t1 = 0.213;
  FlowObserver nothing;
  const FlowResult fa = whole.flow(t0, y0, 0, t1, {}, nothing, true);
  const FlowResult fb = part.flow(t0, split.reduce(y0), 0, t1, {}, nothing, true);
  ASSERT_TRUE(fa.ok() && fb.ok() && fa.jacobian && fb.jacobian);
  ASSERT_GT(fa.events, 2);
  const Matrix lifted = split.lift_jacobian(t0, t1, *fb.jacobian);
  EXPECT_LT((lifted - *fa.jacobian).cwiseAbs().maxCoeff(),
            1e-8 * fa.jacobian->cwiseAbs().maxCoeff());
  // Central differences of the lifted flow, column by column.
  const auto lifted_flow = [&](const Vector& y) {
    const FlowResult f = part.flow(t0, split.reduce(y), 0, t1, {}, nothing);
    return split.lift(t0, split.rigid(y), f.end_time_s, f.state);
  };
  for (Eigen::Index j = 0; j < 6; ++j) {
    const double h = j < 3 ? 1e-8 : 1e-6;
    Vector up = y0, down = y0;
    up(j) += h;
    down(j) -= h;
    const Vector column = (lifted_flow(up) - lifted_flow(down)) / (2 * h);
    EXPECT_LT((column - lifted.col(j)).cwiseAbs().maxCoeff(),
              1e-5 * lifted.col(j).cwiseAbs().maxCoeff() + 1e-9)
        << j;
  }
}

// The refusal of splitting r = (1, 1, 1) off the line `x`, "" when it splits.
std::string refusal(const Line& x) {
  try {
    RigidSplit(line_system(x), kFree, kMass);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// A direction a term acts on (a ground spring) or an observable reads (one body's coordinate
// alone) is not free: refused saying which.
TEST(RigidSplit, ADirectionSomethingActsOnOrReadsIsRefused) {
  EXPECT_EQ(refusal(Line{}), "");
  Line grounded;
  grounded.ground = 1e3;
  EXPECT_NE(refusal(grounded).find("acts on the free motion through the coordinates"),
            std::string::npos)
      << refusal(grounded);
  Line read;
  read.read_body = 2;
  EXPECT_NE(refusal(read).find("observable 2 reads the free motion's coordinate"),
            std::string::npos)
      << refusal(read);
  EXPECT_THROW(RigidSplit(line_system(Line{}), Vector::Ones(2), kMass), std::invalid_argument);
}

// A forcing that overflowed cannot be compared region to region, so the split is refused when
// it is made (its user then steps the whole system, which fails as its state does), not when a
// later region is built from it.
TEST(RigidSplit, AForcingThatOverflowedIsRefusedAtOnce) {
  Line huge;
  huge.fluctuation = std::numeric_limits<double>::infinity();
  EXPECT_NE(refusal(huge).find("the forcing is not finite"), std::string::npos) << refusal(huge);
  huge.fluctuation = 1e300;
  EXPECT_EQ(refusal(huge), "");  // large, and finite
}

}  // namespace
}  // namespace geardyn::ode
