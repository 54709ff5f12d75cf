// geardyn: the drag, [[train.drag]]: a torque on one body against its rotation, constant and
// viscous (a loose gear's oil churning, a bearing's friction). One element, whole in this file
// and drag.cpp: its keys and its element (joint.hpp) (model layer).
//
// On its body's rotation theta (rad, counted in the body's sense) it acts as the torque
//
//   T = -sign(w) T_c - c theta',
//
// w the body's nominal speed in its own sense: the constant part T_c opposes the nominal
// rotation, the viscous part c damps the fluctuation theta' about it (not the nominal speed:
// its mean is T_c's to give). It is one joint of one stage on x = theta with no stiffness, so
// every region holds it and it adds no guard. A drag on a body whose speed is prescribed would
// do nothing, and a constant drag on a body at rest has no rotation to oppose: both refused.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "geardyn/joint.hpp"

namespace geardyn {

template <class E>
struct ElementKey;  // element_keys.hpp

struct TrainDragData {
  std::string name, body;
  double constant_nm = 0;            // T_c >= 0
  double viscous_n_m_s_per_rad = 0;  // c >= 0

  // The element it is in a train (SI), for train_of.
  std::shared_ptr<const train::Element> element() const;
};

// Its keys: the one table the case reader, the writer, `--set` and the docs read.
const std::vector<ElementKey<TrainDragData>>& drag_keys();

}  // namespace geardyn
