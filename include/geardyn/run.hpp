// geardyn: one run, the whole pipeline from a case to its reading.
//
// case -> geometry -> mesh stiffness -> model -> integrator -> analysis.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/analysis.hpp"
#include "geardyn/case.hpp"
#include "geardyn/case_model.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/geometry.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/model.hpp"
#include "geardyn/spectrum.hpp"
#include "geardyn/steady.hpp"
#include "geardyn/stiffness.hpp"

namespace geardyn {

// Points per period of the fastest time scale of a case for the automatic Newmark step. The
// convergence study in docs/numerics.md shows the readings converged to ~1e-4 at this value.
constexpr double kStepsPerFastestPeriod = 200.0;
// Automatic output interval: this many samples over the window, or more where needed to put
// the fastest period's frequency below the Nyquist frequency (kSamplesPerFastestPeriod), but
// never more than kMaxAutomaticSamples.
constexpr double kAutomaticSamples = 5000.0;
constexpr double kSamplesPerFastestPeriod = 4.0;
constexpr double kMaxAutomaticSamples = 200000.0;
// Work bounds of a run, checked before it starts (an InputError naming the key, its value and
// the bound): samples kept, periods of the fastest time scale in the window, Newmark steps, and
// the Newmark step against the fastest time scale (a step that cannot resolve it reads
// nonsense as "completed").
constexpr double kMaxSamples = 5e6;         // about 200 MB of samples, 400 MB of CSV
constexpr double kMaxFastestPeriods = 1e8;  // e.g. 4e4 s of the Table 1 pair
constexpr double kMaxNewmarkSteps = 1e10;   // minutes at the Newmark rate of this machine
constexpr double kMinStepsPerFastestPeriod = 10.0;
// Dominant frequencies reported per signal.
constexpr std::size_t kReportedPeaks = 5;

// Quantities derived from the case that a reader of the run wants beside it (summary.json).
struct Derived {
  double m_eq_kg = 0;
  double natural_frequency_hz = 0;  // linearised contact, sqrt(cos^2 beta_b k_m / m_eq) / 2 pi
  double damping_n_s_per_m = 0;
  double mean_force_n = 0;       // F_m
  double static_delta_bar = 0;   // 1 + F_m / (b k_m cos^2 beta_b)
  double mesh_frequency_hz = 0;  // z1 f_1
  double base_helix_angle_deg = 0;
  double working_pressure_angle_deg = 0;
  double transverse_contact_ratio = 0;
  double overlap_ratio = 0;
  double fastest_period_s = 0;  // the shortest time scale of the case
  double time_step_s = 0;       // the Newmark step used (0 for the other methods)
  double output_interval_s = 0;
  // The static transmission error the run used, in um (units of b in the non-dimensional
  // form): its mean, and harmonic i - 1 at i times the mesh frequency; empty without one.
  double transmission_error_mean_um = 0;
  std::vector<ErrorHarmonic> transmission_error_um;
};

struct RunOptions {
  bool keep_samples = true;
  bool keep_events = true;
  // Called now and then with the fraction of the window done; returning false cancels.
  std::function<bool(double)> progress;
  // A mesh stiffness computed once for runs whose cases differ only in keys that leave it
  // alone (shared_stiffness): a study's samples. Null: the case's own.
  const MeshStiffness* stiffness = nullptr;
};

// The readings over the steady part of a run, [from_s, t1]: the start-up transient (from rest
// mid-backlash, or from static contact) left out.
// Where it starts and why (the distance in b and b w_n), and its reading.
struct SteadyPart : SteadyStart {
  RunReading reading;  // its regime: separated anywhere in the part or not
};

struct RunResult {
  Case input;
  Geometry geometry;
  Derived derived;
  ode::IntegrationSummary integration;
  RunReading reading;
  std::vector<ContactEvent> events;
  Timeseries samples;
  SteadyPart steady;
  // Spectra of F_bar and delta_bar over the steady part (t >= steady_start_s = steady.from_s)
  // of the samples.
  double steady_start_s = 0;
  Spectrum force_spectrum, delta_spectrum;
  std::vector<SpectralPeak> force_peaks, delta_peaks;
  double wall_time_s = 0;
};

// The engine's series truncation for solver.tolerance: this fraction of it (the engine's error
// grows with the number of cells and events; the default 1e-10 then holds delta/b to ~1e-12).
constexpr double kExactToleranceFraction = 1e-4;

// The shortest time scale of a model: the linearised contact period at the largest stiffness,
// the period of the highest stiffness harmonic and of the torque fluctuation.
double fastest_period_s(const GearPairParameters& p);

// The automatic Newmark step: fastest_period_s / kStepsPerFastestPeriod.
double automatic_time_step_s(const GearPairParameters& p);

// The output interval of a run of `c` whose fastest time scale is `fastest_period_s` (the
// model's fastest natural period in contact or excitation): solver.output_interval_s, or when it
// is 0 the automatic one (kAutomaticSamples). Throws InputError, naming the key and
// where it was given, past the work bounds above (kMaxSamples samples, kMaxFastestPeriods
// periods of the fastest scale in the window); `what` names the model in that message.
double checked_output_interval_s(const Case& c, double fastest_period_s, const char* what);

// The start of a pair's run (run(), and the one-degree model's own run among the references): its
// one-degree model (build_model, with `stiffness` as there), returned, and what the result
// holds before it integrates: result.input, result.geometry and result.derived (the model's
// derived quantities and output interval). Throws InputError on bad input and past the work
// bounds (checked_output_interval_s's; a Newmark step too long for the fastest time scale).
GearPairModel begin_pair_run(const Case& c, const MeshStiffness* stiffness, RunResult& result);

// A reading that is not finite (an overflow, a denormal backlash) makes `s` a numerical failure
// (Termination::kDiverged, naming the reading), never "completed".
void refuse_non_finite(const RunReading& x, ode::IntegrationSummary& s);

// Fills r's spectra and their peaks from r.samples over t >= r.steady_start_s, sampled every
// r.derived.output_interval_s (run calls it; so does a result read back from storage).
void compute_spectra(RunResult& r);

// Runs a case of the one-degree forms ("gear_pair", "nondimensional") as its train of
// elements (train_form_of: the one path of every form, train_run.hpp), read back in the pair's
// terms: its mesh's d - e over b as delta_bar, its rate as the velocity, F over b k_m as F_bar,
// the mesh's contact changes as the events, its readings over the window and its steady part,
// with the one-degree model's derived quantities and output interval beside them. Throws
// InputError on bad input; a numerical failure is reported in result.integration (termination
// and message), never thrown. result.integration's steps are the train's cells (exact) or steps,
// its end state is not filled.
RunResult run(const Case& c, const RunOptions& options = {});

}  // namespace geardyn
