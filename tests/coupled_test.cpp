// The coupled model: its modes against closed forms and an independent eigen-solve of the
// engine's matrices, energy kept in a free vibration, the transmission error's forced response
// against its closed form, the exact decoupling of a spur pair's axial motion, and the rigid
// limit, where it must reproduce the one-degree model.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "geardyn/coupled_model.hpp"
#include "geardyn/coupled_orbit.hpp"
#include "geardyn/coupled_run.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/run.hpp"
#include "geardyn/sweep.hpp"
#include "geardyn/sweep_output.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_statics.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;

using testing::coupled;

// The Table 1 pair with a helix of 0 (a spur pair): its tip and centre distance follow.
void make_spur(Case& c) {
  c.gear.helix_angle_deg = 0;
  c.gear.outside_diameter_mm = {146.0375, 146.0375};  // 140 + 2 m_n (1 + x)
  c.gear.center_distance_mm = 141.0;
}

TEST(CoupledModes, ASymmetricThreeDofPairHasItsClosedForms) {
  // Equal gears on equal bearings, dof 3 (u, y1, y2): y1 = y2 leaves the mesh alone, w^2 =
  // k_r / m; y1 = -y2 = s couples with u as m_eq u'' + k cb^2 (u + 2 s) = 0, m s'' + k_r s +
  // k cb^2 (u + 2 s) = 0, whose w^2 are the roots of w^4 - tr w^2 + det of M^-1 K.
  Case c = coupled(3);
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;  // k_m, constant
  const CoupledParameters p = coupled_parameters(c);
  const double k = p.stiffness_n_per_m.offset, cb2 = p.cos_base_helix * p.cos_base_helix;
  const double meq = p.equivalent_mass_kg, m = p.mass(p.line[0], p.line[0]);
  const double kr = p.bearing_stiffness[p.line[0]];
  const double a = k * cb2 / meq, b2 = 2 * k * cb2 / meq, c2 = k * cb2 / m,
               d = (kr + 2 * k * cb2) / m;
  const double tr = a + d, det = a * d - b2 * c2;
  const double root = std::sqrt(tr * tr - 4 * det);
  std::vector<double> expected = {std::sqrt((tr - root) / 2), std::sqrt(kr / m),
                                  std::sqrt((tr + root) / 2)};
  std::sort(expected.begin(), expected.end());
  const ModeSet set = modes(CoupledModel(p));
  ASSERT_EQ(set.modes.size(), 3U);
  for (int r = 0; r < 3; ++r)
    EXPECT_NEAR(set.modes[r].frequency_hz, expected[r] / (2 * kPi), 1e-10 * expected[r]) << r;
  // The bearing mode holds no mesh energy; the energies of every mode sum to 1.
  for (const Mode& x : set.modes) {
    const double sum = x.mesh_energy + x.line_energy[0] + x.line_energy[1];
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
  EXPECT_LT(set.modes[1].mesh_energy, 1e-20);
}

TEST(CoupledModes, ASpurPairsAxialModesAreTheBearingsAlone) {
  // helix 0: z decouples, w^2 = k_a / m exactly; every mode's energies sum to 1.
  Case c = coupled(12);
  make_spur(c);
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.bearings.axial_stiffness_n_per_m = {3e8, 7e8};
  const CoupledParameters p = coupled_parameters(c);
  const ModeSet set = modes(CoupledModel(p));
  for (int i = 0; i < 2; ++i) {
    const int j = p.index(i == 0 ? Coordinate::kAxial1 : Coordinate::kAxial2);
    const double mj = p.mass(j, j);
    const double w = std::sqrt(c.bearings.axial_stiffness_n_per_m[i] / mj);
    int found = 0;
    for (const Mode& x : set.modes)
      if (std::abs(x.frequency_hz - w / (2 * kPi)) < 1e-10 * w) {
        ++found;
        EXPECT_NEAR(x.axial_energy[i], 1.0, 1e-12);
        EXPECT_NEAR(std::abs(x.shape[j]), 1 / std::sqrt(mj), 1e-9 / std::sqrt(mj));
      }
    EXPECT_EQ(found, 1) << "axial mode of gear " << i + 1;
  }
  for (const Mode& x : set.modes) {
    double sum = x.mesh_energy;
    for (int i = 0; i < 2; ++i)
      sum += x.line_energy[i] + x.axial_energy[i] + x.tilt_energy[i] + x.cross_energy[i];
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
}

TEST(CoupledModes, DampedEigenvaluesEqualThoseOfTheEnginesMatrix) {
  // modes() assembles K and C itself; the engine's drive-contact region assembles its state
  // matrix separately: both give the same eigenvalues, and the undamped frequencies those of
  // -M^-1 K from the engine's matrix.
  Case c = coupled(12);
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  const CoupledModel model(coupled_parameters(c));
  const ModeSet set = modes(model);
  const ode::LinearSwitchedSystem sys = model.linear_system();
  ode::Matrix a = sys.regions[coupled_region({kDriveContact, {0, 0}})].a.constant;
  // The same eigenvalues balanced: the state scaled by M^1/2, velocities over the highest w.
  const Eigen::Index n = model.parameters().size();
  const double w_top = 2 * kPi * set.modes.back().frequency_hz;
  ode::Vector scale(2 * n);
  const ode::Vector root = model.parameters().mass.diagonal().cwiseSqrt();  // M is diagonal here
  scale << root, root / w_top;
  a = scale.asDiagonal() * a * scale.cwiseInverse().asDiagonal();
  Eigen::EigenSolver<ode::Matrix> solver(a, false);
  std::vector<std::array<double, 2>> engine;
  for (Eigen::Index i = 0; i < solver.eigenvalues().size(); ++i) {
    const std::complex<double> l = solver.eigenvalues()[i];
    if (l.imag() < 0) continue;
    engine.push_back({std::abs(l) / (2 * kPi), -l.real() / std::abs(l)});
  }
  std::sort(engine.begin(), engine.end());
  ASSERT_EQ(engine.size(), set.damped.size());
  for (std::size_t r = 0; r < engine.size(); ++r) {
    EXPECT_NEAR(engine[r][0], set.damped[r][0], 1e-9 * engine[r][0]);
    EXPECT_NEAR(engine[r][1], set.damped[r][1], 1e-9);
  }
  Eigen::EigenSolver<ode::Matrix> stiffness(-a.bottomLeftCorner(n, n) * w_top, false);
  std::vector<double> w2;
  for (Eigen::Index i = 0; i < n; ++i) w2.push_back(stiffness.eigenvalues()[i].real());
  std::sort(w2.begin(), w2.end());
  for (int r = 0; r < n; ++r)
    EXPECT_NEAR(std::sqrt(w2[r]) / (2 * kPi), set.modes[r].frequency_hz,
                1e-10 * set.modes[r].frequency_hz);
  // Light damping: the damped frequencies are close to the undamped ones.
  for (std::size_t r = 0; r < set.modes.size(); ++r)
    EXPECT_NEAR(set.damped[r][0], set.modes[r].frequency_hz, 1e-3 * set.modes[r].frequency_hz);
}

class CoupledEnergy : public ::testing::TestWithParam<bool> {};

TEST_P(CoupledEnergy, AFreeVibrationKeepsItsEnergy) {
  // No damping, constant stiffness, steady torque, permanent contact: from the static state
  // displaced along every coordinate, E = 1/2 q'^T M q' + 1/2 (q - q_s)^T K (q - q_s) stays;
  // with shafts (GetParam()), M is full in the torsional block.
  Case c = coupled(12);
  if (GetParam()) {
    c.shafts.end_inertia_kg_m2 = {0.05, 0.3};
    c.shafts.damping_ratio = 0;
  }
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.mesh.damping_ratio = 0;
  c.bearings.damping_ratio = 0;
  c.load.fluctuation_ratio = 0;
  c.load.torque_nm = 400;  // deep contact
  c.solver.duration_s = 0.01;
  c.solver.initial = InitialCondition::kStatic;
  const CoupledModel model(coupled_parameters(c));
  const Eigen::Index n = model.parameters().size();
  const ode::Vector ys = model.static_state();
  // The run from a displaced start, through the engine directly.
  ode::Vector y0 = ys;
  for (int j = 0; j < n; ++j) y0[j] += 1e-7 * (j % 2 ? 1 : -1) * (j + 1) / n;
  const ode::ExactEngine engine(model.linear_system());
  struct Energy : ode::FlowObserver {
    ode::Matrix m, k;
    ode::Vector qs;
    std::vector<double> e;
    int regions_seen = 0;
    void on_sample(double, const ode::Vector& y, int region) override {
      const int n2 = static_cast<int>(qs.size());
      const ode::Vector dq = y.head(n2) - qs;
      const ode::Vector v = y.tail(n2);
      e.push_back(0.5 * v.dot(m * v) + 0.5 * dq.dot(k * dq));
      regions_seen |= 1 << (coupled_state(region).mesh + 2);
    }
  } obs;
  obs.m = model.parameters().mass;
  obs.k = model.contact_stiffness();
  obs.qs = ys.head(n);
  const ode::FlowResult r = engine.flow(0, y0, model.classify(0, y0), c.solver.duration_s,
                                        ode::make_output_grid(0, c.solver.duration_s, 1e-5), obs);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(obs.regions_seen, 1 << (kDriveContact + 2));  // never left contact
  ASSERT_GT(obs.e.size(), 900U);
  const double e0 = obs.e.front();
  EXPECT_GT(e0, 0);
  for (double e : obs.e) EXPECT_NEAR(e, e0, 1e-10 * e0);
}

INSTANTIATE_TEST_SUITE_P(CoupledRun, CoupledEnergy, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& i) {
                           return i.param ? "shafts" : "no_shafts";
                         });

TEST(CoupledRun, TheTransmissionErrorsForcedResponseIsTheClosedForm) {
  // Permanent contact, constant stiffness: M q'' + C q' + K q = V^T (k e + c e') + Q_s, so
  // q - q_s = Re(H a e^{i(wt + phi)}), H = (K - w^2 M + i w C)^-1 V^T (k + i w c), per harmonic.
  Case c = coupled(12);
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.load.fluctuation_ratio = 0;
  c.load.torque_nm = 400;
  // Stiff bearings (1e9, 5e8, 1e7): every mode decays within the window.
  c.bearings.radial_stiffness_n_per_m = {1e9, 1e9};
  c.bearings.axial_stiffness_n_per_m = {5e8, 5e8};
  c.bearings.tilt_stiffness_n_m_per_rad = {1e7, 1e7};
  c.speed.shaft_frequency_hz = 30;  // mesh 1680 Hz, between modes
  c.mesh.transmission_error_um = {{1.0, 20.0}, {0.3, 0.0}};
  c.solver.duration_s = 0.2;  // the slowest mode (damping ratio 0.014 at 1.8 kHz) decays e^-30
  c.solver.output_interval_s = 1e-5;
  c.solver.initial = InitialCondition::kStatic;
  const CoupledRunResult r = run_coupled(c);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.mesh.impacts, 0);
  const CoupledModel model(r.parameters);
  const CoupledParameters& p = r.parameters;
  const Eigen::Index n = p.size();
  const ode::Vector qs = model.static_state().head(n);
  const ode::Matrix m = p.mass, k = model.contact_stiffness(), damping = model.contact_damping();
  const double km = p.stiffness_n_per_m.offset, cm = p.mesh_damping_n_s_per_m;
  std::vector<Eigen::VectorXcd> h;
  for (const Harmonic& x : p.transmission_error_m.terms) {
    const double w = x.angular_frequency_rad_s;
    const Eigen::MatrixXcd z = k.cast<std::complex<double>>() -
                               w * w * m.cast<std::complex<double>>() +
                               std::complex<double>(0, w) * damping.cast<std::complex<double>>();
    const Eigen::VectorXcd f = p.mesh_vector.transpose().cast<std::complex<double>>() *
                               std::complex<double>(km, w * cm) *
                               std::polar(x.amplitude, x.phase_rad);
    h.push_back(z.partialPivLu().solve(f));
  }
  double worst = 0, scale = 0;
  for (std::size_t s = 0; s < r.samples.t_s.size(); ++s) {
    const double t = r.samples.t_s[s];
    if (t < 0.8 * c.solver.duration_s) continue;
    ode::Vector q = qs;
    for (std::size_t i = 0; i < h.size(); ++i)
      q += (h[i] * std::exp(std::complex<double>(
                       0, p.transmission_error_m.terms[i].angular_frequency_rad_s * t)))
               .real();
    const ode::Vector run = r.samples.state[s].head(n);
    worst = std::max(worst, (run - q).cwiseAbs().maxCoeff());
    scale = std::max(scale, (q - qs).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(scale, 1e-7);
  EXPECT_LT(worst, 1e-8 * scale) << "scale " << scale;
}

TEST(CoupledRun, ASpurPairsAxialMotionStaysAtRestAndTheRestIsTheThreeDofRun) {
  Case c = coupled(12);
  make_spur(c);
  c.solver.duration_s = 0.01;
  const CoupledRunResult r12 = run_coupled(c);
  c.model.dof = 3;
  const CoupledRunResult r3 = run_coupled(c);
  ASSERT_TRUE(r12.ok() && r3.ok());
  EXPECT_GT(r12.mesh.impacts, 0);
  EXPECT_EQ(r12.mesh.impacts, r3.mesh.impacts);
  const CoupledParameters& p = r12.parameters;
  ASSERT_EQ(r12.samples.t_s.size(), r3.samples.t_s.size());
  double axial = 0, worst = 0;
  for (std::size_t s = 0; s < r12.samples.t_s.size(); ++s) {
    for (Coordinate x : {Coordinate::kAxial1, Coordinate::kAxial2, Coordinate::kTilt1,
                         Coordinate::kTilt2, Coordinate::kCross1, Coordinate::kRock2})
      axial = std::max(axial, std::abs(r12.samples.state[s][p.index(x)]));
    for (int j = 0; j < 3; ++j)
      worst = std::max(worst, std::abs(r12.samples.state[s][j] - r3.samples.state[s][j]));
  }
  EXPECT_EQ(axial, 0.0);
  EXPECT_EQ(r12.max_axial_force_n[0], 0.0);
  EXPECT_LT(worst, 1e-12 * p.backlash_m);
}

// The largest |delta_bar| difference between the coupled run with bearings `ratio` times
// stiffer than the mesh and the one-degree run `one` (same samples), after checking that both
// read the same impacts and last separation.
double rigid_limit_difference(const Case& one_case, const RunResult& one, int dof, double ratio) {
  Case c = one_case;
  c.model.form = ModelForm::kCoupled;
  c.model.dof = dof;
  const double k = ratio * c.mesh.mean_stiffness_n_per_m;
  c.bearings.radial_stiffness_n_per_m = {k, k};
  c.bearings.axial_stiffness_n_per_m = {k, k};
  // The mesh's tilt stiffness is k_m (sin(beta_b) R_b)^2, about (0.022 m)^2 k_m.
  c.bearings.tilt_stiffness_n_m_per_rad = {k * 0.022 * 0.022, k * 0.022 * 0.022};
  const CoupledRunResult r = run_coupled(c);
  EXPECT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.mesh.impacts, one.reading.impacts) << dof << " " << ratio;
  EXPECT_EQ(r.mesh.regime, one.reading.regime);
  EXPECT_EQ(r.mesh.separations, one.reading.separations);
  // The separated time sums the impact and separation times, each shifted by the bearings'
  // compliance (about 1e-7 s here).
  EXPECT_NEAR(r.mesh.separated_fraction, one.reading.separated_fraction, 1e-5);
  EXPECT_TRUE(r.mesh.last_separation_s && one.reading.last_separation_s);
  if (r.mesh.last_separation_s && one.reading.last_separation_s)
    EXPECT_NEAR(*r.mesh.last_separation_s, *one.reading.last_separation_s,
                1e-6 * one_case.solver.duration_s);
  EXPECT_EQ(r.samples.t_s.size(), one.samples.size());
  double worst = 0;
  for (std::size_t s = 0; s < std::min(r.samples.t_s.size(), one.samples.size()); ++s)
    worst = std::max(worst, std::abs(r.samples.deflection_bar[s] - one.samples.delta_bar[s]));
  return worst;
}

TEST(CoupledRun, RigidBearingsReproduceTheOneDegreeModel) {
  // Bearings 1e5 and 1e6 times stiffer than the mesh: the coupled runs (dof 3 and 12) read as
  // the one-degree run, impacts and last separation alike, and their delta_bar differs from
  // it in proportion to k_m / k_bearing (the bearings' compliance, not an error): 1.45e-6
  // (dof 3) and 3.3e-6 (dof 12) at 1e6, ten times less than at 1e5 (so below 1e-6 from 1e7).
  Case one;
  one.solver.duration_s = 0.02;
  one.solver.output_interval_s = 1e-5;
  const RunResult r1 = run_one_degree_model(one);
  ASSERT_TRUE(r1.integration.ok());
  for (int dof : {3, 12}) {
    const double loose = rigid_limit_difference(one, r1, dof, 1e5);
    const double stiff = rigid_limit_difference(one, r1, dof, 1e6);
    EXPECT_LT(stiff, 4e-6) << dof;
    EXPECT_LT(stiff, loose / 7) << dof << ": " << loose << " then " << stiff;
    EXPECT_GT(stiff, loose / 13) << dof << ": " << loose << " then " << stiff;
  }
}

TEST(CoupledRun, ItsSteadyPartIsTheOneDegreeRunsOnRigidBearings) {
  // The coupled run seeks its steady part as the one-degree run does (integrate_watching): on
  // bearings 1e6 times stiffer than the mesh it settles where the one-degree run does, and its
  // dynamic factor is the steady part's (the start-up's beside it), both the one-degree run's.
  // Against the bearings' compliance, forces agree to 1e-5 and the settling to a few periods.
  Case one;
  one.speed.shaft_frequency_hz = 10000;  // a rattling start-up that dies out into contact
  one.solver.duration_s = 0.08;
  const RunResult r1 = run_one_degree_model(one);
  ASSERT_TRUE(r1.integration.ok());
  ASSERT_EQ(r1.steady.basis, SteadyBasis::kSettled);
  Case c = one;
  c.model.form = ModelForm::kCoupled;
  c.model.dof = 3;
  const double k = 1e6 * c.mesh.mean_stiffness_n_per_m;
  c.bearings.radial_stiffness_n_per_m = {k, k};
  const CoupledRunResult r = run_coupled(c);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.steady.basis, SteadyBasis::kSettled);
  EXPECT_TRUE(r.steady.marked);
  const double period = coupled_section_period_s(c);
  EXPECT_NEAR(r.steady.from_s, r1.steady.from_s, 5 * period);
  EXPECT_EQ(r.steady_part.mesh.impacts, 0);
  EXPECT_GT(r.mesh.impacts, 0);
  EXPECT_EQ(r.steady_part.mesh.regime, r1.steady.reading.regime);
  ASSERT_TRUE(r1.steady.reading.dynamic_factor && r1.reading.dynamic_factor);
  EXPECT_NEAR(r.dynamic_mesh_factor / *r1.steady.reading.dynamic_factor, 1.0, 1e-5);
  EXPECT_NEAR(r.dynamic_mesh_factor_with_startup / *r1.reading.dynamic_factor, 1.0, 1e-5);
  EXPECT_LT(r.dynamic_mesh_factor, r.dynamic_mesh_factor_with_startup);
  EXPECT_DOUBLE_EQ(r.dynamic_mesh_factor,
                   r.steady_part.max_force_n / r.parameters.static_mesh_force_n());
  // The bearing factors are the steady part's too.
  EXPECT_LE(r.steady_part.max_bearing_force_n[0], r.max_bearing_force_n[0]);
  EXPECT_DOUBLE_EQ(r.bearing_factor[0],
                   r.steady_part.max_bearing_force_n[0] /
                       (r.parameters.cos_base_helix * r.parameters.static_mesh_force_n()));
}

TEST(CoupledSweep, ItsResonancesAreTheMeshCriticalModes) {
  // A speed sweep of the 3-DOF pair in permanent contact (torque 400 N m, no torque
  // fluctuation, the stiffness harmonics excite): its mesh force peaks where the mesh frequency
  // meets the modes that hold mesh energy, within the grid step (0.25 Hz of shaft speed), and
  // the up and down sweeps agree (nothing is nonlinear in contact). Every point settles.
  Case c = coupled(3);
  c.load.torque_nm = 400;
  c.load.fluctuation_ratio = 0;
  c.bearings.radial_stiffness_n_per_m = {1e9, 1e9};  // both torsion-translation modes in range
  SweepOptions o;
  o.axis = {"speed.shaft_frequency_hz", 25, 80, 221, false};
  o.direction = SweepDirection::kBoth;
  // The down sweep starts at 80 Hz, where a mesh period (0.22 ms) is short against the
  // slowest mode's decay (5.7 ms): it needs more periods than the default allows.
  o.max_settle_periods = 5000;
  const SweepResult r = sweep(c, o);
  const ModeSet m = modes(CoupledModel(coupled_parameters(c)));
  std::vector<const SweepPoint*> up;
  for (const SweepPoint& pt : r.points) {
    EXPECT_TRUE(pt.failure.empty()) << pt.failure;
    EXPECT_TRUE(pt.settled) << pt.value;
    EXPECT_EQ(pt.impacts_per_period, 0);
    if (pt.direction == SweepDirection::kUp) up.push_back(&pt);
  }
  for (const SweepPoint& pt : r.points)
    if (pt.direction == SweepDirection::kDown)
      for (const SweepPoint* u : up)
        if (u->value == pt.value) EXPECT_NEAR(u->rms_force_bar, pt.rms_force_bar, 1e-6);
  // A linear response in permanent contact neither jumps nor differs up and down, however
  // steep its resonance peaks.
  EXPECT_TRUE(r.jumps.empty()) << r.jumps.size() << " jumps, the first at "
                               << (r.jumps.empty() ? 0.0 : r.jumps[0].from_value);
  EXPECT_TRUE(r.hysteresis.empty());
  // Local maxima of the rms mesh force.
  std::vector<double> peaks;
  for (std::size_t i = 1; i + 1 < up.size(); ++i)
    if (up[i]->rms_force_bar > up[i - 1]->rms_force_bar &&
        up[i]->rms_force_bar > up[i + 1]->rms_force_bar)
      peaks.push_back(up[i]->value);
  const double z1 = c.gear.teeth[0];
  std::vector<double> expected;
  for (const Mode& x : m.modes)
    if (x.mesh_energy > 0.05 && x.frequency_hz / z1 > 25 && x.frequency_hz / z1 < 80)
      expected.push_back(x.frequency_hz / z1);
  ASSERT_EQ(expected.size(), 2U);  // the two torsion-translation modes
  for (double f : expected) {
    const auto near =
        std::find_if(peaks.begin(), peaks.end(), [&](double p) { return std::abs(p - f) <= 0.25; });
    EXPECT_NE(near, peaks.end()) << "no peak near " << f << " Hz";
  }
}

TEST(CoupledSweep, AJumpIsWhereTheContactChangesNotASteepLinearPeak) {
  // Light damping (0.005): in permanent contact the response is linear, and its mesh
  // deflection's peak-to-peak grows by 64 % between 18.9 and 20.2 Hz, on a steep flank; that is
  // no jump. Near 39 Hz the down sweep leaves rattle (one impact a period) for contact: that is
  // one (the up sweep stays in contact there: the two differ from 39.3 to 58.4 Hz).
  Case c = coupled(3);
  c.load.torque_nm = 400;
  c.load.fluctuation_ratio = 0;
  c.mesh.damping_ratio = 0.005;
  c.bearings.damping_ratio = 0.005;
  SweepOptions o;
  // The whole grid: the down sweep must come from above 58 Hz to carry the rattle down.
  o.axis = {"speed.shaft_frequency_hz", 10, 80, 56, false};
  o.direction = SweepDirection::kBoth;
  o.max_settle_periods = 5000;
  const SweepResult r = sweep(c, o);
  const auto at = [&](SweepDirection d, double v) {
    for (const SweepPoint& p : r.points)
      if (p.direction == d && std::abs(p.value - v) < 1e-9) return &p;
    return static_cast<const SweepPoint*>(nullptr);
  };
  const SweepPoint *low = at(SweepDirection::kUp, 10 + 70.0 / 55 * 7),
                   *high = at(SweepDirection::kUp, 10 + 70.0 / 55 * 8);
  ASSERT_TRUE(low && high);
  EXPECT_EQ(low->impacts_per_period, 0);
  EXPECT_EQ(high->impacts_per_period, 0);
  EXPECT_GT(high->pp_delta_bar, 1.5 * low->pp_delta_bar);  // the steep flank
  ASSERT_EQ(r.jumps.size(), 1U);
  EXPECT_EQ(r.jumps[0].direction, SweepDirection::kDown);
  EXPECT_NEAR(r.jumps[0].from_value, 10 + 70.0 / 55 * 23, 1e-9);
  EXPECT_NEAR(r.jumps[0].to_value, 10 + 70.0 / 55 * 22, 1e-9);
  EXPECT_GT(r.jumps[0].before, 1.0);  // rattle, then contact
  EXPECT_LT(r.jumps[0].after, 0.1);
}

TEST(CoupledModel, TheEnginesEquationsAreTheModelsInEveryRegion) {
  // The assembled system (products k(t) e(t), e'(t), clearance offsets, damping forms) against
  // M q'' = Q(t) - K_b q - C_b q' - V^T F_n written out directly, at random times and states,
  // in every region, with varying stiffness, a transmission error and clearances.
  for (const DampingForm damping : {DampingForm::kContact, DampingForm::kAlways}) {
    Case c = coupled(12);
    c.mesh.damping = damping;
    c.mesh.transmission_error_um = {{1.0, 30.0}, {0.4, -60.0}};
    c.bearings.radial_clearance_um = {15, 25};
    const CoupledModel model(coupled_parameters(c));
    const CoupledParameters& p = model.parameters();
    const ode::LinearSwitchedSystem sys = model.linear_system();
    const Eigen::Index n = p.size();
    std::srand(7);
    for (int r = 0; r < kCoupledRegions; ++r) {
      const CoupledState s = coupled_state(r);
      if (std::abs(s.mesh) == 2) continue;  // clipped: only with tension "clip"
      for (int trial = 0; trial < 3; ++trial) {
        const double t = 1e-4 * (trial + 1) + 3.7e-6 * r;
        const ode::Vector y = ode::Vector::Random(2 * n) * 1e-5;
        const ode::Vector q = y.head(n), v = y.tail(n);
        const HarmonicSeries& e = p.transmission_error_m;
        double de = 0;
        for (const Harmonic& h : e.terms)
          de -= h.amplitude * h.angular_frequency_rad_s *
                std::sin(h.angular_frequency_rad_s * t + h.phase_rad);
        const double d = p.mesh_vector.dot(q) - e(t), dv = p.mesh_vector.dot(v) - de;
        const double k = p.stiffness_n_per_m(t), cm = p.mesh_damping_n_s_per_m;
        const double b = p.backlash_m;
        double fn = 0;
        if (s.mesh == kDriveContact) fn = k * (d - b) + cm * dv;
        if (s.mesh == kBackContact) fn = k * (d + b) + cm * dv;
        if (s.mesh == kSeparated && damping == DampingForm::kAlways) fn = cm * dv;
        ode::Vector force = -p.mesh_vector.transpose() * fn;
        force += p.force(t);
        for (Eigen::Index j = 0; j < n; ++j) {
          double kb = p.bearing_stiffness[j], cb = p.bearing_damping[j], shift = 0;
          for (int i = 0; i < 2; ++i)
            if (j == p.line[i]) {
              if (s.bearing[i] == 0) kb = cb = 0;
              shift = s.bearing[i] * p.clearance_m[i];
            }
          force[j] -= kb * (q[j] - shift) + cb * v[j];
        }
        const ode::Vector expected = p.mass.partialPivLu().solve(force);
        const ode::Vector got = ode::derivative(sys, r, t, y);
        EXPECT_LT((got.head(n) - v).cwiseAbs().maxCoeff(), 1e-20);
        EXPECT_LT((got.tail(n) - expected).cwiseAbs().maxCoeff(),
                  1e-9 * expected.cwiseAbs().maxCoeff())
            << "region " << r << " damping " << static_cast<int>(damping);
      }
    }
  }
}

// A pair with a motor and a load on torsional shafts (dof 3 unless told).
Case with_shafts(int dof = 3) {
  Case c = coupled(dof);
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.shafts.end_inertia_kg_m2 = {0.05, 0.3};
  c.shafts.stiffness_n_m_per_rad = {4e4, 9e4};
  return c;
}

TEST(CoupledShafts, TheStaticTorquesAreThoseOfTheAcceleratingChain) {
  // Steady torques on the chain motor - shaft - pinion = wheel - shaft - load accelerate it
  // rigidly at alpha = (R2 T1 - R1 T2) / (R2 (J_m + J_1) + R1^2 (J_L + J_2) / R2) (theta_1's
  // sense); then the drive shaft carries T1 - J_m alpha, the load shaft T2 + J_L R1 alpha / R2,
  // and the mesh F_n = (T1 - (J_m + J_1) alpha) / (R1 cos(beta_b)). The matched load (T2 =
  // R2 T1 / R1) leaves alpha = 0: F_n = T1 / (R1 cos(beta_b)) whatever the inertias.
  for (const std::optional<double> t2 : {std::optional<double>(), std::optional<double>(30.0)}) {
    Case c = with_shafts();
    c.load.load_torque_nm = t2;
    const CoupledParameters p = coupled_parameters(c);
    const Geometry g = case_geometry(c);
    const double r1 = g.base_radius_m[0], r2 = g.base_radius_m[1];
    const double j1 = g.inertia_kg_m2[0], j2 = g.inertia_kg_m2[1];
    const double jm = c.shafts.end_inertia_kg_m2[0], jl = c.shafts.end_inertia_kg_m2[1];
    const double t1 = c.load.torque_nm, load = t2 ? *t2 : r2 * t1 / r1;
    const double alpha = (r2 * t1 - r1 * load) / (r2 * (jm + j1) + r1 * r1 * (jl + j2) / r2);
    const double fn = (t1 - (jm + j1) * alpha) / (r1 * p.cos_base_helix);
    EXPECT_NEAR(p.static_mesh_force_n(), fn, 1e-12 * fn);
    EXPECT_NEAR(p.static_shaft_torque_nm(0), t1 - jm * alpha, 1e-12 * t1);
    EXPECT_NEAR(p.static_shaft_torque_nm(1), load + jl * r1 * alpha / r2, 1e-12 * t1);
    if (!t2) EXPECT_NEAR(fn, t1 / (r1 * p.cos_base_helix), 1e-12 * fn);
    // Each shaft is damped at its ratio against the reduced inertia of its two ends (docs).
    for (int i = 0; i < 2; ++i) {
      const double je = c.shafts.end_inertia_kg_m2[i], jg = g.inertia_kg_m2[i],
                   ks = c.shafts.stiffness_n_m_per_rad[i];
      EXPECT_NEAR(p.bearing_damping[p.shaft[i]],
                  2 * c.shafts.damping_ratio * std::sqrt(ks * je * jg / (je + jg)),
                  1e-12 * p.bearing_damping[p.shaft[i]]);
    }
    if (t2) EXPECT_GT(std::abs(alpha), 1.0);
    // The static state holds those torques in its twists and that force in its mesh.
    const CoupledModel model(p);
    const ode::Vector y = model.static_state();
    for (int i = 0; i < 2; ++i)
      EXPECT_NEAR(p.bearing_stiffness[p.shaft[i]] * y[p.shaft[i]], p.static_shaft_torque_nm(i),
                  1e-9 * t1);
    const double d = p.mesh_vector.dot(y.head(p.size()));
    EXPECT_NEAR(p.stiffness_n_per_m.offset * (d - p.backlash_m), fn, 1e-9 * fn);
  }
}

TEST(CoupledShafts, TheModesAreThoseOfTheAbsoluteRotations) {
  // The same chain written in the absolute rotations (theta_1, theta_2, theta_m, theta_L, y1,
  // y2) with a diagonal mass matrix: one rigid rotation at w = 0, and the other frequencies
  // those of the coupled model's reduced coordinates, to 1e-10.
  const Case c = with_shafts();
  const CoupledParameters p = coupled_parameters(c);
  const Geometry g = case_geometry(c);
  const double r1 = g.base_radius_m[0], r2 = g.base_radius_m[1], cb = p.cos_base_helix;
  ode::Matrix m = ode::Matrix::Zero(6, 6), k = ode::Matrix::Zero(6, 6);
  m.diagonal() << g.inertia_kg_m2[0], g.inertia_kg_m2[1], c.shafts.end_inertia_kg_m2[0],
      c.shafts.end_inertia_kg_m2[1], p.mass(p.line[0], p.line[0]), p.mass(p.line[1], p.line[1]);
  ode::RowVector mesh(6), drive(6), load(6);
  mesh << cb * r1, cb * r2, 0, 0, cb, -cb;  // d = cb (R1 th1 + R2 th2 + y1 - y2)
  drive << -1, 0, 1, 0, 0, 0;               // phi_1 = th_m - th_1
  load << 0, -1, 0, 1, 0, 0;                // phi_2 = th_L - th_2
  k += p.stiffness_n_per_m.offset * mesh.transpose() * mesh;
  k += c.shafts.stiffness_n_m_per_rad[0] * drive.transpose() * drive;
  k += c.shafts.stiffness_n_m_per_rad[1] * load.transpose() * load;
  k(4, 4) += c.bearings.radial_stiffness_n_per_m[0];
  k(5, 5) += c.bearings.radial_stiffness_n_per_m[1];
  Eigen::GeneralizedSelfAdjointEigenSolver<ode::Matrix> absolute(k, m);
  const ModeSet set = modes(CoupledModel(p));
  ASSERT_EQ(set.modes.size(), 5U);
  const double top = absolute.eigenvalues()[5];
  EXPECT_LT(std::abs(absolute.eigenvalues()[0]), 1e-12 * top);  // the rigid rotation
  for (int r = 0; r < 5; ++r) {
    const double w = std::sqrt(absolute.eigenvalues()[r + 1]) / (2 * kPi);
    EXPECT_NEAR(set.modes[r].frequency_hz, w, 1e-10 * w) << r;
  }
  // The shafts hold strain energy in the modes that twist them; the shares sum to 1.
  double shafts = 0;
  for (const Mode& x : set.modes) {
    EXPECT_NEAR(
        x.mesh_energy + x.line_energy[0] + x.line_energy[1] + x.shaft_energy[0] + x.shaft_energy[1],
        1.0, 1e-12);
    shafts = std::max(shafts, x.shaft_energy[0] + x.shaft_energy[1]);
  }
  EXPECT_GT(shafts, 0.5);
}

TEST(CoupledShafts, TheEnginesEquationsAreTheAbsoluteRotationsOnes) {
  // theta'' = J^-1 (f - S^T e_r) in the absolute rotations, f the torques (T1(t) on the motor;
  // T2 on the load, matched or given), e_r the elastic and damping forces on (u, phi_1, phi_2):
  // the engine's r'' must be S theta'', at random states in drive contact and separated.
  for (const std::optional<double> t2 : {std::optional<double>(), std::optional<double>(-20.0)}) {
    Case c = with_shafts();
    c.load.load_torque_nm = t2;
    c.load.fluctuation_ratio = 0.3;
    if (t2) {  // a fluctuating load torque at twice the shaft frequency
      c.load.load_fluctuation_nm = 7;
      c.load.load_fluctuation_order = 2;
      c.load.load_fluctuation_phase_deg = 40;
    }
    const CoupledModel model(coupled_parameters(c));
    const CoupledParameters& p = model.parameters();
    const Geometry g = case_geometry(c);
    const double r1 = g.base_radius_m[0], r2 = g.base_radius_m[1];
    const ode::LinearSwitchedSystem sys = model.linear_system();
    ode::Matrix s = ode::Matrix::Zero(3, 4);  // (u, phi_1, phi_2) of (th1, th2, th_m, th_L)
    s << r1, r2, 0, 0, -1, 0, 1, 0, 0, -1, 0, 1;
    ode::Vector inertia(4);
    inertia << g.inertia_kg_m2[0], g.inertia_kg_m2[1], c.shafts.end_inertia_kg_m2[0],
        c.shafts.end_inertia_kg_m2[1];
    std::srand(11);
    for (const int mesh : {kDriveContact, kSeparated}) {
      const int region = coupled_region({mesh, {0, 0}});
      for (int trial = 0; trial < 4; ++trial) {
        const double t = 2.3e-4 * (trial + 1);
        const ode::Vector y = ode::Vector::Random(10) * 1e-5;
        const ode::Vector q = y.head(5), v = y.tail(5);
        const double d = p.mesh_vector.dot(q), dv = p.mesh_vector.dot(v);
        const double fn = mesh == kDriveContact ? p.stiffness_n_per_m(t) * (d - p.backlash_m) +
                                                      p.mesh_damping_n_s_per_m * dv
                                                : 0.0;
        ode::Vector elastic = p.mesh_vector.transpose() * fn;
        elastic += p.bearing_stiffness.cwiseProduct(q) + p.bearing_damping.cwiseProduct(v);
        const double t1 = p.drive_torque_nm(t);
        ode::Vector f = ode::Vector::Zero(4);
        f[2] = t1;
        const double w2 = 2 * kPi * 2 * c.speed.shaft_frequency_hz;
        f[3] = t2 ? *t2 + 7 * std::cos(w2 * t + 40 * kPi / 180) : r2 * t1 / r1;
        const ode::Vector theta = (f - s.transpose() * elastic.head(3)).cwiseQuotient(inertia);
        const ode::Vector got = ode::derivative(sys, region, t, y);
        const ode::Vector expected = s * theta;
        EXPECT_LT((got.segment(5, 3) - expected).cwiseAbs().maxCoeff(),
                  1e-9 * expected.cwiseAbs().maxCoeff());
        for (int i = 0; i < 2; ++i) {
          const int j = p.line[i];
          EXPECT_NEAR(got[5 + j], -elastic[j] / p.mass(j, j),
                      1e-9 * std::abs(elastic[j] / p.mass(j, j)));
        }
      }
    }
  }
}

TEST(CoupledShafts, StiffShaftsJoinTheirInertiasToTheGears) {
  // As the shafts stiffen, the modes other than the shafts' own tend to those of the pair
  // without shafts whose gears carry the motor's and the load's inertias, the difference
  // falling in proportion to 1 / k_s.
  Case joined = coupled(3);
  joined.mesh.stiffness_source = StiffnessSource::kHarmonics;
  const Geometry g = case_geometry(joined);
  const std::array<double, 2> ends = {0.02, 0.04};
  joined.gear.inertia_kg_m2 =
      std::array<double, 2>{g.inertia_kg_m2[0] + ends[0], g.inertia_kg_m2[1] + ends[1]};
  const ModeSet target = modes(CoupledModel(coupled_parameters(joined)));
  std::vector<double> error;
  for (const double ks : {1e8, 1e9}) {
    Case c = coupled(3);
    c.mesh.stiffness_source = StiffnessSource::kHarmonics;
    c.shafts.end_inertia_kg_m2 = ends;
    c.shafts.stiffness_n_m_per_rad = {ks, ks};
    const ModeSet set = modes(CoupledModel(coupled_parameters(c)));
    ASSERT_EQ(set.modes.size(), 5U);
    double worst = 0;
    for (int r = 0; r < 3; ++r)
      worst =
          std::max(worst, std::abs(set.modes[r].frequency_hz / target.modes[r].frequency_hz - 1));
    // The two highest are the shafts' own, far above.
    EXPECT_GT(set.modes[3].frequency_hz, 3 * target.modes[2].frequency_hz);
    error.push_back(worst);
  }
  EXPECT_LT(error[1], 1e-3);
  EXPECT_NEAR(error[0] / error[1], 10, 1.5);
}

TEST(CoupledModel, AClearanceShiftsTheStaticStateByItself) {
  // The dead zone: y_i at rest under the mesh force is -+ (cb F / k_r + c_i).
  Case c = coupled(3);
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  const CoupledModel tight(coupled_parameters(c));
  c.bearings.radial_clearance_um = {20, 35};
  const CoupledModel loose(coupled_parameters(c));
  const ode::Vector a = tight.static_state(), b = loose.static_state();
  const auto& p = loose.parameters();
  EXPECT_NEAR(b[p.line[0]] - a[p.line[0]], -20e-6, 1e-15);
  EXPECT_NEAR(b[p.line[1]] - a[p.line[1]], 35e-6, 1e-15);
  const CoupledState s = coupled_state(loose.classify(0, b));
  EXPECT_EQ(s.mesh, kDriveContact);
  EXPECT_EQ(s.bearing[0], -1);
  EXPECT_EQ(s.bearing[1], 1);
}

TEST(CoupledRun, ClearanceBearingsAreReadAsTheMeshIs) {
  // Equal gears on equal bearings with a 20 um clearance, dof 3: the mesh pushes gear 1 to the
  // -c side and gear 2 to the +c side, so their bearings read the same, mirrored (the -c side
  // counts as the "back side"); contacts and separations alternate.
  Case c = coupled(3);
  c.bearings.radial_clearance_um = {20, 20};
  c.solver.duration_s = 0.02;
  const CoupledRunResult r = run_coupled(c);
  ASSERT_TRUE(r.ok()) << r.message;
  const ContactReading &b1 = r.bearing[0], &b2 = r.bearing[1];
  ASSERT_TRUE(b1.present && b2.present);
  EXPECT_GT(b1.impacts, 5);
  EXPECT_EQ(b1.impacts, b2.impacts);
  EXPECT_EQ(b1.backside_impacts, b1.impacts);
  EXPECT_EQ(b2.backside_impacts, 0);
  EXPECT_NEAR(b1.separated_fraction, b2.separated_fraction, 1e-9);
  EXPECT_GT(b1.separated_fraction, 0.0);
  EXPECT_LT(b1.separated_fraction, 1.0);
  EXPECT_LE(std::abs(b1.impacts - b1.separations), 1);
  // The samples agree: inside the clearance the bearing force is 0.
  const CoupledParameters& p = r.parameters;
  for (std::size_t k = 0; k < r.samples.t_s.size(); ++k) {
    const double y1 = r.samples.state[k][p.line[0]];
    if (std::abs(y1) < 0.99 * p.clearance_m[0]) EXPECT_EQ(r.samples.bearing_force_n[k][0], 0.0);
  }
}

TEST(CoupledRun, TheExtremesAreThoseOfEveryCell) {
  // The run skips a cell (and jumps whole periods) when interval bounds of an observable leave
  // no room for a new extreme: its extremes must equal those of an observer that asks every
  // cell, with shafts, clearances and a rattling mesh.
  Case c = coupled(12);
  c.shafts.end_inertia_kg_m2 = {0.05, 0.3};
  c.bearings.radial_clearance_um = {3, 3};
  c.solver.duration_s = 0.03;
  const CoupledRunResult r = run_coupled(c);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GT(r.mesh.impacts, 0);
  struct EveryCell : ode::FlowObserver {
    std::array<double, CoupledModel::kObservableCount> max, min;
    EveryCell() {
      max.fill(-1e300);
      min.fill(1e300);
    }
    bool needs_detail(const ode::CellView&) override { return true; }
    void on_cell(const ode::CellView& cell) override {
      if (!(cell.t_end_s > cell.t_begin_s)) return;
      for (int k = 0; k < CoupledModel::kObservableCount; ++k) {
        double v = 0, t = 0;
        if (cell.extreme(k, true, max[k], v, t)) max[k] = v;
        if (cell.extreme(k, false, min[k], v, t)) min[k] = v;
      }
    }
  } every;
  const CoupledModel model(r.parameters);
  const ode::ExactEngine engine(model.linear_system());
  const ode::Vector y0 = ode::Vector::Zero(2 * r.parameters.size());
  ASSERT_TRUE(
      engine.flow(0, y0, model.classify(0, y0), c.solver.duration_s, ode::OutputGrid{}, every)
          .ok());
  const auto same = [](double a, double b) { EXPECT_NEAR(a, b, 1e-9 * std::abs(b)); };
  same(r.max_force_n, every.max[CoupledModel::kObservableForce]);
  same(r.min_force_n, every.min[CoupledModel::kObservableForce]);
  same(r.max_deflection_m, every.max[CoupledModel::kObservableDeflection]);
  same(r.min_deflection_m, every.min[CoupledModel::kObservableDeflection]);
  for (int i = 0; i < 2; ++i) {
    for (const auto& [k, got] :
         {std::pair{CoupledModel::kObservableBearing + i, r.max_bearing_force_n[i]},
          std::pair{CoupledModel::kObservableAxial + i, r.max_axial_force_n[i]},
          std::pair{CoupledModel::kObservableShaft + i, r.max_shaft_torque_nm[i]}})
      same(got, std::max(every.max[k], -every.min[k]));
  }
}

TEST(CoupledRun, TheExtremesBoundEveryDenseSampleAndAreReachedByThem) {
  // The extremes found on the cells' polynomials (the engine's forms of each observable over a
  // cell, and the ranges by which it skips cells) against the samples of the same stretch, 320
  // to a mesh period, of a rattling 12-DOF pair with shafts, past its first 20 ms: no sample
  // beyond an extreme, and the largest sample within what sampling can miss of a smooth peak
  // (under 1e-3 of the observable's swing at this spacing).
  Case c = coupled(12);
  c.shafts.end_inertia_kg_m2 = {0.05, 0.3};
  const CoupledSolver solver(c);
  const double t_a = 0.02, t_b = 0.023, mesh_period = 1 / 56e3, step = mesh_period / 320;
  ode::Vector y_a;
  const ode::Vector y0 = solver.initial_state(InitialCondition::kCenter);
  ASSERT_TRUE(solver.read(0, y0, t_a, ode::OutputGrid{}, t_a, {}, &y_a).ok());
  const auto count = static_cast<std::int64_t>((t_b - t_a) / step);
  const CoupledRunResult r = solver.read(t_a, y_a, t_b, ode::OutputGrid{t_a, step, count}, t_b);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_GT(r.mesh.impacts, 0);
  const CoupledParameters& p = solver.model().parameters();
  const CoupledSamples& s = r.samples;
  ASSERT_EQ(s.t_s.size(), static_cast<std::size_t>(count));
  const auto check = [](const char* what, double low, double high,
                        const std::vector<double>& samples) {
    const auto [lo, hi] = std::minmax_element(samples.begin(), samples.end());
    const double swing = high - low, rounding = 1e-12 * std::max(std::abs(low), std::abs(high));
    ASSERT_GT(swing, 0) << what;
    EXPECT_LE(*hi, high + rounding) << what;
    EXPECT_GE(*lo, low - rounding) << what;
    EXPECT_LE(high - *hi, 1e-3 * swing) << what;
    EXPECT_LE(*lo - low, 1e-3 * swing) << what;
  };
  std::vector<double> force, deflection;
  for (std::size_t k = 0; k < s.t_s.size(); ++k) {
    force.push_back(s.force_bar[k] * p.backlash_m * p.stiffness_n_per_m.offset);
    deflection.push_back(s.deflection_bar[k] * p.backlash_m);
  }
  check("force", r.min_force_n, r.max_force_n, force);
  check("deflection", r.min_deflection_m, r.max_deflection_m, deflection);
  for (int i = 0; i < 2; ++i) {
    std::vector<double> bearing, axial, shaft;
    for (std::size_t k = 0; k < s.t_s.size(); ++k) {
      bearing.push_back(s.bearing_force_n[k][i]);
      axial.push_back(s.axial_force_n[k][i]);
      shaft.push_back(s.shaft_torque_nm[k][i]);
    }
    // The run keeps the largest magnitude: the samples' own smallest, then, bounds the other end.
    const auto magnitude = [](const std::vector<double>& v) {
      const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
      return std::abs(*hi) >= std::abs(*lo);
    };
    const auto bounds = [&](const std::vector<double>& v, double largest) {
      const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
      return magnitude(v) ? std::pair{*lo, largest} : std::pair{-largest, *hi};
    };
    for (const auto& [what, v, largest] :
         {std::tuple{"bearing force", &bearing, r.max_bearing_force_n[i]},
          std::tuple{"axial force", &axial, r.max_axial_force_n[i]},
          std::tuple{"shaft torque", &shaft, r.max_shaft_torque_nm[i]}}) {
      const auto [low, high] = bounds(*v, largest);
      check(what, low, high, *v);
    }
  }
}

TEST(CoupledModel, OtherCommandsAndMethodsRefuseIt) {
  Case c = coupled(12);
  EXPECT_THROW((void)build_model(c), InputError);
  c.solver.method = Method::kDopri5;
  EXPECT_THROW((void)run_coupled(c), InputError);
}

// The largest |bearing force| of a coupled run over [from, end], sampled: line of action
// (axial = false) or axial, per gear.
std::array<double, 2> sampled_bearing_max(const CoupledRunResult& r, double from_s, bool axial) {
  std::array<double, 2> top{0, 0};
  for (std::size_t k = 0; k < r.samples.t_s.size(); ++k) {
    if (r.samples.t_s[k] < from_s) continue;
    const auto& f = axial ? r.samples.axial_force_n[k] : r.samples.bearing_force_n[k];
    for (std::size_t i = 0; i < 2; ++i) top[i] = std::max(top[i], std::abs(f[i]));
  }
  return top;
}

// A coupled sweep point's reading of a quantity of a bearing or shaft of the train form
// (train_form_of): gear i's bearing is "pinion_bearing" or "wheel_bearing", its line of action
// the bearing's y, its axis the axial force.
const PartReading& part_of(const SweepResult& r, const SweepPoint& p, std::size_t gear,
                           const std::string& what) {
  const std::string part = gear == 0 ? "pinion_bearing" : "wheel_bearing";
  for (std::size_t k = 0; k < r.parts.size(); ++k)
    if (r.parts[k].part == part && r.parts[k].what == what) return p.parts.at(k);
  throw std::out_of_range(part + " has no " + what);
}

TEST(CoupledSweep, ItsBearingColumnsAreTheBearingForcesOfItsSettledResponse) {
  // A one-point sweep starts from static contact, settles k periods and measures m: its bearing
  // readings (run as its train form) are those of the coupled model's own run of the same k
  // periods, read on the next m from samples 1/4000 of a period apart (the sweep's are the
  // engine's exact extremes, so they lie at or above the samples' and within their spacing's
  // error; the two assemblies are integrated apart, so "at or above" holds to the engine's
  // tolerance, 1e-6, not to rounding). Its factors are the largest forces over the static bearing
  // loads cos(beta_b) F_n and sin(beta_b) F_n. At 1 kHz the helical pair rattles, at 2.5 kHz it
  // stays in contact; the spur pair carries no axial force (its axial factor is NaN), and only a
  // bearing with a clearance counts impacts: at 900 Hz the first one knocks in its 30 um, 4 times
  // in a response of 6 periods, as often as the coupled model's reading counts.
  for (const auto& [f1, spur, clearance_um] : std::vector<std::tuple<double, bool, double>>{
           {1000, false, 0}, {2500, false, 0}, {900, true, 30}}) {
    SCOPED_TRACE(::testing::Message() << "f1 " << f1 << " Hz, " << (spur ? "spur" : "helical")
                                      << ", clearance " << clearance_um << " um");
    Case c = coupled(12);
    if (spur) make_spur(c);
    c.bearings.radial_clearance_um = {clearance_um, 0};
    c.speed.shaft_frequency_hz = f1;
    c.solver.initial = InitialCondition::kStatic;
    SweepOptions o;
    o.axis = {"speed.shaft_frequency_hz", f1, f1, 1, false};
    o.direction = SweepDirection::kUp;
    o.max_settle_periods = 2000;
    const SweepResult s = sweep(c, o);
    ASSERT_EQ(s.points.size(), 1U);
    const SweepPoint& pt = s.points[0];
    ASSERT_TRUE(pt.failure.empty()) << pt.failure;
    ASSERT_EQ(pt.parts.size(), s.parts.size());
    const int m = std::max(pt.period_multiple, 1) *
                  ((o.measure_periods + std::max(pt.period_multiple, 1) - 1) /
                   std::max(pt.period_multiple, 1));
    EXPECT_TRUE(pt.settled);
    // The same settling from static contact, then the measured periods sampled finely.
    const double period = s.period_s, from = pt.settle_periods * period, end = from + m * period;
    const CoupledSolver solver(c);
    const ode::FlowResult settled =
        solver.advance(0, solver.initial_state(InitialCondition::kStatic), from);
    ASSERT_TRUE(settled.ok());
    const CoupledRunResult r = solver.read(
        from, settled.state, end, ode::OutputGrid{from, period / 4000, 4000 * m}, end - period);
    ASSERT_TRUE(r.ok()) << r.message;
    const std::array<double, 2> line = sampled_bearing_max(r, from, false);
    const std::array<double, 2> axial = sampled_bearing_max(r, from, true);
    const CoupledParameters& p = r.parameters;
    for (std::size_t i = 0; i < 2; ++i) {
      const PartReading& across = part_of(s, pt, i, "force_x_n");
      const PartReading& along = part_of(s, pt, i, "force_y_n");
      const PartReading& axis = part_of(s, pt, i, "axial_force_n");
      EXPECT_EQ(across.peak, 0);
      EXPECT_TRUE(std::isnan(across.factor));
      EXPECT_GE(along.peak, line[i] * (1 - 1e-6));
      EXPECT_LE(along.peak, line[i] * (1 + 1e-5));
      EXPECT_NEAR(along.factor, along.peak / (p.cos_base_helix * p.static_mesh_force_n()),
                  1e-9 * along.factor);
      if (!spur) {
        EXPECT_GE(axis.peak, axial[i] * (1 - 1e-6));
        EXPECT_LE(axis.peak, axial[i] * (1 + 1e-5));
        EXPECT_NEAR(axis.factor, axis.peak / (p.sin_base_helix * p.static_mesh_force_n()),
                    1e-9 * axis.factor);
      } else {
        EXPECT_LT(axis.peak, 1e-9 * along.peak);
        EXPECT_TRUE(std::isnan(axis.factor));
      }
    }
    // The clearance directions: x and y of each bearing that has one.
    ASSERT_EQ(s.clearances.size(), clearance_um > 0 ? 2U : 0U);
    if (clearance_um > 0) {
      EXPECT_EQ(s.clearances[0], "pinion_bearing_x");
      EXPECT_EQ(s.clearances[1], "pinion_bearing_y");
      EXPECT_EQ(pt.period_multiple, 6);
      EXPECT_EQ(pt.clearances[0][0], 0);  // nothing moves across the line of action
      EXPECT_GT(pt.clearances[1][0], 0);
      EXPECT_EQ(pt.clearances[1][0], static_cast<double>(r.bearing[0].impacts) / m);
    }
  }
}

TEST(CoupledSweep, WritesItsBearingColumnsAndAFigureOfWhatOccurred) {
  // A coupled pair sweeps as its train form: sweep.csv gains its mesh's columns and two columns
  // per bearing quantity (<part>_peak_<what>, <part>_<what>_factor) before `failure`, read back
  // to the same doubles, and the figure part_forces has a panel of axial forces only for a
  // helical pair and one of impacts only for a bearing with a clearance. A one-degree sweep has
  // neither.
  const auto dir =
      std::filesystem::temp_directory_path() / ("geardyn_csweep_" + std::to_string(getpid()));
  const auto text = [&](const char* name) {
    std::ifstream in(dir / name);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  SweepOptions o;
  o.direction = SweepDirection::kUp;
  o.max_settle_periods = 2000;
  o.axis = {"speed.shaft_frequency_hz", 2000, 2500, 2, false};
  const SweepResult helical = sweep(coupled(12), o);
  ASSERT_EQ(helical.points.size(), 2U);
  std::filesystem::remove_all(dir);
  EXPECT_EQ(write_sweep(dir, helical),
            (std::vector<std::string>{"frequency_response", "bifurcation", "mesh_responses",
                                      "part_forces"}));
  const std::string csv = text("sweep.csv");
  std::istringstream rows(csv);
  std::string header, row;
  std::getline(rows, header);
  std::getline(rows, row);
  std::vector<std::string> names, cells;
  for (std::istringstream h(header); std::getline(h, names.emplace_back(), ',');) {
  }
  names.pop_back();
  for (std::istringstream r(row); std::getline(r, cells.emplace_back(), ',');) {
  }
  // Each bearing: force x and y, axial force, moments about x and y (dof 12).
  std::size_t bearings = 0;
  for (const SweepPart& q : helical.parts) bearings += q.part.ends_with("_bearing");
  EXPECT_EQ(bearings, 10U);
  ASSERT_EQ(names.size(), 22 + 10 + 2 * helical.parts.size() + 1);
  EXPECT_EQ(names.back(), "failure");
  EXPECT_EQ(names[22], "mesh_mean_delta_bar");
  const auto cell = [&](const std::string& name) {
    const auto at = std::find(names.begin(), names.end(), name);
    EXPECT_NE(at, names.end()) << name;
    return at == names.end() ? std::string() : cells[static_cast<std::size_t>(at - names.begin())];
  };
  for (std::size_t k = 0; k < helical.parts.size(); ++k) {
    const SweepPart& q = helical.parts[k];
    const PartReading& x = helical.points[0].parts[k];
    EXPECT_EQ(std::strtod(cell(q.peak_column()).c_str(), nullptr), x.peak) << q.label();
    if (std::isnan(x.factor)) {
      EXPECT_EQ(cell(q.factor_column()), "nan") << q.label();
    } else {
      EXPECT_EQ(std::strtod(cell(q.factor_column()).c_str(), nullptr), x.factor) << q.label();
    }
  }
  EXPECT_EQ(names[names.size() - 1 - 2 * helical.parts.size()], helical.parts[0].peak_column());
  std::string body = text("part_forces_body.gp");
  EXPECT_NE(body.find("largest bearing force"), std::string::npos);
  EXPECT_NE(body.find("largest axial force"), std::string::npos);
  EXPECT_NE(body.find("'up: pinion_bearing_force_y_n'"), std::string::npos);
  EXPECT_EQ(body.find("pinion_bearing_force_x_n'"), std::string::npos);  // never loaded
  EXPECT_EQ(body.find("impacts per period"), std::string::npos);
  EXPECT_EQ(body.find("'down:"), std::string::npos);

  Case spur = coupled(12);
  make_spur(spur);
  spur.bearings.radial_clearance_um = {30, 0};
  o.axis = {"speed.shaft_frequency_hz", 900, 900, 1, false};
  std::filesystem::remove_all(dir);
  write_sweep(dir, sweep(spur, o));
  body = text("part_forces_body.gp");
  EXPECT_EQ(body.find("largest axial force"), std::string::npos);
  const std::size_t impacts = body.find("impacts per period in the clearance");
  ASSERT_NE(impacts, std::string::npos);
  EXPECT_NE(body.find("pinion_bearing_y", impacts), std::string::npos);
  EXPECT_EQ(body.find("wheel_bearing", impacts), std::string::npos);

  Case one;
  o.axis = {"speed.shaft_frequency_hz", 2000, 2500, 2, false};
  std::filesystem::remove_all(dir);
  EXPECT_EQ(write_sweep(dir, sweep(one, o)),
            (std::vector<std::string>{"frequency_response", "bifurcation"}));
  EXPECT_EQ(text("sweep.csv").find("bearing"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "part_forces.png"));
  std::filesystem::remove_all(dir);
}

TEST(CoupledSweep, TheShippedCasesRattleLoadsItsBearingsMostAsDocsSweepsSays) {
  // docs/sweeps.md's figure: cases/park2010_coupled.toml from 500 to 3000 Hz (60 points, up
  // and down). Its largest line-of-action bearing force, 3.3 to 3.6 kN, is met inside the
  // rattle between the jumps (754 to 924 Hz, where the points do not settle in 200 periods and
  // the last 10 run are read), 4.3 to 4.7 times the force in contact at 3 kHz; the two gears'
  // bearings carry the same force.
  const Case c = load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010_coupled.toml");
  SweepOptions o;
  o.axis = {"speed.shaft_frequency_hz", 500, 3000, 60, false};
  const SweepResult r = sweep(c, o);
  ASSERT_EQ(r.failed, 0U);
  const SweepPoint* top = nullptr;
  const SweepPoint* contact = nullptr;
  const auto line = [&](const SweepPoint& p, std::size_t gear) {
    return part_of(r, p, gear, "force_y_n").peak;
  };
  for (const SweepPoint& p : r.points) {
    // In permanent contact the model is linear: a settled point's response is of period T0.
    if (p.settled && p.impacts_per_period == 0 && p.separated_fraction == 0)
      EXPECT_EQ(p.period_multiple, 1) << to_string(p.direction) << " " << p.value;
    EXPECT_NEAR(line(p, 0), line(p, 1), 1e-9 * line(p, 0));
    if (!top || line(p, 0) > line(*top, 0)) top = &p;
    if (p.direction == SweepDirection::kUp && p.value == 3000) contact = &p;
  }
  ASSERT_NE(contact, nullptr);
  EXPECT_EQ(contact->impacts_per_period, 0);
  EXPECT_GT(top->impacts_per_period, 0);
  EXPECT_GT(top->value, 754);
  EXPECT_LT(top->value, 924);
  const double peak = line(*top, 0);
  EXPECT_GT(peak, 3300);
  EXPECT_LT(peak, 3600);
  EXPECT_GT(peak / line(*contact, 0), 4.3);
  EXPECT_LT(peak / line(*contact, 0), 4.7);
}

TEST(CoupledSweep, APointInContactIsMeasuredOnItsPeriodicResponse) {
  // cases/park2010_coupled.toml in permanent contact (a linear system, one periodic response):
  // a one-point sweep settles until the mesh and every bearing displacement are predicted
  // within the tolerance (1e-6 b) of it, and then reads what 3000 periods read, peak-to-peak
  // delta_bar to 2e-6 and the bearing forces to 1e-4. Settled on the mesh alone, the points
  // of docs/sweeps.md's sweep read them 5e-5 and 1.6e-3 off while their bearings still decayed.
  const Case c = load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010_coupled.toml");
  for (const double f1 : {500.0, 2067.7966101694915, 2449.1525423728817}) {
    SweepOptions o;
    o.axis = {"speed.shaft_frequency_hz", f1, f1, 1, false};
    o.direction = SweepDirection::kUp;
    o.max_settle_periods = 1000;  // from static contact; in a sweep the previous point is near
    const SweepResult r = sweep(c, o);
    o.settle_periods = o.max_settle_periods = 3000;
    const SweepResult reference = sweep(c, o);
    ASSERT_EQ(r.points.size(), 1U);
    const SweepPoint& p = r.points[0];
    const SweepPoint& ref = reference.points[0];
    EXPECT_TRUE(p.settled) << f1;
    EXPECT_EQ(p.period_multiple, 1) << f1;  // linear in contact: one response, of period T0
    EXPECT_EQ(p.impacts_per_period, 0) << f1;
    EXPECT_NEAR(p.pp_delta_bar, ref.pp_delta_bar, 2e-6) << f1;
    for (std::size_t i = 0; i < 2; ++i)
      for (const char* what : {"force_y_n", "axial_force_n"}) {
        const double x = part_of(r, p, i, what).peak, at = part_of(reference, ref, i, what).peak;
        EXPECT_NEAR(x, at, 1e-4 * at) << f1 << " " << what;
      }
  }
}

TEST(CoupledSweep, ItsSettledPointsInContactAreWithinTheToleranceOfTheirExactOrbits) {
  // The up sweep of docs/sweeps.md (cases/park2010_coupled.toml, dof 12, 500 to 3000 Hz, 50
  // points), run as the pair's train form: every point settled in permanent contact reads its
  // periodic response, the orbit Newton finds there with the coupled model, peak-to-peak
  // delta_bar to 1e-6 and within the point's own steady_error, and the bearing forces to 5e-5
  // (the steady tolerance, 1e-6 b, is some 2e-5 of a bearing's static deflection). Its last
  // contact period's flow is affine, so its distance to that response is exact (modulo the
  // pair's rigid rotation); judged by the projections' two-dimensional fits alone, points of
  // this sweep read delta_bar 6.7e-7 off while predicting 4.7e-7 (and the coupled model's own
  // sweep, 3.9e-6 off while predicting 3e-7).
  const Case c = load_case(std::string(GEARDYN_SOURCE_DIR) + "/cases/park2010_coupled.toml");
  SweepOptions o;
  o.axis = {"speed.shaft_frequency_hz", 500, 3000, 50, false};
  o.direction = SweepDirection::kUp;
  const SweepResult r = sweep(c, o);
  int checked = 0;
  for (const SweepPoint& p : r.points) {
    if (!p.settled || p.impacts_per_period != 0) continue;
    EXPECT_LE(p.steady_error, o.steady_tolerance) << p.value;
    Case at = c;
    at.speed.shaft_frequency_hz = p.value;
    at.solver.initial = InitialCondition::kStatic;  // the contact branch where a rattle coexists
    const CoupledOrbit orbit = find_coupled_orbit(at, OrbitOptions{});
    ASSERT_TRUE(orbit.converged) << p.value << ": " << orbit.message;
    const CoupledRunResult& exact = orbit.reading;
    const double b = exact.parameters.backlash_m;
    const double pp = (exact.max_deflection_m - exact.min_deflection_m) / b;
    EXPECT_NEAR(p.pp_delta_bar, pp, 1e-6) << p.value;
    EXPECT_LE(std::abs(p.pp_delta_bar - pp), p.steady_error) << p.value;
    for (std::size_t i = 0; i < 2; ++i)
      EXPECT_NEAR(part_of(r, p, i, "force_y_n").peak, exact.max_bearing_force_n[i],
                  5e-5 * exact.max_bearing_force_n[i])
          << p.value << " gear " << i + 1;
    ++checked;
  }
  EXPECT_GE(checked, 40);
}

}  // namespace
}  // namespace geardyn
