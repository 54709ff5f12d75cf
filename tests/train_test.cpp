// Gear trains from elements (train.hpp): the assembled system against the one-degree model,
// closed forms of geared shaft lines, energy, and the checks on the arrangement.
#include "geardyn/train.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <numbers>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "geardyn/adaptive.hpp"
#include "geardyn/case.hpp"
#include "geardyn/coupled_model.hpp"
#include "geardyn/drag.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/model.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_statics.hpp"
#include "geardyn/validation.hpp"
#include "test_support.hpp"

namespace geardyn::train {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Samples of a flow of the exact engine.
class Samples : public ode::FlowObserver {
 public:
  void on_sample(double t_s, const ode::Vector& y, int region) override {
    t.push_back(t_s);
    states.push_back(y);
    regions.push_back(region);
  }
  std::vector<double> t;
  std::vector<ode::Vector> states;
  std::vector<int> regions;
};

Samples flow(const Assembled& a, const ode::Vector& y0, double t1_s, double interval_s,
             ode::FlowResult* result = nullptr) {
  ode::EngineOptions o;
  o.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), o);
  Samples s;
  const ode::FlowResult r = engine.flow(0.0, y0, a.classify(0.0, y0), t1_s,
                                        ode::make_output_grid(0.0, t1_s, interval_s), s);
  EXPECT_TRUE(r.ok()) << r.message;
  if (result) *result = r;
  return s;
}

using geardyn::testing::mesh;

// The paper's pair as a spur pair with given stiffness harmonics (so that its one-degree model
// and a two-body train are the same physics), at f1 = 100 Hz.
Case spur_case() {
  Case c = park2010_pair_case();  // validation.hpp: harmonics, speed, window, tolerance
  c.gear.helix_angle_deg = 0;
  c.gear.normal_module_mm = 2.5;
  c.gear.teeth = {56, 56};
  c.gear.outside_diameter_mm = {145.0, 145.0};  // z m_n + 2 m_n, no profile shift
  c.gear.profile_shift = {0.0, 0.0};
  c.gear.center_distance_mm = 140.0;
  return c;
}

// The two-body train of a one-degree case: the same inertias, radii, k(t), c and torques (the
// load matched to the drive, eq. 7).
Train pair_train(const Case& c, const Geometry& g, const GearPairParameters& p) {
  Train t;
  t.bodies = {{"pinion", g.inertia_kg_m2[0]}, {"wheel", g.inertia_kg_m2[1]}};
  Mesh m = mesh("mesh", "pinion", "wheel", c.gear.teeth, g.base_radius_m, p.backlash_m,
                p.mean_stiffness_n_per_m());
  for (const Harmonic& h : p.stiffness_n_per_m.terms)
    m.stiffness.push_back({h.amplitude / p.mean_stiffness_n_per_m(), h.phase_rad});
  m.damping_n_s_per_m = p.damping_n_s_per_m;
  t.meshes = {m};
  const HarmonicSeries drive = drive_torque_nm(c);
  const double ratio = g.base_radius_m[1] / g.base_radius_m[0];
  const double w1 = kTwoPi * c.speed.shaft_frequency_hz;
  const double w2 = w1 * c.gear.teeth[0] / c.gear.teeth[1];
  Torque in{"motor", "pinion", drive.offset, {}}, out{"load", "wheel", -ratio * drive.offset, {}};
  for (const Harmonic& h : drive.terms) {
    in.harmonics.push_back({h.amplitude, h.angular_frequency_rad_s / w1, h.phase_rad});
    out.harmonics.push_back({-ratio * h.amplitude, h.angular_frequency_rad_s / w2, h.phase_rad});
  }
  t.torques = {in, out};
  t.reference = "pinion";
  t.reference_speed_hz = c.speed.shaft_frequency_hz;
  return t;
}

// A run's sample table: rows appended past the room reserved (the buffer grows, out of line)
// keep every value, in order, whichever way they were appended; a row of another width is
// refused; rows of no value (a train without shafts or bearings) are counted all the same.
TEST(SampleRows, RowsAppendedPastTheRoomReservedKeepTheirValues) {
  geardyn::SampleRows<double> rows;
  rows.reserve(3, 2);
  constexpr std::size_t kRows = 1000;
  for (std::size_t i = 0; i < kRows; ++i) {
    const auto x = static_cast<double>(i);
    if (i % 2 == 0) {
      double* row = rows.append(2);
      row[0] = x;
      row[1] = -x - 0.5;
    } else {
      rows.push_back(std::vector<double>{x, -x - 0.5});
    }
  }
  ASSERT_EQ(rows.size(), kRows);
  EXPECT_EQ(rows.width(), 2U);
  std::size_t i = 0;
  for (const auto row : rows) {
    ASSERT_EQ(row.size(), 2);
    EXPECT_EQ(row[0], static_cast<double>(i));
    EXPECT_EQ(row[1], -static_cast<double>(i) - 0.5);
    ++i;
  }
  EXPECT_EQ(i, kRows);
  EXPECT_THROW(rows.append(3), std::logic_error);
  EXPECT_EQ(rows.size(), kRows);

  geardyn::SampleRows<int> none;
  none.reserve(2, 0);
  for (int k = 0; k < 5; ++k) none.append(0);
  EXPECT_EQ(none.size(), 5U);
  EXPECT_EQ(none.width(), 0U);
}

// Released, a table gives its values row after row, no more (the buffer grown past the rows
// holds room beyond them), and is empty; rows appended afterwards start afresh.
TEST(SampleRows, ReleasedRowsAreTheirValuesInOrder) {
  geardyn::SampleRows<double> column;
  column.reserve(4, 1);
  for (int i = 0; i < 7; ++i) *column.append(1) = 0.5 * i;  // grown past the room reserved
  const std::vector<double> values = column.release();
  ASSERT_EQ(values.size(), 7U);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(values[static_cast<std::size_t>(i)], 0.5 * i);
  EXPECT_TRUE(column.empty());
  *column.append(1) = 9.0;
  ASSERT_EQ(column.size(), 1U);
  EXPECT_EQ(column[0][0], 9.0);

  geardyn::SampleRows<int> pairs;
  for (int i = 0; i < 3; ++i) pairs.push_back(std::vector<int>{i, -i});
  EXPECT_EQ(pairs.release(), (std::vector<int>{0, 0, 1, -1, 2, -2}));
}

TEST(Train, AOneMeshTrainIsTheOneDegreeModel) {
  // The pair rattles from the middle of the backlash into contact: the train's mesh deflection
  // R_1 theta_1 - R_2 theta_2 follows the one-degree model's delta through every impact.
  const Case c = spur_case();
  Geometry g;
  const GearPairModel model = build_model(c, &g);
  const GearPairParameters& p = model.parameters();
  const Assembled a(pair_train(c, g, p));
  const RunResult one = run_one_degree_model(c);
  ASSERT_TRUE(one.integration.ok()) << one.integration.message;
  ASSERT_GT(one.reading.impacts, 3);
  const Samples s = flow(a, ode::Vector::Zero(4), c.solver.duration_s, c.solver.output_interval_s);
  ASSERT_EQ(s.t.size(), one.samples.size());
  const Eigen::RowVectorXd v = a.mesh_vector(0);
  double worst = 0;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    EXPECT_NEAR(s.t[i], one.samples.t_s[i], 1e-15);
    worst = std::max(
        worst, std::abs(v.dot(s.states[i].head(2)) / p.backlash_m - one.samples.delta_bar[i]));
  }
  EXPECT_LT(worst, 1e-8);
  // A mutant that drops the load torque (or flips a radius) moves delta by order 1.
}

TEST(Train, ItsModesAreTheGearedShaftLinesClosedForm) {
  // Motor -shaft- pinion =mesh= wheel -shaft- load, the mesh 1e6 times stiffer than the shafts:
  // the modes are those of the three-inertia chain with the wheel side reflected through the
  // ratio n = R_2 / R_1 (J / n^2, k / n^2), to the order of the stiffness ratio, plus a mesh
  // mode far above.
  const double j_m = 0.05, j_1 = 0.002, j_2 = 0.02, j_l = 0.3, k_1 = 2e4, k_2 = 5e4;
  const double r_1 = 0.03, r_2 = 0.09, n = r_2 / r_1;
  Train t;
  t.bodies = {{"motor", j_m}, {"pinion", j_1}, {"wheel", j_2}, {"load", j_l}};
  t.meshes = {
      mesh("stage", "pinion", "wheel", {20, 60}, {r_1, r_2}, 1e-4, 1e6 * k_1 / (r_1 * r_1))};
  t.shafts = {{"input", "motor", "pinion", k_1, 0}, {"output", "wheel", "load", k_2, 0}};
  t.reference = "motor";
  t.reference_speed_hz = 50;
  const Assembled a(t);
  const std::vector<TrainMode> modes = train::modes(a);
  ASSERT_EQ(modes.size(), 4U);
  // The free-free chain m1 -k1- m2 -k2- m3: w^2 are the roots of
  // m1 m2 m3 w^4 - (k1 m3 (m1 + m2) + k2 m1 (m2 + m3)) w^2 + k1 k2 (m1 + m2 + m3) = 0.
  const double m1 = j_m, m2 = j_1 + j_2 / (n * n), m3 = j_l / (n * n), k1 = k_1, k2 = k_2 / (n * n);
  const double qa = m1 * m2 * m3, qb = -(k1 * m3 * (m1 + m2) + k2 * m1 * (m2 + m3)),
               qc = k1 * k2 * (m1 + m2 + m3);
  const double disc = std::sqrt(qb * qb - 4 * qa * qc);
  const double f_low = std::sqrt((-qb - disc) / (2 * qa)) / kTwoPi;
  const double f_high = std::sqrt((-qb + disc) / (2 * qa)) / kTwoPi;
  EXPECT_EQ(modes[0].frequency_hz, 0.0);  // the rigid rotation
  EXPECT_NEAR(modes[1].frequency_hz / f_low, 1.0, 1e-5);
  EXPECT_NEAR(modes[2].frequency_hz / f_high, 1.0, 1e-5);
  EXPECT_GT(modes[3].frequency_hz, 100 * f_high);
  EXPECT_GT(modes[3].mesh_energy[0], 0.99);  // the mesh mode strains the mesh
  EXPECT_LT(modes[1].mesh_energy[0], 1e-5);  // the chain's do not
  for (const TrainMode& x : modes) {
    double sum = x.mesh_energy[0];
    for (double e : x.shaft_energy) sum += e;
    if (x.frequency_hz > 1) EXPECT_NEAR(sum, 1.0, 1e-9);
  }
}

// A two-stage reducer: input pinion (20 teeth) on the motor's shaft, an intermediate shaft with
// a wheel (50) and a pinion (17) as one body, the output wheel (61) on the load.
Train two_stage(double second_stiffness_n_per_m) {
  Train t;
  t.bodies = {{"input", 0.004}, {"intermediate", 0.03}, {"output", 0.25}};
  Mesh first = mesh("first", "input", "intermediate", {20, 50}, {0.0235, 0.0587}, 5e-5, 3e8);
  first.stiffness = {{0.08, 0.3}};
  first.transmission_error = {{2e-6, 0.0}};
  first.damping_n_s_per_m = 800;
  t.meshes = {first, mesh("second", "intermediate", "output", {17, 61}, {0.0240, 0.0861}, 5e-5,
                          second_stiffness_n_per_m)};
  t.torques = {{"motor", "input", 40.0, {{8.0, 2, 0.0}}},
               {"load", "output", -40.0 * (0.0587 / 0.0235) * (0.0861 / 0.0240), {}}};
  t.reference = "input";
  t.reference_speed_hz = 30;
  return t;
}

TEST(Train, ItsMeshFrequenciesAreCommensurateFromTheTeeth) {
  const Assembled a(two_stage(3e8));
  const std::vector<Ratio> f = a.mesh_frequency_ratios();
  EXPECT_EQ(f[0].num, 20);
  EXPECT_EQ(f[0].den, 1);
  EXPECT_EQ(f[1].num, 34);  // 17 teeth at 20 / 50 of the input's speed: 340 / 50, reduced
  EXPECT_EQ(f[1].den, 5);
  EXPECT_NEAR(a.mesh_frequency_hz(1), 30 * 6.8, 1e-12);
  // Only the first mesh varies: the period is its own.
  EXPECT_NEAR(a.coefficient_period_s(), 1.0 / (30 * 20), 1e-15);
}

TEST(Train, ItsSystemPeriodIsTheCommonPeriodOfEveryExcitationOrNoneWhenQuasiPeriodic) {
  // The reducer's first mesh at 20 and its motor torque at order 2 of the input speed: a common
  // period of 1 / (2 f_ref). With the second mesh varying too (34/5) it is 5 / (2 f_ref); a
  // torque at order sqrt(2) has none, and the answer says which element and why; a torque at
  // order 2.5 (an engine's half order) has one again, 10 / f_ref (gcd of 20, 34/5 and 5/2 is
  // 1/10).
  Train t = two_stage(3e8);
  EXPECT_NEAR(*Assembled(t).system_period_s(), 1.0 / (2 * 30), 1e-15);
  t.meshes[1].stiffness = {{0.05, 0.0}};
  EXPECT_NEAR(*Assembled(t).system_period_s(), 5.0 / (2 * 30), 1e-15);
  t.torques[0].harmonics[0].order = std::sqrt(2.0);
  std::string why;
  EXPECT_FALSE(Assembled(t).system_period_s(&why));
  EXPECT_NE(why.find("torque 'motor': order 1.41421"), std::string::npos) << why;
  EXPECT_NE(why.find("quasi-periodic"), std::string::npos) << why;
  t.torques[0].harmonics[0].order = 2.5;
  EXPECT_NEAR(*Assembled(t).system_period_s(), 10.0 / 30, 1e-15);
  // An exact period past the bound: an order of 10007/10000 makes it 10000 input periods, 10007
  // periods of that torque (more than kMaxPeriodMultiple).
  t.torques[0].harmonics[0].order = 1.0007;
  EXPECT_FALSE(Assembled(t).system_period_s(&why));
  EXPECT_NE(why.find("periods of the slowest"), std::string::npos) << why;
}

TEST(Train, AStiffSecondStageIsTheSinglePairWithTheReflectedInertia) {
  // The second mesh k times stiffer than the first holds the output to the intermediate
  // shaft: the first mesh's deflection tends to that of the single pair whose wheel carries
  // J_int + J_out (R_2' / R_3)^2 and the load reflected, the difference shrinking as 1/k.
  const Train stiff = two_stage(3e8);
  Train single;
  const double ratio = 0.0240 / 0.0861;
  single.bodies = {{"input", 0.004}, {"intermediate", 0.03 + 0.25 * ratio * ratio}};
  single.meshes = {stiff.meshes[0]};
  single.torques = {stiff.torques[0],
                    {"load", "intermediate", stiff.torques[1].mean_nm * ratio, {}}};
  single.reference = "input";
  single.reference_speed_hz = 30;
  const Assembled one(single);
  // Start both at the single pair's static contact (the mesh loaded, the load balanced).
  const double duration = 0.02, interval = 1e-4;
  const double b = stiff.meshes[0].backlash_m;
  const double f_static = stiff.torques[0].mean_nm / 0.0235;
  const double d0 = b + f_static / 3e8;
  ode::Vector y1 = ode::Vector::Zero(4);
  y1(0) = d0 / 0.0235;
  const Samples ref = flow(one, y1, duration, interval);
  std::vector<double> error;
  for (double factor : {1e2, 1e3}) {
    const Assembled a(two_stage(factor * 3e8));
    const double f2 = f_static * 0.0587 / 0.0240;
    ode::Vector y = ode::Vector::Zero(6);
    y(0) = d0 / 0.0235;
    y(2) = -(b + f2 / (factor * 3e8)) / 0.0861;
    const Samples s = flow(a, y, duration, interval);
    double worst = 0;
    for (std::size_t i = 0; i < s.t.size(); ++i)
      worst = std::max(worst, std::abs(a.mesh_vector(0).dot(s.states[i].head(3)) -
                                       one.mesh_vector(0).dot(ref.states[i].head(2))) /
                                  b);
    error.push_back(worst);
  }
  EXPECT_LT(error[1], 0.02);
  EXPECT_NEAR(error[0] / error[1], 10.0, 3.0);  // first order in 1 / k
}

TEST(Train, ItsResponseToBothStagesTransmissionErrorsIsTheFrequencyDomainSolution) {
  // The two-stage reducer in permanent contact, each mesh at its constant mean stiffness with a
  // transmission error of two harmonics at its own frequency, and damping: linear in contact,
  // so its periodic response is the frequency-domain solution, harmonic by harmonic,
  // (K - w^2 M + i w C) Theta = V^T (k + i w c) E, beside the static part K theta = Q + sum
  // V^T k b (the train's free rotation left out: the loads balance). Started on it, the flow
  // stays on it through both stages' harmonics.
  Train t = two_stage(2e8);
  t.meshes[0].stiffness.clear();
  t.meshes[0].transmission_error = {{1.5e-6, 0.4}, {0.5e-6, -1.0}};
  t.meshes[1].transmission_error = {{2.0e-6, 1.2}, {0.7e-6, 0.3}};
  t.meshes[1].damping_n_s_per_m = 600;
  t.torques[0].harmonics.clear();
  const Assembled a(t);
  const int n = a.size();
  const Eigen::MatrixXd k = a.contact_stiffness(), c = a.contact_damping(), m = a.mass();
  // The static part (a particular solution: K is singular along the free rotation).
  Eigen::VectorXd q = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < 2; ++i) q(a.index(t.torques[i].body)) += t.torques[i].mean_nm;
  for (int j = 0; j < 2; ++j)
    q += a.mesh_vector(j).transpose() * t.meshes[j].mean_stiffness_n_per_m * t.meshes[j].backlash_m;
  const Eigen::VectorXd theta_static = k.completeOrthogonalDecomposition().solve(q);
  ASSERT_LT((k * theta_static - q).norm(), 1e-9 * q.norm());
  // Each harmonic: complex amplitudes of theta.
  struct Term {
    double w;
    Eigen::VectorXcd theta;
  };
  std::vector<Term> terms;
  for (int j = 0; j < 2; ++j) {
    const double w_mesh = kTwoPi * a.mesh_frequency_hz(j);
    for (std::size_t h = 0; h < t.meshes[j].transmission_error.size(); ++h) {
      const double w = (h + 1) * w_mesh;
      const std::complex<double> e = std::polar(t.meshes[j].transmission_error[h].value,
                                                t.meshes[j].transmission_error[h].phase_rad);
      const Eigen::MatrixXcd d = k.cast<std::complex<double>>() -
                                 w * w * m.cast<std::complex<double>>() +
                                 std::complex<double>(0, w) * c.cast<std::complex<double>>();
      const Eigen::VectorXcd rhs = a.mesh_vector(j).transpose().cast<std::complex<double>>() *
                                   (std::complex<double>(t.meshes[j].mean_stiffness_n_per_m,
                                                         w * t.meshes[j].damping_n_s_per_m) *
                                    e);
      terms.push_back({w, d.partialPivLu().solve(rhs)});
    }
  }
  const auto exact = [&](double time) {
    ode::Vector y(2 * n);
    y.head(n) = theta_static;
    y.tail(n).setZero();
    for (const Term& x : terms) {
      const std::complex<double> rot = std::polar(1.0, x.w * time);
      y.head(n) += (x.theta * rot).real();
      y.tail(n) += (std::complex<double>(0, x.w) * x.theta * rot).real();
    }
    return y;
  };
  const double duration = 0.01;
  const Samples s = flow(a, exact(0.0), duration, 1e-5);
  double worst = 0, largest = 0;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    ASSERT_EQ(a.states(s.regions[i]), (std::vector<int>{1, 1})) << s.t[i];  // in contact
    const ode::Vector want = exact(s.t[i]);
    for (int j = 0; j < 2; ++j) {
      const double d = a.mesh_vector(j).dot(s.states[i].head(n)),
                   d_exact = a.mesh_vector(j).dot(want.head(n));
      worst = std::max(worst, std::abs(d - d_exact));
      largest = std::max(largest, std::abs(d_exact - t.meshes[j].backlash_m));
    }
  }
  EXPECT_LT(worst, 1e-8 * largest);
}

TEST(Train, AnUndampedTrainKeepsItsEnergyThroughImpacts) {
  // No damping, no torque, constant stiffness: started with the input spinning, the meshes
  // rattle through back side, backlash and drive side; kinetic plus mesh and shaft strain
  // energy stays as it was to 1e-10 across every event.
  Train t = two_stage(2e8);
  for (Mesh& m : t.meshes) {
    m.stiffness.clear();
    m.transmission_error.clear();
    m.damping_n_s_per_m = 0;
  }
  t.torques.clear();
  t.bodies.push_back({"flywheel", 0.1});
  t.shafts = {{"spring", "output", "flywheel", 50.0, 0.0}};
  const Assembled a(t);
  ode::Vector y0 = ode::Vector::Zero(8);
  y0(4) = 2.0;  // rad/s on the input
  ode::FlowResult r;
  const Samples s = flow(a, y0, 0.05, 1e-5, &r);
  EXPECT_GT(r.events, 20);
  const auto energy = [&](const ode::Vector& y) {
    const Eigen::VectorXd q = y.head(4), v = y.tail(4);
    double e = 0.5 * v.dot(a.mass() * v) + 0.5 * 50.0 * std::pow(q(2) - q(3), 2);
    for (int m = 0; m < 2; ++m) {
      const double d = a.mesh_vector(m).dot(q), b = t.meshes[m].backlash_m;
      const double over = d > b ? d - b : d < -b ? d + b : 0.0;
      e += 0.5 * t.meshes[m].mean_stiffness_n_per_m * over * over;
    }
    return e;
  };
  const double e0 = energy(y0);
  std::set<int> seen;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    EXPECT_NEAR(energy(s.states[i]) / e0, 1.0, 1e-10) << s.t[i];
    for (int st : a.states(s.regions[i])) seen.insert(st);
  }
  EXPECT_EQ(seen.size(), 3U);  // each contact state was visited
}

TEST(Train, RegionsBuiltOnDemandFlowAsRegionsBuiltUpFront) {
  // The rattling two-stage train of the test above, its regions built up front and on demand
  // (LinearSwitchedSystem::make_lazy, the default): the same regions, and the same
  // flow bit for bit through every event, with the exact engine and with dopri5; the lazy system
  // builds only the regions the flow enters.
  Train t = two_stage(2e8);
  for (Mesh& m : t.meshes) m.damping_n_s_per_m = 0;
  const Assembled a(t);
  const ode::LinearSwitchedSystem eager = a.linear_system(Assembled::RegionBuild::kEager),
                                  lazy = a.linear_system(Assembled::RegionBuild::kLazy);
  ASSERT_FALSE(eager.lazy());
  ASSERT_TRUE(lazy.lazy());
  EXPECT_TRUE(a.linear_system().lazy());  // the default: a run enters few of its regions
  EXPECT_EQ(lazy.region_count(), 9);
  EXPECT_TRUE(lazy.regions.empty());
  EXPECT_EQ(lazy.validate(), "");
  for (const int r : {0, 4, 8}) {
    EXPECT_EQ(lazy.region(r).a.constant, eager.regions[static_cast<std::size_t>(r)].a.constant);
    EXPECT_EQ(lazy.region(r).u.constant, eager.regions[static_cast<std::size_t>(r)].u.constant);
    EXPECT_EQ(lazy.region(r).guards.size(),
              eager.regions[static_cast<std::size_t>(r)].guards.size());
  }
  ASSERT_EQ(eager.dimension, 6);
  ode::Vector y0 = ode::Vector::Zero(eager.dimension);
  y0(4) = 2.0;  // the intermediate shaft's speed
  const auto run = [&](const ode::LinearSwitchedSystem& sys, bool adaptive) {
    Samples s;
    const ode::OutputGrid grid = ode::make_output_grid(0.0, 0.05, 1e-5);
    ode::FlowResult r;
    if (adaptive) {
      ode::AdaptiveOptions o;
      o.tolerance = 1e-10;
      r = ode::adaptive_flow(sys, 0.0, y0, a.classify(0.0, y0), 0.05, grid, s, o);
    } else {
      ode::EngineOptions o;
      o.tolerance = 1e-12;
      r = ode::ExactEngine(sys, o).flow(0.0, y0, a.classify(0.0, y0), 0.05, grid, s);
    }
    EXPECT_TRUE(r.ok()) << r.message;
    EXPECT_GT(r.events, 20);
    return s;
  };
  for (const bool adaptive : {false, true}) {
    SCOPED_TRACE(adaptive ? "dopri5" : "exact");
    const Samples e = run(eager, adaptive), l = run(lazy, adaptive);
    ASSERT_EQ(e.t.size(), l.t.size());
    for (std::size_t i = 0; i < e.t.size(); ++i) {
      ASSERT_EQ(e.regions[i], l.regions[i]) << e.t[i];
      ASSERT_EQ(e.states[i], l.states[i]) << e.t[i];
    }
  }
}

// Samples and contact changes of a flow.
class Contacts : public Samples {
 public:
  void on_event(double t_s, const ode::Vector&, int from, int to) override {
    events.push_back({t_s, from, to});
  }
  std::vector<ode::FlowEvent> events;
};

// A loose gear driven by a gear whose speed fluctuates at the second order (a four-cylinder
// engine's firing order at 15 Hz idle), against a constant oil drag.
struct LooseGear {
  double j_loose = 2e-4, r_driver = 0.04, r_loose = 0.03, drag_nm = 0.05, speed_hz = 15;
  double order = 2, k = 1e8, zeta = 0.05, b = 5e-5;

  double w() const { return order * kTwoPi * speed_hz; }
  // Rattle begins where the driver's angular acceleration a w^2, reflected to the loose gear,
  // asks for more deceleration than the drag gives: J (R_d / R_l) a w^2 = T_drag.
  double onset_rad() const { return drag_nm * r_loose / (j_loose * r_driver * w() * w()); }

  Train train(double amplitude_rad) const {
    Train t;
    t.bodies = {{"driver", 1.0}, {"loose", j_loose}};
    Mesh m = mesh("mesh", "driver", "loose", {40, 30}, {r_driver, r_loose}, b, k);
    m.damping_n_s_per_m = 2 * zeta * std::sqrt(k * j_loose / (r_loose * r_loose));
    t.meshes = {m};
    // A sine: the driver's acceleration is 0 at the start, where the gear rests on its flank.
    t.speeds = {{"engine", "driver", {{amplitude_rad, order, -std::numbers::pi / 2}}}};
    t.elements = {TrainDragData{"oil", "loose", drag_nm, 0.0}.element()};
    t.reference = "driver";
    t.reference_speed_hz = speed_hz;
    return t;
  }

  // Separations of the mesh per period of the fluctuation, over the last `periods` of
  // 4 x `periods`.
  double separations_per_period(double amplitude_rad, int periods = 10) const {
    const Assembled a(train(amplitude_rad));
    ode::Vector y = ode::Vector::Zero(4);
    a.prescribe(0.0, y);
    // On the drive flank, pressed by the drag, moving with the driver.
    y(1) = (r_driver * y(0) - b - drag_nm / r_loose / k) / r_loose;
    y(3) = r_driver / r_loose * y(2);
    const double period = kTwoPi / w(), t1 = 4 * periods * period;
    ode::EngineOptions o;
    o.tolerance = 1e-14;
    const ode::ExactEngine engine(a.linear_system(), o);
    Contacts c;
    const ode::FlowResult r =
        engine.flow(0.0, y, a.classify(0.0, y), t1, ode::make_output_grid(0.0, t1, period / 50), c);
    EXPECT_TRUE(r.ok()) << r.message;
    // The driver follows its prescription whatever the mesh does.
    for (std::size_t i = 0; i < c.t.size(); ++i) {
      ode::Vector want = c.states[i];
      a.prescribe(c.t[i], want);
      EXPECT_NEAR(c.states[i](0), want(0), 1e-9 * amplitude_rad);
    }
    int separations = 0;
    for (const ode::FlowEvent& e : c.events)
      if (e.t_s > t1 - periods * period && a.states(e.to)[0] == 0) ++separations;
    return static_cast<double>(separations) / periods;
  }
};

TEST(Train, ALooseGearRattlesWhereItsClosedFormSays) {
  // The onset of rattle against its closed form J (R_d / R_l) a w^2 = T_drag, to within the
  // mesh compliance's effect ((w / w_n)^2 = 8e-5 here; the computed onset lies between 0.9995
  // and 1.0005 of it): on its flank 0.2 % below, rattling 0.2 % above, and more the further
  // above (the separations per period read).
  const LooseGear g;
  const double onset = g.onset_rad();
  EXPECT_EQ(g.separations_per_period(0.998 * onset), 0.0);
  const double just_above = g.separations_per_period(1.002 * onset);
  EXPECT_GE(just_above, 1.0);
  EXPECT_GE(g.separations_per_period(3 * onset), just_above);
}

TEST(Train, APrescribedBodyIsHeldInTheModes) {
  // The loose gear on its mesh against a held driver: one mode, sqrt(k R_l^2 / J) / 2 pi.
  const LooseGear g;
  const std::vector<TrainMode> m = modes(Assembled(g.train(1e-3)));
  ASSERT_EQ(m.size(), 1U);
  EXPECT_NEAR(m[0].frequency_hz, std::sqrt(g.k * g.r_loose * g.r_loose / g.j_loose) / kTwoPi,
              1e-9 * m[0].frequency_hz);
  EXPECT_EQ(m[0].shape(0), 0.0);
}

// The coupled model of a case with dof = 3 (test_support.hpp's coupled) as a train of two planar
// gears on their bearings: the same inertias, radii, base helix, k(t), c and torques as its
// one-degree pair (pair_train), the gears' masses and their line-of-action bearings', the
// pinion's centre seen from the wheel's at psi.
Train planar_pair(const CoupledParameters& p, const Case& c, double psi_rad) {
  const Case one = gear_pair_of(c);
  Geometry g;
  const GearPairModel model = build_model(one, &g);
  Train t = pair_train(one, g, model.parameters());
  t.meshes[0].base_helix_angle_rad = g.base_helix_angle_rad;
  t.meshes[0].transverse_pressure_angle_rad = g.transverse_pressure_angle_rad;
  t.meshes[0].position_angle_rad = psi_rad;
  for (int i = 0; i < 2; ++i) {
    const int line = p.line[static_cast<std::size_t>(i)];
    t.bodies[i].planar = true;
    t.bodies[i].mass_kg = p.mass(line, line);
    t.bearings.push_back({"bearing" + std::to_string(i + 1), t.bodies[i].name,
                          p.bearing_stiffness(line), p.bearing_damping(line)});
  }
  return t;
}

// The coupled model with dof 3 on bearings of unequal stiffness, its parameters and its modes'
// frequencies (ascending).
struct CoupledPair {
  Case c;
  CoupledParameters p;
  std::vector<double> frequencies_hz;
};
CoupledPair coupled_pair_on_bearings() {
  CoupledPair x{testing::coupled(3), {}, {}};
  x.c.bearings.radial_stiffness_n_per_m = {1.2e8, 3.1e8};
  x.p = coupled_parameters(x.c);
  for (const Mode& m : modes(CoupledModel(x.p)).modes) x.frequencies_hz.push_back(m.frequency_hz);
  return x;
}

TEST(Train, APlanarPairsModesAreTheCoupledPairsAndItsBearingsAlone) {
  // Two planar gears on isotropic bearings: the line of action's direction takes the coupled
  // model's y (dof 3: u, y1, y2, a test of its own against closed forms), and each centre's
  // motion across it is its bearing alone, w^2 = k_r / m. With a helix (cos(beta_b) on every
  // entry of V) and at any psi. A mutant without cos(beta_b) on the centres, or with n not a
  // unit vector, moves the coupled frequencies by percents.
  const auto [c, p, coupled_hz] = coupled_pair_on_bearings();
  std::vector<double> expected = coupled_hz;
  for (int i = 0; i < 2; ++i) {
    const int line = p.line[static_cast<std::size_t>(i)];
    expected.push_back(std::sqrt(p.bearing_stiffness(line) / p.mass(line, line)) / kTwoPi);
  }
  std::sort(expected.begin(), expected.end());
  for (const double psi : {0.0, 0.7, -2.5}) {
    SCOPED_TRACE(psi);
    const Assembled a(planar_pair(p, c, psi));
    ASSERT_EQ(a.size(), 6);
    EXPECT_EQ(a.coordinate_names(),
              (std::vector<std::string>{"pinion_rad", "wheel_rad", "pinion_x_m", "pinion_y_m",
                                        "wheel_x_m", "wheel_y_m"}));
    const std::vector<TrainMode> m = modes(a);
    ASSERT_EQ(m.size(), 6U);
    EXPECT_EQ(m[0].frequency_hz, 0.0);  // the rigid rotation
    for (std::size_t r = 1; r < 6; ++r) {
      EXPECT_NEAR(m[r].frequency_hz / expected[r - 1], 1.0, 1e-9) << r;
      EXPECT_NEAR(m[r].mesh_energy[0] + m[r].bearing_energy[0] + m[r].bearing_energy[1], 1.0,
                  1e-12);
    }
  }
}

TEST(Train, ABodyHeldToItsLineIsThePlanarBodyAlongIt) {
  // The planar pair above with each gear held to the line of action (Body::line): one
  // coordinate w per centre, u = n w. Its modes are the coupled model's alone (the bearings'
  // motions across the line are gone), whatever psi, and its flow through the mesh's impacts
  // at a slant (n along neither x nor y), and through a bearing clearance's with n along y, is
  // the planar pair's: theta, and n . u = w, to 1e-9 of their range, its centres' motion across
  // n staying 0. A mutant that drops n from the mesh's or the bearing's columns, or keeps the
  // clearance of a direction the line does not reach, fails.
  const auto [c, p, expected] = coupled_pair_on_bearings();
  for (const double psi : {0.0, 0.7, -2.5}) {
    SCOPED_TRACE(psi);
    Train held = planar_pair(p, c, psi);
    for (Body& b : held.bodies) b.line = true;
    const Assembled a(held);
    EXPECT_EQ(a.coordinate_names(), (std::vector<std::string>{"pinion_rad", "wheel_rad",
                                                              "pinion_line_m", "wheel_line_m"}));
    EXPECT_NEAR(a.mass()(2, 2), held.bodies[0].mass_kg, 1e-15 * held.bodies[0].mass_kg);
    const std::vector<TrainMode> m = modes(a);
    ASSERT_EQ(m.size(), 4U);
    EXPECT_EQ(m[0].frequency_hz, 0.0);
    for (std::size_t r = 1; r < 4; ++r)
      EXPECT_NEAR(m[r].frequency_hz / expected[r - 1], 1.0, 1e-9) << r;
  }
  // The flow, rattling from rest at the backlash's middle under the torques' fluctuation: at a
  // slant (n along neither x nor y), and with n along y (the coupled pair's psi = alpha_t) and
  // the wheel's bearing with a clearance of a third of the mesh's backlash. (A clearance acts
  // in x and in y each, so at a slant it pushes a planar centre across the line.)
  const double alpha_t = compute_geometry(c.gear).transverse_pressure_angle_rad;
  for (const double psi : {0.7, alpha_t}) {
    SCOPED_TRACE(psi);
    Train planar = planar_pair(p, c, psi);
    if (psi == alpha_t) planar.bearings[1].clearance_m = planar.meshes[0].backlash_m / 3;
    for (Torque& q : planar.torques)
      for (TorqueHarmonic& h : q.harmonics) h.amplitude_nm *= 40;
    Train held = planar;
    for (Body& b : held.bodies) b.line = true;
    const Assembled ap(planar), ah(held);
    EXPECT_EQ(ap.clearances().size(), psi == alpha_t ? 2U : 0U);
    EXPECT_EQ(ah.clearances().size(), psi == alpha_t ? 1U : 0U);  // y alone: x never closes
    // 10 ms: the rattle is chaotic, the two assemblies' rounding (1e-18 rad) growing some tenfold
    // a millisecond (to 1e-10 relative by 20 ms).
    const double t1 = 0.01, dt = 2e-5;
    ode::FlowResult rp, rh;
    const Samples sp = flow(ap, ode::Vector::Zero(2 * ap.size()), t1, dt, &rp);
    const Samples sh = flow(ah, ode::Vector::Zero(2 * ah.size()), t1, dt, &rh);
    EXPECT_GT(rh.events, 10);
    ASSERT_EQ(sp.t.size(), sh.t.size());
    const Eigen::Vector2d n = ap.line_of_action(0);
    double range_theta = 0, range_w = 0, off_theta = 0, off_w = 0, across = 0;
    for (std::size_t i = 0; i < sp.t.size(); ++i) {
      const ode::Vector& yp = sp.states[i];
      const ode::Vector& yh = sh.states[i];
      for (int b = 0; b < 2; ++b) {
        const Eigen::Vector2d u = yp.segment(ap.translation(b), 2);
        const double w = yh(ah.translation(b));
        range_theta = std::max(range_theta, std::abs(yh(b)));
        range_w = std::max(range_w, std::abs(w));
        off_theta = std::max(off_theta, std::abs(yp(b) - yh(b)));
        off_w = std::max(off_w, std::abs(n.dot(u) - w));
        across = std::max(across, std::abs(n.x() * u.y() - n.y() * u.x()));
      }
    }
    if (psi == alpha_t) EXPECT_GT(range_w, planar.bearings[1].clearance_m);  // it closes
    EXPECT_LT(off_theta, 1e-9 * range_theta);
    EXPECT_LT(off_w, 1e-9 * range_w);
    EXPECT_LT(across, 1e-12 * range_w);
  }
}

TEST(Train, ABodyHeldToItsLineNeedsOneMeshAndNoPin) {
  Case c = testing::coupled(3);
  const CoupledParameters p = coupled_parameters(c);
  Train t = planar_pair(p, c, 0.3);
  t.bodies[1].line = true;
  t.bodies.push_back({"idler", 1e-3});
  t.meshes.push_back(t.meshes[0]);
  t.meshes[1].name = "second";
  t.meshes[1].driving = "wheel";
  t.meshes[1].driven = "idler";
  const auto error = [](const Train& x) {
    try {
      Assembled a(x);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(error(t),
            "body 'wheel': is held to its line (dof = \"line\") but is in 2 meshes: it moves "
            "along the line of action of one mesh (give it dof = \"planar\")");
  Train pinned = planar_pair(p, c, 0.3);
  pinned.bodies[1].line = true;
  pinned.bodies.push_back({"carrier", 1e-2});
  pinned.bearings[1].on = "carrier";
  EXPECT_NE(error(pinned).find("bearing 'bearing2': body = \"wheel\" is held to its line"),
            std::string::npos)
      << error(pinned);
}

TEST(Train, TheMeshPushesTheDrivenCentreAlongItsLineOfAction) {
  // The static state of a planar pair under its mean torques: the mesh force F = T1 / (R_1
  // cos(beta_b)) pushes the wheel's centre by cos(beta_b) F n / k_2 and the pinion's by the
  // opposite over k_1, n = s cos(alpha_t) t + sin(alpha_t) e (train.hpp): tangent to the base
  // circles in the driving gear's sense s and away from it. The pinion turns counterclockwise
  // when it is the reference, clockwise when the wheel is (the mesh reverses the sense). A
  // mutant with the tangent's sign fixed, or the separating part toward the driver, fails.
  Case c = testing::coupled(3);
  const CoupledParameters p = coupled_parameters(c);
  const double psi = 0.5, alpha = compute_geometry(c.gear).transverse_pressure_angle_rad;
  const Eigen::Vector2d e(std::cos(psi), std::sin(psi)), t(-std::sin(psi), std::cos(psi));
  for (const int sense : {1, -1}) {
    SCOPED_TRACE(sense);
    Train x = planar_pair(p, c, psi);
    if (sense < 0) x.reference = "wheel";
    const Assembled a(x);
    EXPECT_EQ(a.sense(0), sense);
    EXPECT_EQ(a.sense(1), -sense);
    const std::optional<Eigen::VectorXd> y = static_state(a);
    ASSERT_TRUE(y);
    const Mesh& m = x.meshes[0];
    const double cb = std::cos(m.base_helix_angle_rad);
    const double force = x.torques[0].mean_nm / (m.base_radius_driving_m * cb);
    EXPECT_NEAR(static_mesh_forces_n(a, *y)[0] / force, 1.0, 1e-9);
    const Eigen::Vector2d n = sense * std::cos(alpha) * t + std::sin(alpha) * e;
    const Eigen::Vector2d wheel = y->segment(a.translation(1), 2);
    const Eigen::Vector2d pinion = y->segment(a.translation(0), 2);
    const double scale = cb * force / x.bearings[1].stiffness_n_per_m;
    EXPECT_LT((wheel - scale * n).norm(), 1e-9 * scale);
    EXPECT_LT((pinion + cb * force / x.bearings[0].stiffness_n_per_m * n).norm(), 1e-9 * scale);
  }
}

TEST(Train, AnInternalMeshKeepsTheSenseAndPressesThePinionTowardTheRingsCentre) {
  // A pinion (20 teeth) inside a ring (60), both planar on bearings, the ring's centre at psi
  // from the pinion's. The ring turns the pinion's way at a third of its speed; in torsion the
  // pair is the external one's (one mode, w^2 = k (R_p^2 / J_p + R_r^2 / J_r), spur, the
  // centres held). At rest under the mean torques the separating force presses the
  // pinion toward the ring's centre and the ring's rim away from the pinion: F n / k on each
  // centre with n = s cos(alpha_t) t + sigma sin(alpha_t) e at the pitch point's angle
  // (train.hpp), whichever of the two drives. A mutant that reverses the sense across an
  // internal mesh, or pushes the pinion away from the ring's centre, fails.
  const double psi = 1.1, alpha = 0.35, r_p = 0.02, r_r = 0.06, j_p = 1e-4, j_r = 0.05;
  const double k = 4e8, torque = 30;
  for (const bool ring_drives : {false, true}) {
    SCOPED_TRACE(ring_drives);
    Train t;
    t.bodies = {{"pinion", j_p, true, 0.3}, {"ring", j_r, true, 2.0}};
    Mesh m = ring_drives ? mesh("m", "ring", "pinion", {60, 20}, {r_r, r_p}, 5e-5, k)
                         : mesh("m", "pinion", "ring", {20, 60}, {r_p, r_r}, 5e-5, k);
    m.internal = true;
    m.position_angle_rad = ring_drives ? psi + std::numbers::pi : psi;  // driven seen from driving
    m.transverse_pressure_angle_rad = alpha;
    t.meshes = {m};
    t.bearings = {{"bp", "pinion", 1e12, 0}, {"br", "ring", 1e12, 0}};
    const double drive = ring_drives ? torque * r_r / r_p : torque;
    t.torques = {{"in", ring_drives ? "ring" : "pinion", drive, {}},
                 {"out",
                  ring_drives ? "pinion" : "ring",
                  -drive * (ring_drives ? r_p / r_r : r_r / r_p),
                  {}}};
    t.reference = "pinion";
    t.reference_speed_hz = 50;
    const Assembled a(t);
    EXPECT_EQ(a.sense(1), 1);  // the ring turns the pinion's way
    EXPECT_EQ(a.speed_ratios()[1].num, 1);
    EXPECT_EQ(a.speed_ratios()[1].den, 3);
    Train torsional = t;  // the centres held: the torsional pair alone
    torsional.bodies[0].planar = torsional.bodies[1].planar = false;
    torsional.bearings.clear();
    const std::vector<TrainMode> modes = train::modes(Assembled(torsional));
    const double w2 = k * (r_p * r_p / j_p + r_r * r_r / j_r);
    ASSERT_EQ(modes.size(), 2U);
    EXPECT_NEAR(modes[1].frequency_hz / (std::sqrt(w2) / kTwoPi), 1.0, 1e-12);
    const std::optional<Eigen::VectorXd> y = static_state(a);
    ASSERT_TRUE(y);
    const double force = torque / r_p;  // the pinion's torque over its base radius, both ways
    EXPECT_NEAR(static_mesh_forces_n(a, *y)[0] / force, 1.0, 1e-9);
    const Eigen::Vector2d to_ring_centre(std::cos(psi), std::sin(psi));  // from the pinion's
    const Eigen::Vector2d pinion = y->segment(a.translation(0), 2);
    const Eigen::Vector2d ring = y->segment(a.translation(1), 2);
    const double scale = force / 1e12;
    EXPECT_NEAR(pinion.dot(to_ring_centre), scale * std::sin(alpha), 1e-9 * scale);
    EXPECT_NEAR(ring.dot(to_ring_centre), -scale * std::sin(alpha), 1e-9 * scale);
    // Tangentially the ring's tooth goes the pinion's way (counterclockwise) at the pitch
    // point, which lies opposite the ring's centre from the pinion's.
    const Eigen::Vector2d tangent(std::sin(psi), -std::cos(psi));  // ccw at the pitch point
    const double along = ring_drives ? -1.0 : 1.0;  // the driven gear is pushed along the motion
    EXPECT_NEAR(ring.dot(tangent), along * scale * std::cos(alpha), 1e-9 * scale);
    EXPECT_NEAR(pinion.dot(tangent), -along * scale * std::cos(alpha), 1e-9 * scale);
  }
}

// x mod 1 in [0, 1).
double cycles(double x) { return x - std::floor(x); }

TEST(Train, AnIdlersTwoMeshesArePhasedByTheTravelOfItsTeethBetweenThem) {
  // Driver -> idler -> driven, the phase from the layout. An idler tooth driven at the first
  // pitch point on its trailing flank drives at the second on its leading flank, half a pitch
  // ahead, after turning through the angle Delta between the two pitch points in its own sense
  // (clockwise here): the second mesh's cycle lags the first's by z Delta / 2 pi - 1/2, so
  // u_out = u_in - (z Delta / 2 pi - 1/2) mod 1 (a diametral idler: in phase for an odd z, half
  // a cycle apart for an even one). Each mesh's stiffness is its given curve delayed by u.
  for (const int z : {47, 48}) {
    for (const double theta : {0.0, 0.3, 2.0, -1.2}) {
      SCOPED_TRACE(fmt::format("z {} theta {}", z, theta));
      Train t;
      t.bodies = {{"driver", 0.01}, {"idler", 0.02}, {"driven", 0.03}};
      Mesh in = mesh("in", "driver", "idler", {30, z}, {0.03, 0.047}, 5e-5, 4e8);
      Mesh out = mesh("out", "idler", "driven", {z, 60}, {0.047, 0.06}, 5e-5, 4e8);
      in.position_angle_rad = 0;
      out.position_angle_rad = theta;
      in.stiffness = out.stiffness = {{0.1, 0.4}, {0.02, -1.0}};
      t.meshes = {in, out};
      t.reference = "driver";
      t.reference_speed_hz = 20;
      t.mesh_phase_from_layout = true;
      const Assembled a(t);
      const std::vector<double>& u = a.mesh_phases();
      // The idler (clockwise) turns from its first pitch point (at pi) to its second (theta).
      const double delta = cycles((std::numbers::pi - theta) / kTwoPi) * kTwoPi;
      const double lag = cycles(z * delta / kTwoPi - 0.5);
      const double miss = cycles(u[1] - (u[0] - lag) + 0.5) - 0.5;
      EXPECT_NEAR(miss, 0.0, 1e-12);
      if (theta == 0.0)
        EXPECT_NEAR(cycles(u[1] - u[0] - (z % 2 == 1 ? 0.0 : 0.5) + 0.5) - 0.5, 0.0, 1e-12);
      // The stiffness of each mesh: the given curve k_g(tau) at tau = t + u T.
      t.mesh_phase_from_layout = false;
      const Assembled given(t);
      for (int j = 0; j < 2; ++j) {
        const double period = 1.0 / a.mesh_frequency_hz(j);
        for (const double time : {0.0, 1e-4, 7e-4})
          EXPECT_NEAR(a.stiffness_series(j)(time),
                      given.stiffness_series(j)(time + u[static_cast<std::size_t>(j)] * period),
                      1e-6);  // N/m of 4e8
      }
    }
  }
}

// A star gear set (the carrier held): a sun, n planets at equal spacing and a ring, every axis
// fixed, the phase from the layout.
Train star(int sun, int planet, int ring, int planets) {
  Train t;
  t.bodies = {{"sun", 1e-3}, {"ring", 0.2}};
  for (int n = 0; n < planets; ++n) {
    const std::string p = fmt::format("planet{}", n + 1);
    const double psi = kTwoPi * n / planets;
    t.bodies.push_back({p, 5e-4});
    Mesh sp = mesh("sun-" + p, "sun", p, {sun, planet}, {0.01 * sun, 0.01 * planet}, 5e-5, 4e8);
    sp.position_angle_rad = psi;
    Mesh rp = mesh("ring-" + p, p, "ring", {planet, ring}, {0.01 * planet, 0.01 * ring}, 5e-5, 4e8);
    rp.internal = true;
    rp.position_angle_rad = psi + std::numbers::pi;  // the ring's centre, seen from the planet's
    t.meshes.push_back(sp);
    t.meshes.push_back(rp);
  }
  t.reference = "sun";
  t.reference_speed_hz = 50;
  t.mesh_phase_from_layout = true;
  return t;
}

TEST(Train, AStarSetAssemblesWhenItsTeethAllowAndItsSunMeshesArePhasedByTheSunsTeeth) {
  // Equally spaced planets assemble when (z_s + z_r) / N is whole (the classical condition): a
  // layout that breaks it is refused at the mesh that closes the loop. A planet's ring mesh
  // follows its sun mesh as an idler's second mesh its first. The sun-planet meshes
  // follow one another by the sun's teeth over the spacing: u_n = u_1 - z_s psi_n / 2 pi mod 1
  // (Parker and Lin's sun-planet phasing, the sun turning counterclockwise).
  for (const auto& [sun, planet, planets] :
       {std::array<int, 3>{20, 25, 3}, std::array<int, 3>{20, 26, 4},
        std::array<int, 3>{21, 24, 5}}) {
    const int ring = sun + 2 * planet;
    SCOPED_TRACE(fmt::format("{} {} {} x{}", sun, planet, ring, planets));
    ASSERT_EQ((sun + ring) % planets, 0);
    const Assembled a(star(sun, planet, ring, planets));
    const std::vector<double>& u = a.mesh_phases();
    // A planet is an idler turned half a turn between its two pitch points: its ring mesh lags
    // its sun mesh by z_p / 2 - 1/2 cycles (in phase for an odd z_p, half a cycle for an even).
    for (int n = 0; n < planets; ++n) {
      const double lag = cycles(planet / 2.0 - 0.5);
      const auto j = static_cast<std::size_t>(2 * n);
      EXPECT_NEAR(cycles(u[j + 1] - (u[j] - lag) + 0.5) - 0.5, 0.0, 1e-9) << n;
    }
    for (int n = 1; n < planets; ++n) {
      const double expected = u[0] - static_cast<double>(sun * n) / planets;
      EXPECT_NEAR(cycles(u[static_cast<std::size_t>(2 * n)] - expected + 0.5) - 0.5, 0.0, 1e-9)
          << n;
    }
    // One tooth more on the sun and the ring (the planets unchanged): (z_s + z_r) / N is no
    // longer whole.
    try {
      Assembled bad(star(sun + 1, planet, ring + 1, planets));
      ADD_FAILURE() << "a set that cannot assemble was taken";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("closes a loop of meshes whose teeth cannot interlock"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(Train, ABadArrangementIsRefusedNamingTheElement) {
  const auto refused = [](Train t, const std::string& piece) {
    try {
      Assembled a(std::move(t));
      ADD_FAILURE() << "accepted; expected: " << piece;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(piece), std::string::npos) << e.what();
    }
  };
  Train t = two_stage(3e8);
  Train x = t;
  x.meshes[1].driven = "shaft3";
  refused(x, "mesh 'second': driven = \"shaft3\": no body of that name");
  x = t;
  x.bodies.push_back({"input", 1.0});
  refused(x, "body 'input': is named twice");
  x = t;
  x.meshes.clear();
  refused(x, "has no mesh");
  x = t;
  x.shafts = {{"lock", "input", "output", 1e3, 0}};  // input and output on one shaft: locked
  refused(x, "closes a loop whose speed ratios disagree");
  refused(x, "the train is locked and cannot turn");
  x = t;
  x.bodies.push_back({"loose", 0.1});
  refused(x, "body 'loose': is joined to the reference 'input' by no mesh, shaft or pin");
  x = t;
  x.meshes[0].teeth_driven = 0;
  refused(x, "mesh 'first': teeth = [20, 0]");
  x = t;
  x.speeds = {{"engine", "input", {}}};
  refused(x, "torque 'motor': body = \"input\": its speed is prescribed, so no torque acts on it");
  x.torques.clear();
  x.speeds.push_back({"again", "input", {}});
  refused(x, "speed 'again': body = \"input\": its speed is prescribed twice");
  x = t;
  x.bearings = {{"b1", "output", 1e8, 0}};
  refused(x, "bearing 'b1': body = \"output\" keeps torsion only");
  x.bodies[2].planar = true;
  x.bodies[2].mass_kg = 3;
  x.bearings.clear();
  refused(x, "body 'output': is planar (dof = \"planar\") but no bearing carries it");
  x.bearings = {{"b1", "output", 1e8, 0}};
  x.bodies[2].mass_kg = 0;
  refused(x, "body 'output': mass_kg = 0: a planar body needs a finite mass > 0 kg");
  x.bodies[2].mass_kg = 3;
  x.bearings = {{"b1", "output", 0, 0}};
  refused(x, "bearing 'b1': stiffness = 0 N/m: must be finite and > 0");
  x = t;  // a third external mesh closing a triangle: the speeds agree, the senses cannot
  x.meshes.push_back(mesh("back", "output", "input", {61, 20}, {0.0861, 0.0235}, 5e-5, 3e8));
  x.meshes[1].teeth_driving = 50;  // input 20 -> 50 -> 61 -> 20: the speeds close
  refused(x, "closes a loop whose senses of rotation disagree");
  x = t;
  x.meshes[0].internal = true;
  x.meshes[0].teeth_driven = 20;
  refused(x, "mesh 'first': internal with teeth = [20, 20]: a ring gear has more teeth");
}

}  // namespace
}  // namespace geardyn::train
