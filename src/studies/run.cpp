#include "geardyn/run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "geardyn/case_keys.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/transmission_error.hpp"

namespace geardyn {
namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
}

double fastest_period_s(const GearPairParameters& p) {
  double k_max = p.stiffness_n_per_m.offset;
  for (const Harmonic& h : p.stiffness_n_per_m.terms) k_max += std::abs(h.amplitude);
  const double cb2 = p.cos_base_helix * p.cos_base_helix;
  double w = std::sqrt(cb2 * k_max / p.equivalent_mass_kg);
  w = std::max(w, p.stiffness_n_per_m.max_angular_frequency_rad_s());
  w = std::max(w, p.force_n.max_angular_frequency_rad_s());
  return kTwoPi / w;
}

double automatic_time_step_s(const GearPairParameters& p) {
  return fastest_period_s(p) / kStepsPerFastestPeriod;
}

namespace {

// The bounds of kMaxSamples and the others (run.hpp), in floating point before any count is
// made an integer.
// What sets a case's fastest time scale (fastest_period_s), and the keys it comes from, so that
// a window too long for it names the input that made it so.
struct FastestScale {
  std::string what;
  std::vector<std::string> keys;
};

FastestScale fastest_scale(const Case& c, const GearPairParameters& p) {
  const bool nd = c.model.form == ModelForm::kNondimensional;
  double k_max = p.stiffness_n_per_m.offset;
  for (const Harmonic& h : p.stiffness_n_per_m.terms) k_max += std::abs(h.amplitude);
  const double contact =
      std::sqrt(p.cos_base_helix * p.cos_base_helix * k_max / p.equivalent_mass_kg);
  const double stiffness = p.stiffness_n_per_m.max_angular_frequency_rad_s();
  const double force = p.force_n.max_angular_frequency_rad_s();
  if (force >= contact && force >= stiffness)
    return {"the torque's fluctuation",
            nd ? std::vector<std::string>{"model.omega"}
               : std::vector<std::string>{"load.fluctuation_order", "load.load_fluctuation_order",
                                          "speed.shaft_frequency_hz"}};
  if (stiffness >= contact)
    return {"the mesh stiffness's highest harmonic",
            nd ? std::vector<std::string>{"model.omega", "model.stiffness_harmonics"}
               : std::vector<std::string>{"speed.shaft_frequency_hz", "gear.teeth",
                                          "mesh.harmonics_kept", "mesh.stiffness_harmonics"}};
  return {"the contact oscillation",
          nd ? std::vector<std::string>{}
             : std::vector<std::string>{"mesh.mean_stiffness_n_per_m", "gear.inertia_kg_m2"}};
}

void check_work(const Case& c, const GearPairParameters& p, const Derived& d, double window_s) {
  const double samples = window_s / d.output_interval_s + 1;
  if (!(samples <= kMaxSamples))
    throw InputError(fmt::format(
        "solver.output_interval_s = {:.6g}: {:.3g} samples over solver.duration_s = {:.6g}; at "
        "most {:.0e} (choose a larger interval, or 0 for the automatic one)",
        d.output_interval_s, samples, window_s, kMaxSamples));
  const double periods = window_s / d.fastest_period_s;
  if (!(periods <= kMaxFastestPeriods)) {
    // Named by the input that made the window too long: a given key of what sets the fastest
    // time scale (a torque order of 1e300), else the window itself.
    const FastestScale scale = fastest_scale(c, p);
    std::string lead = fmt::format("solver.duration_s = {:.6g}", window_s);
    for (const std::string& key : scale.keys)
      if (const auto given = c.origins.find(key); given != c.origins.end()) {
        lead = fmt::format("{} = {} ({})", key, find_case_key(key)->value_text(c), given->second);
        break;
      }
    throw InputError(with_origins(
        c,
        fmt::format("{}: {} sets the case's fastest time scale ({:.3g} s), and "
                    "solver.duration_s = {:.6g} holds {:.3g} of its periods; at most {:.0e}",
                    lead, scale.what, d.fastest_period_s, window_s, periods, kMaxFastestPeriods)));
  }
  if (c.solver.method != Method::kNewmark) return;
  const double largest = d.fastest_period_s / kMinStepsPerFastestPeriod;
  if (c.solver.time_step_s > largest)
    throw InputError(fmt::format(
        "solver.time_step_s = {:.6g}: does not resolve the case's fastest time scale ({:.3g} "
        "s); at most {:.3g} s ({:g} steps a period), or 0 for the automatic step",
        c.solver.time_step_s, d.fastest_period_s, largest, kMinStepsPerFastestPeriod));
  const double step =
      c.solver.time_step_s > 0 ? c.solver.time_step_s : d.fastest_period_s / kStepsPerFastestPeriod;
  if (!(window_s / step <= kMaxNewmarkSteps))
    throw InputError(fmt::format(
        "solver.time_step_s = {:.6g}: {:.3g} Newmark steps over solver.duration_s = {:.6g}; at "
        "most {:.0e}",
        step, window_s / step, window_s, kMaxNewmarkSteps));
}

}  // namespace

// A reading that is not finite (an overflow, a denormal backlash) is a numerical failure, never
// "completed".
void refuse_non_finite(const RunReading& x, ode::IntegrationSummary& s) {
  const std::pair<const char*, double> values[] = {
      {"max_force_bar", x.max_force_bar},
      {"min_force_bar", x.min_force_bar},
      {"mean_force_bar", x.mean_force_bar},
      {"rms_force_bar", x.rms_force_bar},
      {"max_delta_bar", x.max_delta_bar},
      {"min_delta_bar", x.min_delta_bar},
      {"mean_delta_bar", x.mean_delta_bar},
      {"rms_delta_bar", x.rms_delta_bar},
      {"max_impact_velocity_m_s", x.max_impact_velocity_m_s}};
  for (const auto& [name, value] : values)
    if (!std::isfinite(value)) {
      s.termination = ode::Termination::kDiverged;
      s.message =
          fmt::format("the reading {} is not finite ({}): non-finite readings", name, value);
      return;
    }
}

void compute_spectra(RunResult& r) {
  const Timeseries& ts = r.samples;
  std::size_t first = 0;
  while (first < ts.size() && ts.t_s[first] < r.steady_start_s) ++first;
  const auto tail = [&](const std::vector<double>& x) {
    return std::vector<double>(x.begin() + static_cast<std::ptrdiff_t>(first), x.end());
  };
  r.force_spectrum = amplitude_spectrum(tail(ts.force_bar), r.derived.output_interval_s);
  r.delta_spectrum = amplitude_spectrum(tail(ts.delta_bar), r.derived.output_interval_s);
  r.force_peaks = dominant_peaks(r.force_spectrum, kReportedPeaks);
  r.delta_peaks = dominant_peaks(r.delta_spectrum, kReportedPeaks);
}

double checked_output_interval_s(const Case& c, double fastest_period_s, const char* what) {
  const double t1 = c.solver.duration_s;
  const double interval =
      c.solver.output_interval_s > 0
          ? c.solver.output_interval_s
          : std::max(t1 / kMaxAutomaticSamples,
                     std::min(t1 / kAutomaticSamples, fastest_period_s / kSamplesPerFastestPeriod));
  const double samples = t1 / interval + 1;
  if (!(samples <= kMaxSamples))
    throw InputError(
        with_origins(c, fmt::format("solver.output_interval_s = {:.6g}: {:.3g} samples over "
                                    "solver.duration_s = {:.6g}; at most {:.0e}",
                                    interval, samples, t1, kMaxSamples)));
  if (!(t1 / fastest_period_s <= kMaxFastestPeriods))
    throw InputError(with_origins(
        c, fmt::format("solver.duration_s = {:.6g}: {:.3g} periods of the {}'s fastest time "
                       "scale ({:.3g} s); at most {:.0e}",
                       t1, t1 / fastest_period_s, what, fastest_period_s, kMaxFastestPeriods)));
  return interval;
}

GearPairModel begin_pair_run(const Case& c, const MeshStiffness* stiffness, RunResult& result) {
  result.input = c;
  GearPairModel model = build_model(c, &result.geometry, stiffness);
  const GearPairParameters& p = model.parameters();
  const Geometry& g = result.geometry;
  Derived& d = result.derived;
  d.m_eq_kg = p.equivalent_mass_kg;
  d.natural_frequency_hz = p.natural_angular_frequency_rad_s() / kTwoPi;
  d.damping_n_s_per_m = p.damping_n_s_per_m;
  d.mean_force_n = p.mean_force_n();
  const double cb2 = p.cos_base_helix * p.cos_base_helix;
  d.static_delta_bar = 1.0 + p.mean_force_n() / (p.backlash_m * p.mean_stiffness_n_per_m() * cb2);
  d.mesh_frequency_hz =
      c.model.form == ModelForm::kNondimensional ? c.model.omega / kTwoPi : mesh_frequency_hz(c);
  d.base_helix_angle_deg = g.base_helix_angle_rad * 180.0 / std::numbers::pi;
  d.working_pressure_angle_deg = g.working_pressure_angle_rad * 180.0 / std::numbers::pi;
  d.transverse_contact_ratio = g.transverse_contact_ratio;
  d.overlap_ratio = g.overlap_ratio;
  d.fastest_period_s = fastest_period_s(p);
  const double te_unit_m = c.model.form == ModelForm::kNondimensional ? 1.0 : 1e-6;
  d.transmission_error_mean_um = p.transmission_error_m.offset / te_unit_m;
  for (const Harmonic& h : p.transmission_error_m.terms)
    d.transmission_error_um.push_back(
        {h.amplitude / te_unit_m, h.phase_rad * 180.0 / std::numbers::pi});
  const double t1 = c.solver.duration_s;
  d.output_interval_s = c.solver.output_interval_s > 0
                            ? c.solver.output_interval_s
                            : std::max(t1 / kMaxAutomaticSamples,
                                       std::min(t1 / kAutomaticSamples,
                                                d.fastest_period_s / kSamplesPerFastestPeriod));
  check_work(c, p, d, t1);
  return model;
}

namespace {

// The pair's reading of its mesh from the train's: F over b k_m, d - e over b.
RunReading pair_reading(const TrainMeshPart& x, double backlash_m, double force_scale_n,
                        const std::optional<double>& dynamic_factor) {
  RunReading r;
  static_cast<ContactCounts&>(r) = x;
  r.max_impact_velocity_m_s = x.max_impact_velocity_m_s;
  r.max_force_bar = x.max_force_n / force_scale_n;
  r.min_force_bar = x.min_force_n / force_scale_n;
  r.mean_force_bar = x.mean_force_n / force_scale_n;
  r.rms_force_bar = x.rms_force_n / force_scale_n;
  r.max_delta_bar = x.max_deflection_m / backlash_m;
  r.min_delta_bar = x.min_deflection_m / backlash_m;
  r.mean_delta_bar = x.mean_deflection_m / backlash_m;
  r.rms_delta_bar = x.rms_deflection_m / backlash_m;
  r.dynamic_factor = dynamic_factor;
  return r;
}

}  // namespace

RunResult run(const Case& c, const RunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  RunResult result;
  // The mesh stiffness computed once, for the model's derived quantities and for its train.
  std::optional<MeshStiffness> own;
  const MeshStiffness* stiffness = options.stiffness;
  if (!stiffness && c.model.form == ModelForm::kGearPair)
    stiffness = &own.emplace(case_stiffness(c));
  begin_pair_run(c, stiffness, result);
  const double t1 = c.solver.duration_s;

  // The pair's own output interval (its automatic one is the one-degree model's).
  Case as_train = c;
  as_train.solver.output_interval_s = result.derived.output_interval_s;
  TrainRunOptions o;
  o.progress = options.progress;
  o.keep_samples = options.keep_samples;
  o.keep_states = false;  // read per mesh: no body's angle is written
  o.read_peaks = false;   // compute_spectra reads them in the pair's units
  o.stiffness = stiffness;
  TrainRunResult x = run_train(as_train, o);

  ode::IntegrationSummary& sum = result.integration;
  sum.termination = x.termination;
  sum.message = x.message;
  sum.steps = x.cells;
  sum.transitions = x.events;
  sum.unsplit_steps = x.unsplit_steps;
  sum.end_time_s = x.ok() || x.samples.t_s.empty() ? t1 : x.samples.t_s.back();
  result.derived.time_step_s = x.time_step_s;

  if (x.meshes.size() != 1) throw std::logic_error("run: a pair's train has one mesh");
  const TrainMeshReading& m = x.meshes.front();
  const double b = m.backlash_m, force_scale = m.backlash_m * m.mean_stiffness_n_per_m;
  result.reading = pair_reading(m, b, force_scale, m.dynamic_factor_with_startup);
  if (sum.ok()) refuse_non_finite(result.reading, sum);
  if (options.keep_events)
    for (const TrainContactEvent& e : x.contact_events)
      if (e.part == 0) result.events.push_back({e.t_s, e.kind, e.velocity_m_s});
  if (options.keep_samples) {
    // The train's one mesh makes each row one value wide: its columns are moved, not copied,
    // so that a run holds its samples once.
    TrainSamples& s = x.samples;
    Timeseries& ts = result.samples;
    ts.t_s = std::move(s.t_s);
    ts.delta_bar = s.deflection_bar.release();
    ts.velocity_m_s = s.deflection_rate_m_s.release();
    ts.force_bar = s.force_n.release();
    for (double& f : ts.force_bar) f /= force_scale;
    ts.contact = s.contact.release();
  }
  if (sum.ok()) {
    static_cast<SteadyStart&>(result.steady) = x.steady;
    result.steady.reading = pair_reading(m.steady, b, force_scale, m.dynamic_factor);
  }
  result.steady_start_s = sum.ok() ? result.steady.from_s : t1 - kSteadyFraction * t1;
  if (options.keep_samples) compute_spectra(result);
  result.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace geardyn
