// geardyn's shipped validation (validation.hpp). Each check reads its case the way a user's
// command would and compares with a reference computed here from the case's own data, by
// another method, or cited. docs/validation.md states every check's equations and sources.
#include "geardyn/validation.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <boost/math/tools/toms748_solve.hpp>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <stdexcept>

#include "geardyn/case.hpp"
#include "geardyn/continuation.hpp"
#include "geardyn/coupled_model.hpp"
#include "geardyn/coupled_run.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/one_degree_orbit.hpp"
#include "geardyn/one_degree_run.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/output_folder.hpp"
#include "geardyn/reproduce.hpp"
#include "geardyn/run.hpp"
#include "geardyn/stability.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_orbit.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();

// The exact engine's promise at its default tolerance, and any integrator's at a tolerance
// asked of it: the largest |delta/b| error over a run (docs/numerics.md).
constexpr double kDefaultAccuracyB = 1e-8;
// A located event (time, velocity) against its closed form: events are found by root finding
// to near the rounding of the state, whatever the tolerance; 1e-9 relative leaves room.
constexpr double kClosedFormRelative = 1e-9;
// Printed references (ISO/TR 6336-30 prints five or six digits).
constexpr double kPrintedRelative = 1e-4;
// The reference integrator's tolerance.
constexpr double kReferenceTolerance = 1e-13;

std::string number(double x, std::string_view unit = "") {
  return fmt::format("{:.10g}{}{}", x, unit.empty() ? "" : " ", unit);
}

// Collects the rows of one check.
class Rows {
 public:
  Rows(std::vector<ValidationRow>& out, std::string check) : out_(out), check_(std::move(check)) {}

  // |value - reference| / scale against tolerance.
  void compare(const std::string& quantity, double value, double reference, double scale,
               double tolerance, std::string_view unit, const std::string& source,
               const std::string& measure, bool cited = false) {
    const double error = std::abs(value - reference) / scale;
    add(quantity, number(value, unit), number(reference, unit), source, cited,
        std::isfinite(error) ? error : kInf, measure, tolerance);
  }
  void relative(const std::string& quantity, double value, double reference, double tolerance,
                std::string_view unit, const std::string& source, bool cited = false) {
    compare(quantity, value, reference, std::abs(reference), tolerance, unit, source, "relative",
            cited);
  }
  void count(const std::string& quantity, std::int64_t value, std::int64_t reference,
             const std::string& source) {
    add(quantity, std::to_string(value), std::to_string(reference), source, false,
        static_cast<double>(std::abs(value - reference)), "count", 0.0);
  }
  // A statement that agrees or not (a regime, a set of windows).
  void agree(const std::string& quantity, const std::string& value, const std::string& reference,
             bool agrees, const std::string& source, bool cited) {
    add(quantity, value, reference, source, cited, agrees ? 0.0 : 1.0, "agrees (0) or not (1)",
        0.0);
  }
  void failed(const std::string& why) {
    add("the check ran", "failed: " + why, "ran", "", false, kInf, "", 0.0);
  }

 private:
  void add(const std::string& quantity, std::string value, std::string reference,
           const std::string& source, bool cited, double error, const std::string& measure,
           double tolerance) {
    ValidationRow r;
    r.check = check_;
    r.quantity = quantity;
    r.value = std::move(value);
    r.reference = std::move(reference);
    r.source = source;
    r.cited = cited;
    r.error = error;
    r.measure = measure;
    r.tolerance = tolerance;
    r.passed = std::isfinite(error) && error <= tolerance;
    out_.push_back(std::move(r));
  }
  std::vector<ValidationRow>& out_;
  std::string check_;
};

RunResult checked(RunResult r) {
  if (!r.integration.ok()) throw std::runtime_error(r.integration.message);
  return r;
}

// A run on the user's path (run: a pair's form as its train).
RunResult checked_run(const Case& c) { return checked(run(c)); }

// A run on the one-degree model's own reader (run_one_degree_model): the independent reference
// of the checks that set a train or the coupled model against the one-degree model.
RunResult checked_one_degree_run(const Case& c) { return checked(run_one_degree_model(c)); }

// The mean normal mesh force and its fluctuation's amplitude of the one-degree model, from the
// gear data alone (docs/model.md, "Equation of motion"): F = T1 cos(beta_b) / R_b1.
double per_pinion_torque(const Geometry& g) {
  return std::cos(g.base_helix_angle_rad) / g.base_radius_m[0];
}

// ---- free_flight -------------------------------------------------------------------------

void free_flight(Rows& rows, bool) {
  // From rest in the middle of the backlash under a steady torque: m_eq delta'' = F_m until
  // delta = b: t_1 = sqrt(2 b m_eq / F_m), v_1 = sqrt(2 b F_m / m_eq).
  Case c;
  c.load.fluctuation_ratio = 0.0;
  c.solver.duration_s = 2e-3;
  const RunResult r = checked_run(c);
  const Geometry g = compute_geometry(c.gear);
  const double b = c.mesh.backlash_um * 1e-6, m = g.equivalent_mass_kg;
  const double F = c.load.torque_nm * per_pinion_torque(g);
  if (r.events.empty()) throw std::runtime_error("no impact in 2 ms");
  const std::string source = "closed form (free flight)";
  rows.relative("first impact time", r.events[0].t_s, std::sqrt(2 * b * m / F), kClosedFormRelative,
                "s", source);
  rows.relative("impact velocity", r.events[0].velocity_m_s, std::sqrt(2 * b * F / m),
                kClosedFormRelative, "m/s", source);
}

// ---- contact_response --------------------------------------------------------------------

// From static contact with a constant stiffness and a small torque fluctuation: the linear
// damped oscillator m y'' + C y' + K y = F_a cos(W t), y(0) = y'(0) = 0, y = delta - delta_s,
// with K = cos^2(beta_b) k_m and the damping ratio of the case's definition (docs/model.md).
void contact_response(Rows& rows, bool) {
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.load.fluctuation_ratio = 0.1;
  c.solver.initial = InitialCondition::kStatic;
  c.solver.duration_s = 0.01;
  c.solver.output_interval_s = 1e-5;
  const Geometry g = compute_geometry(c.gear);
  const double cb = std::cos(g.base_helix_angle_rad), m = g.equivalent_mass_kg;
  const double K = cb * cb * c.mesh.mean_stiffness_n_per_m, z = c.mesh.damping_ratio;
  const double Fm = c.load.torque_nm * per_pinion_torque(g), Fa = c.load.fluctuation_ratio * Fm;
  const double W = 2 * kPi * c.load.fluctuation_order * c.speed.shaft_frequency_hz;
  const double wn = std::sqrt(K / m), wd = wn * std::sqrt(1 - z * z), C = 2 * z * wn * m;
  const double X = Fa / std::hypot(K - m * W * W, C * W), th = std::atan2(C * W, K - m * W * W);
  const double A = -X * std::cos(th), B = (z * wn * A - X * W * std::sin(th)) / wd;
  const double b = c.mesh.backlash_um * 1e-6, delta_s = b + Fm / K;
  const auto y = [&](double t) {
    return X * std::cos(W * t - th) +
           std::exp(-z * wn * t) * (A * std::cos(wd * t) + B * std::sin(wd * t));
  };
  for (const auto& [method, tolerance, name] :
       {std::tuple{Method::kExact, 0.0, "exact engine, default tolerance"},
        std::tuple{Method::kExact, 1e-12, "exact engine, tolerance 1e-12"},
        std::tuple{Method::kDopri5, 1e-12, "dopri5, tolerance 1e-12"}}) {
    Case d = c;
    d.solver.method = method;
    if (tolerance > 0) d.solver.tolerance = tolerance;
    const RunResult r = checked_run(d);
    double worst = 0, at = 0, value = 0;
    for (std::size_t i = 0; i < r.samples.size(); ++i) {
      const double t = r.samples.t_s[i], run_y = r.samples.delta_bar[i] * b - delta_s;
      if (std::abs(run_y - y(t)) >= worst) {
        worst = std::abs(run_y - y(t));
        at = t;
        value = run_y;
      }
    }
    rows.compare(fmt::format("delta - delta_s at its worst sample ({}, t = {:.5g} s)", name, at),
                 value / b, y(at) / b, 1.0, tolerance > 0 ? tolerance * 10 : kDefaultAccuracyB, "b",
                 "closed form (damped forced oscillator)", "in b");
    rows.count(fmt::format("impacts ({})", name), r.reading.impacts, 0,
               "closed form (stays in contact)");
  }
}

// ---- contact_orbit -----------------------------------------------------------------------

void contact_orbit(Rows& rows, bool) {
  // The non-dimensional pair always in contact: x'' + 2 zeta x' + (x - 1) = F_m + F_a cos(W t).
  // Orbit x = 1 + F_m + Re(H e^{iWt}), H = F_a / (1 - W^2 + 2 i zeta W); multipliers
  // exp(lambda T), lambda = -zeta +- i sqrt(1 - zeta^2).
  const double zeta = 0.05, fm = 1.0, fa = 0.1, omega = 0.5;
  Case c;
  c.model.form = ModelForm::kNondimensional;
  c.model.zeta = zeta;
  c.model.force_mean = fm;
  c.model.force_alternating = fa;
  c.model.omega = omega;
  OrbitOptions o;
  o.settle_periods = 3;
  const Orbit orbit = find_orbit(c, o);
  if (!orbit.converged) throw std::runtime_error(orbit.message);
  const std::complex<double> H = fa / std::complex<double>(1 - omega * omega, 2 * zeta * omega);
  const std::string source = "closed form (linear periodic response)";
  rows.compare("orbit's x at t = 0", orbit.state.q, 1 + fm + H.real(), 1.0, 1e-11, "", source,
               "absolute");
  rows.compare("orbit's x' at t = 0", orbit.state.v, -omega * H.imag(), 1.0, 1e-11, "", source,
               "absolute");
  const double T = 2 * kPi / omega;
  const double mu = std::exp(-zeta * T);
  double largest = 0;
  for (const auto& m : orbit.multipliers) largest = std::max(largest, std::abs(m));
  rows.compare("largest Floquet multiplier modulus", largest, mu, 1.0, 1e-12, "",
               "closed form exp(-zeta T)", "absolute");
}

// ---- newmark_order -----------------------------------------------------------------------

void newmark_order(Rows& rows, bool) {
  // The paper's gear at 1 kHz over 3 ms (impacts and separations): delta at the end against
  // dopri5 at 1e-13, for steps halved three times; the observed order is log2 of successive
  // error ratios.
  Case c;
  c.solver.method = Method::kNewmark;
  c.solver.duration_s = 3e-3;
  c.solver.output_interval_s = 3e-3;
  Case ref = c;
  ref.solver.method = Method::kDopri5;
  ref.solver.tolerance = kReferenceTolerance;
  const RunResult r_ref = checked_run(ref);
  std::vector<double> errors;
  const double steps[] = {4e-7, 2e-7, 1e-7, 5e-8};
  for (const double dt : steps) {
    c.solver.time_step_s = dt;
    const RunResult r = checked_run(c);
    if (r.integration.transitions != r_ref.integration.transitions)
      throw std::runtime_error(fmt::format("Newmark at {} s crosses {} contact changes, dopri5 {}",
                                           dt, r.integration.transitions,
                                           r_ref.integration.transitions));
    errors.push_back(std::abs(r.samples.delta_bar.back() - r_ref.samples.delta_bar.back()));
  }
  for (std::size_t i = 1; i < errors.size(); ++i)
    rows.compare(fmt::format("observed order, dt {:g} to {:g} s", steps[i - 1], steps[i]),
                 std::log2(errors[i - 1] / errors[i]), 2.0, 1.0, 0.1, "",
                 "Newmark's order 2; errors against dopri5 at 1e-13", "absolute");
}

// ---- paper_dopri5 ------------------------------------------------------------------------

void paper_dopri5(Rows& rows, bool quick) {
  // The paper's cases over 20 ms, the user's default method and tolerance against dopri5 at
  // 1e-13: contact counts, the last separation and delta/b at every sample.
  const Study study = park2010_study();
  for (const StudyCase& sc : study.cases) {
    if (quick && sc.id != "fig4a" && sc.id != "fig4c" && sc.id != "fig6b") continue;
    Case c = sc.input;
    c.solver.duration_s = 0.02;
    c.solver.output_interval_s = 1e-5;
    Case d = c;
    d.solver.method = Method::kDopri5;
    d.solver.tolerance = kReferenceTolerance;
    const RunResult re = checked_run(c), rd = checked_run(d);
    const std::string source = "dopri5 at 1e-13";
    rows.count(sc.id + ": impacts", re.reading.impacts, rd.reading.impacts, source);
    rows.count(sc.id + ": back-side impacts", re.reading.backside_impacts,
               rd.reading.backside_impacts, source);
    if (re.reading.last_separation_s && rd.reading.last_separation_s)
      rows.compare(sc.id + ": last separation", *re.reading.last_separation_s,
                   *rd.reading.last_separation_s, c.solver.duration_s, 1e-8, "s", source,
                   "over the window");
    else
      rows.agree(sc.id + ": last separation", re.reading.last_separation_s ? "occurs" : "none",
                 rd.reading.last_separation_s ? "occurs" : "none",
                 !re.reading.last_separation_s && !rd.reading.last_separation_s, source, false);
    if (re.samples.size() != rd.samples.size())
      throw std::runtime_error(sc.id + ": the runs have different samples");
    double err = 0;
    std::size_t at = 0;
    for (std::size_t i = 0; i < re.samples.size(); ++i)
      if (std::abs(re.samples.delta_bar[i] - rd.samples.delta_bar[i]) > err) {
        err = std::abs(re.samples.delta_bar[i] - rd.samples.delta_bar[i]);
        at = i;
      }
    rows.compare(
        fmt::format("{}: delta/b at its worst sample (t = {:.5g} s)", sc.id, re.samples.t_s[at]),
        re.samples.delta_bar[at], rd.samples.delta_bar[at], 1.0, kDefaultAccuracyB, "", source,
        "in b");
  }
}

// ---- paper_findings ----------------------------------------------------------------------

std::string regime_words(Regime r, bool double_sided) {
  return fmt::format("{}, {}", to_string(r), double_sided ? "back-side contact" : "drive side");
}

void paper_findings(Rows& rows, bool) {
  const StudyResult r = run_study(park2010_study(), 1);
  const std::string source = "Park 2010, Figs. 4-6";
  for (const CaseOutcome& o : r.outcomes)
    rows.agree(fmt::format("{} {} ({}): regime over {:g} ms", o.spec.id, o.spec.label,
                           o.spec.figure, r.study.window_s * 1e3),
               regime_words(o.run.reading.regime, o.run.reading.double_sided),
               regime_words(o.spec.paper_regime, o.spec.paper_double_sided), o.holds, source, true);
  std::string windows;
  for (const auto& [from, to] : r.all_hold)
    windows += fmt::format("{}{:.2f}-{:.2f} ms", windows.empty() ? "" : ", ", from * 1e3, to * 1e3);
  rows.agree("windows over which all findings hold",
             windows.empty() ? std::string("none") : windows,
             fmt::format("include the study's {:g} ms", r.study.window_s * 1e3),
             contains(r.all_hold, r.study.window_s), source + " (docs/reproduction.md)", true);
}

// ---- iso6336_example ---------------------------------------------------------------------

void iso6336_example(Rows& rows, bool) {
  const Case c = iso_tr_6336_30_example_1();
  const Iso6336Stiffness s = iso6336_stiffness(c, compute_geometry(c.gear));
  const std::string source = "ISO/TR 6336-30:2017, example 1";
  rows.relative("virtual teeth z_n1", s.virtual_teeth[0], 18.905, kPrintedRelative, "", source,
                true);
  rows.relative("virtual teeth z_n2", s.virtual_teeth[1], 114.543, kPrintedRelative, "", source,
                true);
  rows.relative("q' (minimum flexibility of a tooth pair)", s.q_prime, 1 / 17.85584,
                kPrintedRelative, "mm um/N", source + " (1 / c'_th as printed)", true);
  rows.relative("c'_th", s.c_prime_th, 17.85584, kPrintedRelative, "N/(mm um)", source, true);
  rows.relative("c'", s.c_prime, 12.37047, kPrintedRelative, "N/(mm um)", source, true);
  // c_gamma_alpha needs the tip diameters, which the example's excerpt does not give: with
  // standard tips it agrees to 0.5 %.
  rows.relative("c_gamma_alpha (standard tips)", s.c_gamma_alpha, 17.46485, 5e-3, "N/(mm um)",
                source, true);
}

// ---- energy_vs_iso -----------------------------------------------------------------------

void energy_vs_iso(Rows& rows, bool) {
  // The energy method models ideal elastic teeth; ISO 6336-1's c' is fitted to measurements:
  // at full load they agree within +-30 % for standard gears (docs/stiffness.md).
  Case helical;
  Case spur;
  spur.gear.helix_angle_deg = 0;
  spur.gear.outside_diameter_mm = {146.0375, 146.0375};
  spur.gear.center_distance_mm = 141.0;
  for (auto [name, c] : {std::pair{"Park 2010 Table 1 (helical)", helical},
                         std::pair{"Table 1 as a spur pair", spur}}) {
    c.mesh.application_factor = 5.0;
    c.load.torque_nm = 20000;  // above 100 N/mm: ISO's load factor is 1
    const Geometry g = compute_geometry(c.gear);
    const double iso = iso6336_stiffness(c, g).mesh_stiffness_n_per_m;
    const double energy = energy_method_cycle(c, g).mean_n_per_m();
    rows.compare(fmt::format("{}: energy method's mean stiffness / ISO 6336-1 c_gamma b", name),
                 energy / iso, 1.0, 1.0, 0.3, "",
                 "ISO 6336-1 (Method B), scatter of c' against measurement", "absolute", true);
  }
}

// ---- mathieu_hill ------------------------------------------------------------------------

// Hill's determinant of the damped Mathieu equation x'' + 2 zeta x' + (1 + eps cos(W t)) x = 0
// for solutions of period 2T (multiplier -1): harmonic balance over odd harmonics k of W t / 2,
// truncated at kHillHarmonics, in real form.
constexpr int kHillHarmonics = 40;
double hill_determinant(double zeta, double eps, double omega) {
  using Index = Eigen::Index;
  const Index n = kHillHarmonics;
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  const double w = omega / 2;
  for (Index i = 0; i < n; ++i) {
    const double k = static_cast<double>(2 * i + 1);
    const double diag = 1 - k * k * w * w;
    const Index c = 2 * i, s = 2 * i + 1;  // the rows (and columns) of a_k and b_k
    h(c, c) = diag;
    h(c, s) = 2 * zeta * k * w;
    h(s, s) = diag;
    h(s, c) = -2 * zeta * k * w;
    if (i > 0) {
      h(c, c - 2) += eps / 2;
      h(s, s - 2) += eps / 2;
    }
    if (i + 1 < n) {
      h(c, c + 2) += eps / 2;
      h(s, s + 2) += eps / 2;
    }
    if (i == 0) {  // cos(-theta) = cos(theta), sin(-theta) = -sin(theta)
      h(0, 0) += eps / 2;
      h(1, 1) -= eps / 2;
    }
  }
  return h.determinant();
}

double hill_root(double zeta, double eps, double a, double b) {
  std::uintmax_t iterations = 200;
  const auto r = boost::math::tools::toms748_solve(
      [&](double w) { return hill_determinant(zeta, eps, w); }, a, b,
      [](double x, double y) { return std::abs(x - y) < 1e-14; }, iterations);
  return 0.5 * (r.first + r.second);
}

void mathieu_hill(Rows& rows, bool quick) {
  std::vector<std::pair<double, double>> pairs = {{0.02, 0.5}, {0.0, 0.2}};
  if (!quick) pairs.insert(pairs.end(), {{0.01, 0.2}, {0.05, 0.4}});
  for (const auto& [zeta, eps] : pairs) {
    Case c;
    c.model.form = ModelForm::kNondimensional;
    c.model.zeta = zeta;
    c.model.force_mean = 1.0;
    c.model.force_alternating = 0.0;
    c.model.omega = 2.0;
    c.model.stiffness_harmonics = {{eps, 0.0}};
    StabilityOptions o;
    o.axis.key = "model.omega";
    o.axis.from = 1.5;
    o.axis.to = 2.5;
    o.axis.points = 41;
    const StabilityResult r = stability(c, o);
    std::vector<double> pd;
    for (const auto& b : r.boundaries)
      if (b.type == BifurcationType::kPeriodDoubling) pd.push_back(b.param);
    if (pd.size() != 2)
      throw std::runtime_error(fmt::format("zeta {}, eps {}: {} period-doubling boundaries, not 2",
                                           zeta, eps, pd.size()));
    for (int side = 0; side < 2; ++side)
      rows.compare(fmt::format("zeta {:g}, eps {:g}: principal tongue's {} edge (Omega)", zeta, eps,
                               side == 0 ? "left" : "right"),
                   pd[side], hill_root(zeta, eps, pd[side] - 0.02, pd[side] + 0.02), 1.0, 1e-8, "",
                   "Hill's determinant, 40 odd harmonics", "absolute");
  }
}

// ---- ks_continuation ---------------------------------------------------------------------

struct Settled {
  double amplitude;
  std::int64_t impacts;
};

// (max - min) / 2 of x over the last of `periods` periods of an exact simulation at omega
// from `start` (on the section t = 0) at tolerance 1e-12.
Settled simulate(double omega, ode::State start, int periods) {
  const Case c = kahraman_singh_case(omega);
  const GearPairModel model = build_model(c);
  SolverData sd = c.solver;
  sd.tolerance = 1e-12;
  const Solver solver(model, sd);
  const double T = 2 * kPi / omega;
  start.t = 0;
  start.region = model.classify(model.drive(0), start.q, start.v);
  const auto settled = solver.advance(start, (periods - 1) * T);
  if (!settled.ok()) throw std::runtime_error(settled.message);
  RunReader reader(model, (periods - 1) * T, periods * T, 1.0, true, false);
  const auto r = solver.run(settled.end_state, periods * T, ode::OutputGrid{}, reader);
  if (!r.ok()) throw std::runtime_error(r.message);
  const RunReading x = reader.reading();
  return {0.5 * (x.max_delta_bar - x.min_delta_bar), x.impacts};
}

ode::State section_state(const BranchOrbit& o) { return {0.0, o.state[0], o.state[1], 0.0, 0}; }

void ks_continuation(Rows& rows, bool quick) {
  // The Kahraman-Singh oscillator (zeta 0.05, F_m 0.1, F_a 0.02) continued in Omega.
  ContinuationOptions o;
  o.key = "model.omega";
  o.from = 0.5;
  o.to = 1.5;
  const ContinuationResult r = continuation(kahraman_singh_case(0.5), o);
  if (!r.completed) throw std::runtime_error(r.message);
  if (r.bifurcations.size() != 4)
    throw std::runtime_error(
        fmt::format("{} bifurcations, not 2 grazings and 2 folds", r.bifurcations.size()));
  // The grazings of the linear contact orbit: |H| = F_a / |1 - W^2 + 2 i zeta W| reaches F_m
  // where (1 - u)^2 + 4 zeta^2 u = (F_a / F_m)^2, u = W^2.
  const double zeta = 0.05, ratio = 0.02 / 0.1;
  const double bq = -(2 - 4 * zeta * zeta), cq = 1 - ratio * ratio;
  const double disc = std::sqrt(bq * bq - 4 * cq);
  const std::string closed = "closed form (grazing of the contact orbit)";
  rows.compare("grazing below resonance (Omega)", r.bifurcations[0].param,
               std::sqrt((-bq - disc) / 2), 1.0, 1e-9, "", closed, "absolute");
  rows.compare("grazing above resonance (Omega)", r.bifurcations[3].param,
               std::sqrt((-bq + disc) / 2), 1.0, 1e-9, "", closed, "absolute");
  // The folds: just short of a fold a long simulation from the fold's orbit stays on its
  // branch, just past it jumps to the other (0.107 against 0.18 in amplitude).
  const double d = 2e-4;
  const std::string sims = "long simulations (3000 periods) at the fold +- 2e-4";
  for (const int which : {1, 2}) {
    const Bifurcation& f = r.bifurcations[which];
    const ode::State s = section_state(f.orbit);
    const double stay = which == 1 ? f.param - d : f.param + d;
    const double jump = which == 1 ? f.param + d : f.param - d;
    const Settled a = simulate(stay, s, 3000), b = simulate(jump, s, 3000);
    const double on_branch = 0.5 * (f.orbit.reading.max_delta_bar - f.orbit.reading.min_delta_bar);
    const bool jumps =
        std::abs(a.amplitude - on_branch) < 0.02 && std::abs(b.amplitude - a.amplitude) > 0.05;
    rows.agree(fmt::format("{} fold at Omega = {:.8f}: amplitude short of it / past it",
                           which == 1 ? "upper" : "lower", f.param),
               fmt::format("{:.4f} / {:.4f}", a.amplitude, b.amplitude),
               fmt::format("{:.4f} / the other branch", on_branch), jumps, sims, false);
  }
  // Stable points not near a fold (multipliers below 0.9): a simulation from 1e-3 off the
  // orbit settles to its amplitude in 400 periods.
  int checked = 0;
  const std::size_t stride = quick ? 16 : 8;
  for (std::size_t i = 0; i < r.points.size(); i += stride) {
    const auto& p = r.points[i];
    if (!p.orbit.stable || p.orbit.max_multiplier() > 0.9) continue;
    ode::State s = section_state(p.orbit);
    s.q += 1e-3;
    const Settled x = simulate(p.param, s, 400);
    rows.compare(fmt::format("amplitude at Omega = {:.5f} ({} impacts a period)", p.param,
                             p.orbit.reading.impacts),
                 p.amplitude(), x.amplitude, 1.0, 1e-9, "",
                 "a simulation from 1e-3 off the orbit, 400 periods", "absolute");
    ++checked;
  }
  if (checked == 0) throw std::runtime_error("no stable point to check");
}

// ---- floquet_fd --------------------------------------------------------------------------

void floquet_fd(Rows& rows, bool) {
  // The Kahraman-Singh oscillator at Omega 0.95 rattles on one side (an impact and a
  // separation a period): its monodromy (saltation at both events) against central
  // differences of the period map, steps 1e-6.
  const Case c = kahraman_singh_case(0.95);
  OrbitOptions oo;
  oo.settle_periods = 3;
  const Orbit o = find_orbit(c, oo);
  if (!o.converged) throw std::runtime_error(o.message);
  const GearPairModel model = build_model(c);
  SolverData sd = c.solver;
  sd.tolerance = 1e-12;
  const Solver solver(model, sd);
  const auto map = [&](double q, double v) {
    const ode::State s{0, q, v, 0, model.classify(model.drive(0), q, v)};
    const auto r = solver.advance(s, o.period_s);
    if (!r.ok()) throw std::runtime_error(r.message);
    return std::array<double, 2>{r.end_state.q, r.end_state.v};
  };
  rows.count("impacts a period", o.reading.impacts, 1, "the orbit's regime (one-sided rattle)");
  const double h = 1e-6;
  for (int j = 0; j < 2; ++j) {
    const double dq = j == 0 ? h : 0, dv = j == 1 ? h : 0;
    const auto plus = map(o.state.q + dq, o.state.v + dv);
    const auto minus = map(o.state.q - dq, o.state.v - dv);
    for (int i = 0; i < 2; ++i)
      rows.compare(fmt::format("monodromy entry ({}, {})", i, j), o.monodromy(i, j),
                   (plus[i] - minus[i]) / (2 * h), 1.0, 1e-6, "",
                   "central differences of the period map, step 1e-6", "absolute");
  }
}

// ---- coupled_rigid -----------------------------------------------------------------------

void coupled_rigid(Rows& rows, bool) {
  // The coupled model with bearings 1e6 times stiffer than the mesh reads as the one-degree
  // model: the same impacts and last separation, delta/b within the bearings' compliance
  // (about 1e-6 of b per 1e6 of stiffness ratio; docs/model.md).
  Case one;
  one.solver.duration_s = 0.02;
  one.solver.output_interval_s = 1e-5;
  const RunResult r1 = checked_one_degree_run(one);
  for (const int dof : {3, 12}) {
    Case c = one;
    c.model.form = ModelForm::kCoupled;
    c.model.dof = dof;
    const double k = 1e6 * c.mesh.mean_stiffness_n_per_m;
    c.bearings.radial_stiffness_n_per_m = {k, k};
    c.bearings.axial_stiffness_n_per_m = {k, k};
    c.bearings.tilt_stiffness_n_m_per_rad = {k * 0.022 * 0.022, k * 0.022 * 0.022};
    const CoupledRunResult r = run_coupled(c);
    if (!r.ok()) throw std::runtime_error(r.message);
    const std::string source = "the one-degree model (its rigid limit)";
    const std::string name = fmt::format("dof {}", dof);
    rows.count(name + ": impacts", r.mesh.impacts, r1.reading.impacts, source);
    if (r.mesh.last_separation_s && r1.reading.last_separation_s)
      rows.compare(name + ": last separation", *r.mesh.last_separation_s,
                   *r1.reading.last_separation_s, one.solver.duration_s, 1e-6, "s", source,
                   "over the window");
    double worst = 0;
    std::size_t at = 0;
    const std::size_t n = std::min(r.samples.t_s.size(), r1.samples.size());
    for (std::size_t s = 0; s < n; ++s)
      if (std::abs(r.samples.deflection_bar[s] - r1.samples.delta_bar[s]) > worst) {
        worst = std::abs(r.samples.deflection_bar[s] - r1.samples.delta_bar[s]);
        at = s;
      }
    rows.compare(name + ": delta/b at its worst sample", r.samples.deflection_bar[at],
                 r1.samples.delta_bar[at], 1.0, 4e-6, "", source, "in b");
  }
}

// ---- coupled_modes -----------------------------------------------------------------------

void coupled_modes(Rows& rows, bool) {
  // Equal gears on equal bearings, dof 3 (u, y1, y2), constant stiffness: y1 = y2 leaves the
  // mesh alone, w^2 = k_r / m; y1 = -y2 couples with u, w^2 the roots of w^4 - tr w^2 + det.
  Case c;
  c.model.form = ModelForm::kCoupled;
  c.model.dof = 3;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  const CoupledParameters p = coupled_parameters(c);
  const Geometry g = compute_geometry(c.gear);
  const double cb2 = std::pow(std::cos(g.base_helix_angle_rad), 2);
  const double k = c.mesh.mean_stiffness_n_per_m, meq = g.equivalent_mass_kg;
  const double m = p.mass(p.line[0], p.line[0]);
  const double kr = c.bearings.radial_stiffness_n_per_m[0];
  const double a = k * cb2 / meq, b2 = 2 * k * cb2 / meq, c2 = k * cb2 / m,
               d = (kr + 2 * k * cb2) / m;
  const double tr = a + d, det = a * d - b2 * c2, root = std::sqrt(tr * tr - 4 * det);
  std::vector<double> expected = {std::sqrt((tr - root) / 2), std::sqrt(kr / m),
                                  std::sqrt((tr + root) / 2)};
  std::sort(expected.begin(), expected.end());
  const ModeSet set = modes(CoupledModel(p));
  if (set.modes.size() != 3) throw std::runtime_error("not 3 modes");
  for (std::size_t r = 0; r < 3; ++r)
    rows.relative(fmt::format("mode {} frequency", r + 1), set.modes[r].frequency_hz,
                  expected[r] / (2 * kPi), 1e-10, "Hz", "closed form (symmetric 3-DOF pair)");
}

// ---- te_response -------------------------------------------------------------------------

void te_response(Rows& rows, bool) {
  // Permanent contact, constant stiffness, e = sum a_i cos(w_i t + phi_i): the steady delta =
  // b + F_m / (cb2 k) + sum |D_i| a_i cos(w_i t + phi_i + arg D_i), D = cb2 (k + i c w) /
  // (cb2 k - m w^2 + i cb2 c w), c = 2 zeta sqrt(m k) / cb (the case's damping ratio).
  const Case c = gear_with_transmission_error();
  const RunResult r = checked_run(c);
  const Geometry g = compute_geometry(c.gear);
  const double cb = std::cos(g.base_helix_angle_rad), cb2 = cb * cb, m = g.equivalent_mass_kg;
  const double k = c.mesh.mean_stiffness_n_per_m, b = c.mesh.backlash_um * 1e-6;
  const double damping = 2 * c.mesh.damping_ratio * std::sqrt(m * k) / cb;
  const double wm = 2 * kPi * c.speed.shaft_frequency_hz * c.gear.teeth[0];
  const double mean = b + c.load.torque_nm * per_pinion_torque(g) / (cb2 * k);
  const auto e = [&](double t, bool response) {
    double x = 0;
    for (std::size_t i = 0; i < c.mesh.transmission_error_um.size(); ++i) {
      const double a = c.mesh.transmission_error_um[i].amplitude * 1e-6;
      const double phase = c.mesh.transmission_error_um[i].phase_deg * kPi / 180;
      const double w = static_cast<double>(i + 1) * wm;
      const std::complex<double> d =
          response ? cb2 * std::complex<double>(k, damping * w) /
                         std::complex<double>(cb2 * k - m * w * w, cb2 * damping * w)
                   : 1.0;
      x += std::abs(d) * a * std::cos(w * t + phase + std::arg(d));
    }
    return x;
  };
  double worst = 0, lo = kInf, hi = -kInf, value = 0, reference = 0;
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    const double t = r.samples.t_s[i];
    if (t < 0.8 * c.solver.duration_s) continue;  // the start has decayed (e^-26)
    const double delta = r.samples.delta_bar[i] * b + e(t, false);
    const double closed = mean + e(t, true);
    lo = std::min(lo, delta);
    hi = std::max(hi, delta);
    if (std::abs(delta - closed) >= worst) {
      worst = std::abs(delta - closed);
      value = delta;
      reference = closed;
    }
  }
  rows.compare("delta at its worst sample of the last fifth, over the response's range", value,
               reference, hi - lo, 1e-9, "m", "frequency domain (transfer function per harmonic)",
               "of the range");
  rows.count("impacts", r.reading.impacts, 0, "the frequency domain's contact (never left)");
}

// ---- train_pair --------------------------------------------------------------------------

// Park 2010's helical pair (Table 1) written as a train of two gears, with the stiffness
// harmonics, torques and speed of the one-degree case beside it.
constexpr const char* kPairTrain = R"(
[model]
form = "train"
[train]
reference_speed_hz = 100
[[train.body]]
name = "pinion"
teeth = 56
normal_module_mm = 2.5
helix_angle_deg = 20
face_width_mm = 20
[[train.body]]
name = "wheel"
teeth = 56
normal_module_mm = 2.5
helix_angle_deg = 20
face_width_mm = 20
[[train.mesh]]
driving = "pinion"
driven = "wheel"
backlash_um = 100
mean_stiffness_n_per_m = 2.34e8
stiffness_harmonics = [[0.1, 20], [0.03, -40]]
damping_ratio = 0.02
[[train.torque]]
body = "pinion"
mean_nm = 49.5
harmonics = [[12.375, 1, 0]]
[[train.torque]]
body = "wheel"
mean_nm = -49.5
harmonics = [[12.375, 1, 180]]
[solver]
duration_s = 0.02
tolerance = 1e-13
output_interval_s = 2e-5
)";

void train_pair(Rows& rows, bool) {
  const Case pair = park2010_pair_case();
  const RunResult one = checked_one_degree_run(pair);
  const TrainRunResult train = run_train(park2010_pair_as_train());
  if (!train.ok()) throw std::runtime_error(train.message);
  if (train.samples.t_s.size() != one.samples.size())
    throw std::runtime_error("the runs have different samples");
  const std::string source = "the one-degree model of the same pair";
  const TrainMeshReading& m = train.meshes.at(0);
  rows.count("impacts", m.impacts, one.reading.impacts, source);
  rows.count("back-side impacts", m.backside_impacts, one.reading.backside_impacts, source);
  double worst = 0;
  std::size_t at = 0;
  for (std::size_t i = 0; i < one.samples.size(); ++i)
    if (std::abs(train.samples.deflection_bar[i][0] - one.samples.delta_bar[i]) > worst) {
      worst = std::abs(train.samples.deflection_bar[i][0] - one.samples.delta_bar[i]);
      at = i;
    }
  rows.compare("delta/b at its worst sample", train.samples.deflection_bar[at][0],
               one.samples.delta_bar[at], 1.0, kDefaultAccuracyB, "", source, "in b");
  // The static mesh force: the pinion's torque over the base radius, along the normal line of
  // action, F = T1 / (R_b1 cos(beta_b)).
  const Geometry g = compute_geometry(pair.gear);
  if (!m.static_force_n) throw std::runtime_error("the train has no static state");
  rows.relative("static mesh force", *m.static_force_n,
                pair.load.torque_nm / (g.base_radius_m[0] * std::cos(g.base_helix_angle_rad)),
                1e-12, "N", "closed form T1 / (R_b1 cos(beta_b))");
}

// ---- pair_forms ----------------------------------------------------------------------------

// Each sample's mesh deflection (d - e)/b of a train's first mesh against another model's, as
// a row at its worst sample.
void worst_sample(Rows& rows, const std::string& what, const TrainRunResult& train,
                  const std::vector<double>& reference, const std::string& source) {
  if (train.samples.t_s.size() != reference.size())
    throw std::runtime_error(what + ": the runs have different samples");
  std::size_t at = 0;
  for (std::size_t i = 0; i < reference.size(); ++i)
    if (std::abs(train.samples.deflection_bar[i][0] - reference[i]) >
        std::abs(train.samples.deflection_bar[at][0] - reference[at]))
      at = i;
  rows.compare(what + ": (d - e)/b at its worst sample", train.samples.deflection_bar[at][0],
               reference[at], 1.0, kDefaultAccuracyB, "", source, "in b");
}

void pair_forms(Rows& rows, bool quick) {
  // The paper's pair with a two-harmonic transmission error and its tension clipped.
  Case pair = park2010_pair_case();
  pair.mesh.transmission_error_um = {{0.5, 30.0}, {0.2, -60.0}};
  pair.mesh.tension = TensionRule::kClip;
  pair.mesh.damping_ratio = 0.15;
  const RunResult one = checked_one_degree_run(pair);
  const TrainRunResult train = run_train(train_form_of(pair));
  if (!train.ok()) throw std::runtime_error(train.message);
  const std::string source = "the one-degree model of the same pair";
  rows.count("pair: impacts", train.meshes.at(0).impacts, one.reading.impacts, source);
  worst_sample(rows, "pair", train, one.samples.delta_bar, source);
  // The same pair on bearings and shafts, coupled with 3, 6 and 12 degrees of freedom.
  for (const int dof : quick ? std::vector<int>{12} : std::vector<int>{3, 6, 12}) {
    Case c = pair;
    c.mesh.tension = TensionRule::kAllow;
    c.mesh.damping_ratio = 0.02;
    c.model.form = ModelForm::kCoupled;
    c.model.dof = dof;
    c.shafts.end_inertia_kg_m2 = {0.004, 0.009};
    const CoupledRunResult coupled = run_coupled(c);
    if (!coupled.ok()) throw std::runtime_error(coupled.message);
    const TrainRunResult x = run_train(train_form_of(c));
    if (!x.ok()) throw std::runtime_error(x.message);
    const std::string what = fmt::format("coupled dof {}", dof);
    const std::string from = fmt::format("the coupled model with dof {}", dof);
    rows.count(what + ": impacts", x.meshes.at(0).impacts, coupled.mesh.impacts, from);
    worst_sample(rows, what, x, coupled.samples.deflection_bar, from);
  }
  // The non-dimensional oscillator with a varying stiffness and a transmission error.
  Case nd;
  nd.model.form = ModelForm::kNondimensional;
  nd.model.force_alternating = 0.02;
  nd.model.omega = 1.3;
  nd.model.stiffness_harmonics = {{0.2, 10.0}, {0.05, 0.0}};
  nd.model.transmission_error = {{0.1, 45.0}};
  nd.solver.duration_s = 60;
  const RunResult oscillator = checked_one_degree_run(nd);
  const TrainRunResult as_train = run_train(train_form_of(nd));
  if (!as_train.ok()) throw std::runtime_error(as_train.message);
  const std::string of = "the non-dimensional model";
  rows.count("non-dimensional: impacts", as_train.meshes.at(0).impacts, oscillator.reading.impacts,
             of);
  worst_sample(rows, "non-dimensional", as_train, oscillator.samples.delta_bar, of);
}

// ---- train_loose_gear --------------------------------------------------------------------

// A loose gear on its bearing, meshed with an input gear whose speed fluctuates at the firing
// order (the shipped cases/loose_gear_rattle.toml at 750 rpm).
constexpr const char* kLooseGear = R"(
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
name = "loose"
teeth = 40
normal_module_mm = 2.5
face_width_mm = 15
bore_diameter_mm = 45
[[train.mesh]]
name = "rattle"
driving = "input"
driven = "loose"
backlash_um = 50
mean_stiffness_n_per_m = 3e8
damping_ratio = 0.05
[[train.speed]]
body = "input"
acceleration_harmonics = [[240, 2, 0]]
[[train.drag]]
body = "loose"
constant_nm = 0.2
[solver]
duration_s = 0.4
initial = "static"
)";

void train_loose_gear(Rows& rows, bool) {
  // The loose gear stays on its drive flank while the drag can decelerate it as fast as the
  // input does: J (R_in / R_loose) a <= T_drag, so rattle starts at a* = T_drag R_loose /
  // (J R_in). Within the mesh compliance's effect (0.05 %), 2 % below a* nothing separates and
  // 2 % above it the gear rattles.
  Case c = parse_case(kLooseGear, "a loose gear");
  const double j_loose = assembled_train(c).mass()(1, 1);
  const double onset = 0.2 / (j_loose * 30.0 / 40.0);
  const std::string source = "closed form a* = T_drag R_loose / (J R_in)";
  for (const double f : {0.98, 1.02}) {
    set_case_value(
        c, {"train.speed[0].acceleration_harmonics", fmt::format("[[{}, 2, 0]]", f * onset)});
    const TrainRunResult r = run_train(c);
    if (!r.ok()) throw std::runtime_error(r.message);
    const std::int64_t separations = r.meshes.at(0).separations;
    rows.agree(fmt::format("separations in 0.4 s at {:g} a* ({:.2f} rad/s^2)", f, f * onset),
               std::to_string(separations), f < 1 ? "none" : "some", (separations > 0) == (f > 1),
               source, false);
  }
}

// ---- planetary_lin_parker ----------------------------------------------------------------

// Lin and Parker's (1999) planetary set, Table 1, as cases/lin_parker_1999.toml writes it (a
// [[train.planetary]] preset): each inertia their I / r^2 times this gear's r_b^2, the carrier's
// times its pin radius squared (the 97.5 mm its teeth mesh at; the frequencies depend on r only
// through I / r^2), the ring held by 1e9 N/m on u_r = r_b theta_r.
constexpr const char* kLinParker = R"(
[model]
form = "train"
[train]
reference = "sun"
reference_speed_hz = 10
planets = 3
[[train.planetary]]
sun_teeth = 85
planet_teeth = 110
ring_teeth = 305
normal_module_mm = 1
normal_pressure_angle_deg = 24.6
sun_inertia_kg_m2 = 0.000582366
sun_mass_kg = 0.4
planet_inertia_kg_m2 = 0.00152549
planet_mass_kg = 0.66
ring_inertia_kg_m2 = 0.0576785
ring_mass_kg = 2.35
carrier_inertia_kg_m2 = 0.0597943
carrier_mass_kg = 5.43
mesh_stiffness_n_per_m = 5e8
bearing_stiffness_n_per_m = 1e8
held = "ring"
support_n_m_per_rad = 1.92262e7
)";

// Table 2: the distinct natural frequencies (Hz) for N = 3, 4, 5 planets, with each one's type
// (r rotational, t translational, p planet); multiplicities 1, 2 and N - 3.
struct TableFrequency {
  double hz;
  char type;
};
const std::vector<TableFrequency>& lin_parker_table2(int planets) {
  static const std::vector<TableFrequency> three = {
      {0, 'r'},      {743.2, 't'},  {1102.4, 't'}, {1475.7, 'r'}, {1896.0, 't'}, {1930.3, 'r'},
      {2276.4, 't'}, {2658.3, 'r'}, {6986.3, 't'}, {7462.8, 'r'}, {9647.9, 't'}, {11775.3, 'r'}};
  static const std::vector<TableFrequency> four = {
      {0, 'r'},      {727.0, 't'},  {1091.0, 't'}, {1536.6, 'r'},  {1808.2, 'p'},
      {1892.8, 't'}, {1970.6, 'r'}, {2342.5, 't'}, {2625.7, 'r'},  {5963.8, 'p'},
      {6981.7, 'p'}, {7189.9, 't'}, {7773.6, 'r'}, {10437.6, 't'}, {13071.1, 'r'}};
  static const std::vector<TableFrequency> five = {
      {0, 'r'},      {710.0, 't'},  {1072.0, 't'}, {1567.4, 'r'},  {1808.2, 'p'},
      {1888.1, 't'}, {2006.1, 'r'}, {2425.3, 't'}, {2614.8, 'r'},  {5963.8, 'p'},
      {6981.7, 'p'}, {7382.4, 't'}, {8065.4, 'r'}, {11172.3, 't'}, {14253.1, 'r'}};
  return planets == 3 ? three : planets == 4 ? four : five;
}

void planetary_lin_parker(Rows& rows, bool quick) {
  // Every frequency within 0.05 % (the paper's N = 4 column is printed up to 0.3 Hz off its own
  // computation), its multiplicity and its type read from the shape.
  const std::string source = "Lin and Parker (1999), Table 2";
  for (const int planets : quick ? std::vector<int>{3} : std::vector<int>{3, 4, 5}) {
    Case c = parse_case(kLinParker, "Lin and Parker's set");
    set_case_value(c, {"train.planets", std::to_string(planets)});
    const std::vector<train::TrainMode> modes = train::modes(assembled_train(c));
    std::vector<const train::TrainMode*> distinct;
    for (const train::TrainMode& m : modes)
      if (distinct.empty() || m.frequency_hz - distinct.back()->frequency_hz >
                                  train::kSameModeFrequency * m.frequency_hz)
        distinct.push_back(&m);
    const std::vector<TableFrequency>& table = lin_parker_table2(planets);
    if (distinct.size() != table.size())
      throw std::runtime_error(fmt::format("N = {}: {} distinct frequencies, the table has {}",
                                           planets, distinct.size(), table.size()));
    for (std::size_t i = 0; i < table.size(); ++i) {
      const train::TrainMode& m = *distinct[i];
      const std::string type = table[i].type == 'r'   ? "rotational"
                               : table[i].type == 't' ? "translational"
                                                      : "planet";
      const int multiplicity = table[i].type == 'r' ? 1 : table[i].type == 't' ? 2 : planets - 3;
      const std::string what = fmt::format("N = {}, {} mode", planets, type);
      if (table[i].hz == 0)
        rows.compare(what + " (rigid)", m.frequency_hz, 0.0, 1.0, 0.0, "Hz", source, "absolute",
                     true);
      else
        rows.relative(what, m.frequency_hz, table[i].hz, 5e-4, "Hz", source, true);
      rows.agree(fmt::format("{} at {:g} Hz: type and multiplicity", what, table[i].hz),
                 fmt::format("{} x{}", m.type, m.multiplicity),
                 fmt::format("{} x{}", type, multiplicity),
                 m.type == type && m.multiplicity == multiplicity, source, true);
    }
  }
}

// ---- the table of checks -----------------------------------------------------------------

struct CheckEntry {
  ValidationCheck info;
  void (*run)(Rows&, bool quick);
};

const std::vector<CheckEntry>& entries() {
  static const std::vector<CheckEntry> e = {
      {{"free_flight", "Free flight to the first impact", true}, free_flight},
      {{"contact_response", "Linear forced response in permanent contact", true}, contact_response},
      {{"contact_orbit", "Periodic orbit and multipliers in permanent contact", true},
       contact_orbit},
      {{"newmark_order", "Newmark's order of convergence through impacts", true}, newmark_order},
      {{"paper_dopri5", "The paper's cases against an independent integrator", true}, paper_dopri5},
      {{"paper_findings", "The paper's findings and the windows they hold over", true},
       paper_findings},
      {{"iso6336_example", "ISO 6336-1 stiffness: the technical report's example", true},
       iso6336_example},
      {{"energy_vs_iso", "Energy method against ISO 6336-1", true}, energy_vs_iso},
      {{"mathieu_hill", "Mathieu tongue boundaries against Hill's determinant", true},
       mathieu_hill},
      {{"ks_continuation", "Kahraman-Singh branch: grazings, folds, stable amplitudes", true},
       ks_continuation},
      {{"floquet_fd", "Floquet multipliers through impacts against finite differences", true},
       floquet_fd},
      {{"coupled_rigid", "Coupled model's rigid limit is the one-degree model", true},
       coupled_rigid},
      {{"coupled_modes", "Coupled model's modes against their closed forms", true}, coupled_modes},
      {{"te_response", "Transmission-error response against the frequency domain", true},
       te_response},
      {{"train_pair", "A two-gear train is the gear pair", true}, train_pair},
      {{"pair_forms", "The pair's forms written as trains of elements run as themselves", true},
       pair_forms},
      {{"train_loose_gear", "A loose gear rattles where the drag can no longer hold it", true},
       train_loose_gear},
      {{"planetary_lin_parker", "A planetary set's natural frequencies: Lin and Parker's table",
        true},
       planetary_lin_parker},
  };
  return e;
}

}  // namespace

Case iso_tr_6336_30_example_1() {
  // m_n = 8 mm, alpha_n = 20 deg, beta = 15.8 deg, z = 17/103, b = 100 mm, x = 0.145/0,
  // a = 500 mm, basic rack dedendum 1.4 m_n, steel, T1 = 9 kN m.
  Case c;
  GearData& g = c.gear;
  g.normal_module_mm = 8;
  g.normal_pressure_angle_deg = 20;
  g.helix_angle_deg = 15.8;
  g.teeth = {17, 103};
  g.face_width_mm = 100;
  g.profile_shift = {0.145, 0.0};
  g.center_distance_mm = 500;
  g.basic_rack_dedendum = {1.4, 1.4};
  g.outside_diameter_mm = {160, 872};  // a placeholder for the probe of the standard tips
  const Geometry probe = compute_geometry(g);
  g.outside_diameter_mm = {probe.expected_outside_diameter_m[0] * 1e3,
                           probe.expected_outside_diameter_m[1] * 1e3};
  c.load.torque_nm = 9000;
  return c;
}

Case gear_with_transmission_error() {
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.load.torque_nm = 100;
  c.load.fluctuation_ratio = 0;
  c.speed.shaft_frequency_hz = 33;
  c.mesh.transmission_error_um = {{1.0, 0.0}, {0.3, 40.0}};
  c.solver.initial = InitialCondition::kStatic;
  c.solver.duration_s = 0.08;
  c.solver.tolerance = 1e-12;
  c.solver.output_interval_s = 2e-5;
  return c;
}

Case kahraman_singh_case(double omega) {
  Case c;
  c.model.form = ModelForm::kNondimensional;
  c.model.zeta = 0.05;
  c.model.force_mean = 0.1;
  c.model.force_alternating = 0.02;
  c.model.omega = omega;
  return c;
}

Case park2010_pair_case() {
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.mesh.stiffness_harmonics = {{0.1, 20.0}, {0.03, -40.0}};
  c.speed.shaft_frequency_hz = 100;
  c.solver.duration_s = 0.02;
  c.solver.tolerance = 1e-13;
  c.solver.output_interval_s = 2e-5;
  return c;
}

Case park2010_pair_as_train() { return parse_case(kPairTrain, "the paper's pair as a train"); }

const std::vector<ValidationCheck>& validation_checks() {
  static const std::vector<ValidationCheck> checks = [] {
    std::vector<ValidationCheck> out;
    for (const CheckEntry& e : entries()) out.push_back(e.info);
    return out;
  }();
  return checks;
}

std::size_t ValidationResult::failures() const {
  return static_cast<std::size_t>(
      std::count_if(rows.begin(), rows.end(), [](const ValidationRow& r) { return !r.passed; }));
}

ValidationResult validate(const ValidationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  ValidationResult result;
  result.quick = options.quick;
  std::vector<const CheckEntry*> chosen;
  for (const CheckEntry& e : entries())
    if (!options.quick || e.info.quick) chosen.push_back(&e);
  result.checks_total = chosen.size();
  for (const CheckEntry* e : chosen) {
    if (options.progress && !options.progress(result.checks_run, chosen.size(), e->info.id)) {
      result.cancelled = true;
      break;
    }
    Rows rows(result.rows, e->info.id);
    try {
      e->run(rows, options.quick);
    } catch (const std::exception& x) {
      rows.failed(x.what());
    }
    ++result.checks_run;
  }
  if (options.progress && !result.cancelled) options.progress(chosen.size(), chosen.size(), "");
  result.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace geardyn
