#include "geardyn/study_sample.hpp"

#include <fmt/format.h>

#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "geardyn/case_keys.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double or_nan(const std::optional<double>& x) { return x.value_or(kNaN); }

void add(SampleReadings& s, std::string name, double value) {
  s.names.push_back(std::move(name));
  s.values.push_back(value);
}

// The run's outcome: its failure (the values NaN), or cancelled (nothing read).
void outcome(SampleReadings& s, ode::Termination termination, const std::string& message) {
  if (termination == ode::Termination::kCompleted) return;
  if (termination == ode::Termination::kCancelled) {
    s = SampleReadings{};
    s.cancelled = true;
    return;
  }
  s.failure = fmt::format("numerical failure ({}): {}", ode::to_string(termination), message);
  s.values.assign(s.values.size(), kNaN);
}

// A run's options for a study's sample (RunOptions or TrainRunOptions): no output samples
// kept, the shared stiffness and the progress hook given.
template <class Options>
Options sample_options(const MeshStiffness* stiffness,
                       const std::function<bool(double)>& progress) {
  Options o;
  o.keep_samples = false;
  o.stiffness = stiffness;
  o.progress = progress;
  return o;
}

SampleReadings one_degree_sample(const Case& c, const MeshStiffness* stiffness,
                                 const std::function<bool(double)>& progress) {
  RunOptions o = sample_options<RunOptions>(stiffness, progress);
  o.keep_events = false;
  const RunResult r = run(c, o);
  const RunReading& x = r.reading;
  const ModelForm form = c.model.form;
  SampleReadings s;
  const auto named = [&](const char* key, double value) { add(s, form_key(key, form), value); };
  named("impacts", static_cast<double>(x.impacts));
  named("backside_impacts", static_cast<double>(x.backside_impacts));
  named("separations", static_cast<double>(x.separations));
  named("separated_fraction", x.separated_fraction);
  named("max_force_bar", x.max_force_bar);
  named("max_delta_bar", x.max_delta_bar);
  named("max_impact_velocity_m_s", x.max_impact_velocity_m_s);
  named("dynamic_factor", or_nan(r.steady.reading.dynamic_factor));
  named("dynamic_factor_with_startup", or_nan(x.dynamic_factor));
  named("rattle", x.regime == Regime::kSustained ? 1.0 : 0.0);
  if (form != ModelForm::kNondimensional)
    named("natural_frequency_hz", r.derived.natural_frequency_hz);
  outcome(s, r.integration.termination, r.integration.message);
  return s;
}

SampleReadings train_sample(const Case& c, const MeshStiffness* stiffness,
                            const std::function<bool(double)>& progress) {
  const TrainRunResult r = run_train(c, sample_options<TrainRunOptions>(stiffness, progress));
  SampleReadings s;
  for (const TrainMeshReading& m : r.meshes) {
    const auto named = [&](const char* reading, double value) {
      add(s, fmt::format("{}.{}", m.name, reading), value);
    };
    named("impacts", static_cast<double>(m.impacts));
    named("backside_impacts", static_cast<double>(m.backside_impacts));
    named("separations", static_cast<double>(m.separations));
    named("separated_fraction", m.separated_fraction);
    named("max_force_n", m.max_force_n);
    named("dynamic_factor", or_nan(m.dynamic_factor));
    named("dynamic_factor_with_startup", or_nan(m.dynamic_factor_with_startup));
    named("rattle", m.regime == Regime::kSustained ? 1.0 : 0.0);
  }
  for (const TrainLoadSharing& g : r.load_sharing) {
    add(s, g.label + ".load_sharing_static_factor", or_nan(g.static_factor));
    add(s, g.label + ".load_sharing_factor", or_nan(g.factor));
    add(s, g.label + ".load_sharing_factor_with_startup", or_nan(g.factor_with_startup));
  }
  outcome(s, r.termination, r.message);
  return s;
}

}  // namespace

SampleReadings run_sample(const Case& c, const MeshStiffness* stiffness,
                          const std::function<bool(double)>& progress) {
  return runs_as_train(c) ? train_sample(c, stiffness, progress)
                          : one_degree_sample(c, stiffness, progress);
}

}  // namespace geardyn
