// geardyn: when a response is steady, judged on a stroboscopic section.
//
// A response of the gear model settles onto a periodic response of period q T0 (T0 the system
// period, model.hpp's system_period_s). Its state on the section t = k T0 tells how far it
// still is: near a hyperbolic periodic response the q-period map is affine,
// x_(j+q) - x* = M (x_j - x*), so the Poincare residuals d_j = x_j - x_(j-q) obey
// d_(j+q) = M d_j. M is fitted from the last three residuals, its spectral radius is the rate at
// which the transient decays, and the distance left is the rest of the geometric series,
// x_j - x* = M (M - I)^-1 d_j. Two similar stretches of a response are no such evidence: a
// lightly damped transient changes little from one period to the next and is still far off.
// Sweeps settle their points with it; runs find their steady part with it.
#pragma once

#include <functional>
#include <limits>
#include <optional>
#include <vector>

#include "geardyn/engine.hpp"
#include "geardyn/integrator.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn {

// The largest period multiple q tested (period-q responses settle as such; longer ones,
// quasi-periodic and chaotic responses do not).
constexpr int kMaxSettledMultiple = 8;
// SectionSeries::judge reads at most the latest this many section states (3 q + 1 for the
// largest q): those before them may be run without being recorded.
constexpr int kJudgedSections = 3 * kMaxSettledMultiple + 1;

// The default tolerance on the distance to the periodic response, in b (delta) and b w_n
// (delta').
constexpr double kSteadyTolerance = 1e-6;
// A run's steady part without a steady state: the final half of the window.
constexpr double kSteadyFraction = 0.5;

struct SteadyVerdict {
  int period_multiple = 0;  // q of the periodic response reached; 0: not steady
  // The predicted distance to it (of the smallest q tried when not steady); infinite when no
  // decay was seen.
  double error = std::numeric_limits<double>::infinity();
  bool settled() const { return period_multiple > 0; }
};

// The section states of one response, scaled: delta / b and delta' / (b w_n).
class SectionSeries {
 public:
  // `integration_tolerance` (the case's solver.tolerance, relative to b) is the noise below
  // which residuals count as zero (at least 1e-12).
  SectionSeries(double backlash_m, double omega_n_rad_s, double integration_tolerance);

  // The state at the next section time, k T0.
  void add(const ode::State& s);
  std::size_t size() const { return x_.size(); }

  // Steady when the predicted distance of the latest state is under half the tolerance (the
  // prediction is an estimate: within a factor 2 of the true distance in the tests, sweep_test
  // ThePredictedDistanceBoundsTheTrueOne), for the smallest q in 1..kMaxSettledMultiple; a
  // q-periodic fixed point that is of a shorter period d (a divisor of q) is reported as d.
  SteadyVerdict judge(double tolerance) const;

  // The predicted distance of the latest state to the period-q response (see the file
  // comment): infinite while the fitted rate is not below 1 or there are fewer than 3 q + 1
  // states; the residual itself when it is at the integration's noise.
  double predicted_error(int q) const;

 private:
  struct Point {
    double delta, velocity;
  };
  double b_, bw_, floor_;
  std::vector<Point> x_;
};

// A response judged on several projections of its state at once (the coupled model's mesh and
// bearing displacements): steady when every projection is, its period the least common
// multiple of theirs (not steady past kMaxSettledMultiple), its distance the largest of theirs.
// A state that is periodic projects to a period that divides its own; a transient that one
// projection barely sees shows in another.
SteadyVerdict judge_together(const std::vector<SectionSeries>& series, double tolerance);

// The periodic response of a piecewise-linear system over whole periods spent in one region
// (no event): there the map over one period is affine, P(y) = M y + c, the same for every such
// period, so its fixed point follows from any one state y, its image P(y) and M,
// x* = y + (I - M)^-1 (P(y) - y), and a state's distance to it is known, not predicted.
// Components are scaled by `scale` (the norm is max_i |v_i| / scale_i).
struct AffineResponse {
  ode::Vector state;  // x*
  // |S^-1 (I - M)^-1 S| (infinity norm, S = diag(scale)): an error of P(y) of e in the scaled
  // norm moves x* by at most amplification x e.
  double amplification = 0;
};

// nullopt when I - M is singular to working precision (a multiplier at 1). Whether the flow
// settles on x* (every multiplier inside the unit circle) and whether it stays in the region
// are the caller's to check.
std::optional<AffineResponse> affine_response(const ode::Matrix& monodromy, const ode::Vector& y,
                                              const ode::Vector& image, const ode::Vector& scale);

// max_i |v_i| / scale_i.
double scaled_norm(const ode::Vector& v, const ode::Vector& scale);

// Where a run's steady part starts, and why.
enum class SteadyBasis {
  kSettled,     // the response reached its periodic response at from_s
  kNotSettled,  // no steady state within the window: the final half is read
  kAperiodic,   // the excitations have no common period: the final half is read
  // A train judged by its statistics (train_steadiness.hpp): its windows of window_s agreed
  // up to from_s.
  kStatistics,
};
const char* to_string(SteadyBasis b);

// Where a run's steady part starts (run.hpp's SteadyPart, the train and coupled runs').
struct SteadyStart {
  SteadyBasis basis = SteadyBasis::kNotSettled;
  double from_s = 0;
  int period_multiple = 0;  // of the periodic response, in periods (kSettled)
  double window_s = 0;      // the statistics window (a train judged by its statistics)
  // The predicted distance to the periodic response at from_s (the series' scales); infinite
  // when no decay was seen (0 in a run that failed).
  double error = 0;
  bool marked = false;  // the part was marked (false: the run ended before it began)
};

// One run over [t0, t1] integrated once while its steady part is sought, the same for every
// model: until the response settles on the section t = t0 + k period_s (judged to
// kSteadyTolerance, with at least one period left to read) it is integrated a period at a
// time; the part from there is marked; without a steady state (or with period_s = 0, no common
// period: kAperiodic), the final half (kSteadyFraction) is marked at its start.
//   judge()      adds the state reached, at t0 and at each section time, and gives the verdict
//                of the sections so far;
//   advance(t)   integrates from where the run is to t (its samples included); false ends the
//                run (a numerical failure or a cancellation, the caller's to report);
//   mark(t)      the steady part starts at t (a time advance stopped at; a later mark starts
//                it afresh).
SteadyStart integrate_watching(double t0, double t1, double period_s,
                               const std::function<SteadyVerdict()>& judge,
                               const std::function<bool(double)>& advance,
                               const std::function<void(double)>& mark);

// The advance of integrate_watching for a flow of the exact engine or the adaptive integrator
// (engine.hpp's FlowResult): each piece from where the last ended, its samples the grid's own
// (bit for bit those of one flow), the cells and events summed, the progress told between
// pieces (false cancels: "cancelled at t = ...").
class FlowPieces {
 public:
  // One piece: (t_from, y, region, t_to, the piece's grid) -> its result.
  using Flow = std::function<ode::FlowResult(double, const ode::Vector&, int, double,
                                             const ode::OutputGrid&)>;
  FlowPieces(double t0, const ode::Vector& y0, int region, double t1, const ode::OutputGrid& grid,
             Flow flow, std::function<bool(double)> progress);
  // Runs to `stop`; false on a failure or a cancellation (total() says which).
  bool operator()(double stop);
  double t_s() const { return t_; }
  const ode::Vector& state() const { return total_.state; }
  // Termination and message of the last piece, cells and events of all, the state reached.
  const ode::FlowResult& total() const { return total_; }

 private:
  double t0_, t_, t1_;
  ode::OutputGrid grid_;
  Flow flow_;
  std::function<bool(double)> progress_;
  std::int64_t sampled_ = 0;  // grid samples emitted
  ode::FlowResult total_;
};

}  // namespace geardyn
