// geardyn: the clutch damper, [[train.damper]]: a torsional spring of stages with free play and
// stops between two bodies, as a manual transmission's clutch disc holds it against gear rattle
// (docs/model.md, "Clutch dampers"). One element, whole in this file and damper.cpp: its keys,
// its element (joint.hpp) and its characteristic (model layer).
//
// The twist x = theta_from - theta_to (rad; positive when `from` leads, the drive side) meets
// the torque
//
//   T(x) = k_0 x                              |x| <= p        (the free play; k_0 often 0)
//          T(p) + k_1 (|x| - p)               p <= |x| <= s_2 (stage 1)
//          T(s_2) + k_2 (|x| - s_2)           s_2 <= |x| <= s (stage 2)
//          T(s) + k_s (|x| - s)               |x| >= s        (the stop)
//
// with the sign of x (odd: the coast side mirrors the drive side), continuous, each stage
// joining where it engages; a stage not given is absent (no free play when p = 0: stage 1 from
// the centre; no stage 2, no stop). The torque acts on `to` as +T and on `from` as -T, each
// counted in its body's sense; the two bodies turn at one nominal speed, as a shaft's (a damper
// to "ground" holds its body). Its viscous damping c acts on x' in every stage but a free play
// without an idle spring (k_0 = 0: nothing touches there); a real damper's friction hysteresis
// is not modelled. Each stage is one linear region of the exact engine: the damper is exact,
// its edges located as events.
//
// Readings: its torque T + c x' (N m, "torque_nm") and its twist x (rad, "twist_rad") in every
// run, sweep and orbit, its contact history (leaving the free play: an impact; back into it: a
// separation), its strain energy in each mode (at the stage it carries the static torque in).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/joint.hpp"

namespace geardyn {

template <class E>
struct ElementKey;  // element_keys.hpp

struct TrainDamperData {
  std::string name, from, to;
  double stiffness_n_m_per_rad = 0;                    // k_1
  double free_play_deg = 0;                            // p, either way from the centre
  double free_play_stiffness_n_m_per_rad = 0;          // k_0
  std::optional<double> stage2_deg;                    // s_2
  std::optional<double> stage2_stiffness_n_m_per_rad;  // k_2
  std::optional<double> stop_deg;                      // s
  std::optional<double> stop_stiffness_n_m_per_rad;    // k_s
  double damping_n_m_s_per_rad = 0;                    // c

  // The element it is in a train (SI), for train_of. Throws InputError naming the key for
  // stages out of order and a stage's angle without its stiffness (or the reverse).
  std::shared_ptr<const train::Element> element() const;
};

// Its keys: the one table the case reader, the writer, `--set` and the docs read.
const std::vector<ElementKey<TrainDamperData>>& damper_keys();

}  // namespace geardyn
