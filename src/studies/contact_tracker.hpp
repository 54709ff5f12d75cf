// geardyn (private): the contact history of one nonlinearity (a mesh, a clearance bearing) read
// from its state changes, as the one-degree run reads its mesh (analysis.hpp): for the runs of
// the coupled model and of trains.
#pragma once

#include <cstdint>
#include <optional>

#include "geardyn/analysis.hpp"

namespace geardyn {

// The contact history of one nonlinearity, from its state changes in time order.
class ContactTracker {
 public:
  ContactTracker(double t0, double t1, double final_from, int state)
      : t0_(t0), t1_(t1), final_from_(final_from), state_(state) {
    if (state == 0) free_since_ = t0;
  }
  void change(double t, int to) {
    if (to == state_) return;
    if (state_ == 0 && to != 0) {  // contact entered: an impact
      ++impacts_;
      if (to < 0) ++backside_;
      close_free(t);
    } else if (state_ != 0 && to == 0) {  // contact left
      ++separations_;
      last_separation_ = t;
      free_since_ = t;
      if (t > final_from_) free_in_final_ = true;  // as the one-degree reading (analysis.hpp)
    }
    if (to < 0) back_ = true;
    state_ = to;
  }
  ContactReading reading() {
    if (state_ == 0) close_free(t1_);
    ContactReading r;
    r.present = true;
    r.impacts = impacts_;
    r.backside_impacts = backside_;
    r.separations = separations_;
    r.last_separation_s = last_separation_;
    r.double_sided = back_;
    r.separated_fraction = free_time_ / (t1_ - t0_);
    r.regime = regime_of(free_in_final_, free_time_);
    return r;
  }

 private:
  // A free stretch that reaches into the final part is a separation there, as the one-degree
  // reading's time separated after its start (analysis.hpp).
  void close_free(double t) {
    if (!free_since_) return;
    if (t > final_from_) free_in_final_ = true;
    free_time_ += t - *free_since_;
    free_since_.reset();
  }
  double t0_, t1_, final_from_;
  int state_;
  std::optional<double> free_since_;
  std::int64_t impacts_ = 0, backside_ = 0, separations_ = 0;
  std::optional<double> last_separation_;
  bool back_ = false, free_in_final_ = false;
  double free_time_ = 0;
};

}  // namespace geardyn
