// Periodic orbits of the coupled model: the multipliers of a linear orbit in permanent contact
// against exp(lambda T) of the contact system's eigenvalues and its state against the forced
// response in closed form; the monodromy with saltation (mesh impacts, bearing clearances)
// against central differences of the flow map; a stable rattle orbit is where a long
// simulation settles.
#include "geardyn/coupled_orbit.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>

#include "geardyn/train_statics.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

using Complex = std::complex<double>;

using testing::coupled;

TEST(CoupledOrbit, ALinearOrbitHasTheClosedFormsMultipliersAndState) {
  // Permanent contact, constant stiffness, steady torque, a transmission error of two mesh
  // harmonics: the orbit is q_s + Re(H a e^{i w t}), H = (K - w^2 M + i w C)^-1 V^T (k + i w c),
  // and its multipliers are exp(lambda T) of the contact region's state matrix.
  Case c = coupled(6);
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.load.fluctuation_ratio = 0;
  c.load.torque_nm = 400;
  c.speed.shaft_frequency_hz = 30;
  c.mesh.transmission_error_um = {{1.0, 20.0}, {0.3, 0.0}};
  OrbitOptions o;
  o.settle_periods = 0;  // Newton from rest in the middle of the backlash: not a good guess
  c.solver.initial = InitialCondition::kStatic;
  const CoupledOrbit orbit = find_coupled_orbit(c, o);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  EXPECT_EQ(orbit.reading.mesh.impacts, 0);
  const CoupledParameters& p = orbit.reading.parameters;
  const CoupledModel model(p);
  const Eigen::Index n = p.size();
  // The state against the closed form at t = 0.
  const ode::Matrix k = model.contact_stiffness(), damping = model.contact_damping();
  ode::Vector q = model.static_state().head(n), v = ode::Vector::Zero(n);
  for (const Harmonic& x : p.transmission_error_m.terms) {
    const double w = x.angular_frequency_rad_s;
    const Eigen::MatrixXcd z = k.cast<Complex>() - w * w * p.mass.cast<Complex>() +
                               Complex(0, w) * damping.cast<Complex>();
    const Eigen::VectorXcd h =
        z.partialPivLu().solve(p.mesh_vector.transpose().cast<Complex>() *
                               Complex(p.stiffness_n_per_m.offset, w * p.mesh_damping_n_s_per_m) *
                               std::polar(x.amplitude, x.phase_rad));
    q += h.real();
    v += (Complex(0, w) * h).real();
  }
  const double scale = (q - model.static_state().head(n)).cwiseAbs().maxCoeff();
  EXPECT_GT(scale, 1e-8);
  EXPECT_LT((orbit.state.head(n) - q).cwiseAbs().maxCoeff(), 1e-8 * scale);
  EXPECT_LT((orbit.state.tail(n) - v).cwiseAbs().maxCoeff(), 1e-8 * v.cwiseAbs().maxCoeff());
  // The multipliers against exp(lambda T), lambda of the contact region's state matrix
  // balanced (M^1/2 q and M^1/2 q' / w_top: entries of one order, eigenvalues to rounding).
  ode::Matrix a = model.linear_system().regions[coupled_region({kDriveContact, {0, 0}})].a.constant;
  const double w_top = std::sqrt((-a.bottomLeftCorner(n, n)).diagonal().maxCoeff());
  const ode::Vector root = p.mass.diagonal().cwiseSqrt();  // M is diagonal without shafts
  ode::Vector balance(2 * n);
  balance << root, root / w_top;
  a = balance.asDiagonal() * a * balance.cwiseInverse().asDiagonal();
  const Eigen::EigenSolver<ode::Matrix> eig(a, false);
  ASSERT_EQ(orbit.multipliers.size(), static_cast<std::size_t>(2 * n));
  std::vector<Complex> expected;
  for (Eigen::Index i = 0; i < eig.eigenvalues().size(); ++i)
    expected.push_back(std::exp(eig.eigenvalues()[i] * orbit.period_s));
  for (const Complex& mu : orbit.multipliers) {
    double nearest = 1e300;
    for (const Complex& e : expected) nearest = std::min(nearest, std::abs(mu - e));
    // The product of the period's few hundred cell matrices keeps about eight digits.
    EXPECT_LT(nearest, 1e-8) << mu;
  }
  EXPECT_TRUE(orbit.stable);
}

// The monodromy of a converged orbit against central differences of the flow map over its
// period (through its events), column by column, relative to the column's size.
void expect_monodromy_is_the_flow_maps_derivative(const Case& c, const CoupledOrbit& orbit) {
  const CoupledSolver solver(c);
  const Eigen::Index n2 = orbit.state.size();
  ode::Vector scale(n2);  // steps: 1e-7 of b (of b / R_b1 for angles), rates times w
  const CoupledParameters& p = solver.model().parameters();
  const double w = 2 * std::numbers::pi * 1000;
  for (Eigen::Index j = 0; j < n2 / 2; ++j) {
    const std::string name = to_string(p.coordinates[j]);
    scale[j] = name.ends_with("_rad") ? p.backlash_m / p.base_radius_m[0] : p.backlash_m;
    scale[n2 / 2 + j] = scale[j] * w;
  }
  const ode::FlowResult nominal = solver.advance(0, orbit.state, orbit.period_s);
  ASSERT_TRUE(nominal.ok());
  // The orbit closes on itself, by the flow without Jacobians.
  EXPECT_LT(((nominal.state - orbit.state).cwiseQuotient(scale)).cwiseAbs().maxCoeff(), 1e-8);
  double worst = 0;
  for (Eigen::Index j = 0; j < n2; ++j) {
    const double h = 1e-7 * scale[j];
    ode::Vector plus = orbit.state, minus = orbit.state;
    plus[j] += h;
    minus[j] -= h;
    const ode::FlowResult fp = solver.advance(0, plus, orbit.period_s);
    const ode::FlowResult fm = solver.advance(0, minus, orbit.period_s);
    ASSERT_TRUE(fp.ok() && fm.ok());
    ASSERT_EQ(fp.events, nominal.events);
    ASSERT_EQ(fm.events, nominal.events);
    const ode::Vector column = (fp.state - fm.state) / (2 * h);
    const ode::Vector exact = orbit.monodromy.col(j);
    const double size =
        std::max({column.cwiseQuotient(scale).cwiseAbs().maxCoeff() * scale[j], 1e-12 * scale[j]});
    worst = std::max(
        worst, ((column - exact).cwiseQuotient(scale).cwiseAbs().maxCoeff() * scale[j]) / size);
  }
  EXPECT_LT(worst, 1e-5);
}

TEST(CoupledOrbit, TheMonodromyThroughImpactsIsTheFlowMapsDerivative) {
  // The Table 1 pair on bearings, dof 3, at 1 kHz: an unstable period-1 rattle orbit, two
  // impacts a period, a multiplier about -4.9 (a period doubling has passed).
  // Three shooting segments: the monodromy is their Jacobians' product.
  Case c = coupled(3);
  OrbitOptions o;
  o.segments = 3;
  const CoupledOrbit orbit = find_coupled_orbit(c, o);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  EXPECT_EQ(orbit.segments, 3);
  EXPECT_EQ(orbit.reading.mesh.impacts, 2);
  EXPECT_FALSE(orbit.stable);
  EXPECT_NEAR(orbit.multipliers.front().real(), -4.856, 0.005);  // docs/orbits.md
  EXPECT_NEAR(orbit.multipliers.front().imag(), 0, 1e-12);
  expect_monodromy_is_the_flow_maps_derivative(c, orbit);
}

TEST(CoupledOrbit, TheMonodromyThroughBearingClearancesIsTheFlowMapsDerivative) {
  // Clearance bearings that open and close within the period: their events' saltation too.
  const Case c = testing::coupled_with_clearances();
  OrbitOptions o;
  o.settle_periods = 300;
  const CoupledOrbit orbit = find_coupled_orbit(c, o);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  EXPECT_GT(orbit.reading.mesh.impacts, 0);
  EXPECT_EQ(orbit.reading.bearing[0].impacts, 2);
  EXPECT_EQ(orbit.reading.bearing[1].impacts, 2);
  expect_monodromy_is_the_flow_maps_derivative(c, orbit);
}

TEST(CoupledOrbit, AStableRattleOrbitIsWhereTheSimulationSettles) {
  // dof 3 at 600 Hz: a stable orbit with two impacts a period. From a start far off (at rest
  // in the middle of the backlash, no settling) Newton reaches it, and a simulation of 400
  // periods from that start ends on it.
  Case c = coupled(3);
  c.speed.shaft_frequency_hz = 600;
  OrbitOptions o;
  o.settle_periods = 0;
  o.segments = 4;  // multiple shooting from a poor guess
  o.periods = 1;
  const CoupledOrbit orbit = find_coupled_orbit(c, o);
  ASSERT_TRUE(orbit.converged) << orbit.message;
  EXPECT_TRUE(orbit.stable);
  EXPECT_NEAR(orbit.max_multiplier(), 0.876, 0.0005);  // docs/orbits.md
  EXPECT_EQ(orbit.reading.mesh.impacts, 2);
  EXPECT_GT(orbit.iterations, 2);
  const CoupledSolver solver(c);
  const ode::FlowResult settled = solver.advance(0, solver.initial_state(InitialCondition::kCenter),
                                                 400 * orbit.system_period_s);
  ASSERT_TRUE(settled.ok());
  const double b = orbit.reading.parameters.backlash_m;
  const Eigen::Index n = orbit.reading.parameters.size();
  EXPECT_LT((settled.state.head(n) - orbit.state.head(n)).cwiseAbs().maxCoeff(), 1e-6 * b);
}

TEST(CoupledOrbit, BadInputIsNamed) {
  Case c = coupled(3);
  try {
    (void)find_coupled_orbit(c, OrbitOptions{}, ode::Vector::Zero(4));
    FAIL() << "a start of 4 values was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("4 values given; this coupled case takes 6"),
              std::string::npos)
        << e.what();
  }
  OrbitOptions o;
  o.periods = 0;
  EXPECT_THROW((void)find_coupled_orbit(c, o), InputError);
  EXPECT_THROW((void)find_coupled_orbit(Case{}, OrbitOptions{}), InputError);
}

}  // namespace
}  // namespace geardyn
