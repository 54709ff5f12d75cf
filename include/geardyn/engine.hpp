// geardyn: the exact engine for piecewise-linear systems with periodic coefficients, pipeline
// stage 5 beside the steppers of integrator.hpp. Nothing here knows of gears.
//
// Between two events the system of linear_system.hpp is linear, so its flow is known: for each
// region the engine cuts time into cells of length h on a fixed grid (t = m h; h divides the
// coefficient period into K cells), and computes once, per cell of the period, the Taylor
// series in s = t - t_m of
//
//     Phi(s)        the state transition matrix of the cell, Phi(0) = I,
//     R0(s)         the response to the constant forcing u0 from rest,
//     Rc_f, Rs_f    the responses to the forcing at frequency w_f with cell-start phase 0 and
//                   pi/2 (the response to any phase is cos(w_f t_m) Rc_f + sin(w_f t_m) Rs_f),
//
// to a truncation below the tolerance (the order is raised, or h halved, until the last terms
// are negligible entry by entry). A whole cell then costs one n x n product and the phasors of
// the forcing; the state anywhere inside it is a polynomial, exact to the same truncation.
//
// Events: over each cell the engine bounds how far every component of the state can move
// (|y(s) - y(t_m)| <= alpha |y(t_m) - y_ref| + beta, alpha and beta precomputed from the series,
// y_ref the region's static state), so a guard that stays above that bound cannot cross in the
// cell. Otherwise the guard's polynomial over the cell is searched by Bernstein subdivision,
// which cannot miss a sign change (the hull of the Bernstein coefficients encloses the
// polynomial), and the earliest crossing is located by Newton's method on the polynomial, kept
// inside its bracket.
//
// Jumps: where no guard can cross and the observer needs no detail, a whole coefficient period
// is one product with its precomputed map; where the coefficients are constant, a block of
// about one forcing period is jumped around the periodic forced response.
//
// Sensitivities: on request the engine carries J = dy(t)/dy(t0), the product of the cells'
// Phi and, at every event, the saltation matrix S = I + (f+ - f-) G / (dg/dt), f+- = y' on each
// side of the event and dg/dt the guard's rate along the arriving flow.
//
// Progress: every cell ends the loop or advances time by a cell; events inside one cell are
// bounded by EngineOptions::max_events_per_cell (a chattering contact ends the flow with
// Termination::kNoProgress and a message, never a hang); the observer may cancel.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/integrator.hpp"
#include "geardyn/linear_system.hpp"

namespace geardyn::ode {

// The finest relative truncation a cell series can be summed to in doubles.
constexpr double kRoundingLimit = 1e-16;

// The highest series order EngineOptions::max_order may ask for.
constexpr int kMaxOrderAllowed = 96;

struct EngineOptions {
  // Relative truncation of the cell series, entry by entry (the engine's accuracy). Values
  // below kRoundingLimit are raised to it: the series cannot be summed more finely in doubles.
  double tolerance = 1e-14;
  // h times the fastest rate of a region (its largest eigenvalue modulus or frequency): the
  // cell length. Near 1 the series need ~25 terms; larger cells need more terms and give
  // looser bounds.
  double cell_rate_product = 1.5;
  int max_order = 48;                           // terms of a cell series at most
  int max_events_per_cell = 64;                 // region changes inside one cell before kNoProgress
  std::int64_t progress_interval_cells = 4096;  // cells between calls of on_progress
  // Empty when valid; otherwise the offending member, its value and the allowed range.
  std::string validate() const;
};

struct KeptStretches;

// Bounds of the state over a stretch of one cell, and its value anywhere inside (valid until
// the observer call returns).
class CellView {
 public:
  double t_begin_s = 0, t_end_s = 0;
  int region = 0;
  const Vector* lower = nullptr;  // componentwise bounds of y over [t_begin, t_end]
  const Vector* upper = nullptr;
  // y(t) for t in [t_begin, t_end].
  virtual void state_at(double t_s, Vector& y) const = 0;
  // Whether the region's observable i goes beyond `beyond` (above it for a maximum, below for a
  // minimum) over [t_begin, t_end]; if so its extreme there (value, time), exact to rounding.
  virtual bool extreme(int observable, bool maximum, double beyond, double& value,
                       double& t_s) const = 0;
  // Bounds of the region's observable i over the stretch where the region gives them for a
  // few products (its cells cache their forms: periodic or constant coefficients): the series'
  // first terms summed exactly, the rest bounded; tighter than those of lower and upper. False,
  // and nothing set, otherwise.
  virtual bool range(int observable, double& low, double& high) const = 0;
  // Appends the stretch to `kept` (ExactEngine::revisit looks at it after the call returns).
  virtual void keep(KeptStretches& kept) const = 0;

 protected:
  ~CellView() = default;
};

// What looks at a flow (Boost.Odeint's observer): every call is in time order.
class FlowObserver {
 public:
  virtual ~FlowObserver() = default;
  // A stretch [t_begin, t_end] inside one region and one cell, before on_step at its end.
  virtual void on_cell(const CellView& /*cell*/) {}
  // Asked before the engine jumps a whole coefficient period in one step (with no on_cell
  // for it): true makes it step the period's cells instead. Only the span's times, region and
  // bounds (lower, upper) are valid here, not state_at or range.
  virtual bool needs_detail(const CellView& /*span*/) { return false; }
  // At the end of every cell and at every event (still in the old region).
  virtual void on_step(double /*t_s*/, const Vector& /*y*/, int /*region*/) {}
  // A point inside a step of an integrator without cells (adaptive.hpp: its dense output), for
  // an observer that reads extremes, which step ends alone would miss by the step's curvature.
  // Never called by the exact engine, whose on_cell gives the whole stretch.
  virtual void on_point(double /*t_s*/, const Vector& /*y*/, int /*region*/) {}
  // A located region change; y is the state at the event.
  virtual void on_event(double /*t_s*/, const Vector& /*y*/, int /*from*/, int /*to*/) {}
  // At the output grid's times.
  virtual void on_sample(double /*t_s*/, const Vector& /*y*/, int /*region*/) {}
  // Now and then; false cancels the flow.
  virtual bool on_progress(double /*t_s*/) { return true; }
};

// Stretches kept from flows (CellView::keep) to be looked at after them (ExactEngine::revisit)
// as on_cell would have: an observer that wants only the greatest of many stretches' extremes
// keeps its candidates and, at the end, searches only those whose range still reaches the best
// value found. Filled by CellView::keep alone; a flat store, so that keeping allocates only as
// it grows.
struct KeptStretches {
  struct Stretch {
    double t_begin_s, t_end_s;
    int region;
    std::int64_t cell;   // the cell's index on the region's grid (t_m = cell h)
    std::size_t values;  // where the cell's start state and forcing phases begin in `values`
  };
  std::vector<Stretch> stretches;
  // Per stretch: the state its cell's series start from (the system's dimension), then cos and
  // sin of each of its region's forced frequencies at the cell's start.
  std::vector<double> values;
  std::size_t size() const { return stretches.size(); }
  void clear() {
    stretches.clear();
    values.clear();
  }
};

struct FlowEvent {
  double t_s;
  int from, to;
};

struct FlowResult {
  Termination termination = Termination::kCompleted;
  std::string message;
  double end_time_s = 0;
  Vector state;            // y at end_time_s
  int region = 0;          // the region there
  std::int64_t cells = 0;  // whole and partial cells stepped (a jump counts its cells)
  // Jumps: whole coefficient periods, or, where the coefficients are constant, blocks of about
  // one forcing period around the periodic forced response.
  std::int64_t periods = 0;
  std::int64_t events = 0;  // region changes
  // Steps of a fixed-step flow (newmark_flow.hpp) that met more region changes than it
  // locates in one step and took the rest unsplit (a chattering contact); 0 for the others.
  std::int64_t unsplit_steps = 0;
  std::optional<Matrix> jacobian;  // dy(t1)/dy(t0), when asked for
  bool ok() const { return termination == Termination::kCompleted; }
};

class ExactEngine {
 public:
  // Precomputes the cells of every region. Throws std::invalid_argument when the system or
  // the options are not valid (their validate() message).
  ExactEngine(LinearSwitchedSystem system, const EngineOptions& options = {});
  ~ExactEngine();
  ExactEngine(ExactEngine&&) noexcept;
  ExactEngine& operator=(ExactEngine&&) noexcept;

  const LinearSwitchedSystem& system() const;
  // Cell length and cells per coefficient period of region r, and the series order.
  double cell_length_s(int region) const;
  int cells_per_period(int region) const;
  int order(int region) const;

  // Flows from (t0, y0) in `region` to t1. Samples at `output`'s times in [t0, t1]. Throws
  // std::invalid_argument unless check_flow_arguments accepts the arguments. A numerical failure
  // or cancellation is reported in the result, never thrown.
  FlowResult flow(double t0_s, const Vector& y0, int region, double t1_s, const OutputGrid& output,
                  FlowObserver& observer, bool jacobian = false) const;

  // One look at kept stretches: `visit(order, look)` hands `look` the kept stretches `order`
  // names (indices into kept, each kept from a flow of this engine), in that order, with the
  // index and the CellView on_cell had (state_at, extreme and range as there; lower and upper
  // are not kept: null), until `look` returns false.
  using Look = std::function<bool(std::size_t, const CellView&)>;
  using Visit = std::function<void(const std::vector<std::size_t>& order, const Look& look)>;
  // Calls `session` with a `visit` over `kept`, which it may call as often as it likes, each
  // order chosen after what the last found (a search of several extremes, each widest bound
  // first): the visits share one scratch flow, built once a session. May be called from inside
  // an observer's call of a flow of this engine; `visit` is valid only during the call.
  void revisit(const KeptStretches& kept, const std::function<void(const Visit&)>& session) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The slack below zero at which a guard counts as crossed, relative to its scale: far below
// any physical tolerance, far above the rounding of the state it is evaluated at.
constexpr double kGuardSlack = 1e-13;
// The value below which guard g counts as crossed: -kGuardSlack in its scale.
inline double crossed_below(const LinearGuard& g) { return -kGuardSlack * g.scale; }

}  // namespace geardyn::ode
