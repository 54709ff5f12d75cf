// geardyn: when a train whose common period is long is steady, judged by what its readings show.
//
// A train settles onto a periodic response of its common period, and steady.hpp judges it on
// the section of that period. A hunting-tooth gearbox's common period is minutes long (a
// wind-turbine gearbox's 437 s), and a train whose excitations have no common period has none:
// such a train is judged window by window instead. A window holds whole periods of its slowest
// excitation, as many as hold kLeastFastCycles cycles of its fastest; the train is steady when
// each window agrees with the one before, kJudgedChanges windows in a row: every mesh's force and
// every shaft's and bearing's load has its mean within kStatisticsTolerance of its scale and its
// standard deviation (the dynamic part: what a dynamic factor's increment and a peak-to-peak read)
// within kDynamicTolerance of itself, and no decay of their changes predicts more to come. Means
// and standard deviations, not extremes: a window's extremes depend on where the excitations'
// crests fall in it, which drifts from window to window when their frequencies are not
// commensurate. Sweeps settle their points with it; runs find their steady part with it.
#pragma once

#include <cstddef>
#include <vector>

#include "geardyn/steady.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn {

// A train whose common period is more than this many periods of its slowest excitation, or
// that has none (quasi-periodic), is judged by its statistics, not on a section of its period.
constexpr double kMaxSectionPeriods = 20;
// A statistics window holds at least this many cycles of the train's fastest excitation.
constexpr double kLeastFastCycles = 200;
// Two windows' means this close, relative to their scale, are the steady state's: the three
// digits a user reads of a force.
constexpr double kStatisticsTolerance = 1e-3;
// Two windows' standard deviations this close, relative to themselves, are the steady state's:
// the two digits a user reads of a dynamic factor's increment or a peak-to-peak.
constexpr double kDynamicTolerance = 1e-2;
// A shaft's or bearing's load below this share of the train's largest of its unit is judged on
// that largest's scale: it carries next to nothing.
constexpr double kNegligibleShare = 1e-2;

// The slowest and the fastest excitations of a train (rad/s): each varying mesh's stiffness
// and error (runouts included), each torque harmonic, each prescribed speed's; both 0 when
// nothing varies.
struct ExcitationRange {
  double slowest_rad_s = 0, fastest_rad_s = 0;
};
ExcitationRange excitation_range(const train::Assembled& a);

// The window a train's statistics are read over (see the file comment), or 0 when it is judged
// on the section of its common period: when nothing varies, or its common period is at most
// kMaxSectionPeriods periods of its slowest excitation.
double statistics_window_s(const train::Assembled& a);

// A statistic of a window and how far it may move to the next: a change of at most `tolerance`
// times `scale` (the larger of the two windows').
struct WindowStatistic {
  double value, scale, tolerance;
};

// The statistics of r's output samples [first, end) (TrainSamples' rows): each mesh's force,
// its mean on the scale of the larger of its static force and b k_m; then, where r kept the
// parts' rows, each shaft's and bearing's quantities (part_quantities), their means on the
// part's scale (the largest RMS of its quantities, at least kNegligibleShare of the largest of
// any part in the same unit). Each mean is followed by its standard deviation, on the scale of
// itself (at least kStatisticsTolerance of the mean's scale, so that a part that hardly moves
// is not held back by its rounding).
std::vector<WindowStatistic> window_statistics(const TrainRunResult& r, std::size_t first,
                                               std::size_t end);

// How far two windows' statistics are apart: the largest change over its allowance, times
// kStatisticsTolerance (so that at most kStatisticsTolerance is steady); infinite when they do
// not read the same quantities.
double statistics_change(const std::vector<WindowStatistic>& now,
                         const std::vector<WindowStatistic>& before);

// How many windows' changes in a row a steady verdict reads: a transient's statistics need not
// move monotonically (a lightly damped mode beating with a slow excitation makes one window
// agree with the one before by chance).
constexpr std::size_t kJudgedChanges = 3;

// The changes of a stationary response's windows do not fall: the largest of the last
// kJudgedChanges is at least this share of the largest of the kJudgedChanges before (a decay
// at 0.9 a window or faster falls below it).
constexpr double kStationaryShare = 0.75;

// The verdict on the windows so far, given each window's statistics_change from the window
// before's (the first's infinite), as steady.hpp's on a section: two similar windows are no
// evidence of a steady state while a transient still decays, and a transient's statistics
// need not fall monotonically (a lightly damped mode beating with a slow excitation makes one
// window agree with the one before by chance). While the changes still fall, steady when each
// of the last kJudgedChanges is at most kStatisticsTolerance and so is the change still to come
// (while the last three fall one after the other, the rest of their geometric series, change
// rate / (1 - rate), rate the last over the one before). Once they no longer fall (stationary:
// the windows' own variation, part cycles and slow beats of incommensurate excitations),
// steady when the last change is at most kStatisticsTolerance. The verdict's error is that
// change to come, or the last change.
SteadyVerdict statistics_verdict(const std::vector<double>& changes);

}  // namespace geardyn
