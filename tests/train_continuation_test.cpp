// Continuation of a gear train's periodic orbits (continuation.hpp on a train case): two loose
// gears on one input, continued in the input's acceleration amplitude through each mesh's
// rattle onset, the grazings against their closed forms and the multipliers of a rattling point
// against central differences of the period map through its impacts.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/continuation.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/one_degree_orbit.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_orbit.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_statics.hpp"
#include "geardyn/validation.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

// An input gear with a prescribed speed at the firing order 2 drives two loose gears, each with
// a constant drag; {0} is the meshes' damping ratio.
constexpr const char* kTwoLooseGears = R"(
[model]
form = "train"
[train]
reference = "input"
reference_speed_hz = 12.5
[[train.body]]
name = "input"
teeth = 30
normal_module_mm = 2.5
face_width_mm = 15
[[train.body]]
name = "loose1"
teeth = 40
normal_module_mm = 2.5
face_width_mm = 15
bore_diameter_mm = 45
[[train.body]]
name = "loose2"
teeth = 35
normal_module_mm = 2.5
face_width_mm = 12
bore_diameter_mm = 40
[[train.mesh]]
name = "first"
driving = "input"
driven = "loose1"
backlash_um = 50
mean_stiffness_n_per_m = 3e8
damping_ratio = {0}
[[train.mesh]]
name = "second"
driving = "input"
driven = "loose2"
backlash_um = 60
mean_stiffness_n_per_m = 2.4e8
damping_ratio = {0}
[[train.speed]]
body = "input"
acceleration_harmonics = [[230, 2, 0]]
[[train.drag]]
body = "loose1"
constant_nm = 0.2
[[train.drag]]
body = "loose2"
constant_nm = 0.11
[solver]
initial = "static"
)";

constexpr const char* kAmplitude = "train.speed[0].acceleration_harmonics[0][0]";

// The free bodies' state (loose1, loose2 angles, then rates) after one period from z at t = 0,
// the input as prescribed; flown by an engine of the test's own at 1e-15.
Eigen::Vector4d period_map(const train::Assembled& a, const ode::ExactEngine& engine, double period,
                           const Eigen::Vector4d& z) {
  return testing::free_period_map(a, engine, period, z);
}

Case two_loose_gears(double damping_ratio) {
  return parse_case(fmt::format(kTwoLooseGears, damping_ratio), "two loose gears");
}

// The branch of `base` along the input's acceleration amplitude from `from` to `to`.
ContinuationResult continued(const Case& base, double from, double to) {
  ContinuationOptions o;
  o.key = kAmplitude;
  o.from = from;
  o.to = to;
  return continuation(base, o);
}

// Central differences (step 1e-7 of the scale) of the period map at the free bodies' state z,
// in the unknowns' scale
// (each angle by its mesh's b over the mesh vector's entry, each rate by that times the
// highest natural frequency in contact), where each entry is of order one; the monodromy
// scaled alike into *exact.
Eigen::Matrix4d scaled_central_differences(const Case& c, const Eigen::Vector4d& z, double period,
                                           const ode::Matrix& monodromy, Eigen::Matrix4d* exact) {
  const train::Assembled a = assembled_train(c);
  ode::EngineOptions eo;
  eo.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), eo);
  double w = 0;
  for (const train::TrainMode& m : train::modes(a))
    w = std::max(w, 2 * std::numbers::pi * m.frequency_hz);
  Eigen::Vector4d scale;
  for (int k = 0; k < 2; ++k) {
    const double angle = (k == 0 ? 50e-6 : 60e-6) / std::abs(a.mesh_vector(k)(k + 1));
    scale(k) = angle;
    scale(k + 2) = angle * w;
  }
  // The orbit closes to the Newton tolerance in the scaled state.
  EXPECT_LT(((period_map(a, engine, period, z) - z).cwiseQuotient(scale)).lpNorm<Eigen::Infinity>(),
            1e-8);
  const Eigen::Matrix4d fd = testing::central_differences(
      [&](const Eigen::VectorXd& x) { return period_map(a, engine, period, x); }, z, 1e-7 * scale);
  const Eigen::Matrix4d s = scale.asDiagonal();
  *exact = s.inverse() * monodromy * s;
  return s.inverse() * fd * s;
}

TEST(TrainContinuation, EachLooseGearGrazesAtItsClosedFormOnset) {
  // Well damped meshes: each onset of rattle is one clean grazing, 0 -> 1 impact a period.
  const Case base = two_loose_gears(0.5);
  const ContinuationResult r = continued(base, 230, 250);
  ASSERT_TRUE(r.completed) << r.message;
  EXPECT_EQ(r.state_names,
            (std::vector<std::string>{"loose1_rad", "loose2_rad", "loose1_rad_s", "loose2_rad_s"}));
  // A loose gear leaves its drive flank once J (R_in / R_loose) a > T_drag: the first grazing
  // of each mesh is there, within the mesh compliance's effect (the mesh is a spring, not a
  // rigid flank: 0.05 % here).
  const train::Assembled a = assembled_train(base);
  const double onset1 = 0.2 / (a.mass()(1, 1) * 30.0 / 40.0);
  const double onset2 = 0.11 / (a.mass()(2, 2) * 30.0 / 35.0);
  const auto first_grazing = [&](const std::string& mesh) -> const Bifurcation* {
    for (const Bifurcation& b : r.bifurcations)
      if (b.type == BifurcationType::kGrazing && b.detail.starts_with("mesh " + mesh + " "))
        return &b;
    return nullptr;
  };
  const Bifurcation* g1 = first_grazing("first");
  const Bifurcation* g2 = first_grazing("second");
  ASSERT_TRUE(g1 && g2);
  EXPECT_NEAR(g1->param / onset1, 1.0, 5e-4) << g1->param << " against " << onset1;
  EXPECT_NEAR(g2->param / onset2, 1.0, 5e-4) << g2->param << " against " << onset2;
  EXPECT_NE(g1->detail.find("impacts 0 -> 1"), std::string::npos) << g1->detail;
  EXPECT_NE(g2->detail.find("impacts 0 -> 1"), std::string::npos) << g2->detail;
  // Below the first onset the branch is in contact; the orbit JSON is the train's.
  EXPECT_EQ(r.points.front().orbit.reading.impacts, 0);
  EXPECT_NE(g1->orbit_json.find("\"model\":\"train\""), std::string::npos);
  // Both meshes rattle at the end.
  const BranchPoint& last = r.points.back();
  ASSERT_EQ(last.orbit.contacts.size(), 2U);
  EXPECT_GE(last.orbit.contacts[0].impacts, 1);
  EXPECT_GE(last.orbit.contacts[1].impacts, 1);
}

TEST(TrainContinuation, ItsPointsReadTheMeshNamedAndEveryMeshMarksItsGrazings) {
  // The same branch read on the second mesh (--mesh second): the same points, whose reading
  // is now the second mesh's (in contact between the two onsets, rattling after its own),
  // and the same grazings of both meshes. A mutant that reads the first mesh whatever the
  // name, or the mesh after the one named, fails at once.
  const Case base = two_loose_gears(0.5);
  ContinuationOptions o;
  o.key = kAmplitude;
  o.from = 238;
  o.to = 250;
  const ContinuationResult first = continuation(base, o);
  o.mesh = "second";
  const ContinuationResult second = continuation(base, o);
  ASSERT_TRUE(first.completed && second.completed) << first.message << second.message;
  EXPECT_EQ(first.mesh, "first");
  EXPECT_EQ(second.mesh, "second");
  ASSERT_EQ(second.points.size(), first.points.size());
  ASSERT_EQ(second.bifurcations.size(), first.bifurcations.size());
  for (std::size_t i = 0; i < first.bifurcations.size(); ++i)
    EXPECT_EQ(second.bifurcations[i].param, first.bifurcations[i].param);
  bool between = false;
  for (std::size_t i = 0; i < first.points.size(); ++i) {
    const BranchPoint &p = first.points[i], &q = second.points[i];
    EXPECT_EQ(q.param, p.param);
    ASSERT_EQ(p.orbit.contacts.size(), 2U);
    EXPECT_EQ(p.orbit.reading.impacts, p.orbit.contacts[0].impacts);
    EXPECT_EQ(q.orbit.reading.impacts, q.orbit.contacts[1].impacts);
    between = between || (p.orbit.reading.impacts > 0 && q.orbit.reading.impacts == 0);
  }
  EXPECT_TRUE(between);  // the first rattles where the second is still on its flank
  EXPECT_GE(second.points.back().orbit.reading.impacts, 1);
  // A name the train does not have, named with the meshes it has.
  o.mesh = "third";
  EXPECT_EQ(testing::error_of([&] { (void)continuation(base, o); }),
            "--mesh = \"third\": the train has no mesh of that name; its meshes are first, "
            "second");
}

TEST(TrainContinuation, ItsMultipliersAreThePeriodMapsAndItsPeriodDoublingIsWhereOneIsMinusOne) {
  // Lightly damped meshes, the first loose gear chattering (20 odd impacts a period): the
  // continuation's monodromy at its last point against central differences of the period map,
  // and the period doubling it locates where the central differences' multiplier nearest -1 is
  // -1 (an omitted saltation misses both by order one). Through so many impacts the period map
  // is far from linear over the differences' step: the largest entries of the differences come
  // within 0.35 % of the exact ones with a step of 1e-6 of the scale, 3e-5 with 1e-7, and
  // rounding takes over below (1e-5 at 1e-8); hence 1e-7 and 1e-4. Their multiplier nearest -1
  // is within 1e-3 of it (it moves by 30 per unit of the amplitude there).
  const Case base = two_loose_gears(0.1);
  const ContinuationResult r = continued(base, 285.9, 286.19);
  ASSERT_TRUE(r.completed) << r.message;
  const auto at = [&](double p) {
    Case c = base;
    set_case_value(c, {kAmplitude, fmt::format("{:.17g}", p)});
    return c;
  };
  const BranchPoint& last = r.points.back();
  EXPECT_NEAR(last.orbit.period_s, 1.0 / 25, 1e-15);
  EXPECT_GE(last.orbit.contacts[0].impacts, 20);
  Eigen::Matrix4d exact;
  const Eigen::Matrix4d central = scaled_central_differences(
      at(last.param), last.orbit.state, last.orbit.period_s, last.orbit.monodromy, &exact);
  testing::expect_matrix_near(central, exact, 1e-4, 1e-6);
  EXPECT_GT(last.orbit.max_multiplier(), 1);  // unstable past the period doubling

  const Bifurcation* pd = nullptr;
  for (const Bifurcation& b : r.bifurcations)
    if (b.type == BifurcationType::kPeriodDoubling) pd = &b;
  ASSERT_TRUE(pd);
  const Eigen::Matrix4d fd = scaled_central_differences(
      at(pd->param), pd->orbit.state, pd->orbit.period_s, pd->orbit.monodromy, &exact);
  const Eigen::Vector4cd mu = fd.eigenvalues();
  double nearest = 1e9;
  for (int k = 0; k < 4; ++k) nearest = std::min(nearest, std::abs(mu(k) + 1.0));
  EXPECT_LT(nearest, 1e-3) << "multipliers of the central differences:\n" << mu;
}

TEST(TrainContinuation, AFreelyTurningPairContinuesAsTheOneDegreeModel) {
  // The paper's pair as a train turning freely (a torque on each gear) at a light load, one
  // impact a period, continued in speed: taken modulo its rigid rotation (train_orbit.hpp),
  // each point's orbit is the one-degree model's at that speed, its amplitude and impacts to
  // 1e-7 b. A mutant that keeps the rigid rotation among the unknowns makes Newton singular.
  // Its unknowns, the wheel's angle and rate each counted from the rigid turn, are the one-degree
  // model's delta and delta' over the mesh's lever, measured alike (b and b w_n): its branch
  // takes the one-degree branch's steps, each point's speed to 1e-10 and state to 1e-8 of its
  // scale. A mutant that takes the wheel's whole rate as the unknown (its measure then half the
  // one-degree's: the pinion's rate shares it) moves the steps by some 1e-7.
  const auto [pair, train] = testing::light_pair();
  ContinuationOptions o;
  o.key = "train.reference_speed_hz";
  o.from = 100;
  o.to = 104;
  const ContinuationResult r = continuation(train, o);
  ASSERT_TRUE(r.completed) << r.message;
  EXPECT_EQ(r.state_names, (std::vector<std::string>{"wheel_rad", "wheel_rad_s"}));
  ASSERT_GE(r.points.size(), 3U);
  ContinuationOptions po = o;
  po.key = "speed.shaft_frequency_hz";
  const ContinuationResult q = continuation(pair, po);
  ASSERT_TRUE(q.completed) << q.message;
  ASSERT_EQ(q.points.size(), r.points.size());
  const train::Assembled a = assembled_train(train);
  const double lever = a.mesh_vector(0)(a.index("wheel")), b = a.train().meshes[0].backlash_m;
  double w = 0;
  for (const train::TrainMode& m : train::modes(a))
    w = std::max(w, 2 * std::numbers::pi * m.frequency_hz);
  for (std::size_t k = 0; k < r.points.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_NEAR(r.points[k].param, q.points[k].param, 1e-10 * q.points[k].param);
    EXPECT_NEAR(lever * r.points[k].orbit.state(0) / b, q.points[k].orbit.state(0) / b, 1e-8);
    EXPECT_NEAR(lever * r.points[k].orbit.state(1) / (b * w), q.points[k].orbit.state(1) / (b * w),
                1e-8);
  }
  for (const std::size_t k : {std::size_t{0}, r.points.size() / 2, r.points.size() - 1}) {
    const BranchPoint& p = r.points[k];
    SCOPED_TRACE(p.param);
    Case at = pair;
    set_case_value(at, {"speed.shaft_frequency_hz", fmt::format("{:.17g}", p.param)});
    OrbitOptions oo;
    oo.settle_periods = 200;
    const Orbit one = find_one_degree_orbit(at, oo);
    ASSERT_TRUE(one.converged) << one.message;
    EXPECT_EQ(p.orbit.reading.impacts, one.reading.impacts);
    EXPECT_NEAR(p.orbit.reading.max_delta_bar, one.reading.max_delta_bar, 1e-7);
    EXPECT_NEAR(p.orbit.reading.min_delta_bar, one.reading.min_delta_bar, 1e-7);
  }
}

TEST(TrainContinuation, ThePapersPairAsATrainHasTheOneDegreeBranch) {
  // The shipped Fig. 4(c) pair (docs/orbits.md's example) continued from 1000 down to 200 Hz,
  // on the one-degree path and as its train (train_form_of): the branch turns back past the
  // grazing at about 671 Hz on both, with as many points (104), the same stability at each, each
  // point's speed and amplitude to 1e-7 and the grazing to 1e-11 of itself. Measured: 1e-8 at
  // the turn, 4e-13 at the grazing. Before the train's rates were counted from the rigid rate,
  // its branch had 103 points and its grazing was 2e-11 off.
  const Case pair = load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010.toml");
  ContinuationOptions o;
  o.key = "speed.shaft_frequency_hz";
  o.from = 1000;
  o.to = 200;
  const ContinuationResult one = continuation(pair, o);
  o.key = "train.reference_speed_hz";
  const ContinuationResult two = continuation(train_form_of(pair), o);
  ASSERT_EQ(one.points.size(), two.points.size()) << one.message << " / " << two.message;
  for (const ContinuationResult* r : {&one, &two})
    EXPECT_NE(r->message.find("turned back"), std::string::npos) << r->message;
  for (std::size_t k = 0; k < one.points.size(); ++k) {
    SCOPED_TRACE(k);
    const BranchPoint &p = one.points[k], &q = two.points[k];
    EXPECT_NEAR(q.param, p.param, 1e-7 * p.param);
    EXPECT_NEAR(q.orbit.reading.max_delta_bar, p.orbit.reading.max_delta_bar, 1e-7);
    EXPECT_NEAR(q.orbit.reading.min_delta_bar, p.orbit.reading.min_delta_bar, 1e-7);
    EXPECT_EQ(q.orbit.stable, p.orbit.stable);
    EXPECT_EQ(q.orbit.reading.impacts, p.orbit.reading.impacts);
  }
  const auto grazing = [](const ContinuationResult& r) {
    for (const Bifurcation& b : r.bifurcations)
      if (b.type == BifurcationType::kGrazing) return b.param;
    return 0.0;
  };
  ASSERT_GT(grazing(one), 600);
  EXPECT_NEAR(grazing(two), grazing(one), 1e-11 * grazing(one));
}

}  // namespace
}  // namespace geardyn

namespace geardyn {
namespace {

// The multipliers of a freely turning train's orbit from central differences of its period map
// in the whole state (q, q') at the section state y, step 1e-7 of each entry's scale (a
// coordinate by the backlash b over its largest entry in a mesh vector or bearing matrix, a
// rate by that times the highest natural frequency in contact): with the rigid rotation's
// angle and rate, an invariant plane the phase condition leaves out (train_orbit.hpp),
// deflated: the multipliers of the map on its orthonormal complement.
std::vector<std::complex<double>> central_multipliers(const Case& c, const Eigen::VectorXd& y,
                                                      double period) {
  const train::Assembled a = assembled_train(c);
  ode::EngineOptions eo;
  eo.tolerance = 1e-15;
  const ode::ExactEngine engine(a.linear_system(), eo);
  const Eigen::Index n = a.size();
  double w = 0;
  for (const train::TrainMode& m : train::modes(a))
    w = std::max(w, 2 * std::numbers::pi * m.frequency_hz);
  const double b = a.train().meshes[0].backlash_m;
  Eigen::VectorXd reach = Eigen::VectorXd::Zero(n);
  for (int m = 0; m < static_cast<int>(a.train().meshes.size()); ++m)
    reach = reach.cwiseMax(a.mesh_vector(m).transpose().cwiseAbs());
  for (int k = 0; k < static_cast<int>(a.train().bearings.size()); ++k)
    reach = reach.cwiseMax(a.bearing_matrix(k).colwise().norm().transpose());
  Eigen::VectorXd scale(2 * n);
  scale.head(n) = b * reach.cwiseInverse();
  scale.tail(n) = w * scale.head(n);
  const Eigen::MatrixXd fd = testing::central_differences(
      [&](const Eigen::VectorXd& z) { return testing::free_period_map(a, engine, period, z); }, y,
      1e-7 * scale);
  const Eigen::MatrixXd s = scale.asDiagonal();
  const Eigen::MatrixXd m = s.inverse() * fd * s;
  const Eigen::MatrixXd rigid = a.rigid_motions();
  EXPECT_EQ(rigid.cols(), 1);
  Eigen::MatrixXd plane = Eigen::MatrixXd::Zero(2 * n, 2);
  plane.col(0).head(n) = rigid.col(0);
  plane.col(1).tail(n) = rigid.col(0);
  plane = s.inverse() * plane;
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(plane);
  const Eigen::MatrixXd basis = qr.householderQ() * Eigen::MatrixXd::Identity(2 * n, 2 * n);
  const Eigen::MatrixXd rest = basis.rightCols(2 * n - 2);
  const Eigen::VectorXcd mu = (rest.transpose() * m * rest).eigenvalues();
  return {mu.data(), mu.data() + mu.size()};
}

// The largest distance from each of `exact` to its nearest unmatched one of `approximate`.
double farthest_match(const std::vector<std::complex<double>>& exact,
                      std::vector<std::complex<double>> approximate) {
  double worst = 0;
  for (const std::complex<double>& x : exact) {
    const auto nearest =
        std::min_element(approximate.begin(), approximate.end(),
                         [&](auto p, auto q) { return std::abs(p - x) < std::abs(q - x); });
    worst = std::max(worst, std::abs(*nearest - x));
    approximate.erase(nearest);
  }
  return worst;
}

TEST(TrainContinuation, ALightlyLoadedPlanetarySetGrazesAndFolds) {
  // The shipped planetary stage at a twentieth of its load with 0.1 um of transmission error on
  // every mesh, turning freely (its ring held), continued in the sun's speed near its resonance
  // (docs/orbits.md, "A planetary set's rattle"): its three sun meshes start to strike together
  // once a period (a grazing, 0 -> 1 impact) and the branch folds back just past it. The
  // multipliers of the fold's orbit, its sun meshes striking, modulo the set's rigid rotation,
  // against central differences of the whole state's period map through the impacts (to 1e-4:
  // the largest is about 1), their nearest +1 within 1e-3.
  Case base = load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/planetary_set.toml");
  for (const auto& [key, value] :
       {std::pair{"train.torque[0].mean_nm", "5"}, std::pair{"train.torque[1].mean_nm", "-21.25"},
        std::pair{"train.mesh[0].transmission_error_um", "[[0.1, 0]]"},
        std::pair{"train.mesh[1].transmission_error_um", "[[0.1, 0]]"}})
    set_case_value(base, {key, value});
  // The sun's speed is its own; relative to the carrier (which the meshes see) it turns at 78 /
  // 102 of it with the ring held: 600 to 616 Hz there.
  constexpr double kOwn = 102.0 / 78;
  ContinuationOptions o;
  o.key = "train.reference_speed_hz";
  o.from = 600 * kOwn;
  o.to = 616 * kOwn;
  o.initial_step = 0.05 * kOwn;
  o.max_step = 0.1 * kOwn;
  o.max_points = 23;
  // Two orbits coexist at 600 Hz relative (the fold's hysteresis, docs/orbits.md): the branch that
  // folds is the one a simulation from the mean static state (the errors left out) settles on in
  // 200 periods; the shipped start, at rest relative to the errors, settles on the other.
  {
    Case c = base;
    set_case_value(c, {o.key, fmt::format("{:.17g}", o.from)});
    const TrainSolver solver(c);
    const std::optional<double> period = solver.assembled().system_period_s();
    ASSERT_TRUE(period);
    const ode::FlowResult settled =
        solver.advance(0.0, static_state(solver.assembled()).value(), 200 * *period);
    ASSERT_TRUE(settled.ok()) << settled.message;
    // The orbit's unknowns: every coordinate but the reference's, counted from the rigid turn
    // that keeps the reference's at 0, then their rates, counted from the rigid rate that goes
    // with the reference's (train_orbit.hpp).
    const train::Assembled& a = solver.assembled();
    const Eigen::VectorXd rigid = a.rigid_motions().col(0);
    const int n = a.size(), ref = a.index(a.train().reference);
    std::vector<double> z, rates;
    for (int i = 0; i < n; ++i) {
      if (i == ref) continue;
      z.push_back(settled.state(i) - rigid(i) / rigid(ref) * settled.state(ref));
      rates.push_back(settled.state(n + i) - rigid(i) / rigid(ref) * settled.state(n + ref));
    }
    z.insert(z.end(), rates.begin(), rates.end());
    o.start = Eigen::Map<const Eigen::VectorXd>(z.data(), static_cast<Eigen::Index>(z.size()));
  }
  const ContinuationResult r = continuation(base, o);
  ASSERT_EQ(r.points.size(), 23U) << r.message;
  const Bifurcation *grazing = nullptr, *fold = nullptr;
  for (const Bifurcation& x : r.bifurcations) {
    if (x.type == BifurcationType::kGrazing) grazing = &x;
    if (x.type == BifurcationType::kFold) fold = &x;
  }
  ASSERT_TRUE(grazing && fold);
  for (const char* mesh : {"sun_planet1", "sun_planet2", "sun_planet3"})
    EXPECT_NE(grazing->detail.find(fmt::format("mesh {} impacts 0 -> 1", mesh)), std::string::npos)
        << grazing->detail;
  EXPECT_GT(grazing->param, 610 * kOwn);
  EXPECT_LT(grazing->param, fold->param);
  EXPECT_LT(fold->param, 615 * kOwn);
  EXPECT_LT(r.points.back().param, fold->param);  // turned back
  EXPECT_FALSE(r.points.back().orbit.stable);

  const auto at = [&](double p) {
    Case c = base;
    set_case_value(c, {o.key, fmt::format("{:.17g}", p)});
    return c;
  };
  // The fold's orbit in the whole state (its section state, from its unknowns by Newton).
  const TrainOrbit t = find_train_orbit(at(fold->param), OrbitOptions{}, fold->orbit.state);
  ASSERT_TRUE(t.converged) << t.message;
  ASSERT_TRUE(t.modulo_rotation);
  EXPECT_LT(farthest_match(fold->orbit.multipliers, t.multipliers), 1e-9);
  EXPECT_EQ(t.impacts_per_period[0], 1);
  const std::vector<std::complex<double>> fd =
      central_multipliers(at(fold->param), t.state, t.period_s);
  ASSERT_EQ(fd.size(), t.multipliers.size());
  EXPECT_LT(farthest_match(t.multipliers, fd), 1e-4);
  double nearest = 1e9;
  for (const std::complex<double>& x : fd) nearest = std::min(nearest, std::abs(x - 1.0));
  EXPECT_LT(nearest, 1e-3);
}

}  // namespace
}  // namespace geardyn
