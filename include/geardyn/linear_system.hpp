// geardyn: a piecewise-linear system with periodic coefficients, the input of the exact engine
// (engine.hpp). Nothing here knows of gears: a model (model.hpp) describes itself in this form.
//
//     y' = A_r(t) y + u_r(t),     y in R^n (n = 2N: the coordinates, then their rates),
//
// r the region (the contact state of every nonlinearity). Every time-dependent term is a
// finite Fourier series over one table of angular frequencies w_f shared by the system:
//
//     A_r(t) = A0 + sum_f (Ac_f cos(w_f t) + As_f sin(w_f t))
//     u_r(t) = u0 + sum_f (uc_f cos(w_f t) + us_f sin(w_f t))
//
// The coefficients A_r(t) are periodic with `coefficient_period_s` (every frequency with a
// non-zero matrix term is a whole multiple of 2 pi / T; 0 when every A_r is constant); the
// forcing u_r(t) may hold any frequency. A region is left when one of its guards, an affine
// function of the state
//
//     g(t, y) = (G0 + sum_f (Gc_f cos + Gs_f sin)) . y + (g0 + sum_f (gc_f cos + gs_f sin)),
//
// turns negative; the state is continuous across the switch.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace geardyn::ode {

using Vector = Eigen::VectorXd;
using RowVector = Eigen::RowVectorXd;
using Matrix = Eigen::MatrixXd;

// A Fourier series over the system's frequency table: constant + per-frequency cos and sin
// terms. `cos` and `sin` are either empty (no time dependence) or hold one entry per frequency.
template <class T>
struct FourierTerms {
  T constant{};  // zero for a scalar; an Eigen type is sized by its user
  std::vector<T> cos, sin;
  bool varies() const { return !cos.empty(); }
};

struct LinearGuard {
  FourierTerms<RowVector> row;  // G(t), 1 x n
  FourierTerms<double> offset;  // g0(t)
  int target = 0;               // the region entered when g turns negative
  // The magnitude of g that counts as "large" (its units): a crossing is declared when g falls
  // below -kGuardSlack * scale, so that the state handed to the next region lies inside it.
  double scale = 1.0;
};

struct LinearRegion {
  FourierTerms<Matrix> a;  // A_r(t), n x n
  FourierTerms<Vector> u;  // u_r(t), n
  std::vector<LinearGuard> guards;
  // Affine functionals of the state (as guards; target and scale unused) whose extremes an
  // observer may ask a cell for, the same number in every region (engine.hpp, CellView).
  std::vector<LinearGuard> observables;
};

// Empties the cos and sin terms of every series of the region (A, u, each guard's and
// observable's row and offset) whose terms are all zero: the series is then constant, as the
// engine reads a series without terms, and a region whose A and guard rows are all constant is
// stepped with constant coefficients (any cell length, the steady jumps of engine.hpp) however
// long its system's coefficient period. A builder that lays out one term per frequency of its
// table calls it on each region it makes.
void drop_zero_terms(LinearRegion& region);

// The regions of a system built on demand (LinearSwitchedSystem::make_lazy), shared by its
// copies.
struct LazyRegionStore;

struct LinearSwitchedSystem {
  int dimension = 0;                      // n
  std::vector<double> frequencies_rad_s;  // w_f, each > 0
  double coefficient_period_s = 0;        // T of every A_r(t) and G(t); 0: all constant
  // Region r is regions[r]; or, for a system with too many regions to hold (a train's 3^meshes),
  // regions is empty and region r is built the first time region(r) is asked for (make_lazy).
  std::vector<LinearRegion> regions;

  // Region r, either way (a lazy one built, checked as validate() checks it, and kept: safe
  // from several threads; a builder's inconsistent region throws std::logic_error).
  const LinearRegion& region(int r) const;
  int region_count() const;
  bool lazy() const { return lazy_ != nullptr; }
  // Makes the system's `count` regions lazy: region r is build(r). `build` must not touch the
  // system (it may run from any thread, once per region).
  void make_lazy(int count, std::function<LinearRegion(int)> build);

  // Empty when the description is consistent; otherwise what is wrong (sizes, frequencies,
  // targets, a period that the coefficient frequencies do not fit). A lazy system's regions are
  // checked as they are built, the first one here.
  std::string validate() const;

 private:
  std::shared_ptr<LazyRegionStore> lazy_;
};

// A frequency fits a period when its cycles over it are an integer to within this fraction
// (of the cycles, at least of one): the tolerance validate() holds the coefficients to.
inline constexpr double kHarmonicFit = 1e-9;
// Whether w_rad_s makes a whole number of cycles over period_s, to within `fraction` of the
// cycles (at least of one).
bool harmonic_of(double w_rad_s, double period_s, double fraction);

// Empty when a flow may start from (t0, y0) in `region` to t1 of s: a region of s, y0 of its
// dimension, finite times with t1 >= t0; otherwise what is wrong. Both flows (ExactEngine::flow,
// adaptive_flow) throw std::invalid_argument with it, in every build: a state of the wrong size
// would otherwise be read past its end.
std::string check_flow_arguments(const LinearSwitchedSystem& s, double t0_s, const Vector& y0,
                                 int region, double t1_s);

// y' in region r at (t, y). Requires a region of s and y of its dimension (asserted in debug
// builds), as do the guard functions for the guard's index.
Vector derivative(const LinearSwitchedSystem& s, int region, double t_s, const Vector& y);
// g(t, y) of guard i of region r, and the row G(t).
double guard_value(const LinearSwitchedSystem& s, int region, int guard, double t_s,
                   const Vector& y);
RowVector guard_row(const LinearSwitchedSystem& s, int region, int guard, double t_s);
// The value of any affine functional of the system (a guard or an observable) at (t, y).
double functional_value(const LinearSwitchedSystem& s, const LinearGuard& g, double t_s,
                        const Vector& y);
// cos(w_f t) and sin(w_f t) of every frequency of a table, one entry per frequency.
struct Phases {
  std::vector<double> cos_wt, sin_wt;
};
// The phases of the table w at t_s: each std::cos(w[f] * t_s) and std::sin(w[f] * t_s) bit for
// bit, or what a GivenPhases gave for this table and time. The last table and time asked or
// given on a thread are kept (a table asked by value, a given one by address), so that a
// stepper's acceleration, guards and observables at one time compute them once between them;
// the reference is valid until this thread's next call of phases_at or GivenPhases::give, or
// the end of the GivenPhases that gave it.
const Phases& phases_at(const std::vector<double>& w, double t_s);
// While it lives, makes phases_at return the phases last given for (w, t_s) on this thread, by
// reference and without copying them, until another table or time is asked: a stepper on a
// uniform grid advances them by rotation (PhaseGrid) and gives them once a step to its
// acceleration, its guards and its observer. The table and the phases given must outlive it
// (or the next give); its end forgets them, so that no reader is handed them afterwards. One
// at a time on a thread (a flow's own).
class GivenPhases {
 public:
  GivenPhases() = default;
  GivenPhases(const GivenPhases&) = delete;
  GivenPhases& operator=(const GivenPhases&) = delete;
  ~GivenPhases();
  // phases: of w's size, the phases of w at t_s (a stepper's rotated ones).
  void give(const std::vector<double>& w, double t_s, const Phases& phases);
};
// The phases phases_at computed directly for (w, t_s), when this thread keeps them (not those a
// GivenPhases gave); else null. A reader of a few of the table's frequencies at a time whose
// phases were just asked (a sample's lift after its observables) takes them from here, bit
// for bit its own std::cos and std::sin, without computing the whole table.
const Phases* kept_direct_phases(const std::vector<double>& w, double t_s);

// cos(w_f t) and sin(w_f t) of a frequency table at t0 + k dt, k = 1, 2, ... in turn, advanced by
// a rotation each step (four products a frequency instead of a cosine and a sine) and computed
// afresh every kResyncSteps steps: within about 1e-13 of the direct values (HarmonicGrid's
// scheme, harmonic_series.hpp). The table must outlive it.
class PhaseGrid {
 public:
  static constexpr std::int64_t kResyncSteps = 1024;
  PhaseGrid(const std::vector<double>& w, double t0_s, double dt_s);
  // Advances to step k (the previous call's k + 1, from 1); the phases at t0 + k dt.
  void advance(std::int64_t k);
  const Phases& phases() const { return now_; }
  const std::vector<double>& cos_wt() const { return now_.cos_wt; }
  const std::vector<double>& sin_wt() const { return now_.sin_wt; }

 private:
  const std::vector<double>* w_;
  double t0_s_, dt_s_;
  std::vector<double> rot_cos_, rot_sin_;
  Phases now_;
};

// The values of a list of functionals (a region's guards or observables) at many (t, y), each
// equal to the last bit to functional_value's: built once per list, it keeps the frequencies
// each functional's row or offset holds (a harmonic whose terms are zero adds nothing) and the
// entries where its row varies (a mesh's row reads a few of the state's), each with its terms
// in one contiguous table, sums only those, in functional_value's order, and reads the cosines
// and sines once per call (phases_at), without allocating. The system and the list must
// outlive the reader; the list's coefficients are copied when it is built (a list changed
// afterwards needs a new reader).
class FunctionalValues {
 public:
  FunctionalValues(const LinearSwitchedSystem& s, const std::vector<LinearGuard>& gs);
  // Requires y of the system's dimension (asserted in debug builds); `values` is resized.
  void operator()(double t_s, const Vector& y, std::vector<double>& values) const;
  // The list read (a region's guards or observables).
  const std::vector<LinearGuard>& functionals() const { return *gs_; }

 private:
  // A harmonic's coefficients of cos(w_f t) and sin(w_f t), f its frequency's index.
  struct Term {
    double c, s;
    std::size_t f;
  };
  // A varying entry j of a functional's row: its constant and its terms [begin, end).
  struct Entry {
    Eigen::Index j;
    double constant;
    std::size_t begin, end;
  };
  // A functional's varying entries [entry_begin, entry_end) and its offset's terms.
  struct Functional {
    std::size_t entry_begin, entry_end;
    double offset;
    std::size_t term_begin, term_end;
  };
  const LinearSwitchedSystem* s_;
  const std::vector<LinearGuard>* gs_;
  std::vector<Functional> functionals_;
  std::vector<Entry> entries_;
  std::vector<Term> terms_;
  bool any_ = false;                     // some functional holds a harmonic
  mutable std::vector<RowVector> rows_;  // per functional, its row at the last time asked
};

// One T per region of a system, T(system, region) made the first time a flow asks for region's
// (a train's 3^meshes regions are mostly never visited). The system must outlive it; one flow's
// own (not for two threads at once).
template <class T>
class PerRegion {
 public:
  explicit PerRegion(const LinearSwitchedSystem& s)
      : s_(&s), items_(static_cast<std::size_t>(s.region_count())) {}
  const T& operator()(int region) {
    std::unique_ptr<T>& item = items_[static_cast<std::size_t>(region)];
    if (!item) item = std::make_unique<T>(*s_, region);
    return *item;
  }

 private:
  const LinearSwitchedSystem* s_;
  std::vector<std::unique_ptr<T>> items_;
};

// The guards of one region as FunctionalValues (a PerRegion's item).
class RegionGuards : public FunctionalValues {
 public:
  RegionGuards(const LinearSwitchedSystem& s, int region)
      : FunctionalValues(s, s.region(region).guards) {}
};

// Interval bounds of an affine functional (a guard or an observable) over every time and every
// state of a box lo <= y <= hi, the tighter of two, each conservative: each row entry and the
// offset ranging apart over their amplitudes (|c cos + s sin| <= hypot(c, s)), then interval
// arithmetic; and the constant part by interval arithmetic plus, per frequency, the amplitude
// of its coefficients' largest values over the box, row and offset together (a force
// k(t) (d - b) near contact then bounds by k's ripple times d - b, not by k's ripple times d
// and b apart). Attained where the functional is constant. Built once per functional, cheap to
// apply (zero entries skipped). When every harmonic of the row and the offset is one pattern
// (p, p0) scaled, to rounding (a mesh force k(t) (d - b) without a transmission error), the
// second bound's amplitude is taken at once: sum over f of hypot(c_f, s_f), times the largest
// |p y + p0| over the box, plus what the pattern leaves out of each harmonic (at rounding) over
// the box: the same bound, one interval for all the harmonics.
class FunctionalBounds {
 public:
  explicit FunctionalBounds(const LinearGuard& g);
  void bounds(const Vector& lo, const Vector& hi, double& low, double& high) const;

 private:
  std::vector<std::pair<Eigen::Index, double>> fixed_;             // constant entries: index, value
  std::vector<std::tuple<Eigen::Index, double, double>> varying_;  // index, least, largest
  double offset_ = 0, offset_spread_ = 0;
  // A frequency's offset coefficients and its row entries [first, last) of harmonic_entries_.
  struct Harmonic {
    std::size_t first = 0, last = 0;
    double offset_cos = 0, offset_sin = 0;
  };
  std::vector<Harmonic> harmonics_;
  std::vector<std::pair<Eigen::Index, double>> varying_constant_;  // varying entries' constants
  std::vector<std::tuple<Eigen::Index, double, double>> harmonic_entries_;  // index, cos, sin
  // The common pattern of the harmonics, when they have one: its entries (index, value, what
  // the pattern leaves out of the harmonics there, summed), its offset and what it leaves out
  // there, and sum over f of hypot(c_f, s_f).
  bool one_pattern_ = false;
  std::vector<std::tuple<Eigen::Index, double, double>> pattern_;
  double pattern_offset_ = 0, pattern_offset_left_out_ = 0, pattern_scale_ = 0;
};

}  // namespace geardyn::ode
