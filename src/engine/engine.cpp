#include "geardyn/engine.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

namespace geardyn::ode {

// ---------------------------------------------------------------------------------------------
// Helpers.

namespace {

// cos(x + m pi / 2) and sin(x + m pi / 2) from c = cos x, s = sin x.
double cos_quarter(double c, double s, int m) {
  switch (m & 3) {
    case 0:
      return c;
    case 1:
      return -s;
    case 2:
      return -c;
    default:
      return s;
  }
}
double sin_quarter(double c, double s, int m) { return cos_quarter(s, -c, m); }

// A forcing frequency is folded into a periodic region's cells (RegionCells::phasor_forced)
// when it is a harmonic of the period to within the rounding of computing it as one.
constexpr double kHarmonicFold = 64 * std::numeric_limits<double>::epsilon();

}  // namespace

std::string EngineOptions::validate() const {
  if (!(tolerance > 0) || !(tolerance < 1e-3))
    return fmt::format("tolerance = {}: must be in (0, 1e-3)", tolerance);
  if (!(cell_rate_product >= 0.05 && cell_rate_product <= 4))
    return fmt::format("cell_rate_product = {}: must be in [0.05, 4]", cell_rate_product);
  if (max_order < 8 || max_order > kMaxOrderAllowed)
    return fmt::format("max_order = {}: must be in [8, {}]", max_order, kMaxOrderAllowed);
  if (max_events_per_cell < 2)
    return fmt::format("max_events_per_cell = {}: must be >= 2", max_events_per_cell);
  if (progress_interval_cells < 1)
    return fmt::format("progress_interval_cells = {}: must be >= 1", progress_interval_cells);
  return {};
}

// ---------------------------------------------------------------------------------------------
// Cells.

namespace {

// Cells per period at most, and halvings of a cell whose series will not converge: far beyond
// any physical case (a 12-DOF gear at 1e4 cells per mesh period), a guard against bad input.
constexpr int kMaxCellsPerPeriod = 1 << 16;
constexpr int kMaxHalvings = 24;
// Bernstein subdivisions before a sign change is taken as a tangency: 2^-48 of a cell is
// below the resolution of time.
constexpr int kMaxSubdivisions = 48;
// Intervals one search may look at: a polynomial whose hull does not separate from zero after
// this many is tangent to it to within rounding (a bound on the work, not on the accuracy).
constexpr int kMaxSearchNodes = 2048;
// Local maxima of one stretch looked at: a stretch is shorter than the fastest period of its
// region, so a polynomial of it has one or two.
constexpr int kMaxLocalExtremes = 16;
// Bits to which a crossing is located (safeguarded Newton on the polynomial), of a cell's
// length, and the iterations that may take.
constexpr int kEventBits = 52;
constexpr std::uintmax_t kEventMaxIterations = 200;
// The rounding level of a guard's polynomial, as a multiple of eps times the sum of its
// coefficients' magnitudes: the Horner error bound for the orders used, with a margin.
constexpr double kGuardRounding = 64 * std::numeric_limits<double>::epsilon();
// The rounding allowed for in a functional's range over a cell (Flow::functional_range), as a
// fraction of the magnitudes summed: the order times the dimension times eps (3e-14 for a
// 12-DOF cell of order 11), with a margin of 30.
constexpr double kRangeRounding = 1e-12;
// The terms of an observable's series over a cell that CellView::range sums exactly (a cubic,
// whose extremes are closed forms); the others are bounded by their magnitudes. At the
// engine's cell length (h times the fastest rate about 1.5) the bounded terms are about a
// twelfth of the whole series' swing.
constexpr int kExactRangeTerms = 4;
// The largest forced excursion of a cell along a guard, in units of the guard's scale, and
// the halvings of a cell spent on it at most (2^-16 of the rate's cell: beyond any physical
// force on a backlash).
constexpr double kMaxCellExcursion = 1.0;
constexpr int kMaxExcursionHalvings = 16;
// A static state of a region whose A0 is singular (a train's free rigid rotation) is accepted
// when it solves A0 y + u0 = 0 to this fraction of |A0| |y| + |u0| (max norms): far above the
// rounding of a least-squares solve, far below any residual a torque left unbalanced gives.
constexpr double kStaticResidual = 1e-12;
// Steps of iterative refinement of a cell's virtual start state at a region entry.
constexpr int kEntryRefinements = 2;
// Cells between exact resynchronisations of the forcing phasors.
constexpr std::int64_t kPhasorResyncCells = 256;
// Cells in one steady jump of a constant-coefficient region without forcing, and at most with.
constexpr int kSteadyBlockCells = 16;
// A whole-period jump whose end is the flow's end t1 to within this many units of rounding of
// the times is taken, the flow then ending at t1: a caller's t1 = t0 + k T and the engine's
// m h differ by a rounding (a sweep settles one period per flow).
constexpr double kEndTimeUlps = 8;
constexpr int kMaxSteadyBlockCells = 4096;

// The Taylor series of one cell, in the scaled variable x = s / h in [0, 1]: a term k is the
// k-th coefficient times h^k.
template <int D>
struct Cell {
  using M = Eigen::Matrix<double, D, D>;
  using V = Eigen::Matrix<double, D, 1>;
  double t_offset_s = 0;               // the cell's start within the coefficient period
  int order = 0;                       // highest term kept
  std::vector<M> phi;                  // Phi_k
  std::vector<V> r0;                   // response to u0
  std::vector<std::vector<V>> rc, rs;  // [forced frequency][k]
  M phi_end;                           // Phi(1)
  V r0_end;
  std::vector<V> rc_end, rs_end;
  // A guard's or observable's series over this cell as a linear form of the cell's start
  // state and forcing phases: g_k = phi_k . z + r0_k + sum_j (C_j rc_jk + S_j rs_jk) (offsets
  // in r0). Cached where every cell has a fixed phase (periodic regions, or constant
  // functionals; RegionCells::functionals_cached); empty otherwise. The guards' are built with
  // the cell; the observables' when a flow first reads one in the region
  // (LazyRegions::with_observables), so a flow that reads none (a shooting) never pays for them.
  struct Functional {
    std::vector<Eigen::Matrix<double, 1, D>> phi;
    std::vector<double> r0;
    std::vector<std::vector<double>> rc, rs;
    // Over the cell |g(x) - g_0| <= swing_row . |z - y_ref| + swing_rest (|C_j|, |S_j| <= 1):
    // swing_row = sum_{k>=1} |phi_k|, swing_rest = sum_{k>=1} (|phi_k . y_ref + r0_k| +
    // sum_j (|rc_jk| + |rs_jk|)); magnitude_rest is swing_rest with the magnitudes of
    // phi_k . y_ref and r0_k, the scale of its rounding.
    Eigen::Matrix<double, 1, D> swing_row;
    double swing_rest = 0, magnitude_rest = 0;
    // The same sums over the terms above kExactRangeTerms - 1 alone: with the first
    // kExactRangeTerms terms summed exactly, they bound the rest (Flow::range).
    Eigen::Matrix<double, 1, D> tail_row;
    double tail_rest = 0;
    // Entry by entry, the magnitudes of the exact terms' packed rows summed: the scale of their
    // rounding is its dot product with |(z, 1, C_1, S_1, ...)|.
    std::vector<double> head_magnitude;
    // The same terms packed row by row, term k's row being (phi_k, r0_k, rc_1k, rs_1k, ...,
    // rc_jk, rs_jk): term k is its row's dot product with (z, 1, C_1, S_1, ...), which reads
    // one contiguous table (Flow::functional_series).
    std::vector<double> packed;
  };
  std::vector<Functional> fn;             // the guards'
  std::vector<Functional> observable_fn;  // the observables'
  M alpha;                                // sum_{k>=1} |Phi_k|
  V beta;  // sum_{k>=1} |Phi_k y_ref + r0_k| + sum_f (|rc_fk| + |rs_fk|)
  // term_weight[k]: the largest entry of |Phi_k| over the same entry of sum_j |Phi_j|, and of
  // each response's term over its sum. Wherever sum_{k>K} x^k term_weight[k] <= tolerance,
  // the terms above K change the state at x by less than the truncation `converged` accepted
  // for the whole cell, entry by entry: a sample at x sums terms 0..K alone. Formed for more
  // than two states when a flow first samples the region (LazyRegions::with_term_weights; the
  // two-state path's 2 x 2 terms are all summed).
  std::vector<double> term_weight;
};

template <int D>
struct RegionCells {
  using M = Eigen::Matrix<double, D, D>;
  using V = Eigen::Matrix<double, D, 1>;
  using R = Eigen::Matrix<double, 1, D>;
  double h = 0;             // cell length, s
  int K = 1;                // cells per coefficient period (1 for constant coefficients)
  V y_ref;                  // a static state of the region (0 when it has none)
  bool has_static = false;  // y_ref solves A0 y + u0 = 0
  std::vector<int> forced;  // frequencies with a forcing term
  std::vector<double> rot_cos, rot_sin;  // cos, sin of w_f h for the forced frequencies
  std::vector<Cell<D>> cells;
  bool functionals_cached = false;  // every cell holds its functionals' forms (Cell::fn)
  // The forced frequencies (positions in `forced`) whose phasors a cached form still reads
  // (Cell::Functional::packed): in a periodic region a harmonic of the coefficient period has
  // the same phase at every start of cell k, so its terms are folded into the form's r0.
  std::vector<int> phasor_forced;
  std::vector<bool> guard_varies;          // the guard's row depends on t
  std::vector<double> guard_offset_swing;  // bound of the offset's change over a cell
  std::vector<R> guard_abs_row;            // |G0|

  // The whole coefficient period (K >= 2 and every guard row constant): its map, its forced
  // responses for period-start phase 0 and pi/2, and a bound of the state's excursion over it,
  // |y(s) - y(0)| <= alpha_T |y(0) - y_ref| + beta_T, so that a period can be jumped.
  bool period_jumps = false;
  M phi_T;
  V r0_T;
  std::vector<V> rc_T, rs_T;
  M alpha_T;
  V beta_T;
  std::vector<double> rot_cos_T, rot_sin_T;  // cos, sin of w_f K h
  std::vector<double> guard_offset_swing_T;  // bound of the offsets' change over a period
  int jump_cells = 0;                        // cells in one jump (K, or the steady block)

  // Constant coefficients whose forced response has a bounded periodic part
  // y_p(t) = y_ref + sum_j (pc_j cos w_j t + ps_j sin w_j t): blocks of jump_cells cells are
  // jumped around it, with |y(s) - y_p(s)| <= alpha_T |y(0) - y_p(0)| over a block (phi_T is
  // the block's map) and every guard at y_p(t) at least guard_floor.
  bool steady_jumps = false;
  std::vector<V> pc, ps;
  V p_swing;                        // sum_j sqrt(pc_j^2 + ps_j^2), entrywise
  std::vector<double> guard_floor;  // min over t of guard i at y_p(t)
};

// The period quantities of RegionCells from its cells (see there).
template <int D>
void build_period(const LinearSwitchedSystem& sys, RegionCells<D>& rc) {
  using M = Eigen::Matrix<double, D, D>;
  using V = Eigen::Matrix<double, D, 1>;
  const int n = sys.dimension;
  const std::size_t nf = rc.forced.size();
  const auto& w = sys.frequencies_rad_s;
  M phi = M::Identity(n, n);  // Phi from the period start to cell k's start
  V p0 = V::Zero(n);          // forced response there, for phases (1, 0) ... split by basis
  std::vector<V> pc(nf, V::Zero(n)), ps(nf, V::Zero(n));
  rc.alpha_T = M::Zero(n, n);
  rc.beta_T = V::Zero(n);
  const M I = M::Identity(n, n);
  for (int k = 0; k < rc.K; ++k) {
    const Cell<D>& cell = rc.cells[k];
    // Excursion bound inside cell k, from the period start.
    V q = ((phi - I) * rc.y_ref + p0).cwiseAbs();
    for (std::size_t j = 0; j < nf; ++j) q += pc[j].cwiseAbs() + ps[j].cwiseAbs();
    const M u = (phi - I).cwiseAbs() + cell.alpha * phi.cwiseAbs();
    const V v = q + cell.alpha * q + cell.beta;
    rc.alpha_T = rc.alpha_T.cwiseMax(u);
    rc.beta_T = rc.beta_T.cwiseMax(v);
    // Advance to the next cell's start: the cell's end maps, with phases rotated by w k h.
    p0 = cell.phi_end * p0 + cell.r0_end;
    for (std::size_t j = 0; j < nf; ++j) {
      const double th = w[rc.forced[j]] * k * rc.h, c = std::cos(th), s = std::sin(th);
      pc[j] = cell.phi_end * pc[j] + c * cell.rc_end[j] + s * cell.rs_end[j];
      ps[j] = cell.phi_end * ps[j] - s * cell.rc_end[j] + c * cell.rs_end[j];
    }
    phi = cell.phi_end * phi;
  }
  rc.phi_T = phi;
  rc.r0_T = p0;
  rc.rc_T = pc;
  rc.rs_T = ps;
  const double T = rc.K * rc.h;
  for (int f : rc.forced) {
    rc.rot_cos_T.push_back(std::cos(w[f] * T));
    rc.rot_sin_T.push_back(std::sin(w[f] * T));
  }
  rc.guard_offset_swing_T.clear();
  for (std::size_t i = 0; i < rc.guard_varies.size(); ++i) rc.guard_offset_swing_T.push_back(0);
  rc.jump_cells = rc.K;
  rc.period_jumps = rc.alpha_T.allFinite() && rc.beta_T.allFinite();
}

// The steady-jump quantities of RegionCells for a region of constant coefficients (see there):
// the periodic particular solution is y_ref (a static state, rc.has_static) plus, per forced
// frequency, the solution of (A0 + i w I)(pc + i ps) = -(uc + i us); none exists without a
// static state or when a forced frequency is an eigenfrequency. A singular A0 (a train's free
// rigid rotation) keeps its static states: the flow around y_p is exact through phi_T.
template <int D>
void build_steady_jumps(const LinearSwitchedSystem& sys, const LinearRegion& reg,
                        RegionCells<D>& rc) {
  using M = Eigen::Matrix<double, D, D>;
  using V = Eigen::Matrix<double, D, 1>;
  using CM = Eigen::Matrix<std::complex<double>, D, D>;
  using CV = Eigen::Matrix<std::complex<double>, D, 1>;
  const int n = sys.dimension;
  const auto& w = sys.frequencies_rad_s;
  if (!rc.has_static) return;
  rc.pc.clear();
  rc.ps.clear();
  rc.p_swing = V::Zero(n);
  double w_min = 0;
  for (int f : rc.forced) {
    CM a = reg.a.constant.template cast<std::complex<double>>();
    a.diagonal().array() += std::complex<double>(0, w[f]);
    Eigen::FullPivLU<CM> lu(a);
    if (!lu.isInvertible()) return;
    CV rhs(n);
    for (int i = 0; i < n; ++i) rhs(i) = -std::complex<double>(reg.u.cos[f](i), reg.u.sin[f](i));
    const CV x = lu.solve(rhs);
    if (!x.allFinite()) return;
    rc.pc.push_back(x.real());
    rc.ps.push_back(x.imag());
    rc.p_swing += x.cwiseAbs();
    w_min = (w_min == 0) ? w[f] : std::min(w_min, w[f]);
  }
  // A block: one period of the slowest forcing (kSteadyBlockCells cells without forcing).
  rc.jump_cells = (w_min > 0)
                      ? static_cast<int>(std::clamp(std::ceil(2 * std::numbers::pi / w_min / rc.h),
                                                    1.0, static_cast<double>(kMaxSteadyBlockCells)))
                      : kSteadyBlockCells;
  const Cell<D>& cell = rc.cells[0];
  const M I = M::Identity(n, n);
  M phi = I;
  rc.alpha_T = M::Zero(n, n);
  for (int k = 0; k < rc.jump_cells; ++k) {
    rc.alpha_T = rc.alpha_T.cwiseMax((I + cell.alpha) * phi.cwiseAbs());
    phi = cell.phi_end * phi;
  }
  rc.phi_T = phi;
  // The guards along y_p: constant part minus the amplitude of each frequency's part.
  rc.guard_floor.clear();
  for (const LinearGuard& q : reg.guards) {
    double floor = q.row.constant.dot(rc.y_ref) + q.offset.constant;
    for (std::size_t f = 0; f < w.size(); ++f) {
      double a = (f < q.offset.cos.size()) ? q.offset.cos[f] : 0.0;
      double b = (f < q.offset.sin.size()) ? q.offset.sin[f] : 0.0;
      for (std::size_t j = 0; j < rc.forced.size(); ++j)
        if (rc.forced[j] == static_cast<int>(f)) {
          a += q.row.constant.dot(rc.pc[j]);
          b += q.row.constant.dot(rc.ps[j]);
        }
      floor -= std::hypot(a, b);
    }
    rc.guard_floor.push_back(floor);
  }
  const double T = rc.jump_cells * rc.h;
  rc.rot_cos_T.clear();
  rc.rot_sin_T.clear();
  for (int f : rc.forced) {
    rc.rot_cos_T.push_back(std::cos(w[f] * T));
    rc.rot_sin_T.push_back(std::sin(w[f] * T));
  }
  rc.steady_jumps = rc.alpha_T.allFinite() && rc.phi_T.allFinite() && rc.p_swing.allFinite() &&
                    std::all_of(rc.guard_floor.begin(), rc.guard_floor.end(),
                                [](double g) { return std::isfinite(g); });
  rc.period_jumps = rc.steady_jumps;
}

// Scaled Taylor coefficients (w h)^m / m! cos(w t0 + m pi/2), ... for m = 0 .. p.
void trig_taylor(double w, double t0, double h, int p, std::vector<double>& c,
                 std::vector<double>& s) {
  c.resize(p + 1);
  s.resize(p + 1);
  const double c0 = std::cos(w * t0), s0 = std::sin(w * t0);
  double f = 1;
  for (int m = 0; m <= p; ++m) {
    if (m > 0) f *= w * h / m;
    c[m] = f * cos_quarter(c0, s0, m);
    s[m] = f * sin_quarter(c0, s0, m);
  }
}

// The series over a cell starting at t0 (length h, p + 1 terms) of an affine functional's
// time-varying parts: its row G(t0 + x h) in G's first p + 1 entries, and its offset (g0
// included). Returns how many row terms it wrote: p + 1, or 0 when the row is constant (G then
// as it was). G only grows, so that its rows keep their storage from one call to the next.
template <class R>
int functional_terms(const LinearSwitchedSystem& sys, const LinearGuard& q, double t0, double h,
                     int p, std::vector<R>& G, std::vector<double>& off) {
  const auto& w = sys.frequencies_rad_s;
  thread_local std::vector<double> tc, ts;  // trig_taylor's, kept between calls
  int terms = 0;
  if (q.row.varies()) {
    terms = p + 1;
    if (G.size() < static_cast<std::size_t>(terms)) G.resize(static_cast<std::size_t>(terms));
    for (int m = 0; m < terms; ++m) G[m].setZero(sys.dimension);
    G[0] = q.row.constant;
    for (std::size_t f = 0; f < w.size(); ++f) {
      if (!q.row.cos[f].any() && !q.row.sin[f].any()) continue;
      trig_taylor(w[f], t0, h, p, tc, ts);
      for (int m = 0; m <= p; ++m) G[m] += tc[m] * q.row.cos[f] + ts[m] * q.row.sin[f];
    }
  }
  off.assign(p + 1, 0.0);
  off[0] = q.offset.constant;
  for (std::size_t f = 0; f < q.offset.cos.size(); ++f) {
    if (q.offset.cos[f] == 0 && q.offset.sin[f] == 0) continue;
    trig_taylor(w[f], t0, h, p, tc, ts);
    for (int m = 0; m <= p; ++m) off[m] += q.offset.cos[f] * tc[m] + q.offset.sin[f] * ts[m];
  }
  return terms;
}

// The series of the functionals in `list` over cell k of `rc` (Cell::fn or
// Cell::observable_fn), into `out`.
template <int D>
void cache_functionals(const LinearSwitchedSystem& sys, const std::vector<LinearGuard>& list,
                       const RegionCells<D>& rc, int k_cell,
                       std::vector<typename Cell<D>::Functional>& out) {
  using R = Eigen::Matrix<double, 1, D>;
  const Cell<D>& cell = rc.cells[static_cast<std::size_t>(k_cell)];
  const double t0 = k_cell * rc.h, h = rc.h;
  const Eigen::Matrix<double, D, 1>& y_ref = rc.y_ref;
  const int p = cell.order;
  const std::size_t nf = cell.rc.size();
  const Eigen::Index n = sys.dimension;
  std::vector<R> G;
  std::vector<double> off;
  // A row's time-varying part (G[m], m >= 1) lies in the columns where some of its cos or sin
  // terms is nonzero (a mesh force's: the mesh's coordinates): those terms are formed on the
  // cell's series at those columns alone, gathered once per set of columns.
  struct Gathered {
    std::vector<Eigen::Index> cols;
    std::vector<Matrix> phi;                // each term's rows at the columns
    std::vector<std::vector<Vector>> resp;  // r0, then rc and rs per forced frequency
  };
  std::vector<Gathered> gathered;  // one per set of columns met (a mesh's), kept for the cell
  std::vector<Eigen::Index> cols;
  std::vector<RowVector> g_cols;  // G[m] at those columns, m >= 1
  out.clear();
  for (const LinearGuard& q : list) {
    int g_terms = functional_terms(sys, q, t0, h, p, G, off);
    if (g_terms == 0) {  // constant: one term
      if (G.empty()) G.resize(1);
      G[0] = q.row.constant;
      g_terms = 1;
    }
    typename Cell<D>::Functional f;
    f.phi.assign(p + 1, R::Zero(n));
    f.r0 = off;
    f.rc.assign(nf, std::vector<double>(p + 1, 0.0));
    f.rs.assign(nf, std::vector<double>(p + 1, 0.0));
    cols.clear();
    for (Eigen::Index c = 0; c < n && g_terms > 1; ++c)
      for (std::size_t w = 0; w < q.row.cos.size(); ++w)
        if (q.row.cos[w][c] != 0 || q.row.sin[w][c] != 0) {
          cols.push_back(c);
          break;
        }
    const bool blocked =
        D == Eigen::Dynamic && g_terms > 1 && 2 * static_cast<Eigen::Index>(cols.size()) <= n;
    const Gathered* at = nullptr;
    if (blocked) {
      auto it = std::find_if(gathered.begin(), gathered.end(),
                             [&](const Gathered& g) { return g.cols == cols; });
      if (it == gathered.end()) {
        Gathered g;
        g.cols = cols;
        g.resp.assign(1 + 2 * nf, {});
        const auto rows_at = [&](const auto& v) {
          Vector out(static_cast<Eigen::Index>(cols.size()));
          for (std::size_t c = 0; c < cols.size(); ++c)
            out[static_cast<Eigen::Index>(c)] = v[cols[c]];
          return out;
        };
        for (int k = 0; k <= p; ++k) {
          Matrix phi(static_cast<Eigen::Index>(cols.size()), n);
          for (std::size_t c = 0; c < cols.size(); ++c)
            phi.row(static_cast<Eigen::Index>(c)) = cell.phi[k].row(cols[c]);
          g.phi.push_back(std::move(phi));
          g.resp[0].push_back(rows_at(cell.r0[k]));
          for (std::size_t j = 0; j < nf; ++j) {
            g.resp[1 + 2 * j].push_back(rows_at(cell.rc[j][k]));
            g.resp[2 + 2 * j].push_back(rows_at(cell.rs[j][k]));
          }
        }
        gathered.push_back(std::move(g));
        it = std::prev(gathered.end());
      }
      at = &*it;
      g_cols.resize(static_cast<std::size_t>(g_terms));
      for (int m = 1; m < g_terms; ++m) {
        g_cols[m].resize(static_cast<Eigen::Index>(cols.size()));
        for (std::size_t c = 0; c < cols.size(); ++c)
          g_cols[m][static_cast<Eigen::Index>(c)] = G[m][cols[c]];
      }
    }
    for (int k = 0; k <= p; ++k) {
      f.phi[k] += G[0] * cell.phi[k];
      f.r0[k] += G[0].dot(cell.r0[k]);
      for (std::size_t j = 0; j < nf; ++j) {
        f.rc[j][k] += G[0].dot(cell.rc[j][k]);
        f.rs[j][k] += G[0].dot(cell.rs[j][k]);
      }
      // No varying column: the terms m >= 1 are zero.
      for (int m = 1; m <= (cols.empty() ? 0 : std::min(k, g_terms - 1)); ++m) {
        if (at) {
          const RowVector& g = g_cols[m];
          f.phi[k] += g * at->phi[k - m];
          f.r0[k] += g.dot(at->resp[0][k - m]);
          for (std::size_t j = 0; j < nf; ++j) {
            f.rc[j][k] += g.dot(at->resp[1 + 2 * j][k - m]);
            f.rs[j][k] += g.dot(at->resp[2 + 2 * j][k - m]);
          }
          continue;
        }
        f.phi[k] += G[m] * cell.phi[k - m];
        f.r0[k] += G[m].dot(cell.r0[k - m]);
        for (std::size_t j = 0; j < nf; ++j) {
          f.rc[j][k] += G[m].dot(cell.rc[j][k - m]);
          f.rs[j][k] += G[m].dot(cell.rs[j][k - m]);
        }
      }
    }
    f.swing_row = R::Zero(n);
    f.tail_row = R::Zero(n);
    for (int k = 1; k <= p; ++k) {
      f.swing_row += f.phi[k].cwiseAbs();
      const double at_ref = f.phi[k].dot(y_ref);
      double rest = std::abs(at_ref + f.r0[k]);
      f.magnitude_rest += f.phi[k].cwiseAbs().dot(y_ref.cwiseAbs()) + std::abs(f.r0[k]);
      for (std::size_t j = 0; j < nf; ++j) {
        const double forced = std::abs(f.rc[j][k]) + std::abs(f.rs[j][k]);
        rest += forced;
        f.magnitude_rest += forced;
      }
      f.swing_rest += rest;
      if (k >= kExactRangeTerms) {
        f.tail_row += f.phi[k].cwiseAbs();
        f.tail_rest += rest;
      }
    }
    // The packed rows: the frequencies without a phasor enter r0 at this cell's phase.
    std::vector<bool> has_phasor(nf, false);
    for (int j : rc.phasor_forced) has_phasor[static_cast<std::size_t>(j)] = true;
    const std::size_t width = static_cast<std::size_t>(n) + 1 + 2 * rc.phasor_forced.size();
    f.packed.resize(width * static_cast<std::size_t>(p + 1));
    for (int k = 0; k <= p; ++k) {
      double* row = f.packed.data() + width * static_cast<std::size_t>(k);
      for (Eigen::Index i = 0; i < n; ++i) row[i] = f.phi[k][i];
      double r0 = f.r0[k];
      for (std::size_t j = 0; j < nf; ++j)
        if (!has_phasor[j]) {
          const double th = sys.frequencies_rad_s[static_cast<std::size_t>(rc.forced[j])] * t0;
          r0 += std::cos(th) * f.rc[j][k] + std::sin(th) * f.rs[j][k];
        }
      row[n] = r0;
      for (std::size_t i = 0; i < rc.phasor_forced.size(); ++i) {
        const auto j = static_cast<std::size_t>(rc.phasor_forced[i]);
        row[n + 1 + 2 * i] = f.rc[j][k];
        row[n + 2 + 2 * i] = f.rs[j][k];
      }
    }
    f.head_magnitude.assign(width, 0.0);
    for (int k = 0; k <= std::min(p, kExactRangeTerms - 1); ++k)
      for (std::size_t c = 0; c < width; ++c)
        f.head_magnitude[c] += std::abs(f.packed[width * static_cast<std::size_t>(k) + c]);
    out.push_back(std::move(f));
  }
}

// Entry by entry, the sum of the terms' magnitudes.
template <class M>
M sum_abs(const std::vector<M>& terms) {
  M sum = terms[0].cwiseAbs();
  for (std::size_t i = 1; i < terms.size(); ++i) sum += terms[i].cwiseAbs();
  return sum;
}

// True when every entry of the last two terms is below tol times the entry's sum of
// magnitudes (entries that are exactly zero throughout pass).
template <class M>
bool converged(const std::vector<M>& terms, double tol) {
  const int k = static_cast<int>(terms.size()) - 1;
  if (k < 4) return false;
  // Entry by entry, with nothing allocated: the sum of magnitudes in sum_abs's order.
  for (Eigen::Index i = 0; i < terms[0].size(); ++i) {
    double sum = std::abs(terms[0].data()[i]);
    for (int j = 1; j <= k; ++j) sum += std::abs(terms[static_cast<std::size_t>(j)].data()[i]);
    const double last = std::abs(terms[static_cast<std::size_t>(k)].data()[i]) +
                        std::abs(terms[static_cast<std::size_t>(k - 1)].data()[i]);
    if (last > tol * sum) return false;
  }
  return true;
}

// The rows and columns of a Fourier series of matrices where some cos or sin term is nonzero:
// the block that holds the series' time-varying part.
struct VaryingBlock {
  std::vector<Eigen::Index> rows, cols;
  Eigen::Index n = 0;

  static VaryingBlock of(const FourierTerms<Matrix>& a, Eigen::Index n) {
    VaryingBlock b;
    b.n = n;
    Eigen::Array<bool, Eigen::Dynamic, 1> r = Eigen::Array<bool, Eigen::Dynamic, 1>::Zero(n),
                                          c = Eigen::Array<bool, Eigen::Dynamic, 1>::Zero(n);
    for (const auto* terms : {&a.cos, &a.sin})
      for (const Matrix& m : *terms)
        for (Eigen::Index j = 0; j < n; ++j)
          for (Eigen::Index i = 0; i < n; ++i)
            if (m(i, j) != 0) r[i] = c[j] = true;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (r[i]) b.rows.push_back(i);
      if (c[i]) b.cols.push_back(i);
    }
    return b;
  }
  // Whether products on the block cost well under the full ones.
  bool pays() const {
    return !rows.empty() && 2 * rows.size() * cols.size() <= static_cast<std::size_t>(n * n);
  }
  // out(rows, :) += x.
  template <class X, class Out>
  void scatter_add(const X& x, Out& out) const {
    for (std::size_t i = 0; i < rows.size(); ++i) out.row(rows[i]) += x.row(i);
  }
};

// The order at which the Taylor series of cos and sin over a cell of wh radians converge as
// `converged` has it (the last two terms within tol of the sum of all), or p_max + 1 when they
// do not within p_max.
int trig_order(double wh, double tol, int p_max) {
  double term = 1, last = 1, sum = 1;
  for (int k = 1; k <= p_max; ++k) {
    last = term;
    term *= std::abs(wh) / k;
    sum += term;
    if (term + last <= tol * sum) return k;
  }
  return p_max + 1;
}

// Expands one cell starting at coefficient phase t0 (absolute time modulo the period), of
// length h; returns false when the series do not converge within max_order terms.
template <int D>
bool expand_cell(const LinearSwitchedSystem& sys, const LinearRegion& reg, const RegionCells<D>& rc,
                 double t0, double h, double tol, int max_order, Cell<D>& cell) {
  using M = Eigen::Matrix<double, D, D>;
  using V = Eigen::Matrix<double, D, 1>;
  const int n = sys.dimension;
  const int p_max = max_order;
  const auto& w = sys.frequencies_rad_s;
  // A(t0 + x h) = sum_m Ahat_m x^m.
  std::vector<M> A(p_max + 1, M::Zero(n, n));
  A[0] = reg.a.constant;
  // Each varying frequency's Taylor coefficients of cos(w_f t) and sin(w_f t) over the cell.
  struct Varying {
    std::size_t f;
    std::vector<double> tc, ts;
  };
  std::vector<Varying> varying;
  if (reg.a.varies()) {
    for (std::size_t f = 0; f < w.size(); ++f) {
      if (!reg.a.cos[f].any() && !reg.a.sin[f].any()) continue;
      Varying& v = varying.emplace_back(Varying{f, {}, {}});
      trig_taylor(w[f], t0, h, p_max, v.tc, v.ts);
      for (int m = 0; m <= p_max; ++m) A[m] += v.tc[m] * reg.a.cos[f] + v.ts[m] * reg.a.sin[f];
    }
  }
  int a_terms = 0;  // A[m] == 0 for m > a_terms
  for (int m = 0; m <= p_max; ++m)
    if (A[m].any()) a_terms = m;
  // The time-varying part of A (A[m], m >= 1) lies in the rows and columns where some Ac_f or
  // As_f is nonzero: for a gear, the mesh stiffness's, a few of a coupled model's. Its products
  // are formed on that block alone (the full products cost n^3 each, of which O(order^2) are
  // needed per cell); the 2-state fast path keeps the plain products.
  const VaryingBlock block = VaryingBlock::of(reg.a, n);
  const bool blocked = D == Eigen::Dynamic && a_terms >= 1 && block.pays();
  std::vector<Matrix> A_block;                 // A[m] on the block, m >= 1
  std::vector<Matrix> phi_cols;                // Phi_k's rows at the block's columns
  std::vector<std::vector<Vector>> resp_cols;  // the same for the forced responses
  // On the block, sum_m A[m] Phi_{k-m} (m >= 1) is also sum_f (Ac_f S^c_f + As_f S^s_f) with
  // S^c_f = sum_m tc_f[m] Phi_{k-m}: two products per varying frequency instead of one per
  // term, once the terms outnumber twice the frequencies (a planetary set's contact region:
  // two frequencies and cells of order 25).
  std::vector<std::array<Matrix, 2>> cos_sin_block;  // per entry of `varying`: Ac_f, As_f
  if (blocked) {
    for (int m = 0; m <= a_terms; ++m) A_block.emplace_back(A[m](block.rows, block.cols));
    for (const Varying& v : varying)
      cos_sin_block.push_back({Matrix(reg.a.cos[v.f](block.rows, block.cols)),
                               Matrix(reg.a.sin[v.f](block.rows, block.cols))});
  }
  const int factored_from = 2 * static_cast<int>(varying.size());

  // Forcing series, per basis: u0; per forced frequency the cos-phase and the sin-phase parts.
  const int nf = static_cast<int>(rc.forced.size());
  // Written into `out` (of size n: its storage kept from one call to the next).
  auto forcing = [&](int basis, int k, V& out) {
    if (basis == 0) {
      if (k == 0)
        out = reg.u.constant;
      else
        out.setZero();
      return;
    }
    const int f = rc.forced[(basis - 1) / 2];
    const bool sin_phase = ((basis - 1) % 2) == 1;
    double fk = 1;
    for (int i = 1; i <= k; ++i) fk *= w[f] * h / i;
    const double ck = cos_quarter(1, 0, k), sk = sin_quarter(1, 0, k);
    const V& uc = reg.u.cos[f];
    const V& us = reg.u.sin[f];
    // cos basis: uc cos(w s) + us sin(w s); sin basis: -uc sin(w s) + us cos(w s).
    if (sin_phase)
      out = fk * (-uc * sk + us * ck);
    else
      out = fk * (uc * ck + us * sk);
  };
  // The guards' and observables' own time-varying parts (a transmission error in an offset,
  // the stiffness in a row) are expanded to the cell's order too (functional_terms): the order
  // is at least what their Taylor series need to converge, even where the state's series
  // converge sooner (a separated mesh whose state the error does not force).
  int functional_order = 0;
  for (const auto* list : {&reg.guards, &reg.observables})
    for (const LinearGuard& q : *list)
      for (std::size_t f = 0; f < w.size(); ++f) {
        const bool row = q.row.varies() && (q.row.cos[f].any() || q.row.sin[f].any());
        const bool offset = !q.offset.cos.empty() && (q.offset.cos[f] != 0 || q.offset.sin[f] != 0);
        if (row || offset)
          functional_order = std::max(functional_order, trig_order(w[f] * h, tol, p_max));
      }
  const int bases = 1 + 2 * nf;
  std::vector<std::vector<V>> resp(bases);
  cell.phi.assign(1, M::Identity(n, n));
  for (int b = 0; b < bases; ++b) resp[b].assign(1, V::Zero(n));

  if (blocked) {
    phi_cols.emplace_back(cell.phi[0](block.cols, Eigen::all));
    resp_cols.resize(bases);
    for (int b = 0; b < bases; ++b) resp_cols[b].emplace_back(resp[b][0](block.cols));
  }
  bool done = false;
  // Kept from one order to the next, so that their storage is allocated once per cell.
  Matrix acc, sum_cos, sum_sin;
  Vector acc_v;
  M next = M::Zero(n, n);
  V v = V::Zero(n);
  for (int k = 0; k < p_max && !done; ++k) {
    const double scale = h / (k + 1);
    next.setZero();
    const int m_last = std::min(k, a_terms);
    if (blocked) {
      next.noalias() += A[0] * cell.phi[k];
      acc = Matrix::Zero(block.rows.size(), n);
      if (m_last > factored_from) {
        for (std::size_t j = 0; j < varying.size(); ++j) {
          const Varying& term = varying[j];
          sum_cos = term.tc[1] * phi_cols[k - 1];
          sum_sin = term.ts[1] * phi_cols[k - 1];
          for (int m = 2; m <= m_last; ++m) {
            sum_cos += term.tc[m] * phi_cols[k - m];
            sum_sin += term.ts[m] * phi_cols[k - m];
          }
          acc.noalias() += cos_sin_block[j][0] * sum_cos;
          acc.noalias() += cos_sin_block[j][1] * sum_sin;
        }
      } else {
        for (int m = 1; m <= m_last; ++m) acc.noalias() += A_block[m] * phi_cols[k - m];
      }
      block.scatter_add(acc, next);
    } else {
      for (int m = 0; m <= m_last; ++m) next.noalias() += A[m] * cell.phi[k - m];
    }
    cell.phi.push_back(scale * next);
    if (blocked) phi_cols.emplace_back(cell.phi.back()(block.cols, Eigen::all));
    for (int b = 0; b < bases; ++b) {
      forcing(b, k, v);
      if (blocked) {
        v.noalias() += A[0] * resp[b][k];
        acc_v = Vector::Zero(block.rows.size());
        for (int m = 1; m <= m_last; ++m) acc_v.noalias() += A_block[m] * resp_cols[b][k - m];
        block.scatter_add(acc_v, v);
      } else {
        for (int m = 0; m <= m_last; ++m) v.noalias() += A[m] * resp[b][k - m];
      }
      resp[b].push_back(scale * v);
      if (blocked) resp_cols[b].emplace_back(resp[b].back()(block.cols));
    }
    done = k + 1 >= functional_order && converged(cell.phi, tol);
    for (int b = 0; b < bases && done; ++b) done = converged(resp[b], tol);
  }
  if (!done) return false;
  cell.order = static_cast<int>(cell.phi.size()) - 1;
  cell.t_offset_s = t0;
  cell.r0 = std::move(resp[0]);
  cell.rc.resize(nf);
  cell.rs.resize(nf);
  for (int j = 0; j < nf; ++j) {
    cell.rc[j] = std::move(resp[1 + 2 * j]);
    cell.rs[j] = std::move(resp[2 + 2 * j]);
  }
  auto sum = [](const auto& terms) {
    auto s = terms[0];
    for (std::size_t i = 1; i < terms.size(); ++i) s += terms[i];
    return s;
  };
  cell.phi_end = sum(cell.phi);
  cell.r0_end = sum(cell.r0);
  cell.rc_end.resize(nf);
  cell.rs_end.resize(nf);
  for (int j = 0; j < nf; ++j) {
    cell.rc_end[j] = sum(cell.rc[j]);
    cell.rs_end[j] = sum(cell.rs[j]);
  }
  cell.alpha = M::Zero(n, n);
  cell.beta = V::Zero(n);
  for (int k = 1; k <= cell.order; ++k) {
    cell.alpha += cell.phi[k].cwiseAbs();
    cell.beta += (cell.phi[k] * rc.y_ref + cell.r0[k]).cwiseAbs();
    for (int j = 0; j < nf; ++j) cell.beta += cell.rc[j][k].cwiseAbs() + cell.rs[j][k].cwiseAbs();
  }
  return true;
}

// Fills cell.term_weight (Cell's comment) from the cell's series.
template <int D>
void weigh_terms(Cell<D>& cell) {
  cell.term_weight.assign(static_cast<std::size_t>(cell.order) + 1, 0.0);
  auto weigh = [&](const auto& terms) {
    const auto total = sum_abs(terms);
    for (int k = 0; k <= cell.order; ++k) {
      const auto& t = terms[static_cast<std::size_t>(k)];
      double& w_k = cell.term_weight[static_cast<std::size_t>(k)];
      for (Eigen::Index i = 0; i < t.size(); ++i)
        if (t.data()[i] != 0) w_k = std::max(w_k, std::abs(t.data()[i]) / total.data()[i]);
    }
  };
  weigh(cell.phi);
  weigh(cell.r0);
  for (std::size_t j = 0; j < cell.rc.size(); ++j) {
    weigh(cell.rc[j]);
    weigh(cell.rs[j]);
  }
}

// The largest eigenvalue modulus of the matrices stacked in `samples` (n x n each, by
// columns), remembered for the last kRateMemoEntries stacks. A study builds an engine for each
// value of its key, and where the key leaves A(t) at the sampled phases as it was (the shaft
// speed only scales time; loads and the transmission error force the state), the matrices and
// so their eigenvalues are the same: the memo returns the value computed before, bit for bit.
// Thread-safe (a sweep builds engines on several threads).
double largest_eigenvalue_modulus(const Matrix& samples) {
  constexpr std::size_t kRateMemoEntries = 8;
  static std::mutex mutex;
  static std::vector<std::pair<Matrix, double>> memo;  // most recent last
  const auto same = [&](const Matrix& m) {
    return m.rows() == samples.rows() && m.cols() == samples.cols() &&
           std::equal(m.data(), m.data() + m.size(), samples.data());
  };
  {
    const std::lock_guard<std::mutex> lock(mutex);
    for (const auto& [m, rho] : memo)
      if (same(m)) return rho;
  }
  const Eigen::Index n = samples.rows();
  double rho = 0;
  for (Eigen::Index i = 0; i < samples.cols() / n; ++i) {
    const Eigen::VectorXcd ev =
        Eigen::EigenSolver<Matrix>(samples.middleCols(i * n, n), false).eigenvalues();
    for (Eigen::Index j = 0; j < ev.size(); ++j) rho = std::max(rho, std::abs(ev[j]));
  }
  const std::lock_guard<std::mutex> lock(mutex);
  if (memo.size() >= kRateMemoEntries) memo.erase(memo.begin());
  memo.emplace_back(samples, rho);
  return rho;
}

// The fastest rate of a region: the largest eigenvalue modulus of A(t) over the period, and
// every frequency its terms hold. A(t) is sampled at kSamples phases of the coefficient period,
// each term's phase from its whole number of cycles in the period (LinearSwitchedSystem::
// validate), so that the samples do not depend on the period's length: the same A(t) at
// another speed gives the same matrices (and the memo's value).
double region_rate(const LinearSwitchedSystem& sys, const LinearRegion& reg) {
  constexpr int kSamples = 16;
  const int samples = reg.a.varies() ? kSamples : 1;
  const Eigen::Index n = sys.dimension;
  const auto& w = sys.frequencies_rad_s;
  Matrix stacked(n, n * samples);
  for (int i = 0; i < samples; ++i) {
    auto A = stacked.middleCols(i * n, n);
    A = reg.a.constant;
    for (std::size_t f = 0; f < reg.a.cos.size(); ++f) {
      if (!reg.a.cos[f].any() && !reg.a.sin[f].any()) continue;
      const double cycles = std::round(w[f] * sys.coefficient_period_s / (2 * std::numbers::pi));
      const double phase = 2 * std::numbers::pi * std::fmod(cycles * i, samples) / samples;
      A += reg.a.cos[f] * std::cos(phase) + reg.a.sin[f] * std::sin(phase);
    }
  }
  double rho = largest_eigenvalue_modulus(stacked);
  for (std::size_t f = 0; f < w.size(); ++f) {
    bool used = reg.a.varies() && (reg.a.cos[f].any() || reg.a.sin[f].any());
    used |= reg.u.varies() && (reg.u.cos[f].any() || reg.u.sin[f].any());
    for (const LinearGuard& q : reg.guards) {
      used |= q.row.varies() && (q.row.cos[f].any() || q.row.sin[f].any());
      used |= !q.offset.cos.empty() && (q.offset.cos[f] != 0 || q.offset.sin[f] != 0);
    }
    if (used) rho = std::max(rho, w[f]);
  }
  return rho;
}

// Coefficients c_0..c_p of a polynomial in x on [0, 1]; Horner.
double horner(const double* c, int p, double x) {
  double v = c[p];
  for (int k = p - 1; k >= 0; --k) v = v * x + c[k];
  return v;
}

// Binomial coefficients up to the largest order, and the ratios C(i, k) / C(p, k) that turn
// power coefficients of degree p into Bernstein ones (no division in the conversion).
struct Binomials {
  std::vector<std::vector<double>> c;
  std::vector<std::vector<std::vector<double>>> ratio;  // [p][i][k], k <= i <= p
  explicit Binomials(int n) : c(n + 1), ratio(n + 1) {
    for (int i = 0; i <= n; ++i) {
      c[i].assign(i + 1, 1.0);
      for (int j = 1; j < i; ++j) c[i][j] = c[i - 1][j - 1] + c[i - 1][j];
    }
    for (int p = 0; p <= n; ++p) {
      ratio[p].resize(p + 1);
      for (int i = 0; i <= p; ++i) {
        ratio[p][i].resize(i + 1);
        for (int k = 0; k <= i; ++k) ratio[p][i][k] = c[i][k] / c[p][k];
      }
    }
  }
};

// Finds the first x in [a, b] at which the polynomial P (coefficients c on [0, 1]) turns
// negative, given P(a) > 0; nullopt when it stays >= 0. Bernstein subdivision: on an interval
// whose Bernstein coefficients are all positive P has no root; with one sign change it has
// exactly one, located by a safeguarded Newton method; otherwise the interval is
// halved (left first).
class RootFinder {
 public:
  // The subdivision buffers are sized once: the recursion holds references into them.
  RootFinder() : binom_(shared_binomials()) {}

  std::optional<double> first_crossing(const std::vector<double>& c, double a, double b) {
    // A lower bound from the coefficients' signs (0 <= a <= x <= b <= 1, so x^k lies between
    // a^k and b^k): positive, no crossing, and no search.
    {
      const int p = static_cast<int>(c.size()) - 1;
      double lower = c[0], ak = 1, bk = 1;
      for (int k = 1; k <= p; ++k) {
        ak *= a;
        bk *= b;
        lower += c[k] >= 0 ? c[k] * ak : c[k] * bk;
      }
      if (lower > 0) return std::nullopt;
    }
    p_ = static_cast<int>(c.size()) - 1;
    coef_ = c;
    bernstein(c, a, b, bern_);
    a_ = a;
    w_ = b - a;
    nodes_ = 0;
    return search(bern_, 0.0, 1.0, 0);
  }

  // The largest value of P over [a, b], and where (x_at): a bound from the coefficients' signs
  // first (no search when it cannot exceed `floor`; the result is then <= floor), then the
  // endpoints, and, unless P's Bernstein coefficients on [a, b] (its convex hull, a bound far
  // tighter than the signs') show that nothing between them exceeds `floor` either, every root
  // of P' at which it turns from positive to negative (a local maximum), found by the Bernstein
  // search.
  double maximum(const std::vector<double>& c, double a, double b, double floor, double& x_at) {
    const int p = static_cast<int>(c.size()) - 1;
    // Bounds from the signs of the coefficients (0 <= a <= x <= b <= 1): an upper bound, and
    // monotony when every coefficient but c_0 has one sign.
    double upper = c[0], ak = 1, bk = 1;
    bool rising = true, falling = true;
    for (int k = 1; k <= p; ++k) {
      ak *= a;
      bk *= b;
      upper += c[k] > 0 ? c[k] * bk : c[k] * ak;
      rising &= c[k] >= 0;
      falling &= c[k] <= 0;
    }
    if (upper <= floor) {
      x_at = a;
      return floor;
    }
    if (rising || falling) {
      x_at = rising ? b : a;
      return std::max(floor, horner(c.data(), p, x_at));
    }
    double best = horner(c.data(), p, a);
    x_at = a;
    if (const double vb = horner(c.data(), p, b); vb > best) {
      best = vb;
      x_at = b;
    }
    if (p < 2) return best;
    if (!(best > floor)) {
      bernstein(c, a, b, hull_);
      if (*std::max_element(hull_.begin(), hull_.end()) <= floor) return best;
    }
    std::vector<double>& d = d_;
    std::vector<double>& minus = minus_;
    d.resize(p);
    minus.resize(p);
    for (int k = 1; k <= p; ++k) {
      d[k - 1] = k * c[k];
      minus[k - 1] = -d[k - 1];
    }
    double x = a;
    for (int i = 0; i < kMaxLocalExtremes && x < b; ++i) {
      if (!(horner(d.data(), p - 1, x) > 0)) {
        // Falling (or flat): on to where P' turns positive.
        const auto up = first_crossing(minus, x, b);
        if (!up || !(*up > x)) break;
        x = *up;
      }
      const auto down = first_crossing(d, x, b);  // P' turns negative: a local maximum
      if (!down || !(*down > x)) break;
      x = *down;
      if (const double v = horner(c.data(), p, x); v > best) {
        best = v;
        x_at = x;
      }
    }
    return best;
  }

 private:
  std::optional<double> search(const std::vector<double>& bern, double u0, double u1, int depth) {
    if (*std::min_element(bern.begin(), bern.end()) > 0) return std::nullopt;
    if (bern[0] <= 0) return x_of(u0);
    int changes = 0;
    for (int i = 1; i <= p_; ++i) changes += (bern[i] <= 0) != (bern[i - 1] <= 0);
    if (changes == 1 && bern[p_] <= 0) return locate(x_of(u0), x_of(u1));
    if (depth >= kMaxSubdivisions || ++nodes_ > kMaxSearchNodes) {
      // A tangency to within the resolution of time: a crossing only if it reaches below 0.
      const double xm = x_of(0.5 * (u0 + u1));
      if (horner(coef_.data(), p_, xm) < 0) return xm;
      return std::nullopt;
    }
    // de Casteljau at u = 1/2, into this depth's buffers.
    std::array<std::vector<double>, 3>& buffers = scratch_[depth];
    std::vector<double>& left = buffers[0];
    std::vector<double>& right = buffers[1];
    std::vector<double>& work = buffers[2];
    left.resize(p_ + 1);
    right.resize(p_ + 1);
    work = bern;
    left[0] = work[0];
    right[p_] = work[p_];
    for (int r = 1; r <= p_; ++r) {
      for (int i = 0; i <= p_ - r; ++i) work[i] = 0.5 * (work[i] + work[i + 1]);
      left[r] = work[0];
      right[p_ - r] = work[p_ - r];
    }
    const double um = 0.5 * (u0 + u1);
    if (auto x = search(left, u0, um, depth + 1)) return x;
    return search(right, um, u1, depth + 1);
  }

  double x_of(double u) const { return a_ + w_ * u; }

  // The Bernstein coefficients on [a, b] of P (coefficients c on [0, 1]).
  void bernstein(const std::vector<double>& c, double a, double b, std::vector<double>& bern) {
    const int p = static_cast<int>(c.size()) - 1;
    // Q(u) = P(a + (b - a) u): Taylor shift by a, then scale.
    q_ = c;
    if (a != 0)
      for (int i = 0; i < p; ++i)
        for (int j = p - 1; j >= i; --j) q_[j] += a * q_[j + 1];
    double scale = 1;
    for (int k = 0; k <= p; ++k) {
      q_[k] *= scale;
      scale *= (b - a);
    }
    bern.resize(p + 1);
    const std::vector<std::vector<double>>& ratio = binom_.ratio[p];
    for (int i = 0; i <= p; ++i) {
      double s = 0;
      for (int k = 0; k <= i; ++k) s += ratio[i][k] * q_[k];
      bern[i] = s;
    }
  }

  // The root of P in [x0, x1], P(x0) > 0 >= P(x1), the only sign change there: the side where
  // P <= 0. Newton's method on the polynomial, kept inside the bracket (a bisection where a
  // step would leave it); the bracket closes to kEventBits.
  double locate(double x0, double x1) const {
    double lo = x0, hi = x1;
    const double p0 = horner(coef_.data(), p_, lo), p1 = horner(coef_.data(), p_, hi);
    if (!(p0 > 0)) return lo;
    if (!(p1 <= 0)) return hi;  // rounding of the hull: the crossing is at the end
    const double resolution = std::ldexp(1.0, -kEventBits);
    double x = lo + (hi - lo) * p0 / (p0 - p1);  // a secant start
    for (std::uintmax_t it = 0; it < kEventMaxIterations && hi - lo > resolution * (1 + hi); ++it) {
      double v = coef_[p_], dv = 0;
      for (int k = p_ - 1; k >= 0; --k) {
        dv = dv * x + v;
        v = v * x + coef_[k];
      }
      if (v > 0) {
        lo = x;
      } else {
        hi = x;
      }
      double next = dv != 0 ? x - v / dv : 0.5 * (lo + hi);
      // Newton from one side never closes the bracket: step just past the estimate.
      next += (v > 0 ? 1 : -1) * resolution * (1 + std::abs(next));
      x = (next > lo && next < hi) ? next : 0.5 * (lo + hi);
    }
    return hi;
  }

  // The tables for every order the options allow, built once for all flows.
  static const Binomials& shared_binomials() {
    static const Binomials table(kMaxOrderAllowed);
    return table;
  }

  const Binomials& binom_;
  int p_ = 0;
  int nodes_ = 0;
  std::vector<double> coef_, bern_, q_, d_, minus_, hull_;
  // Per subdivision depth, held inline (a flow makes one RootFinder: no allocation for it).
  std::array<std::array<std::vector<double>, 3>, kMaxSubdivisions + 1> scratch_;
  double a_ = 0, w_ = 1;
};

// The cells of region r in state dimension D (2: the fast path of one degree of freedom), for
// the rate rho. Throws std::invalid_argument when the series do not converge.
template <int D>
RegionCells<D> build_region(const LinearSwitchedSystem& sys, std::size_t r, double rho,
                            const EngineOptions& options) {
  using V = Eigen::Matrix<double, D, 1>;
  const double tol = std::max(options.tolerance, kRoundingLimit);
  const int n = sys.dimension;
  const auto& w = sys.frequencies_rad_s;
  {
    const LinearRegion& reg = sys.region(r);
    RegionCells<D> rc;
    for (std::size_t f = 0; f < w.size(); ++f)
      if (reg.u.varies() && (reg.u.cos[f].any() || reg.u.sin[f].any()))
        rc.forced.push_back(static_cast<int>(f));
    const double T = sys.coefficient_period_s;
    const bool periodic =
        reg.a.varies() || std::any_of(reg.guards.begin(), reg.guards.end(),
                                      [](const LinearGuard& q) { return q.row.varies(); });
    // The static state: A0 y + u0 = 0, the one where A0 is invertible, the least-squares
    // one where it is singular and the forcing leaves its null directions alone (a train's
    // rigid rotation under balanced torques).
    rc.y_ref = V::Zero(n);
    Eigen::FullPivLU<Matrix> lu(reg.a.constant);
    if (lu.isInvertible()) {
      const Vector y = lu.solve(-reg.u.constant);
      rc.has_static = y.allFinite();
      if (rc.has_static) rc.y_ref = y;
    } else {
      const Vector y =
          Eigen::CompleteOrthogonalDecomposition<Matrix>(reg.a.constant).solve(-reg.u.constant);
      const double residual = (reg.a.constant * y + reg.u.constant).lpNorm<Eigen::Infinity>();
      const double size = reg.a.constant.lpNorm<Eigen::Infinity>() * y.lpNorm<Eigen::Infinity>() +
                          reg.u.constant.lpNorm<Eigen::Infinity>();
      rc.has_static = y.allFinite() && residual <= kStaticResidual * size;
      if (rc.has_static) rc.y_ref = y;
    }
    if (periodic) {
      rc.K = static_cast<int>(std::min<double>(
          kMaxCellsPerPeriod, std::max(1.0, std::ceil(T * rho / options.cell_rate_product))));
      rc.h = T / rc.K;
    } else {
      rc.K = 1;
      rc.h = options.cell_rate_product / rho;
    }
    // A cell whose forced excursion along a guard exceeds the guard's scale sums large terms to
    // a small state (free flight under a large force): shorter cells keep the digits. A force
    // that moves the state across many scales in any cell (or a non-finite one) is left to the
    // flow after kMaxExcursionHalvings, which reports it.
    const auto short_enough = [&](const Cell<D>& cell) {
      for (const LinearGuard& q : reg.guards)
        if (!(q.row.constant.cwiseAbs().dot(cell.beta) <= kMaxCellExcursion * q.scale))
          return false;
      return true;
    };
    for (int halving = 0;; ++halving) {
      rc.cells.assign(rc.K, Cell<D>{});
      // Each cell is judged as it is made: a length too long is given up at its first cell
      // that fails, not after the whole period (a planetary set's contact region built 41
      // cells, to throw them all away for 82, where its first cell already fails).
      const bool excursion_checked = halving < kMaxExcursionHalvings;
      bool ok = true;
      for (int k = 0; k < rc.K && ok; ++k) {
        ok = expand_cell<D>(sys, reg, rc, k * rc.h, rc.h, tol, options.max_order, rc.cells[k]);
        if (ok && excursion_checked) ok = short_enough(rc.cells[k]);
      }
      if (ok) break;
      if (halving >= kMaxHalvings || rc.K * 2 > kMaxCellsPerPeriod)
        throw std::invalid_argument(fmt::format(
            "linear system: region {}: the cell series do not converge (rate {} 1/s)", r, rho));
      if (periodic) rc.K *= 2;
      rc.h /= 2;
    }
    for (int f : rc.forced) {
      rc.rot_cos.push_back(std::cos(w[f] * rc.h));
      rc.rot_sin.push_back(std::sin(w[f] * rc.h));
    }
    for (const LinearGuard& q : reg.guards) {
      rc.guard_varies.push_back(q.row.varies());
      rc.guard_abs_row.push_back(q.row.constant.cwiseAbs());
      double swing = 0;
      for (std::size_t f = 0; f < q.offset.cos.size(); ++f)
        swing +=
            (std::abs(q.offset.cos[f]) + std::abs(q.offset.sin[f])) * std::min(2.0, w[f] * rc.h);
      rc.guard_offset_swing.push_back(swing);
    }
    // Cache the functionals' series where every cell has a fixed phase: the coefficient
    // period's frequencies, which the validation holds rows to; offsets only if theirs fit.
    if (periodic) {
      bool offsets_fit = true;
      for (const auto* list : {&reg.guards, &reg.observables})
        for (const LinearGuard& q : *list)
          for (std::size_t f = 0; f < q.offset.cos.size(); ++f) {
            if (q.offset.cos[f] == 0 && q.offset.sin[f] == 0) continue;
            offsets_fit &= harmonic_of(w[f], T, kHarmonicFit);
          }
      rc.functionals_cached = offsets_fit;
      for (std::size_t j = 0; j < rc.forced.size(); ++j)
        if (!harmonic_of(w[static_cast<std::size_t>(rc.forced[j])], T, kHarmonicFold))
          rc.phasor_forced.push_back(static_cast<int>(j));
    } else {
      bool constant = true;
      for (const auto* list : {&reg.guards, &reg.observables})
        for (const LinearGuard& q : *list) constant &= !q.row.varies() && q.offset.cos.empty();
      rc.functionals_cached = constant;  // one cell (K = 1) at phase 0
      for (std::size_t j = 0; j < rc.forced.size(); ++j)
        rc.phasor_forced.push_back(static_cast<int>(j));
    }
    if (rc.functionals_cached)
      for (int k = 0; k < rc.K; ++k) cache_functionals(sys, reg.guards, rc, k, rc.cells[k].fn);
    const bool rows_constant =
        std::none_of(rc.guard_varies.begin(), rc.guard_varies.end(), [](bool v) { return v; });
    if (!periodic) build_steady_jumps(sys, reg, rc);
    if (rc.K >= 2 && rows_constant) {
      build_period(sys, rc);
      for (std::size_t i = 0; i < reg.guards.size(); ++i) {
        const LinearGuard& q = reg.guards[i];
        double swing = 0;
        for (std::size_t f = 0; f < q.offset.cos.size(); ++f)
          swing += (std::abs(q.offset.cos[f]) + std::abs(q.offset.sin[f])) *
                   std::min(2.0, w[f] * rc.K * rc.h);
        rc.guard_offset_swing_T[i] = swing;
      }
    }
    return rc;
  }
}

// The regions' cells, each built when a flow first enters it (most flows of a gear never
// reach the clipped or the back-side regions). Safe to share between threads.
template <int D>
class LazyRegions {
 public:
  LazyRegions(const LinearSwitchedSystem& sys, const EngineOptions& opt)
      : sys_(&sys),
        opt_(opt),
        cells_(sys.region_count()),
        once_(std::make_unique<std::once_flag[]>(sys.region_count())),
        observables_once_(std::make_unique<std::once_flag[]>(sys.region_count())),
        weights_once_(std::make_unique<std::once_flag[]>(sys.region_count())) {}
  // Throws std::invalid_argument when the region's series do not converge.
  const RegionCells<D>& get(int r) const {
    std::call_once(once_[r], [&] { cells_[r] = build_region<D>(*sys_, r, rate(r), opt_); });
    return cells_[r];
  }
  // get(r), with its cells' observable forms (Cell::observable_fn) where it caches forms.
  const RegionCells<D>& with_observables(int r) const {
    const RegionCells<D>& rc = get(r);
    if (rc.functionals_cached)
      std::call_once(observables_once_[r], [&] {
        RegionCells<D>& w = cells_[r];
        for (int k = 0; k < w.K; ++k)
          cache_functionals(*sys_, sys_->region(r).observables, w, k, w.cells[k].observable_fn);
      });
    return rc;
  }
  // get(r), with its cells' term weights (Cell::term_weight), which only samples read.
  const RegionCells<D>& with_term_weights(int r) const {
    const RegionCells<D>& rc = get(r);
    std::call_once(weights_once_[r], [&] {
      for (Cell<D>& cell : cells_[r].cells) weigh_terms(cell);
    });
    return rc;
  }
  int max_order() const {
    int p = 0;
    for (int r = 0; r < static_cast<int>(cells_.size()); ++r)
      for (const Cell<D>& c : get(r).cells) p = std::max(p, c.order);
    return p;
  }

 private:
  // A region with no rate of its own (free flight with constant forcing) takes the system's.
  double rate(int r) const {
    double rho = region_rate(*sys_, sys_->region(r));
    // The first region with a rate, in their order (a lazy system builds only up to it).
    for (int i = 0; i < sys_->region_count() && !(rho > 0); ++i)
      rho = std::max(rho, region_rate(*sys_, sys_->region(i)));
    if (!(rho > 0)) rho = 1.0 / std::max(sys_->coefficient_period_s, 1.0);
    return rho;
  }

  const LinearSwitchedSystem* sys_;
  EngineOptions opt_;
  mutable std::vector<RegionCells<D>> cells_;
  std::unique_ptr<std::once_flag[]> once_, observables_once_, weights_once_;
};

}  // namespace

struct ExactEngine::Impl {
  LinearSwitchedSystem sys;
  EngineOptions opt;
  // The regions' cells, of fixed-size matrices (no allocation in a flow) for two states (the
  // one-degree model) and four (a pair or a loose gear as a train), dynamic ones otherwise:
  // one of the three is made (with_flow).
  std::unique_ptr<LazyRegions<2>> fixed;
  std::unique_ptr<LazyRegions<4>> fixed4;
  std::unique_ptr<LazyRegions<Eigen::Dynamic>> general;

  template <class F>
  decltype(auto) visit(int region, F&& f) const {
    return fixed    ? f(fixed->get(region))
           : fixed4 ? f(fixed4->get(region))
                    : f(general->get(region));
  }
};

ExactEngine::ExactEngine(LinearSwitchedSystem system, const EngineOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (std::string e = system.validate(); !e.empty())
    throw std::invalid_argument("linear system: " + e);
  if (std::string e = options.validate(); !e.empty())
    throw std::invalid_argument("engine options: " + e);
  Impl& I = *impl_;
  I.sys = std::move(system);
  I.opt = options;
  if (I.sys.dimension == 2) {
    I.fixed = std::make_unique<LazyRegions<2>>(I.sys, options);
  } else if (I.sys.dimension == 4) {
    I.fixed4 = std::make_unique<LazyRegions<4>>(I.sys, options);
  } else {
    I.general = std::make_unique<LazyRegions<Eigen::Dynamic>>(I.sys, options);
  }
}

ExactEngine::~ExactEngine() = default;
ExactEngine::ExactEngine(ExactEngine&&) noexcept = default;
ExactEngine& ExactEngine::operator=(ExactEngine&&) noexcept = default;

const LinearSwitchedSystem& ExactEngine::system() const { return impl_->sys; }
double ExactEngine::cell_length_s(int region) const {
  return impl_->visit(region, [](const auto& rc) { return rc.h; });
}
int ExactEngine::cells_per_period(int region) const {
  return impl_->visit(region, [](const auto& rc) { return rc.K; });
}
int ExactEngine::order(int region) const {
  return impl_->visit(region, [](const auto& rc) {
    int p = 0;
    for (const auto& c : rc.cells) p = std::max(p, c.order);
    return p;
  });
}

// ---------------------------------------------------------------------------------------------
// The flow.

namespace {

// Where the flow is: region, cell, the cell's (virtual) start state and forcing phases.
template <int D>
struct Cursor {
  using V = Eigen::Matrix<double, D, 1>;
  int region = 0;
  std::int64_t m = 0;  // cell index on the region's grid, t_m = m h
  int k = 0;           // m modulo K
  double tm = 0;
  V z;                       // the state the cell's series start from at t_m
  std::vector<double> C, S;  // cos, sin of w_f t_m for the region's forced frequencies
  std::int64_t since_resync = 0;
};

// The least and greatest value of c0 + c1 x + c2 x^2 + c3 x^3 over [a, b]: the ends and the
// real roots of the derivative inside.
inline void cubic_range(const std::array<double, 4>& c, double a, double b, double& low,
                        double& high) {
  const auto at = [&](double x) { return c[0] + x * (c[1] + x * (c[2] + x * c[3])); };
  low = std::min(at(a), at(b));
  high = std::max(at(a), at(b));
  const auto consider = [&](double x) {
    if (!(x > a && x < b)) return;
    const double v = at(x);
    low = std::min(low, v);
    high = std::max(high, v);
  };
  // 3 c3 x^2 + 2 c2 x + c1 = 0, the roots in the form that keeps their precision.
  const double qa = 3 * c[3], qb = 2 * c[2], qc = c[1];
  if (qa == 0) {
    if (qb != 0) consider(-qc / qb);
    return;
  }
  const double disc = qb * qb - 4 * qa * qc;
  if (disc < 0) return;
  const double q = -0.5 * (qb + std::copysign(std::sqrt(disc), qb));
  consider(q / qa);
  if (q != 0) consider(qc / q);
}

template <int D>
class Flow final : public CellView {
  using M = Eigen::Matrix<double, D, D>;
  using V = Eigen::Matrix<double, D, 1>;
  using R = Eigen::Matrix<double, 1, D>;

 public:
  Flow(const LinearSwitchedSystem& sys, const LazyRegions<D>& regions, const EngineOptions& opt)
      : sys_(sys),
        regions_(regions),
        opt_(opt),
        tol_(std::max(opt.tolerance, kRoundingLimit)),
        n_(sys.dimension) {}

  // A region's cells are built on first entry; if its series do not converge the flow ends
  // there with the reason.
  FlowResult run(double t0, const V& y0, int region, double t1, const OutputGrid& out,
                 FlowObserver& obs, bool want_jacobian) {
    try {
      return run_unchecked(t0, y0, region, t1, out, obs, want_jacobian);
    } catch (const std::invalid_argument& e) {
      FlowResult res;
      res.termination = Termination::kDiverged;
      res.message = e.what();
      res.end_time_s = last_t_;
      res.region = cur_.region;
      res.state = last_y_;
      return res;
    }
  }

 private:
  FlowResult run_unchecked(double t0, const V& y0, int region, double t1, const OutputGrid& out,
                           FlowObserver& obs, bool want_jacobian) {
    FlowResult res;
    obs_ = &obs;
    jac_ = want_jacobian;
    double t = t0;
    V y = y0;
    if (jac_) J_ = M::Identity(n_, n_);
    enter(region, t, y, /*snap=*/true);
    if (std::abs(t - cur_.tm) <= start_rounding(t)) t = cur_.tm;
    std::int64_t next_sample = 0;
    auto emit_samples = [&](double upto, bool inclusive) {
      // Two samples or more in the stretch: the cell's coefficients serve them all.
      if (next_sample + 1 < out.count && out.time(next_sample + 1) < upto) ensure_coefficients();
      while (next_sample < out.count &&
             (out.time(next_sample) < upto || (inclusive && out.time(next_sample) <= upto))) {
        const double ts = std::max(out.time(next_sample), t);
        state_at(ts, out_);
        obs.on_sample(ts, out_, cur_.region);
        ++next_sample;
      }
    };
    int events_in_cell = 0;
    std::int64_t since_progress = 0;
    auto finish = [&](Termination term, std::string msg) {
      res.termination = term;
      res.message = std::move(msg);
      res.end_time_s = t;
      res.state = y;
      res.region = cur_.region;
      if (jac_) res.jacobian = J_;
      return res;
    };

    for (;;) {
      const RegionCells<D>& rc = *rc_;
      // A whole coefficient period at once where no guard can cross, no sample falls and the
      // observer needs no detail.
      if (rc.period_jumps && cur_.k == 0 && t == cur_.tm) {
        const double t_end = cur_.tm + rc.jump_cells * rc.h;
        const bool sample_inside = next_sample < out.count && out.time(next_sample) < t_end;
        const double rounding = kEndTimeUlps * std::numeric_limits<double>::epsilon() *
                                std::max(std::abs(t1), std::abs(t_end));
        if (t_end <= t1 + rounding && !sample_inside && jump_period(t_end, obs)) {
          ++res.periods;
          res.cells += rc.jump_cells;
          if (t_end >= t1 - rounding) {  // the block ends the flow
            t = t1;
            y = cur_.z;
            out_ = y;
            obs.on_step(t, out_, cur_.region);
            break;
          }
          t = cur_.tm;
          y = cur_.z;
          out_ = y;
          obs.on_step(t, out_, cur_.region);
          since_progress += rc.jump_cells;
          if (since_progress >= opt_.progress_interval_cells) {
            since_progress = 0;
            if (!obs.on_progress(t))
              return finish(Termination::kCancelled, fmt::format("cancelled at t = {:.9g} s", t));
          }
          continue;
        }
      }
      const Cell<D>& cell = rc.cells[cur_.k];
      coeffs_ready_ = false;
      const double x_start = std::clamp((t - cur_.tm) / rc.h, 0.0, 1.0);
      const double x_stop = std::min(1.0, (t1 - cur_.tm) / rc.h);
      // Bounds of the state over the cell.
      dev_ = (cur_.z - rc.y_ref).cwiseAbs();
      delta_.noalias() = cell.alpha * dev_;
      delta_ += cell.beta;
      // The earliest guard crossing in [x_start, x_stop].
      double x_end = x_stop;
      int crossed = -1;
      const LinearRegion& reg = *reg_;
      for (int i = 0; i < static_cast<int>(reg.guards.size()); ++i) {
        const LinearGuard& q = reg.guards[i];
        const double slack = kGuardSlack * q.scale;
        if (!rc.guard_varies[i]) {
          double g0 = q.row.constant.dot(cur_.z) + q.offset.constant;
          for (std::size_t f = 0; f < q.offset.cos.size(); ++f)
            g0 += q.offset.cos[f] * std::cos(sys_.frequencies_rad_s[f] * cur_.tm) +
                  q.offset.sin[f] * std::sin(sys_.frequencies_rad_s[f] * cur_.tm);
          if (g0 + slack - rc.guard_abs_row[i].dot(delta_) - rc.guard_offset_swing[i] > 0)
            continue;  // cannot cross in this cell
        }
        if (rc.functionals_cached) {
          double low = 0, high = 0;
          functional_range(i, low, high);
          if (low + slack > 0) continue;  // cannot cross in this cell
        }
        guard_series(i, slack);
        if (!std::all_of(gc_.begin(), gc_.end(), [](double c) { return std::isfinite(c); }))
          return finish(Termination::kDiverged,
                        fmt::format("the state became non-finite at t = {:.9g} s", t));
        // The slack is at least the rounding of the guard's polynomial in this cell, so that
        // a state handed over at the edge of the region is not taken as across it.
        double magnitude = 0;
        for (double c : gc_) magnitude += std::abs(c);
        gc_[0] += std::max(0.0, kGuardRounding * magnitude - slack);
        const int degree = static_cast<int>(gc_.size()) - 1;
        if (const double at = horner(gc_.data(), degree, x_start); at <= 0) {
          // A state just handed over at an event sits on the region's edge, where the series
          // are exact but for their truncation: a guard's time-varying offset (a transmission
          // error's harmonics) is expanded at the cell's start and may be off there by more
          // than the slack, and the event's time, to the last bit, leaves the state a little
          // short of the edge or past it. Such a state is across a guard only when its exact
          // value says so and the motion heads out through it; otherwise it would leave at
          // once and come back at once, again and again at one time (a chattering of stays of
          // no length). Inside, the series is moved through the exact value at the edge.
          const bool handed_over = t == last_t_;
          const double exact =
              handed_over ? guard_value(sys_, cur_.region, i, t, last_y_) + slack : at;
          const bool inward = handed_over && horner_derivative(gc_, x_start) > 0;
          if (exact <= 0 && !inward) {
            x_end = x_start;  // already across: leaves at once
            crossed = i;
            break;
          }
          gc_[0] += std::max(exact, slack) - at;
        }
        if (auto x = roots_.first_crossing(gc_, x_start, x_end)) {
          if (*x < x_end || crossed < 0) {
            x_end = *x;
            crossed = i;
          }
        }
      }
      const double t_end = (crossed < 0 && x_end == 1.0)      ? cur_.tm + rc.h
                           : (crossed < 0 && x_end == x_stop) ? t1
                                                              : cur_.tm + x_end * rc.h;
      t_begin_s = t;
      t_end_s = std::max(t, t_end);
      this->region = cur_.region;
      lower_ = cur_.z - delta_;
      upper_ = cur_.z + delta_;
      lower = &lower_;
      upper = &upper_;
      ++stretches_;
      obs.on_cell(*this);
      emit_samples(t_end_s, crossed < 0 && x_end == x_stop && x_stop < 1.0);
      ++res.cells;
      if (crossed >= 0) {
        // An event: the state on the crossed side, the saltation, the new region.
        ensure_coefficients();
        const V ye = poly(x_end);
        if (!ye.allFinite())
          return finish(Termination::kDiverged,
                        fmt::format("the state became non-finite at t = {:.9g} s", t_end_s));
        const int from = cur_.region, to = reg.guards[crossed].target;
        out_ = ye;
        obs.on_step(t_end_s, out_, from);
        if (jac_) {
          const M Jy = phi_at(x_end) * J_;
          guard_series(crossed, 0.0);
          const double dgdt = horner_derivative(gc_, x_end) / rc.h;
          const V f_minus = poly_derivative(x_end) / rc.h;
          const V f_plus = derivative(sys_, to, t_end_s, ye);
          const R G = guard_row(sys_, from, crossed, t_end_s);
          J_ = Jy + (f_plus - f_minus) * (G * Jy) / dgdt;
        }
        obs.on_event(t_end_s, out_, from, to);
        ++res.events;
        t = t_end_s;
        y = ye;
        if (++events_in_cell > opt_.max_events_per_cell)
          return finish(Termination::kNoProgress,
                        fmt::format("{} region changes within one cell of {:.3g} s at t = {:.9g} s "
                                    "(a chattering contact)",
                                    events_in_cell, rc.h, t));
        enter(to, t, y);
        continue;
      }
      events_in_cell = 0;
      if (x_end == 1.0) {
        // A whole cell: the precomputed end maps.
        znext_.noalias() = cell.phi_end * cur_.z;
        znext_ += cell.r0_end;
        for (std::size_t j = 0; j < rc.forced.size(); ++j)
          znext_ += cur_.C[j] * cell.rc_end[j] + cur_.S[j] * cell.rs_end[j];
        if (jac_) J_ = cell.phi_end * J_;
        if (!znext_.allFinite())
          return finish(Termination::kDiverged,
                        fmt::format("the state became non-finite at t = {:.9g} s", cur_.tm + rc.h));
        advance_cell();
        t = cur_.tm;
        y = cur_.z;
        out_ = y;
        obs.on_step(t, out_, cur_.region);
        if (t >= t1) break;
        if (++since_progress >= opt_.progress_interval_cells) {
          since_progress = 0;
          if (!obs.on_progress(t))
            return finish(Termination::kCancelled, fmt::format("cancelled at t = {:.9g} s", t));
        }
        continue;
      }
      // The end of the window inside the cell.
      ensure_coefficients();
      y = poly(x_stop);
      if (jac_) J_ = phi_at(x_stop) * J_;
      t = t1;
      out_ = y;
      obs.on_step(t, out_, cur_.region);
      break;
    }
    emit_samples(t1, true);
    return finish(Termination::kCompleted, "");
  }

  bool extreme(int observable, bool maximum, double beyond, double& value,
               double& t_s) const override {
    const RegionCells<D>& rc = *rc_;
    const int id = static_cast<int>(reg_->guards.size()) + observable;
    if (rc.functionals_cached) {
      // The cell's range first: most cells cannot hold a new extreme.
      observables_ready();
      double low = 0, high = 0;
      functional_range(id, low, high);
      if (maximum ? !(high > beyond) : !(low < beyond)) return false;
    }
    // One series a stretch and observable: its maximum and minimum read the same.
    if (series_stretch_ != stretches_ || series_id_ != id) {
      functional_series(id, 0.0, series_);
      series_stretch_ = stretches_;
      series_id_ = id;
    }
    const std::vector<double>* series = &series_;
    if (!maximum) {
      oc_.resize(series_.size());
      for (std::size_t k = 0; k < series_.size(); ++k) oc_[k] = -series_[k];
      series = &oc_;
    }
    double x = 0;
    const double target = maximum ? beyond : -beyond;
    const double v = roots_.maximum(*series, std::clamp((t_begin_s - cur_.tm) / rc.h, 0.0, 1.0),
                                    std::clamp((t_end_s - cur_.tm) / rc.h, 0.0, 1.0), target, x);
    if (!(v > target)) return false;
    value = maximum ? v : -v;
    t_s = std::clamp(cur_.tm + x * rc.h, t_begin_s, t_end_s);
    return true;
  }

  // The series' first kExactRangeTerms terms (a cubic) exactly over the stretch, the others
  // bounded by their magnitudes (Cell::Functional::tail_row, tail_rest) times x_end^4.
  bool range(int observable, double& low, double& high) const override {
    const RegionCells<D>& rc = *rc_;
    if (!rc.functionals_cached) return false;
    observables_ready();
    const Cell<D>& cell = rc.cells[cur_.k];
    const typename Cell<D>::Functional& f = cell.observable_fn[observable];
    const std::size_t width = packed_stretch_state(rc);
    const std::vector<double>& w = packed_state_;
    std::array<double, kExactRangeTerms> c{};
    const double* row = f.packed.data();
    for (int k = 0; k <= std::min(cell.order, kExactRangeTerms - 1); ++k, row += width) {
      double v = 0;
      for (std::size_t i = 0; i < width; ++i) v += row[i] * w[i];
      c[static_cast<std::size_t>(k)] = v;
    }
    double magnitude = 0;
    for (std::size_t i = 0; i < width; ++i) magnitude += f.head_magnitude[i] * std::abs(w[i]);
    double tail = f.tail_rest;
    for (Eigen::Index i = 0; i < cur_.z.size(); ++i)
      tail += f.tail_row[i] * std::abs(cur_.z[i] - rc.y_ref[i]);
    const double x0 = std::clamp((t_begin_s - cur_.tm) / rc.h, 0.0, 1.0);
    const double x1 = std::clamp((t_end_s - cur_.tm) / rc.h, x0, 1.0);
    tail *= (x1 * x1) * (x1 * x1);
    cubic_range(c, x0, x1, low, high);
    const double reach = tail + kRangeRounding * (magnitude + tail);
    low -= reach;
    high += reach;
    return true;
  }

  void keep(KeptStretches& kept) const override {
    const std::size_t at = kept.values.size(), n = static_cast<std::size_t>(n_);
    kept.stretches.push_back({t_begin_s, t_end_s, cur_.region, cur_.m, at});
    kept.values.resize(at + n + 2 * cur_.C.size());
    double* v = kept.values.data() + at;
    for (std::size_t i = 0; i < n; ++i) v[i] = cur_.z[static_cast<Eigen::Index>(i)];
    v += n;
    for (std::size_t j = 0; j < cur_.C.size(); ++j) {
      v[j] = cur_.C[j];
      v[cur_.C.size() + j] = cur_.S[j];
    }
  }

  // Makes this the view of kept stretch i (ExactEngine::revisit): the cursor as it was when the
  // stretch was kept. Bounds are not kept.
 public:
  void load(const KeptStretches& kept, std::size_t i) {
    const KeptStretches::Stretch& s = kept.stretches[i];
    rc_ = &regions_.get(s.region);
    reg_ = &sys_.region(s.region);
    const RegionCells<D>& rc = *rc_;
    cur_.region = s.region;
    cur_.m = s.cell;
    cur_.tm = static_cast<double>(s.cell) * rc.h;
    cur_.k = static_cast<int>(((s.cell % rc.K) + rc.K) % rc.K);
    const double* v = kept.values.data() + s.values;
    cur_.z = Eigen::Map<const V>(v, n_);
    v += n_;
    const std::size_t nf = rc.forced.size();
    cur_.C.assign(v, v + nf);
    cur_.S.assign(v + nf, v + 2 * nf);
    coeffs_ready_ = false;
    t_begin_s = s.t_begin_s;
    t_end_s = s.t_end_s;
    this->region = s.region;
    lower = nullptr;
    upper = nullptr;
    ++stretches_;  // extreme's series cache is for the stretch before
  }

 private:
  // The highest term a sample at x (in [0, 1]) needs: the least K with
  // sum_{k>K} x^k term_weight[k] <= the tolerance the cell was summed to.
  int sample_order(const Cell<D>& cell, double x) const {
    double power = 1;
    for (int k = 1; k <= cell.order; ++k) power *= x;
    double tail = 0;
    for (int k = cell.order; k > 0; --k) {
      tail += power * cell.term_weight[static_cast<std::size_t>(k)];
      if (tail > tol_) return k;
      if (x > 0) power /= x;
    }
    return 0;
  }

  // With more than two states a sample sums the terms up to sample_order alone: those above it
  // change the state at x by less than the cell's truncation (Cell::term_weight). The two-state
  // path sums every term: there the shorter sums cost more in tighter tolerances than they save
  // (measured in commit 40795e2).
  void state_at(double t_s, Vector& y) const override {
    const double x = std::clamp((t_s - cur_.tm) / rc_->h, 0.0, 1.0);
    if (coeffs_ready_) {
      y = poly(x);
      return;
    }
    const Cell<D>& cell = rc_->cells[cur_.k];
    if constexpr (D == Eigen::Dynamic) {
      // Horner over the state's terms y_k = Phi_k z + r0_k + sum_j (C_j rc_jk + S_j rs_jk),
      // each formed as it is needed: a matrix-vector product per term reads each Phi_k once
      // (Horner over the matrices would also write a matrix per term).
      const int top = sample_order(regions_.with_term_weights(cur_.region).cells[cur_.k], x);
      V& term = sample_term_;
      for (int k = top; k >= 0; --k) {
        term.noalias() = cell.phi[k] * cur_.z;
        term += cell.r0[k];
        for (std::size_t j = 0; j < rc_->forced.size(); ++j)
          term += cur_.C[j] * cell.rc[j][k] + cur_.S[j] * cell.rs[j][k];
        if (k == top)
          y = term;
        else
          y = y * x + term;
      }
      return;
    }
    // Phi(x) z + R(x) term by term: for two states, cheaper than the cell's coefficients for one
    // point.
    M P = cell.phi[cell.order];
    V r = cell.r0[cell.order];
    for (int k = cell.order - 1; k >= 0; --k) {
      P = P * x + cell.phi[k];
      r = r * x + cell.r0[k];
    }
    V v = P * cur_.z + r;
    for (std::size_t j = 0; j < rc_->forced.size(); ++j) {
      V c = cell.rc[j][cell.order], s = cell.rs[j][cell.order];
      for (int k = cell.order - 1; k >= 0; --k) {
        c = c * x + cell.rc[j][k];
        s = s * x + cell.rs[j][k];
      }
      v += cur_.C[j] * c + cur_.S[j] * s;
    }
    y = v;
  }

  // Places the cursor in region r at time t with state y; J_ then maps y0 to z.
  // Enters region r at (t, y). With `snap` (a flow's start), a t within the rounding of the
  // times (kEndTimeUlps) of a cell's start is taken as that start, so that a flow continuing
  // another from its end starts on the cell and may jump whole periods from there.
  void enter(int r, double t, const V& y, bool snap = false) {
    last_t_ = t;
    last_y_ = y;
    rc_ = &regions_.get(r);
    reg_ = &sys_.region(r);
    const RegionCells<D>& rc = *rc_;
    cur_.region = r;
    cur_.m = static_cast<std::int64_t>(std::floor(t / rc.h));
    if (static_cast<double>(cur_.m + 1) * rc.h <= t) ++cur_.m;
    if (static_cast<double>(cur_.m) * rc.h > t) --cur_.m;
    if (snap && static_cast<double>(cur_.m + 1) * rc.h - t <= start_rounding(t)) ++cur_.m;
    cur_.tm = static_cast<double>(cur_.m) * rc.h;
    cur_.k = static_cast<int>(((cur_.m % rc.K) + rc.K) % rc.K);
    coeffs_ready_ = false;
    resync();
    const double x = (t - cur_.tm) / rc.h;
    if (x <= 0 || (snap && t - cur_.tm <= start_rounding(t))) {
      cur_.z = y;
      return;
    }
    // The virtual start: the state at t_m from which the cell's series pass through y at t.
    // The series at x are linear in z: Phi(x) z + f(x), f the forced response alone.
    const M P = phi_at(x);
    cur_.z = V::Zero(n_);
    coeffs_ready_ = false;
    ensure_coefficients();
    const V f = poly(x);
    const Eigen::PartialPivLU<M> lu(P);
    cur_.z = lu.solve(y - f);
    // Phi is badly scaled in physical units (q and q' differ by the rates): refine the solve
    // until the cell's series pass through y to rounding, so that the guard slack holds.
    for (int i = 0; i < kEntryRefinements; ++i) cur_.z += lu.solve(y - (P * cur_.z + f));
    coeffs_ready_ = false;
    if (jac_) J_ = lu.solve(J_);
  }

  double start_rounding(double t) const {
    return kEndTimeUlps * std::numeric_limits<double>::epsilon() * std::max(std::abs(t), rc_->h);
  }

  void resync() {
    const RegionCells<D>& rc = *rc_;
    const auto& w = sys_.frequencies_rad_s;
    cur_.C.resize(rc.forced.size());
    cur_.S.resize(rc.forced.size());
    for (std::size_t j = 0; j < rc.forced.size(); ++j) {
      cur_.C[j] = std::cos(w[rc.forced[j]] * cur_.tm);
      cur_.S[j] = std::sin(w[rc.forced[j]] * cur_.tm);
    }
    cur_.since_resync = 0;
  }

  // Jumps from the start of a period to its end (t_end) if no guard can cross inside it and
  // the observer needs no detail; false, and nothing changed, otherwise.
  bool jump_period(double t_end, FlowObserver& obs) {
    const RegionCells<D>& rc = *rc_;
    if (rc.steady_jumps) return jump_steady(t_end, obs);
    dev_ = (cur_.z - rc.y_ref).cwiseAbs();
    delta_.noalias() = rc.alpha_T * dev_;
    delta_ += rc.beta_T;
    const LinearRegion& reg = *reg_;
    for (int i = 0; i < static_cast<int>(reg.guards.size()); ++i) {
      const LinearGuard& q = reg.guards[i];
      double g0 = q.row.constant.dot(cur_.z) + q.offset.constant;
      for (std::size_t f = 0; f < q.offset.cos.size(); ++f)
        g0 += q.offset.cos[f] * std::cos(sys_.frequencies_rad_s[f] * cur_.tm) +
              q.offset.sin[f] * std::sin(sys_.frequencies_rad_s[f] * cur_.tm);
      if (!(g0 + kGuardSlack * q.scale - rc.guard_abs_row[i].dot(delta_) -
                rc.guard_offset_swing_T[i] >
            0))
        return false;
    }
    t_begin_s = cur_.tm;
    t_end_s = t_end;
    this->region = cur_.region;
    lower_ = cur_.z - delta_;
    upper_ = cur_.z + delta_;
    lower = &lower_;
    upper = &upper_;
    if (obs.needs_detail(*this)) return false;
    znext_.noalias() = rc.phi_T * cur_.z;
    znext_ += rc.r0_T;
    for (std::size_t j = 0; j < rc.forced.size(); ++j)
      znext_ += cur_.C[j] * rc.rc_T[j] + cur_.S[j] * rc.rs_T[j];
    if (!znext_.allFinite()) return false;  // the cells then report the divergence
    if (jac_) J_ = rc.phi_T * J_;
    cur_.m += rc.K;
    cur_.tm = static_cast<double>(cur_.m) * rc.h;
    cur_.z.swap(znext_);
    coeffs_ready_ = false;
    cur_.since_resync += rc.K;
    if (cur_.since_resync >= kPhasorResyncCells) {
      resync();
    } else {
      for (std::size_t j = 0; j < rc.forced.size(); ++j) {
        const double c = cur_.C[j] * rc.rot_cos_T[j] - cur_.S[j] * rc.rot_sin_T[j];
        const double s = cur_.S[j] * rc.rot_cos_T[j] + cur_.C[j] * rc.rot_sin_T[j];
        cur_.C[j] = c;
        cur_.S[j] = s;
      }
    }
    return true;
  }

  // jump_period for a constant-coefficient region, around its periodic particular solution.
  bool jump_steady(double t_end, FlowObserver& obs) {
    const RegionCells<D>& rc = *rc_;
    const std::size_t nf = rc.forced.size();
    out_ = rc.y_ref;  // y_p at the block's start
    for (std::size_t j = 0; j < nf; ++j) out_ += cur_.C[j] * rc.pc[j] + cur_.S[j] * rc.ps[j];
    dev_ = cur_.z - out_;
    delta_.noalias() = rc.alpha_T * dev_.cwiseAbs();
    const LinearRegion& reg = *reg_;
    for (std::size_t i = 0; i < reg.guards.size(); ++i)
      if (!(rc.guard_floor[i] + kGuardSlack * reg.guards[i].scale -
                rc.guard_abs_row[i].dot(delta_) >
            0))
        return false;
    t_begin_s = cur_.tm;
    t_end_s = t_end;
    this->region = cur_.region;
    lower_ = rc.y_ref - rc.p_swing - delta_;
    upper_ = rc.y_ref + rc.p_swing + delta_;
    lower = &lower_;
    upper = &upper_;
    if (obs.needs_detail(*this)) return false;
    // The block's end: the deviation from y_p maps by phi_T, the phasors rotate.
    znext_.noalias() = rc.phi_T * dev_;
    znext_ += rc.y_ref;
    for (std::size_t j = 0; j < nf; ++j) {
      const double c = cur_.C[j] * rc.rot_cos_T[j] - cur_.S[j] * rc.rot_sin_T[j];
      const double s = cur_.S[j] * rc.rot_cos_T[j] + cur_.C[j] * rc.rot_sin_T[j];
      znext_ += c * rc.pc[j] + s * rc.ps[j];
    }
    if (!znext_.allFinite()) return false;  // the cells then report the divergence
    cur_.m += rc.jump_cells;
    cur_.tm = static_cast<double>(cur_.m) * rc.h;
    cur_.since_resync += rc.jump_cells;
    if (cur_.since_resync >= kPhasorResyncCells) {
      resync();
      // y_p at the exact phase, so that the end state agrees with the resynchronised phasors.
      znext_.noalias() = rc.phi_T * dev_;
      znext_ += rc.y_ref;
      for (std::size_t j = 0; j < nf; ++j) znext_ += cur_.C[j] * rc.pc[j] + cur_.S[j] * rc.ps[j];
    } else {
      for (std::size_t j = 0; j < nf; ++j) {
        const double c = cur_.C[j] * rc.rot_cos_T[j] - cur_.S[j] * rc.rot_sin_T[j];
        const double s = cur_.S[j] * rc.rot_cos_T[j] + cur_.C[j] * rc.rot_sin_T[j];
        cur_.C[j] = c;
        cur_.S[j] = s;
      }
    }
    cur_.z.swap(znext_);
    coeffs_ready_ = false;
    if (jac_) J_ = rc.phi_T * J_;
    return true;
  }

  // Moves the cursor to the next cell, whose start state is znext_.
  void advance_cell() {
    const RegionCells<D>& rc = *rc_;
    ++cur_.m;
    cur_.k = (cur_.k + 1 == rc.K) ? 0 : cur_.k + 1;
    cur_.tm = static_cast<double>(cur_.m) * rc.h;
    cur_.z.swap(znext_);
    coeffs_ready_ = false;
    if (++cur_.since_resync >= kPhasorResyncCells) {
      resync();
      return;
    }
    for (std::size_t j = 0; j < rc.forced.size(); ++j) {
      const double c = cur_.C[j] * rc.rot_cos[j] - cur_.S[j] * rc.rot_sin[j];
      const double s = cur_.S[j] * rc.rot_cos[j] + cur_.C[j] * rc.rot_sin[j];
      cur_.C[j] = c;
      cur_.S[j] = s;
    }
  }

  // The state's series over the current cell: y_k = Phi_k z + r0_k + sum (C rc + S rs).
  void ensure_coefficients() const {
    if (coeffs_ready_) return;
    const RegionCells<D>& rc = *rc_;
    const Cell<D>& cell = rc.cells[cur_.k];
    yk_.resize(cell.order + 1);
    for (int k = 0; k <= cell.order; ++k) {
      V v = cell.phi[k] * cur_.z + cell.r0[k];
      for (std::size_t j = 0; j < rc.forced.size(); ++j)
        v += cur_.C[j] * cell.rc[j][k] + cur_.S[j] * cell.rs[j][k];
      yk_[k] = std::move(v);
    }
    coeffs_ready_ = true;
  }

  // Horner in x^2 over the even and the odd terms: two independent chains.
  V poly(double x) const {
    const int p = static_cast<int>(yk_.size()) - 1;
    const double x2 = x * x;
    const int top_even = p - (p % 2), top_odd = p - 1 + (p % 2);
    V even = yk_[top_even];
    V odd = top_odd >= 1 ? yk_[top_odd] : V::Zero(n_);
    for (int k = top_even - 2; k >= 0; k -= 2) even = even * x2 + yk_[k];
    for (int k = top_odd - 2; k >= 1; k -= 2) odd = odd * x2 + yk_[k];
    return even + x * odd;
  }
  V poly_derivative(double x) const {
    const int p = static_cast<int>(yk_.size()) - 1;
    V v = p * yk_[p];
    for (int k = p - 1; k >= 1; --k) v = v * x + k * yk_[k];
    return v;
  }
  M phi_at(double x) const {
    const Cell<D>& cell = rc_->cells[cur_.k];
    M P = cell.phi[cell.order];
    for (int k = cell.order - 1; k >= 0; --k) P = P * x + cell.phi[k];
    return P;
  }
  static double horner_derivative(const std::vector<double>& c, double x) {
    const int p = static_cast<int>(c.size()) - 1;
    double v = p * c[p];
    for (int k = p - 1; k >= 1; --k) v = v * x + k * c[k];
    return v;
  }

  // Bounds of functional `id` (as functional_series) over the whole current cell, from its
  // cached form (RegionCells::functionals_cached; the observables' built): its value at the
  // cell's start plus or minus the swing its form bounds, widened by the rounding of both.
  void functional_range(int id, double& low, double& high) const {
    const RegionCells<D>& rc = *rc_;
    const Cell<D>& cell = rc.cells[cur_.k];
    const int guards = static_cast<int>(reg_->guards.size());
    const typename Cell<D>::Functional& f =
        id < guards ? cell.fn[id] : cell.observable_fn[id - guards];
    double g0 = f.phi[0].dot(cur_.z) + f.r0[0];
    double magnitude = std::abs(f.r0[0]) + f.magnitude_rest;
    for (std::size_t j = 0; j < rc.forced.size(); ++j) {
      g0 += cur_.C[j] * f.rc[j][0] + cur_.S[j] * f.rs[j][0];
      magnitude += std::abs(f.rc[j][0]) + std::abs(f.rs[j][0]);
    }
    double swing = f.swing_rest;
    for (Eigen::Index i = 0; i < cur_.z.size(); ++i) {
      swing += f.swing_row[i] * std::abs(cur_.z[i] - rc.y_ref[i]);
      magnitude += (std::abs(f.phi[0][i]) + f.swing_row[i]) * std::abs(cur_.z[i]);
    }
    const double reach = swing + kRangeRounding * (magnitude + swing);
    low = g0 - reach;
    high = g0 + reach;
  }

  // (z, 1, C_1, S_1, ...) of the current cell into packed_state_, the phasors those the
  // region's cached forms read (RegionCells::phasor_forced); its width.
  std::size_t pack_state(const RegionCells<D>& rc) const {
    const std::size_t n = static_cast<std::size_t>(cur_.z.size());
    const std::size_t width = n + 1 + 2 * rc.phasor_forced.size();
    std::vector<double>& w = packed_state_;
    w.resize(width);
    for (std::size_t i = 0; i < n; ++i) w[i] = cur_.z[static_cast<Eigen::Index>(i)];
    w[n] = 1;
    for (std::size_t i = 0; i < rc.phasor_forced.size(); ++i) {
      const auto j = static_cast<std::size_t>(rc.phasor_forced[i]);
      w[n + 1 + 2 * i] = cur_.C[j];
      w[n + 2 + 2 * i] = cur_.S[j];
    }
    return width;
  }

  // pack_state once a stretch for range (nothing else packs another cursor's state
  // between two calls within one stretch; others repack without asking).
  std::size_t packed_stretch_state(const RegionCells<D>& rc) const {
    if (packed_stretch_ == stretches_)
      return static_cast<std::size_t>(n_) + 1 + 2 * rc.phasor_forced.size();
    packed_stretch_ = stretches_;
    return pack_state(rc);
  }

  // The current region's observable forms built (LazyRegions::with_observables), asked of the
  // regions once per region and flow.
  void observables_ready() const {
    if (observables_ready_.empty()) observables_ready_.assign(sys_.region_count(), 0);
    char& ready = observables_ready_[static_cast<std::size_t>(cur_.region)];
    if (!ready) {
      regions_.with_observables(cur_.region);
      ready = 1;
    }
  }

  // The series of guard i over the current cell, plus `slack`, into gc_.
  void guard_series(int i, double slack) { functional_series(i, slack, gc_); }

  // The series over the current cell of functional `id` (guard id, or observable id - guards)
  // plus `slack`, into gc: from the cell's cached forms, else from the state's coefficients.
  void functional_series(int id, double slack, std::vector<double>& gc) const {
    const RegionCells<D>& rc = *rc_;
    const Cell<D>& cell = rc.cells[cur_.k];
    const int p = cell.order;
    gc.resize(p + 1);
    const LinearRegion& reg = *reg_;
    const int guards = static_cast<int>(reg.guards.size());
    if (rc.functionals_cached && id >= guards) observables_ready();
    if (rc.functionals_cached) {
      const typename Cell<D>::Functional& f =
          id < guards ? cell.fn[id] : cell.observable_fn[id - guards];
      // Each term a dot product of its packed row with (z, 1, C_1, S_1, ...).
      const std::size_t width = pack_state(rc);
      const std::vector<double>& w = packed_state_;
      const double* row = f.packed.data();
      for (int k = 0; k <= p; ++k, row += width) {
        double v = 0;
        for (std::size_t i = 0; i < width; ++i) v += row[i] * w[i];
        gc[k] = v;
      }
      gc[0] += slack;
      return;
    }
    std::fill(gc.begin(), gc.end(), 0.0);
    ensure_coefficients();
    const LinearGuard& q = id < guards ? reg.guards[id] : reg.observables[id - guards];
    if (functional_terms(sys_, q, cur_.tm, rc.h, p, rows_, offs_) == 0) {
      for (int k = 0; k <= p; ++k) gc[k] = q.row.constant.dot(yk_[k]);
    } else {
      for (int k = 0; k <= p; ++k)
        for (int m = 0; m <= k; ++m) gc[k] += rows_[m].dot(yk_[k - m]);
    }
    for (int k = 0; k <= p; ++k) gc[k] += offs_[k];
    gc[0] += slack;
  }

  const LinearSwitchedSystem& sys_;
  const LazyRegions<D>& regions_;
  const RegionCells<D>* rc_ = nullptr;  // the current region's cells
  // The current region (sys_.region(cur_.region), held: a lazy system's lookup is not free).
  const LinearRegion* reg_ = nullptr;
  double last_t_ = 0;  // the last region entry, for a failure's report
  Vector last_y_;
  const EngineOptions& opt_;
  double tol_;  // the truncation the cells were summed to
  mutable RootFinder roots_;
  mutable std::vector<double> oc_;
  mutable std::vector<double> packed_state_;     // (z, 1, C_1, S_1, ...): pack_state's
  mutable std::vector<char> observables_ready_;  // per region: observables_ready's
  mutable std::int64_t packed_stretch_ = -1;     // the stretch packed_stretch_state packed
  // The stretches handed to on_cell so far, and the observable series last formed (for which
  // stretch, of which functional id): extreme's cache.
  std::int64_t stretches_ = 0;
  mutable std::vector<double> series_;
  mutable std::int64_t series_stretch_ = -1;
  mutable int series_id_ = -1;
  int n_;
  FlowObserver* obs_ = nullptr;
  bool jac_ = false;
  M J_;
  Cursor<D> cur_;
  mutable std::vector<V> yk_;
  mutable bool coeffs_ready_ = false;
  mutable V sample_term_;  // state_at's scratch
  std::vector<double> gc_;
  mutable std::vector<R> rows_;
  mutable std::vector<double> offs_;
  V dev_, delta_, znext_;
  Vector lower_, upper_, out_;  // at the observer's interface
};

}  // namespace

namespace {

// Calls f with a flow of I's system on I's regions at its size (ExactEngine::Impl).
template <class Impl, class F>
decltype(auto) with_flow(const Impl& I, F&& f) {
  if (I.fixed) {
    Flow<2> flow(I.sys, *I.fixed, I.opt);
    return f(flow);
  }
  if (I.fixed4) {
    Flow<4> flow(I.sys, *I.fixed4, I.opt);
    return f(flow);
  }
  Flow<Eigen::Dynamic> flow(I.sys, *I.general, I.opt);
  return f(flow);
}

}  // namespace

FlowResult ExactEngine::flow(double t0_s, const Vector& y0, int region, double t1_s,
                             const OutputGrid& output, FlowObserver& observer,
                             bool jacobian) const {
  const Impl& I = *impl_;
  if (std::string e = check_flow_arguments(I.sys, t0_s, y0, region, t1_s); !e.empty())
    throw std::invalid_argument(e);
  return with_flow(
      I, [&](auto& f) { return f.run(t0_s, y0, region, t1_s, output, observer, jacobian); });
}

void ExactEngine::revisit(const KeptStretches& kept,
                          const std::function<void(const Visit&)>& session) const {
  with_flow(*impl_, [&](auto& flow) {
    const Visit visit = [&](const std::vector<std::size_t>& order, const Look& look) {
      for (std::size_t i : order) {
        assert(i < kept.size());
        flow.load(kept, i);
        if (!look(i, flow)) return;
      }
    };
    session(visit);
  });
}

}  // namespace geardyn::ode
