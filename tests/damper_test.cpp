// The clutch damper (damper.hpp), a train element in one file: its static curve, its natural
// frequencies in each stage and its energy through the stops against closed forms, the loose
// gear's rattle onset with and without it against the damped driveline's, and its refusals.
#include "geardyn/damper.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/plausibility.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_statics.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// The damper of these tests: free play 1.5 deg with an idle spring of 5 N m/rad, stage 1 at
// 600 N m/rad, stage 2 from 6 deg at 1500 N m/rad, a stop at 10 deg of 1e5 N m/rad.
constexpr double kFreePlay = 1.5 * kDeg, kStage2 = 6 * kDeg, kStop = 10 * kDeg;
constexpr double kIdle = 5, kStage1K = 600, kStage2K = 1500, kStopK = 1e5;

// T(x) of that damper, written out stage by stage from its definition (docs/model.md, "Clutch
// dampers").
double torque(double x) {
  const double a = std::abs(x);
  const double t_play = kIdle * kFreePlay;
  const double t_2 = t_play + kStage1K * (kStage2 - kFreePlay);
  const double t_stop = t_2 + kStage2K * (kStop - kStage2);
  const double t = a <= kFreePlay ? kIdle * a
                   : a <= kStage2 ? t_play + kStage1K * (a - kFreePlay)
                   : a <= kStop   ? t_2 + kStage2K * (a - kStage2)
                                  : t_stop + kStopK * (a - kStop);
  return x < 0 ? -t : t;
}

// Its inverse: the twist at which it carries `t`.
double twist(double t) {
  const double a = std::abs(t);
  const double t_play = kIdle * kFreePlay;
  const double t_2 = t_play + kStage1K * (kStage2 - kFreePlay);
  const double t_stop = t_2 + kStage2K * (kStop - kStage2);
  const double x = a <= t_play   ? a / kIdle
                   : a <= t_2    ? kFreePlay + (a - t_play) / kStage1K
                   : a <= t_stop ? kStage2 + (a - t_2) / kStage2K
                                 : kStop + (a - t_stop) / kStopK;
  return t < 0 ? -x : x;
}

// An engine's flywheel driving a gearbox's input gear through the damper, the input meshing with
// an output gear; the engine's mean torque `engine_nm`, the output's balancing it.
std::string driveline(double engine_nm, double damping = 0, double mesh_damping_ratio = 0.02) {
  return fmt::format(R"(
[model]
form = "train"
[train]
reference = "engine"
reference_speed_hz = 25
[[train.body]]
name = "engine"
inertia_kg_m2 = 0.15
{}
[[train.damper]]
name = "clutch"
from = "engine"
to = "input"
free_play_deg = 1.5
free_play_stiffness_n_m_per_rad = 5
stiffness_n_m_per_rad = 600
stage2_deg = 6
stage2_stiffness_n_m_per_rad = 1500
stop_deg = 10
stop_stiffness_n_m_per_rad = 1e5
damping_n_m_s_per_rad = {}
[[train.torque]]
name = "engine"
body = "engine"
mean_nm = {}
[[train.torque]]
name = "load"
body = "output"
balances = true
)",
                     geardyn::testing::spur_stage_toml(mesh_damping_ratio), damping, engine_nm);
}

// The damper's twist theta_engine - theta_input in state y.
double damper_twist(const train::Assembled& a, const Eigen::VectorXd& y) {
  return y(a.index("engine")) - y(a.index("input"));
}

TEST(Damper, StaticTwistFollowsItsCurveInEveryStage) {
  // At each engine torque the static state's twist is the curve's inverse, in the free play,
  // stage 1, stage 2, at the stop and on the coast side, and the joint settles in that stage.
  // (To 1e-10: the static solve's rounding, its stiffness matrix holding the mesh's 4e5 N m/rad
  // beside the idle spring's 5.)
  for (const auto& [t, stage] : std::vector<std::pair<double, int>>{
           {0.05, 3}, {20, 4}, {80, 5}, {300, 6}, {-20, 2}, {-80, 1}, {-300, 0}}) {
    const Case c = parse_case(driveline(t), "damper");
    const train::Assembled a = assembled_train(c);
    const std::optional<Eigen::VectorXd> y = static_state(a);
    ASSERT_TRUE(y) << t;
    EXPECT_NEAR(damper_twist(a, *y), twist(t), 1e-10 * std::abs(twist(t))) << t;
    EXPECT_NEAR(torque(damper_twist(a, *y)), t, 1e-9 * std::abs(t)) << t;
    ASSERT_EQ(a.joints().size(), 1U);
    EXPECT_EQ(a.operating_stages()[0], stage) << t;
    // A run reads the same static torque and twist.
    TrainRunOptions o;
    Case short_run = c;
    set_case_value(short_run, {"solver.duration_s", "0.01"});
    const TrainRunResult r = run_train(short_run, o);
    ASSERT_EQ(r.joints.size(), 1U);
    EXPECT_NEAR(*r.joints[0].static_force, t, 1e-9 * std::abs(t));
    EXPECT_NEAR(*r.joints[0].static_deformation, twist(t), 1e-10 * std::abs(twist(t)));
  }
}

TEST(Damper, NaturalFrequenciesInEachStageAreTheChainsClosedForm) {
  // The engine, the input and the output (reduced through the ratio) are a free-free chain of
  // three inertias, the damper's stage stiffness k and the mesh's k_m R_in^2 between them: its
  // two frequencies are the roots of J1 J2 J3 l^2 - (k J3 (J1 + J2) + k_c J1 (J2 + J3)) l +
  // k k_c (J1 + J2 + J3) = 0, l = w^2.
  for (const auto& [t, k] : std::vector<std::pair<double, double>>{
           {0.05, kIdle}, {20, kStage1K}, {80, kStage2K}, {300, kStopK}, {-20, kStage1K}}) {
    const train::Assembled a = assembled_train(parse_case(driveline(t), "damper"));
    const train::Mesh& m = a.train().meshes[0];
    const double j1 = 0.15, j2 = 0.004,
                 j3 = 0.02 * std::pow(m.base_radius_driving_m / m.base_radius_driven_m, 2);
    const double kc = m.mean_stiffness_n_per_m * std::pow(m.base_radius_driving_m, 2);
    const double qa = j1 * j2 * j3, qb = -(k * j3 * (j1 + j2) + kc * j1 * (j2 + j3)),
                 qc = k * kc * (j1 + j2 + j3);
    const double root = std::sqrt(qb * qb - 4 * qa * qc);
    const std::array<double, 2> expected = {std::sqrt((-qb - root) / (2 * qa)) / (2 * kPi),
                                            std::sqrt((-qb + root) / (2 * qa)) / (2 * kPi)};
    const std::vector<train::TrainMode> modes = train::modes(a);
    ASSERT_EQ(modes.size(), 3U);
    EXPECT_EQ(modes[0].frequency_hz, 0.0);  // the free rotation
    for (int i = 0; i < 2; ++i)
      EXPECT_NEAR(modes[static_cast<std::size_t>(i) + 1].frequency_hz, expected[i],
                  1e-9 * expected[i])
          << t;
    // Below the stop, the damper mode's strain energy sits in the damper, the mesh mode's in
    // the mesh.
    if (k < kStopK) {
      EXPECT_GT(modes[1].joint_energy[0], 0.9) << t;
      EXPECT_LT(modes[2].joint_energy[0], 0.1) << t;
    }
  }
}

// Samples of a flow of the exact engine.
class Samples : public ode::FlowObserver {
 public:
  void on_sample(double t_s, const ode::Vector& y, int region) override {
    states.push_back(y);
    regions.push_back(region);
  }
  std::vector<ode::Vector> states;
  std::vector<int> regions;
};

TEST(Damper, AnUndampedDrivelineKeepsItsEnergyThroughTheStops) {
  // No damping, no torque: the engine started spinning against the rest, the damper swings
  // through its free play, both stages and onto its stops on either side, the mesh through its
  // backlash; kinetic plus the damper's and the mesh's strain energy stays as it was.
  const train::Assembled a = assembled_train(parse_case(driveline(0, 0, 0), "damper"));
  const train::Train& t = a.train();
  ASSERT_EQ(t.meshes[0].damping_n_s_per_m, 0.0);
  const int n = a.size();
  ode::Vector y0 = ode::Vector::Zero(2 * n);
  y0(n + a.index("engine")) = 60.0;  // rad/s, enough to reach the stops
  ode::EngineOptions o;
  o.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), o);
  Samples s;
  const ode::FlowResult r =
      engine.flow(0.0, y0, a.classify(0.0, y0), 1.0, ode::make_output_grid(0.0, 1.0, 1e-4), s);
  ASSERT_TRUE(r.ok()) << r.message;
  const train::Joint& j = a.joints()[0];
  const auto energy = [&](const ode::Vector& y) {
    const Eigen::VectorXd q = y.head(n), v = y.tail(n);
    const double d = a.mesh_vector(0).dot(q), b = t.meshes[0].backlash_m;
    const double over = d > b ? d - b : d < -b ? d + b : 0.0;
    return 0.5 * v.dot(a.mass() * v) + j.energy(damper_twist(a, y)) +
           0.5 * t.meshes[0].mean_stiffness_n_per_m * over * over;
  };
  // The joint's energy is the curve's integral: checked against a quadrature of torque().
  for (const double x : {0.01, 0.05, 0.15, 0.19, -0.19}) {
    double e = 0;
    const int steps = 200000;
    for (int i = 0; i < steps; ++i) e += torque((i + 0.5) * x / steps) * x / steps;
    EXPECT_NEAR(j.energy(x), e, 1e-6 * e) << x;
  }
  const double e0 = energy(y0);
  std::set<int> stages;
  for (std::size_t i = 0; i < s.states.size(); ++i) {
    EXPECT_NEAR(energy(s.states[i]) / e0, 1.0, 1e-9) << i;
    stages.insert(a.joint_states(s.regions[i])[0]);
  }
  EXPECT_EQ(stages, (std::set<int>{-3, -2, -1, 0, 1, 2, 3}));  // every stage, both stops
}

// The shipped loose gear (cases/loose_gear_rattle.toml), or the same behind a clutch damper
// (cases/loose_gear_damper.toml) made linear, one stage of k = 20 N m/rad and c = 0.3 N m s/rad
// from the centre (its stop far beyond the twists it meets), the engine's acceleration
// amplitude `engine_rad_s2`, over 2.4 s.
Case loose_gear(double engine_rad_s2, bool damper) {
  Case c = load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/" +
                     (damper ? "loose_gear_damper.toml" : "loose_gear_rattle.toml"));
  set_case_value(
      c, {"train.speed[0].acceleration_harmonics", fmt::format("[[{}, 2, 0]]", engine_rad_s2)});
  set_case_value(c, {"solver.duration_s", "2.4"});
  if (damper)
    for (const auto& [key, value] :
         std::vector<std::array<const char*, 2>>{{"free_play_deg", "0"},
                                                 {"free_play_stiffness_n_m_per_rad", "0"},
                                                 {"stiffness_n_m_per_rad", "20"},
                                                 {"damping_n_m_s_per_rad", "0.3"}})
      set_case_value(c, {fmt::format("train.damper[0].{}", key), value});
  return c;
}

TEST(Damper, MovesTheLooseGearsRattleOnsetAsTheDampedDrivelineSays) {
  // The loose gear leaves its flank when the input's acceleration a_in exceeds T_drag / (J_l
  // R_in / R_l). Without the damper a_in is the engine's; with it, the input and the loose gear
  // (in contact: J = J_in + J_l (R_in / R_l)^2) ride on the damper, a_in = |H| a_engine with
  // H = (k + i c w) / (k - J w^2 + i c w) at the firing frequency w: the onset moves to
  // a_engine = a_in / |H|. Each side of each onset, 10 % off: rattle or none over the steady
  // part.
  const train::Assembled a = assembled_train(loose_gear(100, true));
  const double j_in = a.mass()(a.index("input"), a.index("input"));
  const double j_l = a.mass()(a.index("loose"), a.index("loose"));
  const double ratio = 30.0 / 40.0, k = 20, c = 0.3;
  const double onset = 0.2 / (j_l * ratio);
  const double w = 2 * kPi * 25, j = j_in + j_l * ratio * ratio;
  const std::complex<double> h =
      std::complex<double>(k, c * w) / std::complex<double>(k - j * w * w, c * w);
  const double damped_onset = onset / std::abs(h);
  // Its damping counts: undamped, |H| would be less than half.
  EXPECT_GT(std::abs(h), 2 * std::abs(k / (k - j * w * w)));
  for (const auto& [damper, at] :
       std::vector<std::pair<bool, double>>{{false, onset}, {true, damped_onset}}) {
    for (const double factor : {0.9, 1.1}) {
      const TrainRunResult r = run_train(loose_gear(factor * at, damper), TrainRunOptions{});
      ASSERT_TRUE(r.ok()) << r.message;
      const bool rattles = r.meshes[0].steady.impacts > 0;
      EXPECT_EQ(rattles, factor > 1)
          << (damper ? "with" : "without") << " the damper at " << factor * at << " rad/s^2";
    }
  }
}

TEST(Damper, AStaticLoadOnItsStopIsSaidBeforeAnyWork) {
  // At 300 N m either way the static twist is past the stop (10 deg): a plausibility warning
  // names the damper, where it was written, and the torque; at 80 N m (stage 2) and without a
  // stop there is none.
  const auto warned = [](const std::string& text) {
    for (const std::string& w : train_plausibility(parse_case(text, "damper.toml")))
      if (w.find("rests on its stop") != std::string::npos) return w;
    return std::string();
  };
  for (const double t : {300.0, -300.0}) {
    const std::string w = warned(driveline(t));
    EXPECT_NE(w.find("damper 'clutch' (damper.toml:"), std::string::npos) << w;
    EXPECT_NE(w.find(fmt::format("({:.6g} N m, twist_rad", t)), std::string::npos) << w;
  }
  EXPECT_EQ(warned(driveline(80)), "");
  std::string no_stop = driveline(300);
  for (const char* line : {"stop_deg = 10\n", "stop_stiffness_n_m_per_rad = 1e5\n"})
    no_stop.erase(no_stop.find(line), std::string(line).size());
  EXPECT_EQ(warned(no_stop), "");
  // Nothing else is said of these cases: the static state settled every joint.
  for (const double t : {0.05, 20.0, 80.0, 300.0, -80.0})
    for (const std::string& w : train_plausibility(parse_case(driveline(t), "damper.toml")))
      EXPECT_EQ(w.find("did not settle"), std::string::npos) << w;
}

TEST(Damper, RefusesStagesOutOfOrderAndHalfAStage) {
  using geardyn::testing::error_of;
  std::string text = driveline(20);
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    t.replace(t.find(from), from.size(), to);
    return error_of([&] { assembled_train(parse_case(t, "damper.toml")); });
  };
  const std::string order = with("stage2_deg = 6", "stage2_deg = 1");
  EXPECT_NE(order.find("damper 'clutch': stage2_deg = 1: a stage engages beyond the one before "
                       "it"),
            std::string::npos)
      << order;
  EXPECT_NE(order.find("damper.toml:"), std::string::npos) << order;  // where it was written
  const std::string half = with("stop_stiffness_n_m_per_rad = 1e5\n", "");
  EXPECT_NE(half.find("stop_deg = 10: give stop_stiffness_n_m_per_rad with it"), std::string::npos)
      << half;
  const std::string body = with("to = \"input\"", "to = \"gearbox\"");
  EXPECT_NE(body.find("damper 'clutch': to = \"gearbox\": no body of that name"), std::string::npos)
      << body;
  const std::string bound = with("free_play_deg = 1.5", "free_play_deg = -1");
  EXPECT_NE(bound.find("train.damper[0].free_play_deg = -1"), std::string::npos) << bound;
}

}  // namespace
}  // namespace geardyn
