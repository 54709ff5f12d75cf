// geardyn: reading a run, pipeline stage 6 (integrator -> analysis).
//
// A run is read as contact states over time (docs/model.md): drive-side contact,
// separation, back-side contact: the readings every run fills (a train's per mesh and
// clearance direction, a pair's in its units). The one-degree model's own reader, which fills
// them from its integrators, is among the references (one_degree_reader.hpp).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/engine.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/model.hpp"

namespace geardyn {

enum class Regime {
  kNone,       // never separated
  kTransient,  // separated, but not within the final part of the window
  kSustained,  // separated within the final part of the window
};
const char* to_string(Regime r);
// The regime of a contact history: sustained when a separation happened within the final part
// of the window, transient when the contact was ever left, none otherwise (the one rule of the
// one-degree reading and of every nonlinearity of the coupled model).
Regime regime_of(bool separated_in_final, double separated_time_s);

enum class EventKind {
  kImpact,          // entry into drive-side contact from separation
  kBacksideImpact,  // entry into back-side contact from separation
  kSeparation,      // exit from contact (either side) into separation
};
const char* to_string(EventKind k);

struct ContactEvent {
  double t_s;
  EventKind kind;
  double velocity_m_s;  // delta' at the event: the impact velocity for an impact
};

// Uniform output samples, one array per column (structure of arrays, so that each column can
// be handed out without a copy).
struct Timeseries {
  std::vector<double> t_s;
  std::vector<double> delta_bar;     // delta / b
  std::vector<double> velocity_m_s;  // delta'
  std::vector<double> force_bar;     // F_G / (b k_m)
  std::vector<int> contact;          // 1 drive side, 0 separated, -1 back side
  std::size_t size() const { return t_s.size(); }
};

// What one contact did over a window: the reading of the one-degree mesh and of each
// nonlinearity of a train (each mesh, each clearance direction of a bearing).
struct ContactCounts {
  Regime regime = Regime::kNone;
  bool double_sided = false;                // back-side contact occurred at all
  std::int64_t impacts = 0;                 // entries into contact from separation, both sides
  std::int64_t backside_impacts = 0;        // of which on the back side
  std::int64_t separations = 0;             // exits from contact into separation
  std::optional<double> last_separation_s;  // time of the last exit from contact
  double separated_fraction = 0;            // time separated over the window
};

// One nonlinearity of a train (or of the coupled reference model, coupled_run.hpp) read as the
// one-degree run is: contact entered from the free state is an impact (on the back side: a
// backside impact), left is a separation.
struct ContactReading : ContactCounts {
  bool present = false;  // false: a bearing without clearance (always in contact)
};

// The mean and the RMS of a run's samples of one quantity, from their running sums (the
// one-degree run's and each mesh of a train's); 0 without a sample.
struct SampleMoments {
  double sum = 0, sum_squares = 0;
  std::int64_t count = 0;
  void add(double x) {
    sum += x;
    sum_squares += x * x;
    ++count;
  }
  double mean() const { return count > 0 ? sum / static_cast<double>(count) : 0.0; }
  double rms() const {
    return count > 0 ? std::sqrt(sum_squares / static_cast<double>(count)) : 0.0;
  }
};

// What a run reads as: its contact's counts, and force and displacement non-dimensional as in
// the paper's figures: delta_bar = delta / b, F_bar = F_G / (b k_m).
struct RunReading : ContactCounts {
  double max_impact_velocity_m_s = 0;
  // Extremes over every step end, transition and sample; mean and RMS over the samples.
  double max_force_bar = 0, min_force_bar = 0, mean_force_bar = 0, rms_force_bar = 0;
  double max_delta_bar = 0, min_delta_bar = 0, mean_delta_bar = 0, rms_delta_bar = 0;
  // max F_G over the static mesh force F_m / cos^2(beta_b); absent when F_m <= 0.
  std::optional<double> dynamic_factor;
};

}  // namespace geardyn
