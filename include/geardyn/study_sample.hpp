// geardyn: one sample of a study's run (docs/studies.md, "What each sample keeps"): a case of
// any form run as `geardyn run` runs it, with neither its output samples nor its events kept,
// read into named numbers. The one place that names a run's study outputs; the Python package's
// study batches (python/src/bind_study.cpp) call it for every form.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "geardyn/case.hpp"

namespace geardyn {

struct MeshStiffness;  // stiffness.hpp

struct SampleReadings {
  // The outputs, named as docs/studies.md names them:
  //   - the one-degree forms: impacts, backside_impacts, separations, separated_fraction,
  //     max_force_bar, max_delta_bar, max_impact_velocity_m_s, dynamic_factor (the steady
  //     part's), dynamic_factor_with_startup, rattle (1 when the regime is sustained) and
  //     natural_frequency_hz, each named by form_key (the non-dimensional form's
  //     max_impact_velocity in b w_n; its natural frequency, the unit of its time, left out);
  //   - a gear train (and a coupled pair, run as its train): each mesh's impacts,
  //     backside_impacts, separations, separated_fraction, max_force_n, dynamic_factor,
  //     dynamic_factor_with_startup and rattle as "<mesh>.<reading>", then each load-sharing
  //     group's as "<label>.load_sharing_static_factor", "_factor" and "_factor_with_startup".
  // The same names, in the same order, for every sample of one base case.
  std::vector<std::string> names;
  // NaN where the reading is absent (a dynamic factor without a static force) and every one
  // when the run failed.
  std::vector<double> values;
  // Empty when the run completed; else "numerical failure (<termination>): <message>".
  std::string failure;
  // The run was stopped by `progress` before its end: nothing is read.
  bool cancelled = false;
};

// Runs c (InputError on bad input, as `geardyn run`) and reads it. `stiffness`, when given, is
// a pair form's mesh stiffness computed once for all the samples (shared_stiffness); a train's
// meshes compute their own. `progress`, when given, is called now and then with the fraction of
// the window done; false stops the run (cancelled).
SampleReadings run_sample(const Case& c, const MeshStiffness* stiffness = nullptr,
                          const std::function<bool(double)>& progress = {});

}  // namespace geardyn
