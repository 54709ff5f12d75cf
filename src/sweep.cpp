#include "geardyn/sweep.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numbers>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>

#include "geardyn/case_keys.hpp"
#include "geardyn/figures.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/output.hpp"
#include "geardyn/parallel.hpp"
#include "geardyn/run.hpp"
#include "geardyn/steady.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_steadiness.hpp"
#include "shooting.hpp"

namespace geardyn {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string number_text(double x) { return fmt::format("{:.17g}", x); }

// The share of the steady tolerance that the error of an exact periodic response may take.
constexpr double kResponseErrorShare = 0.1;

// A train point's periodic response in one contact region, exact (steady.hpp's
// affine_response) to within `error` in the section's measure (TrainSections::distance).
struct RegionResponse {
  ode::Vector state;
  double error = 0;
};

// The periodic response of `region`, from a section state y at t that a whole period left in
// it: one period with the Jacobian gives P(y) and M. It stands when M's multipliers lie inside
// the unit circle (the flow settles on it), a period flown from it stays in the region, and its
// error (the engine's tolerance or what that period returns with, whichever is larger, times
// the amplification, in the norm of `scale`, times `gain` into the section's measure) is within
// kResponseErrorShare of the steady tolerance; otherwise nullopt, and the fits judge. A train
// that turns freely is read modulo its rigid motions: `project` takes a state to its part that
// the elements move (rigid_free), in which the response lies.
std::optional<RegionResponse> region_response(const TrainSolver& solver, double t,
                                              const ode::Vector& y, int region, double period_s,
                                              const ode::Vector& scale, double gain,
                                              double engine_tolerance, double steady_tolerance,
                                              const ode::Matrix& project) {
  const ode::FlowResult f = solver.advance_with_jacobian(t, y, t + period_s);
  if (!f.ok() || f.events != 0 || f.region != region || !f.jacobian) return std::nullopt;
  const ode::Matrix monodromy = project * *f.jacobian * project;
  if (!(std::abs(floquet_multipliers(monodromy).front()) < 1)) return std::nullopt;
  const std::optional<AffineResponse> r =
      affine_response(monodromy, project * y, project * f.state, scale);
  if (!r) return std::nullopt;
  const ode::FlowResult back = solver.advance(t, r->state, t + period_s);
  if (!back.ok() || back.events != 0 || back.region != region) return std::nullopt;
  const double noise =
      std::max(engine_tolerance, scaled_norm(project * back.state - r->state, scale));
  const double error = gain * r->amplification * noise;
  if (!(error <= kResponseErrorShare * steady_tolerance)) return std::nullopt;
  return RegionResponse{r->state, error};
}

// A train's state less its rigid motions (train::Assembled::rigid_motions(): the rotation of a
// train no support holds): P = diag(P_q, P_q), P_q = I - R (R^T M R)^-1 R^T M, which keeps what
// the elements move. No element force does work on a rigid motion (K R = 0, C R = 0) and no
// guard reads one (V R = 0), so the flow of P y is P of the flow of y, and a periodic response
// of the train modulo its rotation is a fixed point of P times the period's map. Identity for a
// train without rigid motions; absent when a viscous drag acts on one (C R != 0: the rotation
// and the rest move together, and the fits judge).
std::optional<ode::Matrix> rigid_free(const train::Assembled& a) {
  const Eigen::Index n = a.size();
  const Eigen::MatrixXd r = a.rigid_motions();
  ode::Matrix p = ode::Matrix::Identity(2 * n, 2 * n);
  if (r.cols() == 0) return p;
  for (const train::Drag& d : a.train().drags)
    if (d.viscous_n_m_s_per_rad > 0) return std::nullopt;
  const Eigen::MatrixXd& m = a.mass();
  const Eigen::MatrixXd rm = r.transpose() * m;
  const Eigen::MatrixXd q = Eigen::MatrixXd::Identity(n, n) - r * (rm * r).ldlt().solve(rm);
  p.topLeftCorner(n, n) = q;
  p.bottomRightCorner(n, n) = q;
  return p;
}

// The state a point hands to the next one of its sequence: the coordinates and rates of its
// train (a pair's form's as its train).
struct Carry {
  std::optional<ode::Vector> coordinates;
};

// A train's section period: its system period; when nothing varies, its fastest natural period
// in contact (any period shows rest); when its excitations have no common period
// (quasi-periodic), its reference body's turn, with *quasi saying why.
double train_section_period_s(const TrainSolver& solver, std::string* quasi) {
  std::string why;
  const std::optional<double> t0 = solver.assembled().system_period_s(&why);
  if (t0 && *t0 > 0) return *t0;
  if (t0) return 2 * std::numbers::pi / solver.top_frequency_rad_s();
  if (quasi)
    *quasi = fmt::format(
        "{}: each point runs --max-settle-periods turns of the reference body and is measured "
        "as it is (not judged steady)",
        why);
  return 1.0 / solver.assembled().train().reference_speed_hz;
}

// A sweep's progress as its user hears it (SweepOptions::progress): the points done plus the
// share done of each point under way, one call at a time, in increasing order; once a call
// returns false, stopped() is true for every thread.
class SweepProgress {
 public:
  SweepProgress(std::size_t sequences, std::size_t total, const SweepOptions::Progress& progress)
      : share_(sequences, 0.0), total_(total), progress_(progress) {}

  // The point under way in `sequence` has done `fraction` (in [0, 1)) of its most work.
  bool under_way(std::size_t sequence, double fraction) {
    const std::lock_guard<std::mutex> lock(mutex_);
    share_[sequence] = std::clamp(fraction, 0.0, kMostShare);
    return report();
  }
  // The point under way in `sequence` is done.
  bool point_done(std::size_t sequence) {
    const std::lock_guard<std::mutex> lock(mutex_);
    share_[sequence] = 0;
    ++done_;
    return report();
  }
  bool stopped() const { return stop_.load(); }

 private:
  // A point under way counts at most this much of itself until it is done.
  static constexpr double kMostShare = 0.99;
  bool report() {
    if (stop_) return false;
    const double shares = std::accumulate(share_.begin(), share_.end(), 0.0);
    const double done = static_cast<double>(done_) + shares;
    if (progress_ && done >= last_ && !progress_(done, total_)) stop_ = true;
    last_ = std::max(last_, done);
    return !stop_;
  }
  std::mutex mutex_;
  std::vector<double> share_;
  std::size_t done_ = 0, total_;
  double last_ = 0;
  const SweepOptions::Progress& progress_;
  std::atomic<bool> stop_{false};
};

struct PointJob {
  std::size_t slot;  // index into the result's points
  double value, value2;
  SweepDirection direction;
};

class PointRunner {
 public:
  // Unless a swept key changes the mesh stiffness curve, the stiffness is computed once for the
  // whole sweep (shared_stiffness).
  PointRunner(const Case& base, const SweepOptions& o) : base_(base), o_(o) {
    mesh_ = mesh_to_read(base, o.mesh);
    if (runs_as_train(base)) {
      // A train's meshes come from its own stiffness sources; the mesh read is named. A coupled
      // pair runs as its train (train_form_of), whose bearings and shafts it has.
      const train::Assembled a = assembled_train(base);
      for (const train::Mesh& m : a.train().meshes) meshes_.push_back(m.name);
      groups_ = load_sharing_groups(a);
      for (std::size_t j = 0; j < a.clearances().size(); ++j)
        clearances_.push_back(a.clearance_name(static_cast<int>(j)));
      TrainRunResult named;
      add_parts(a, std::nullopt, named);
      for (const TrainPartQuantity& q : part_quantities(named)) parts_.push_back({q.part, q.what});
      return;
    }
    // A one-degree form's points run on its train too, read as its one mesh; its stiffness is
    // computed once where the swept keys leave it alone.
    std::vector<std::string> keys{o.axis.key};
    if (o.axis2) keys.push_back(o.axis2->key);
    stiffness_ = shared_stiffness(base, keys);
  }

  const std::vector<std::string>& meshes() const { return meshes_; }
  const std::vector<LoadSharingGroup>& load_sharing() const { return groups_; }
  const std::vector<std::string>& clearances() const { return clearances_; }
  const std::vector<SweepPart>& parts() const { return parts_; }
  const std::string& mesh_read() const {
    static const std::string none;
    return meshes_.empty() ? none : meshes_[mesh_];
  }
  // How the points at these values are judged steady when not on the section of their common
  // period ("" when they are): by their statistics window by window, or not at all.
  std::string period_note_at(double value, double value2) const {
    const TrainSolver solver(case_at(value, value2), stiffness());
    std::string note;
    train_section_period_s(solver, &note);
    if (const double window = statistics_window_s(solver.assembled()); window > 0) {
      std::string why;
      const std::optional<double> t0 = solver.assembled().system_period_s(&why);
      return fmt::format(
          "{}: each point is judged steady by its meshes', shafts' and bearings' mean loads and "
          "their standard deviations over windows of whole periods of its slowest excitation "
          "holding 200 cycles of its fastest, {:.4g} s, "
          "each within {:g} of their scale and {:g} of themselves of the window before's, three "
          "in a row, with no decay of the changes predicting more, and measured over "
          "--measure-periods such windows",
          t0 ? fmt::format("a common period of {:.4g} s", *t0) : why, window, kStatisticsTolerance,
          kDynamicTolerance);
    }
    return note;
  }

  Case case_at(double value, double value2) const {
    Case c = base_;
    set(c, o_.axis.key, value);
    if (o_.axis2) set(c, o_.axis2->key, value2);
    return c;
  }

  // The period the point's blocks and strobe are taken at (train_section_period_s).
  double period_at(double value, double value2) const {
    return train_section_period_s(TrainSolver(case_at(value, value2), stiffness()), nullptr);
  }
  // The window the point is judged and measured in (statistics_window_s), or 0 when it is
  // judged on the section of period_at.
  double window_at(double value, double value2) const {
    return statistics_window_s(TrainSolver(case_at(value, value2), stiffness()).assembled());
  }

  // The wall time (s) of the point's first period (or window) from its start, on this machine:
  // a sample of what its periods cost (the exact engine's regions found on the way make it an
  // upper one). NaN when it fails.
  double time_first_period_s(double value, double value2) const {
    const auto start = std::chrono::steady_clock::now();
    const Case c = case_at(value, value2);
    const TrainSolver solver(c, stiffness());
    const double window = statistics_window_s(solver.assembled());
    const double period = window > 0 ? window : train_section_period_s(solver, nullptr);
    try {
      const ode::Vector y =
          solver.initial_state(o_.start_static ? InitialCondition::kStatic : c.solver.initial);
      if (!solver.advance(0, y, period).ok()) return kNaN;
    } catch (const InputError&) {
      return kNaN;
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  // The work one point may do, against the run's bound on the periods of the fastest time
  // scale (run.hpp): up to max_settle + measure system periods. Throws InputError naming the
  // value (a shaft frequency of 1e-300 Hz makes one system period hold 1e303 contact periods).
  void check_work_at(double value, const std::string& where, double value2,
                     const std::string& where2) const {
    Case c = base_;
    set(c, o_.axis.key, value, where);
    if (o_.axis2) set(c, o_.axis2->key, value2, where2);
    // Each end named with the key it sets: "--from 1e-300 of speed.shaft_frequency_hz".
    const std::string first = fmt::format("{} of {}", where, o_.axis.key);
    const std::string both =
        where2.empty() ? first : fmt::format("{} with {} of {}", first, where2, o_.axis2->key);
    const TrainSolver solver(c, stiffness());
    const double window = statistics_window_s(solver.assembled());
    const double period = window > 0 ? window : train_section_period_s(solver, nullptr);
    const double fastest = solver.fastest_period_s(), step = solver.newmark_step_s();
    if (o_.start_static)  // every sequence starts from the static state
      (void)solver.initial_state(InitialCondition::kStatic);
    const int most = o_.max_settle_periods + o_.measure_periods;
    const double window_s = static_cast<double>(most) * period;
    const double periods = window_s / fastest;
    if (!(periods <= kMaxFastestPeriods))
      throw InputError(fmt::format(
          "{}: a point runs up to {} system periods (--max-settle-periods + --measure-periods) "
          "of {:.3g} s each, {:.3g} periods of the case's fastest time scale ({:.3g} s); at "
          "most {:.0e}",
          both, most, period, periods, fastest, kMaxFastestPeriods));
    // The run's bound on Newmark steps (run.hpp), over a point's longest window.
    if (step > 0 && !(window_s / step <= kMaxNewmarkSteps))
      throw InputError(with_origins(
          c, fmt::format("{}: {}: a point runs up to {} system periods (--max-settle-periods + "
                         "--measure-periods) of {:.3g} s each, {:.3g} Newmark steps of {:.3g} s; "
                         "at most {:.0e}",
                         both,
                         c.solver.time_step_s > 0
                             ? fmt::format("solver.time_step_s = {:.6g}", c.solver.time_step_s)
                             : std::string("the automatic Newmark step"),
                         most, period, window_s / step, step, kMaxNewmarkSteps)));
  }

  // Runs one point from `carry` (the previous point's end state) or from the case's initial
  // condition, and leaves its end state in `carry`: every form as its train (run_train_point).
  // under_way(fraction) hears the share of the point's most work done so far (its settling
  // periods or windows over the most it may run, before the measurement); when it returns false
  // the point stops and is not kept (nullopt).
  std::optional<SweepPoint> run(const PointJob& job, Carry& carry,
                                const std::function<bool(double)>& under_way) const {
    return run_train_point(case_at(job.value, job.value2), job, carry, under_way);
  }

 private:
  // Settles period by period on the section, until the predicted distance to a periodic
  // response is below the tolerance or the periods run out: judge() gives the verdict of the
  // section states so far, step() runs one period and adds its section states (false on a
  // numerical failure, which ends the settling). The periods run.
  // The periods before --settle-periods whose section states no verdict will read (all but
  // the last kJudgedSections - 1) are run by bulk(n) in one flow, which adds the state at its
  // end (false on a numerical failure).
  template <class Judge, class Step, class Bulk>
  int settle(Judge&& judge, SteadyVerdict& verdict, Step&& step, Bulk&& bulk) const {
    int k = 0;
    const int unread = std::min(o_.settle_periods, o_.max_settle_periods) - (kJudgedSections - 1);
    if (unread > 0) {
      if (!bulk(unread)) return k;
      k = unread;
    }
    for (;; ++k) {
      if (k >= o_.settle_periods) {
        verdict = judge();
        if (verdict.settled()) break;
      }
      if (k >= o_.max_settle_periods || !step()) break;
    }
    return k;
  }

  // A point's measurement after its settling: whole response periods from t0_s, at least
  // --measure-periods and a multiple of the response's period q T0 (q = 1 when not settled),
  // sampled samples_per_period times a system period.
  struct Measurement {
    int periods, samples_per_period;
    double t1_s;
    ode::OutputGrid grid;
  };
  Measurement measurement(const SteadyVerdict& verdict, double t0_s, double period) const {
    const int q = std::max(verdict.period_multiple, 1);
    const int m = q * ((o_.measure_periods + q - 1) / q), spp = o_.samples_per_period;
    return {m, spp, t0_s + m * period,
            ode::OutputGrid{t0_s, period / spp, static_cast<std::int64_t>(m) * spp}};
  }

  // settle() for a model whose state is a vector (a train): from (t, y) to
  // the section times k period (k T0 from the point's start, as the one-degree point's), each a
  // flow of solver.advance(t, y, t_next) after which seen(flow) hears it with (t, y) moved on
  // and going(k) that k periods are done (false ends the settling); a numerical failure into
  // `failure`, which ends the settling. The periods run.
  template <class FlowSolver, class Judge, class Seen, class Going>
  int settle_flows(const FlowSolver& solver, double period, double& t, ode::Vector& y,
                   Judge&& judge, SteadyVerdict& verdict, std::optional<ode::FlowResult>& failure,
                   Seen&& seen, Going&& going) const {
    int sections = 0;
    const auto to_section = [&](int periods) {
      sections += periods;
      const double t_next = sections * period;
      ode::FlowResult f = solver.advance(t, y, t_next);
      if (!f.ok()) {
        failure = std::move(f);
        return false;
      }
      y = f.state;
      t = t_next;
      seen(f);
      return going(sections);
    };
    return settle(
        judge, verdict, [&] { return to_section(1); }, to_section);
  }

  // Settles a train window by window (train_steadiness.hpp), each window read as a run reads
  // it, until its statistics agree with the window before's (statistics_verdict) after at least
  // --settle-periods windows, or the windows run out
  // (--max-settle-periods). The verdict's error is the change still to come; (t, y) moved on; a
  // numerical failure's reason into `why`; going(k) hears each window k done (false: stop). The
  // windows run.
  template <class Going>
  int settle_statistics(const TrainSolver& solver, double window, double& t, ode::Vector& y,
                        SteadyVerdict& verdict, std::string& why, Going&& going) const {
    const int spp = o_.samples_per_period;
    std::vector<WindowStatistic> last;
    std::vector<double> changes;
    int k = 0;
    while (k < o_.max_settle_periods) {
      ode::Vector end;
      const TrainRunResult r = solver.read(t, y, t + window, ode::OutputGrid{t, window / spp, spp},
                                           t, std::nullopt, {}, &end, /*keep_samples=*/true,
                                           /*keep_states=*/false);
      if (!r.ok()) {
        why = fmt::format("{}: {}", ode::to_string(r.termination), r.message);
        return k;
      }
      t += window;
      y = end;
      ++k;
      std::vector<WindowStatistic> now = window_statistics(r, 0, r.samples.force_n.size());
      const double change = statistics_change(now, last);
      changes.push_back(change);
      verdict = statistics_verdict(changes);
      if (k > o_.settle_periods && verdict.settled()) return k;
      verdict.period_multiple = 0;
      if (!going(k)) return k;
      last = std::move(now);
    }
    return k;
  }

  // A point of the job, its readings yet to come.
  static SweepPoint point_of(const PointJob& job) {
    SweepPoint pt;
    pt.direction = job.direction;
    pt.value = job.value;
    pt.value2 = job.value2;
    return pt;
  }

  // A numerical failure is the point's result: kept with its reason, the sequence goes on
  // from the initial condition.
  static SweepPoint failed(const PointJob& job, Carry& carry, const char* termination,
                           const std::string& message) {
    SweepPoint pt = point_of(job);
    pt.mean_delta_bar = pt.rms_delta_bar = pt.pp_delta_bar = pt.min_delta_bar = kNaN;
    pt.mean_force_bar = pt.rms_force_bar = pt.pp_force_bar = pt.max_force_bar = kNaN;
    pt.separated_fraction = pt.impacts_per_period = kNaN;
    pt.failure = fmt::format("numerical failure ({}): {}", termination, message);
    carry = Carry{};
    return pt;
  }

  // A point of a gear train (or of a pair's form as its train): settled on the section by every
  // mesh's d - e, every shaft's twist and every centre with their rates (TrainSections), or,
  // where the last period stayed in one contact region, by the exact distance of the whole state
  // (modulo the rigid rotation) to that region's periodic response (region_response); measured
  // by the train's reading (train_run.hpp), each mesh into SweepPoint::meshes, each shaft's and
  // bearing's quantity into SweepPoint::parts, and the mesh read (SweepOptions::mesh) into the
  // point's own statistics, as the one-degree point's (F / (b k_m) with the mesh's mean
  // stiffness).
  std::optional<SweepPoint> run_train_point(const Case& c, const PointJob& job, Carry& carry,
                                            const std::function<bool(double)>& under_way) const {
    const TrainSolver solver(c, stiffness());
    const train::Assembled& a = solver.assembled();
    std::string quasi;
    const double window = statistics_window_s(solver.assembled());
    const double period = window > 0 ? window : train_section_period_s(solver, &quasi);
    const auto failed_train = [&](const char* termination, const std::string& message) {
      SweepPoint pt = failed(job, carry, termination, message);
      MeshReading nan;
      for (const MeshColumn& col : kMeshColumns) nan.*col.member = kNaN;
      pt.meshes.assign(meshes_.size(), nan);
      pt.load_sharing.assign(groups_.size(), {kNaN, kNaN});
      pt.clearances.assign(clearances_.size(), {kNaN, kNaN});
      pt.parts.assign(parts_.size(), {kNaN, kNaN});
      return pt;
    };
    // The previous point's end state at a section time (every excitation back at its phase 0),
    // its prescribed bodies as this point prescribes them.
    ode::Vector y;
    if (carry.coordinates && carry.coordinates->size() == 2 * static_cast<Eigen::Index>(a.size())) {
      y = *carry.coordinates;
      a.prescribe(0.0, y);
    } else {
      try {
        y = solver.initial_state(o_.start_static ? InitialCondition::kStatic : c.solver.initial);
      } catch (const InputError& e) {
        return failed_train("no start", e.what());
      }
    }
    TrainSections section(a, solver.top_frequency_rad_s(), c.solver.tolerance);
    double t = 0;
    section.add(t, y);
    // Where the last period stayed in one region, the distance of the state (less its rigid
    // motions) to that region's periodic response is exact (each region's found once, with the
    // exact engine); elsewhere the fits judge. Without a common period there is no section to
    // be steady on.
    const ode::Vector scale = train_state_scale(a, solver.top_frequency_rad_s());
    const double gain = section.gain(scale);
    const std::optional<ode::Matrix> project =
        solver.method() == Method::kExact ? rigid_free(a) : std::nullopt;
    std::map<int, std::optional<RegionResponse>> responses;
    std::optional<int> steady_region;  // the region of a last period without events
    const auto judge = [&] {
      if (!quasi.empty()) return SteadyVerdict{0, std::numeric_limits<double>::infinity()};
      if (steady_region && project) {
        auto [it, fresh] = responses.try_emplace(*steady_region);
        if (fresh)
          it->second = region_response(solver, t, y, *steady_region, period, scale, gain,
                                       c.solver.tolerance, o_.steady_tolerance, *project);
        if (const std::optional<RegionResponse>& r = it->second) {
          const double distance = section.distance(*project * y - r->state) + r->error;
          return SteadyVerdict{distance <= o_.steady_tolerance ? 1 : 0, distance};
        }
      }
      return section.judge(o_.steady_tolerance);
    };
    SteadyVerdict verdict;
    std::optional<ode::FlowResult> failure;
    bool stopped = false;
    const double most = o_.max_settle_periods + o_.measure_periods;
    const auto going = [&](int periods) {
      stopped = stopped || !under_way(periods / most);
      return !stopped;
    };
    int k = 0;
    if (window > 0) {
      std::string why;
      k = settle_statistics(solver, window, t, y, verdict, why, going);
      if (!why.empty()) return failed_train("failed", why);
    } else {
      k = settle_flows(
          solver, period, t, y, judge, verdict, failure,
          [&](const ode::FlowResult& f) {
            // Without events over the flow, its last period had none.
            steady_region = f.events == 0 ? std::optional<int>(f.region) : std::nullopt;
            section.add(t, y);
          },
          going);
    }
    if (stopped) return std::nullopt;
    if (failure) return failed_train(ode::to_string(failure->termination), failure->message);
    const Measurement w = measurement(verdict, t, period);
    const int m = w.periods, spp = w.samples_per_period;
    ode::Vector end;
    const TrainRunResult r =
        solver.read(t, y, w.t1_s, w.grid, w.t1_s - period, std::nullopt, {}, &end,
                    /*keep_samples=*/true, /*keep_states=*/false);
    if (!r.ok()) return failed_train(ode::to_string(r.termination), r.message);
    SweepPoint pt = point_of(job);
    const TrainSamples& smp = r.samples;
    const double count = static_cast<double>(smp.t_s.size());
    // Every mesh in contact throughout and no bearing clearance: the train is linear there.
    bool contact_only = a.clearances().empty();
    for (std::size_t i = 0; i < r.meshes.size(); ++i) {
      const TrainMeshReading& x = r.meshes[i];
      const double b = x.backlash_m;
      MeshReading mr;
      double sd = 0, sd2 = 0;
      for (std::size_t k = 0; k < smp.deflection_bar.size(); ++k) {
        const double d = smp.deflection_bar[k][i];
        sd += d;
        sd2 += d * d;
      }
      mr.mean_delta_bar = sd / count;
      mr.rms_delta_bar = std::sqrt(sd2 / count);
      mr.pp_delta_bar = (x.max_deflection_m - x.min_deflection_m) / b;
      mr.min_delta_bar = x.min_deflection_m / b;
      mr.max_force_n = x.max_force_n;
      mr.dynamic_factor = x.dynamic_factor_with_startup.value_or(kNaN);
      mr.separated_fraction = x.separated_fraction;
      mr.impacts_per_period = static_cast<double>(x.impacts) / m;
      mr.backside_impacts_per_period = static_cast<double>(x.backside_impacts) / m;
      mr.regime = x.regime;
      mr.double_sided = x.double_sided;
      pt.meshes.push_back(mr);
      contact_only =
          contact_only && x.impacts == 0 && x.separations == 0 && x.separated_fraction == 0;
    }
    // Each clearance direction over the whole measurement.
    for (const auto& [k, axis] : a.clearances()) {
      const TrainBearingReading& b = r.bearings[static_cast<std::size_t>(k)];
      const ContactReading& c = axis == 0 ? b.clearance_x : b.clearance_y;
      pt.clearances.push_back({static_cast<double>(c.impacts) / m, c.separated_fraction});
    }
    // Each load-sharing group over the whole measurement.
    for (const TrainLoadSharing& x : r.load_sharing) {
      const LoadSharingGroup& g = groups_[pt.load_sharing.size()];
      const double lost =
          static_cast<double>(std::count_if(g.meshes.begin(), g.meshes.end(), [&](std::size_t m) {
            return left_drive_flank(r.meshes[m]);
          }));
      pt.load_sharing.push_back({x.factor_with_startup.value_or(kNaN), lost});
    }
    // Each shaft's and bearing's quantity over the whole measurement.
    for (const TrainPartQuantity& q : part_quantities(r))
      pt.parts.push_back({std::max(std::abs(q.whole->max), std::abs(q.whole->min)),
                          part_dynamic_factor(r, *q.whole, *q.at_rest).value_or(kNaN)});
    // The mesh read, as the one-degree point reads its mesh.
    const MeshReading& read = pt.meshes[mesh_];
    const TrainMeshReading& x = r.meshes[mesh_];
    const double force_scale = x.backlash_m * x.mean_stiffness_n_per_m;
    double sf = 0, sf2 = 0;
    for (std::size_t i = 0; i < smp.t_s.size(); ++i) {
      const double f = smp.force_n[i][mesh_] / force_scale;
      sf += f;
      sf2 += f * f;
      if (i % static_cast<std::size_t>(spp) == 0) {
        pt.strobe_delta_bar.push_back(smp.deflection_bar[i][mesh_]);
        pt.strobe_velocity_m_s.push_back(smp.deflection_rate_m_s[i][mesh_]);
        pt.strobe_force_bar.push_back(f);
      }
    }
    pt.mean_delta_bar = read.mean_delta_bar;
    pt.rms_delta_bar = read.rms_delta_bar;
    pt.pp_delta_bar = read.pp_delta_bar;
    pt.min_delta_bar = read.min_delta_bar;
    pt.mean_force_bar = sf / count;
    pt.rms_force_bar = std::sqrt(sf2 / count);
    pt.pp_force_bar = (x.max_force_n - x.min_force_n) / force_scale;
    pt.max_force_bar = x.max_force_n / force_scale;
    if (x.dynamic_factor_with_startup) pt.dynamic_factor = x.dynamic_factor_with_startup;
    pt.separated_fraction = read.separated_fraction;
    pt.impacts_per_period = read.impacts_per_period;
    pt.regime = read.regime;
    pt.double_sided = read.double_sided;
    pt.settle_periods = k;
    pt.settled = verdict.settled();
    pt.period_multiple = verdict.period_multiple;
    // Every mesh in contact throughout and no bearing clearance: linear with coefficients of
    // period T0, its one steady response of period T0.
    if (pt.settled && contact_only) pt.period_multiple = 1;
    pt.steady_error = verdict.error;
    carry.coordinates = end;
    // A one-degree form's point is its mesh's statistics alone, as its sweep.csv names no mesh.
    if (meshes_.empty()) pt.meshes.clear();
    return pt;
  }

  // `origin`: how the user gave the value, for messages ("--to -5"); by default the point.
  static void set(Case& c, const std::string& key, double value, std::string origin = {}) {
    if (origin.empty()) origin = fmt::format("--param {} at {}", key, value);
    set_case_value(c, {key, number_text(value), std::move(origin)});
  }

  // The state a sequence starts from (and restarts from after a failed point).
  const Case& base_;
  const SweepOptions& o_;
  // The shared stiffness, or null (each point computes its own).
  const MeshStiffness* stiffness() const { return stiffness_ ? &*stiffness_ : nullptr; }
  std::optional<MeshStiffness> stiffness_;
  std::vector<std::string> meshes_;  // a train's
  std::vector<LoadSharingGroup> groups_;
  std::vector<std::string> clearances_;  // a train's clearance directions
  std::vector<SweepPart> parts_;         // a train's shaft and bearing quantities
  std::size_t mesh_ = 0;                 // the one the points' statistics read
};

// A point measured as it is: not settled, and not failed (Hysteresis, Jump, UnsettledRange).
bool unsettled(const SweepPoint& p) { return !p.settled && p.failure.empty(); }

// Jumps, hysteresis and the stretches of unsettled points of one row (all points of a 1-D
// sweep; one value of the second key of a map), appended to r. `contact_is_linear`: the model is
// linear while the mesh stays in contact (no bearing clearance), so two neighbours both in
// permanent contact lie on one linear response and cannot jump, however steep its resonance.
void read_row_jumps(SweepResult& r, double value2, bool contact_is_linear) {
  const bool map = r.options.axis2.has_value();
  const auto in_row = [&](const SweepPoint& p) { return !map || p.value2 == value2; };
  // Jumps inside each 1-D sequence, in run order.
  for (SweepDirection d : {SweepDirection::kUp, SweepDirection::kDown}) {
    std::vector<const SweepPoint*> seq;
    for (const SweepPoint& p : r.points)
      if (p.direction == d && in_row(p)) seq.push_back(&p);
    auto change = [&](std::size_t i) {  // between seq[i] and seq[i + 1]; 0 outside
      return i + 1 < seq.size() ? std::abs(seq[i + 1]->pp_delta_bar - seq[i]->pp_delta_bar) : 0.0;
    };
    const auto in_contact = [](const SweepPoint* p) {
      return p->impacts_per_period == 0 && p->separated_fraction == 0;
    };
    for (std::size_t i = 0; i + 1 < seq.size(); ++i) {
      if (contact_is_linear && in_contact(seq[i]) && in_contact(seq[i + 1])) continue;
      const double a = seq[i]->pp_delta_bar, b = seq[i + 1]->pp_delta_bar;
      const double neighbours = std::max(i > 0 ? change(i - 1) : 0.0, change(i + 1));
      if (change(i) > kJumpFraction * std::max(std::abs(a), std::abs(b)) &&
          change(i) > kJumpContrast * neighbours)
        r.jumps.push_back({d, seq[i]->value, seq[i + 1]->value, a, b, value2,
                           unsettled(*seq[i]) || unsettled(*seq[i + 1])});
    }
    // The stretches of points that did not settle, in run order.
    for (std::size_t i = 0; i < seq.size(); ++i) {
      if (!unsettled(*seq[i])) continue;
      if (i == 0 || !unsettled(*seq[i - 1]))
        r.unsettled_ranges.push_back({d, seq[i]->value, seq[i]->value, value2, 0});
      r.unsettled_ranges.back().to_value = seq[i]->value;
      ++r.unsettled_ranges.back().points;
    }
  }
  // Hysteresis: where the up and the down sweep differ at the same value.
  std::map<double, std::pair<const SweepPoint*, const SweepPoint*>> by_value;
  for (const SweepPoint& p : r.points)
    if (in_row(p))
      (p.direction == SweepDirection::kUp ? by_value[p.value].first : by_value[p.value].second) =
          &p;
  std::optional<Hysteresis> open;
  for (const auto& [value, pair] : by_value) {
    const auto [up, down] = pair;
    const bool differ = up && down &&
                        std::abs(up->pp_delta_bar - down->pp_delta_bar) >
                            kHysteresisFraction *
                                std::max(std::abs(up->pp_delta_bar), std::abs(down->pp_delta_bar));
    if (differ) {
      if (!open) open = Hysteresis{value, value, value2};
      open->to_value = value;
      open->unsettled = open->unsettled || unsettled(*up) || unsettled(*down);
    } else if (open) {
      r.hysteresis.push_back(*open);
      open.reset();
    }
  }
  if (open) r.hysteresis.push_back(*open);
}

// Jumps and hysteresis, row by row.
void read_jumps(SweepResult& r, bool contact_is_linear) {
  if (!r.options.axis2) return read_row_jumps(r, 0.0, contact_is_linear);
  for (double y : r.options.axis2->values()) read_row_jumps(r, y, contact_is_linear);
}

}  // namespace

std::vector<double> SweepAxis::values() const {
  std::vector<double> v = explicit_values;
  if (!v.empty()) {
    std::sort(v.begin(), v.end());
    return v;
  }
  for (int i = 0; i < points; ++i) {
    const double f = points == 1 ? 0.0 : static_cast<double>(i) / (points - 1);
    v.push_back(log ? from * std::pow(to / from, f) : from + (to - from) * f);
  }
  std::sort(v.begin(), v.end());
  return v;
}

const char* to_string(SweepDirection d) {
  switch (d) {
    case SweepDirection::kUp:
      return "up";
    case SweepDirection::kDown:
      return "down";
    case SweepDirection::kBoth:
      return "both";
  }
  return "?";
}

std::string SweepOptions::validate() const {
  auto axis_error = [](const SweepAxis& a, const char* suffix) -> std::string {
    if (a.key.empty()) return fmt::format("--param{}: a case key is needed", suffix);
    if (std::string why = check_sweepable(a.key); !why.empty())
      return fmt::format("--param{} {}", suffix, why);
    if (!a.explicit_values.empty()) {
      for (double x : a.explicit_values)
        if (!std::isfinite(x)) return fmt::format("values of {}: {} is not finite", a.key, x);
      return "";
    }
    if (!(a.points >= 1 && a.points <= 100000))
      return fmt::format("--points{} = {}: must be a whole number from 1 to 100000", suffix,
                         a.points);
    if (!std::isfinite(a.from) || !std::isfinite(a.to))
      return fmt::format("--from{} = {}, --to{} = {}: must be finite", suffix, a.from, suffix,
                         a.to);
    if (a.log && !(a.from > 0 && a.to > 0))
      return fmt::format("--log with --from{} = {} and --to{} = {}: both must be > 0", suffix,
                         a.from, suffix, a.to);
    return "";
  };
  if (std::string e = axis_error(axis, ""); !e.empty()) return e;
  if (axis2) {
    if (std::string e = axis_error(*axis2, "2"); !e.empty()) return e;
    if (axis2->key == axis.key)
      return fmt::format("--param2 {}: must differ from --param", axis2->key);
    const auto count = [](const SweepAxis& a) {
      return static_cast<double>(a.explicit_values.empty() ? a.points : a.explicit_values.size());
    };
    if (count(axis) * count(*axis2) > kMaxMapPoints)
      return fmt::format("--points {} x --points2 {}: {:.3g} points in the map; at most {:.0e}",
                         count(axis), count(*axis2), count(axis) * count(*axis2), kMaxMapPoints);
  }
  if (!(settle_periods >= 0 && settle_periods <= 1000000))
    return fmt::format("--settle-periods = {}: must be from 0 to 1000000", settle_periods);
  if (!(measure_periods >= 1 && measure_periods <= 100000))
    return fmt::format("--measure-periods = {}: must be from 1 to 100000", measure_periods);
  if (!(max_settle_periods >= settle_periods))
    return fmt::format("--max-settle-periods = {}: must be at least --settle-periods = {}",
                       max_settle_periods, settle_periods);
  if (!(steady_tolerance >= 1e-12 && steady_tolerance <= 0.1))
    return fmt::format("--steady-tolerance = {}: must be from 1e-12 to 0.1 (in units of b)",
                       steady_tolerance);
  // The work asked for at most: every point settling as long as allowed, in both directions.
  const auto count = [](const SweepAxis& a) {
    return static_cast<double>(a.explicit_values.empty() ? a.points : a.explicit_values.size());
  };
  const double points = count(axis) * (axis2 ? count(*axis2) : 1.0) *
                        (direction == SweepDirection::kBoth ? 2.0 : 1.0);
  const double periods = points * (static_cast<double>(max_settle_periods) + measure_periods);
  if (periods > kMaxSweepPeriods)
    return fmt::format(
        "--max-settle-periods = {} with {:.3g} points: up to {:.3g} system periods; at most "
        "{:.0e} (fewer points or a smaller --max-settle-periods)",
        max_settle_periods, points, periods, kMaxSweepPeriods);
  if (!(samples_per_period >= 4 && samples_per_period <= 100000))
    return fmt::format("samples per period = {}: must be from 4 to 100000", samples_per_period);
  return "";
}

std::vector<AxisValue> axis_ends(const SweepAxis& a, const std::string& suffix) {
  std::vector<AxisValue> out;
  if (!a.explicit_values.empty()) {
    // The least and the largest: the others lie between them, as a range's do (and checking
    // each of thousands of values would cost more than a sweep's start may).
    const auto [lo, hi] = std::minmax_element(a.explicit_values.begin(), a.explicit_values.end());
    for (double x : {*lo, *hi}) out.push_back({x, fmt::format("the value {} of {}", x, a.key)});
    return out;
  }
  out.push_back({a.from, fmt::format("--from{} {}", suffix, a.from)});
  out.push_back({a.to, fmt::format("--to{} {}", suffix, a.to)});
  return out;
}

void check_axes_read(const Case& c, const SweepAxis& axis, const SweepAxis* axis2) {
  const auto corners = [](const SweepAxis& a, const std::string& suffix, const SweepAxis* b,
                          const std::string& suffix_b) {
    std::vector<std::vector<Override>> out;
    const auto set = [](const SweepAxis& x, const AxisValue& v) {
      return Override{x.key, fmt::format("{:.17g}", v.value), v.origin};
    };
    for (const AxisValue& x : axis_ends(a, suffix)) {
      if (!b) {
        out.push_back({set(a, x)});
        continue;
      }
      for (const AxisValue& y : axis_ends(*b, suffix_b)) out.push_back({set(a, x), set(*b, y)});
    }
    return out;
  };
  const auto check = [&](const SweepAxis& a, const std::string& suffix, const SweepAxis* b,
                         const std::string& suffix_b) {
    if (const std::string why = unread_study_key(c, corners(a, suffix, b, suffix_b)); !why.empty())
      throw InputError(
          fmt::format("--param{} {}: the study would vary a key this case does not "
                      "read: {}",
                      suffix, a.key, why));
  };
  check(axis, "", axis2, "2");
  if (axis2) check(*axis2, "2", &axis, "");
}

namespace {

// Every value the sweep sets, against its key's bounds and the work a point may do, before
// any work: the ends of each range (its values lie between them, and the work per point grows
// toward one end: the system period shrinks with the speed faster than the fastest time scale
// does), the corners of a map, the least and largest given value.
void check_sweep(const Case& base, const SweepOptions& o, const PointRunner& runner) {
  if (const std::string e = o.validate(); !e.empty()) throw InputError(e);
  const std::vector<AxisValue> rows2 =
      o.axis2 ? axis_ends(*o.axis2, "2") : std::vector<AxisValue>{{0.0, ""}};
  for (const AxisValue& y : rows2)
    for (const AxisValue& x : axis_ends(o.axis, ""))
      runner.check_work_at(x.value, x.origin, y.value, y.origin);
  check_axes_read(base, o.axis, o.axis2 ? &*o.axis2 : nullptr);
}

// How a point whose statistics window is `window_s` (0: judged on its section) is judged
// steady (SweepResult::steadiness).
std::string steadiness(const SweepOptions& o, double window_s) {
  if (window_s > 0)
    return fmt::format(
        "every mesh's, shaft's and bearing's mean load within {:g} of its scale and its "
        "standard deviation within {:g} of itself from window to window of {:.4g} s, three "
        "windows in a row, with no decay of the changes predicting more",
        kStatisticsTolerance, kDynamicTolerance, window_s);
  return fmt::format("predicted distance to the periodic response under {:g} b",
                     o.steady_tolerance);
}

// The up and down sequences of each row (SweepOptions::direction).
std::size_t sequence_count(const SweepOptions& o) {
  const std::size_t rows = o.axis2 ? o.axis2->values().size() : 1;
  return rows * (o.direction == SweepDirection::kBoth ? 2 : 1);
}

}  // namespace

double SweepPlan::least_wall_s() const {
  return static_cast<double>(points) * least_periods * first_period_wall_s / std::max(threads, 1U);
}
double SweepPlan::most_wall_s() const {
  return static_cast<double>(points) * most_periods * first_period_wall_s / std::max(threads, 1U);
}

SweepPlan plan_sweep(const Case& base, const SweepOptions& o) {
  if (const std::string e = o.validate(); !e.empty()) throw InputError(e);
  const PointRunner runner(base, o);
  check_sweep(base, o, runner);
  SweepPlan p;
  const std::size_t rows = o.axis2 ? o.axis2->values().size() : 1;
  p.points = rows * o.axis.values().size() * (o.direction == SweepDirection::kBoth ? 2 : 1);
  const unsigned cores =
      o.threads > 0 ? o.threads : std::max(1U, std::thread::hardware_concurrency());
  p.threads = static_cast<unsigned>(std::min<std::size_t>(cores, sequence_count(o)));
  const double x = o.axis.values().front(), y = o.axis2 ? o.axis2->values().front() : 0.0;
  const double window = runner.window_at(x, y);
  p.period_s = window > 0 ? window : runner.period_at(x, y);
  p.steadiness = steadiness(o, window);
  p.least_periods = std::max(o.settle_periods, 2) + o.measure_periods;
  p.most_periods = o.max_settle_periods + o.measure_periods;
  p.first_period_wall_s = runner.time_first_period_s(x, y);
  return p;
}

namespace {
// Each sequence's first point with impacts (SweepResult::impact_onsets), the points being in
// sweep order: each row's up sequence, then its down one.
void read_impact_onsets(SweepResult& r) {
  std::vector<std::pair<SweepDirection, double>> seen;
  for (const SweepPoint& p : r.points) {
    const std::pair<SweepDirection, double> sequence{p.direction, p.value2};
    if (std::find(seen.begin(), seen.end(), sequence) != seen.end()) continue;
    ImpactOnset onset{p.direction, p.value, p.value2, {}};
    for (std::size_t m = 0; m < p.meshes.size(); ++m)
      if (p.meshes[m].impacts_per_period > 0) onset.meshes.push_back(r.meshes[m]);
    if (onset.meshes.empty() && !(p.impacts_per_period > 0)) continue;
    seen.push_back(sequence);
    r.impact_onsets.push_back(std::move(onset));
  }
}
}  // namespace

SweepResult sweep(const Case& base, const SweepOptions& o) {
  if (const std::string e = o.validate(); !e.empty()) throw InputError(e);
  const auto start = std::chrono::steady_clock::now();
  SweepResult r;
  r.options = o;
  r.form = base.model.form;
  r.unused_settings = unused_settings(base);
  const PointRunner runner(base, o);
  check_sweep(base, o, runner);
  const double first2 = o.axis2 ? o.axis2->values().front() : 0.0;
  r.steadiness = steadiness(o, runner.window_at(o.axis.values().front(), first2));
  r.period_s = runner.period_at(o.axis.values().front(), first2);
  r.period_note = runner.period_note_at(o.axis.values().front(), first2);
  r.meshes = runner.meshes();
  r.load_sharing = runner.load_sharing();
  r.clearances = runner.clearances();
  r.parts = runner.parts();
  r.mesh = runner.mesh_read();

  // The sequences: for each row, the up sweep and/or the down sweep.
  std::vector<std::vector<PointJob>> sequences;
  const std::vector<double> xs = o.axis.values();
  const std::vector<double> rows = o.axis2 ? o.axis2->values() : std::vector<double>{0.0};
  std::size_t slot = 0;
  for (double y : rows) {
    if (o.direction != SweepDirection::kDown) {
      std::vector<PointJob> seq;
      seq.reserve(xs.size());
      for (double x : xs) seq.push_back({slot++, x, y, SweepDirection::kUp});
      sequences.push_back(std::move(seq));
    }
    if (o.direction != SweepDirection::kUp) {
      std::vector<PointJob> seq;
      for (auto it = xs.rbegin(); it != xs.rend(); ++it)
        seq.push_back({slot++, *it, y, SweepDirection::kDown});
      sequences.push_back(std::move(seq));
    }
  }
  const std::size_t total = slot;
  std::vector<std::optional<SweepPoint>> done_points(total);

  SweepProgress progress(sequences.size(), total, o.progress);
  const ParallelRun pool =
      parallel_for(sequences.size(), o.threads, total, {}, [&](std::size_t i, WorkTicker& ticker) {
        Carry carry;
        const auto under_way = [&](double fraction) { return progress.under_way(i, fraction); };
        for (const PointJob& job : sequences[i]) {
          if (ticker.stopped() || progress.stopped()) return;
          done_points[job.slot] = runner.run(job, carry, under_way);
          if (!done_points[job.slot] || !progress.point_done(i)) ticker.stop();
        }
      });
  r.threads = pool.threads;
  r.cancelled = pool.stopped || progress.stopped();
  for (auto& p : done_points)
    if (p) {
      r.unsettled += unsettled(*p);
      r.failed += !p->failure.empty();
      r.points.push_back(std::move(*p));
    }
  // A bearing clearance makes a train nonlinear in contact too (in the base case or along a key
  // that sets one: the coupled pair's bearings.radial_clearance_um, a train bearing's
  // clearance_um).
  const auto sets_clearance = [](const SweepAxis& a) {
    return a.key.find("clearance") != std::string::npos;
  };
  const bool clearances =
      !r.clearances.empty() || sets_clearance(o.axis) || (o.axis2 && sets_clearance(*o.axis2));
  read_jumps(r, !clearances);
  read_impact_onsets(r);
  r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

namespace {
// The units a key's name ends with (geardyn names every quantity with its unit), longest first,
// as an axis shows them.
constexpr std::array<std::pair<std::string_view, std::string_view>, 17> kUnitSuffixes{{
    {"_n_m_s_per_rad", "N m s/rad"},
    {"_n_m_per_rad", "N m/rad"},
    {"_n_s_per_m", "N s/m"},
    {"_n_per_m", "N/m"},
    {"_kg_m2", "kg m²"},
    {"_kg_m3", "kg/m³"},
    {"_gpa", "GPa"},
    {"_hz", "Hz"},
    {"_um", "µm"},
    {"_mm", "mm"},
    {"_deg", "deg"},
    {"_rad", "rad"},
    {"_nm", "N m"},
    {"_kg", "kg"},
    {"_w", "W"},
    {"_s", "s"},
    {"_n", "N"},
}};

// A swept key as an axis names it: with its unit when its name ends with one
// ("train.reference_speed_hz (Hz)"), else as it is (a ratio, a count, a harmonic's entry).
std::string key_label(const std::string& key) {
  for (const auto& [suffix, unit] : kUnitSuffixes)
    if (key.ends_with(suffix)) return fmt::format("{} ({})", key, unit);
  return key;
}

// A text cell: quoted when it holds a comma or a quote (RFC 4180).
std::string csv_text(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char ch : s) {
    if (ch == '"') q += '"';
    q += ch == '\n' ? ' ' : ch;
  }
  return q + "\"";
}

// sweep.csv's header (no newline); before `failure` a train's (or a coupled pair's) meshes add
// ten columns each, its load-sharing groups two each, its bearing clearance directions two each,
// its shaft and bearing quantities two each.
std::string sweep_csv_header(const SweepResult& r) {
  std::string out =
      "direction,param,value,param2,value2,settled,settle_periods,mean_delta_bar,rms_delta_bar,"
      "pp_delta_bar,min_delta_bar,mean_force_bar,rms_force_bar,pp_force_bar,max_force_bar,"
      "dynamic_factor,separated_fraction,impacts_per_period,regime,double_sided,period_multiple,"
      "steady_error,";
  for (const std::string& mesh : r.meshes) {
    for (const MeshColumn& col : kMeshColumns)
      fmt::format_to(std::back_inserter(out), "{}_{},", mesh, col.name);
    fmt::format_to(std::back_inserter(out), "{}_regime,", mesh);
  }
  for (const LoadSharingGroup& g : r.load_sharing)
    fmt::format_to(std::back_inserter(out), "{0}_load_sharing_factor,{0}_lost_contact,", g.label);
  for (const std::string& c : r.clearances)
    fmt::format_to(std::back_inserter(out), "{0}_impacts_per_period,{0}_inside_fraction,", c);
  for (const SweepPart& q : r.parts)
    fmt::format_to(std::back_inserter(out), "{},{},", q.peak_column(), q.factor_column());
  return out + "failure";
}

// The 1-based column of `name` in sweep.csv (gnuplot's $N); 0 when there is none.
int sweep_csv_column(const SweepResult& r, const std::string& name) {
  std::istringstream header(sweep_csv_header(r));
  int k = 0;
  for (std::string cell; std::getline(header, cell, ',');) {
    ++k;
    if (cell == name) return k;
  }
  return 0;
}

}  // namespace

std::string sweep_csv(const SweepResult& r) {
  const SweepOptions& o = r.options;
  std::string out = sweep_csv_header(r) + "\n";
  for (const SweepPoint& p : r.points) {
    fmt::format_to(
        std::back_inserter(out),
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},",
        to_string(p.direction), o.axis.key, p.value, o.axis2 ? o.axis2->key : "", p.value2,
        p.settled ? 1 : 0, p.settle_periods, p.mean_delta_bar, p.rms_delta_bar, p.pp_delta_bar,
        p.min_delta_bar, p.mean_force_bar, p.rms_force_bar, p.pp_force_bar, p.max_force_bar,
        p.dynamic_factor ? fmt::format("{}", *p.dynamic_factor) : "", p.separated_fraction,
        p.impacts_per_period, p.failure.empty() ? to_string(p.regime) : "failed",
        p.double_sided ? 1 : 0, p.period_multiple, p.steady_error);
    for (std::size_t i = 0; i < r.meshes.size(); ++i) {
      const bool read = i < p.meshes.size() && p.failure.empty();
      for (const MeshColumn& col : kMeshColumns)
        fmt::format_to(std::back_inserter(out), "{},", read ? p.meshes[i].*col.member : kNaN);
      fmt::format_to(std::back_inserter(out), "{},",
                     read ? to_string(p.meshes[i].regime) : "failed");
    }
    for (std::size_t i = 0; i < r.load_sharing.size(); ++i) {
      const bool read = i < p.load_sharing.size() && p.failure.empty();
      fmt::format_to(std::back_inserter(out), "{},{},", read ? p.load_sharing[i].factor : kNaN,
                     read ? p.load_sharing[i].lost_contact : kNaN);
    }
    for (std::size_t i = 0; i < r.clearances.size(); ++i) {
      const bool read = i < p.clearances.size() && p.failure.empty();
      fmt::format_to(std::back_inserter(out), "{},{},", read ? p.clearances[i][0] : kNaN,
                     read ? p.clearances[i][1] : kNaN);
    }
    for (std::size_t i = 0; i < r.parts.size(); ++i) {
      const bool read = i < p.parts.size() && p.failure.empty();
      fmt::format_to(std::back_inserter(out), "{},{},", read ? p.parts[i].peak : kNaN,
                     read ? p.parts[i].factor : kNaN);
    }
    out += csv_text(p.failure) + "\n";
  }
  return out;
}

namespace {

std::string strobe_csv(const SweepResult& r, ModelForm form) {
  std::string out = fmt::format("direction,value,value2,period,delta_bar,{},force_bar\n",
                                form_key("velocity_m_s", form));
  for (const SweepPoint& p : r.points)
    for (std::size_t k = 0; k < p.strobe_delta_bar.size(); ++k)
      fmt::format_to(std::back_inserter(out), "{},{},{},{},{},{},{}\n", to_string(p.direction),
                     p.value, p.value2, k, p.strobe_delta_bar[k], p.strobe_velocity_m_s[k],
                     p.strobe_force_bar[k]);
  return out;
}

std::string summary(const SweepResult& r) {
  const SweepOptions& o = r.options;
  nlohmann::json j;
  j["param"] = o.axis.key;
  j["from"] = o.axis.from;
  j["to"] = o.axis.to;
  j["points"] = o.axis.points;
  j["log"] = o.axis.log;
  if (o.axis2) {
    j["param2"] = o.axis2->key;
    j["from2"] = o.axis2->from;
    j["to2"] = o.axis2->to;
    j["points2"] = o.axis2->points;
  }
  j["direction"] = to_string(o.direction);
  if (!r.meshes.empty()) {
    j["meshes"] = r.meshes;
    j["mesh"] = r.mesh;
  }
  if (!r.load_sharing.empty()) {
    nlohmann::json groups = nlohmann::json::array();
    for (const LoadSharingGroup& g : r.load_sharing) {
      std::vector<std::string> names;
      for (const std::size_t m : g.meshes) names.push_back(r.meshes[m]);
      groups.push_back({{"label", g.label}, {"gear", g.gear}, {"meshes", names}});
    }
    j["load_sharing"] = groups;
  }
  if (!r.clearances.empty()) j["clearances"] = r.clearances;
  if (!r.parts.empty()) {
    nlohmann::json parts = nlohmann::json::array();
    for (const SweepPart& q : r.parts) parts.push_back({{"part", q.part}, {"quantity", q.what}});
    j["parts"] = parts;
  }
  j["steadiness"] = r.steadiness;
  if (!r.period_note.empty()) j["period_note"] = r.period_note;
  j["settle_periods"] = o.settle_periods;
  j["measure_periods"] = o.measure_periods;
  j["max_settle_periods"] = o.max_settle_periods;
  j["steady_tolerance"] = o.steady_tolerance;
  j["start"] = o.start_static ? "static" : "case";
  j[form_key("period_s", r.form)] = r.period_s;
  j["points_computed"] = r.points.size();
  j["unsettled"] = r.unsettled;
  j["failed"] = r.failed;
  j["cancelled"] = r.cancelled;
  j["wall_time_s"] = r.wall_time_s;
  j["threads"] = r.threads;
  j["unused_settings"] = r.unused_settings;
  j["hysteresis"] = nlohmann::json::array();
  for (const Hysteresis& h : r.hysteresis) {
    nlohmann::json x = {
        {"from_value", h.from_value}, {"to_value", h.to_value}, {"unsettled", h.unsettled}};
    if (o.axis2) x["value2"] = h.value2;
    j["hysteresis"].push_back(x);
  }
  j["unsettled_ranges"] = nlohmann::json::array();
  for (const UnsettledRange& u : r.unsettled_ranges) {
    nlohmann::json x = {{"direction", to_string(u.direction)},
                        {"from_value", u.from_value},
                        {"to_value", u.to_value},
                        {"points", u.points}};
    if (o.axis2) x["value2"] = u.value2;
    j["unsettled_ranges"].push_back(x);
  }
  j["impact_onsets"] = nlohmann::json::array();
  for (const ImpactOnset& x : r.impact_onsets) {
    nlohmann::json y = {
        {"direction", to_string(x.direction)}, {"value", x.value}, {"meshes", x.meshes}};
    if (o.axis2) y["value2"] = x.value2;
    j["impact_onsets"].push_back(y);
  }
  j["jumps"] = nlohmann::json::array();
  for (const Jump& x : r.jumps) {
    nlohmann::json y = {{"direction", to_string(x.direction)},
                        {"from_value", x.from_value},
                        {"to_value", x.to_value},
                        {"pp_delta_bar_before", x.before},
                        {"pp_delta_bar_after", x.after},
                        {"unsettled", x.unsettled}};
    if (o.axis2) y["value2"] = x.value2;
    j["jumps"].push_back(y);
  }
  return j.dump(2) + "\n";
}

// The cell edges of a grid: midway between neighbours (geometrically on a log axis), the
// end cells as wide as their neighbours.
std::vector<double> cell_edges(const std::vector<double>& v, bool log) {
  std::vector<double> e(v.size() + 1);
  const auto mid = [log](double a, double b) { return log ? std::sqrt(a * b) : 0.5 * (a + b); };
  if (v.size() == 1) {
    e = log ? std::vector<double>{v[0] / 1.1, v[0] * 1.1}
            : std::vector<double>{v[0] - 0.5, v[0] + 0.5};
    return e;
  }
  for (std::size_t i = 1; i < v.size(); ++i) e[i] = mid(v[i - 1], v[i]);
  e.front() = log ? v.front() * v.front() / e[1] : 2 * v.front() - e[1];
  e.back() = log ? v.back() * v.back() / e[v.size() - 1] : 2 * v.back() - e[v.size() - 1];
  return e;
}

// The regime map of a 2-D sweep: one panel per direction swept, each point a filled cell
// coloured by what happened there (only what occurred is in the legend), and the cells where
// the up and the down sweep differ (coexisting branches) marked in both.
std::string regime_map_body(const SweepResult& r) {
  const SweepOptions& o = r.options;
  const std::vector<double> xs = o.axis.values(), ys = o.axis2->values();
  const std::vector<double> xe = cell_edges(xs, o.axis.log), ye = cell_edges(ys, o.axis2->log);
  const auto index = [](const std::vector<double>& v, double x) {
    return static_cast<std::size_t>(std::lower_bound(v.begin(), v.end(), x) - v.begin());
  };
  struct Class {
    const char* name;
    const char* colour;
  };
  static constexpr std::array<Class, 5> kClasses{{{"none", "#d9efd9"},
                                                  {"transient", "#f7e3a1"},
                                                  {"sustained", "#f4a6a6"},
                                                  {"double-sided", "#7b3294"},
                                                  {"failed", "#9a9a9a"}}};
  const auto class_of = [](const SweepPoint& p) -> std::size_t {
    if (!p.failure.empty()) return 4;
    if (p.double_sided) return 3;
    return static_cast<std::size_t>(p.regime);  // none, transient, sustained
  };
  // Data blocks: cells per direction and class, and the coexistence marks.
  std::string data, body;
  std::map<std::pair<double, double>, std::pair<const SweepPoint*, const SweepPoint*>> at;
  for (const SweepPoint& p : r.points)
    (p.direction == SweepDirection::kUp ? at[{p.value, p.value2}].first
                                        : at[{p.value, p.value2}].second) = &p;
  std::string coexist;
  for (const auto& [xy, pair] : at) {
    const auto [up, down] = pair;
    if (up && down && up->failure.empty() && down->failure.empty() &&
        std::abs(up->pp_delta_bar - down->pp_delta_bar) >
            kHysteresisFraction *
                std::max(std::abs(up->pp_delta_bar), std::abs(down->pp_delta_bar)))
      fmt::format_to(std::back_inserter(coexist), "{},{}\n", xy.first, xy.second);
  }
  if (!coexist.empty()) data += "$coexist << EOD\n" + coexist + "EOD\n";
  std::vector<SweepDirection> panels;
  for (SweepDirection d : {SweepDirection::kUp, SweepDirection::kDown})
    if (std::any_of(r.points.begin(), r.points.end(),
                    [&](const SweepPoint& p) { return p.direction == d; }))
      panels.push_back(d);
  for (SweepDirection d : panels) {
    std::string plot;
    for (std::size_t k = 0; k < kClasses.size(); ++k) {
      std::string cells;
      for (const SweepPoint& p : r.points) {
        if (p.direction != d || class_of(p) != k) continue;
        const std::size_t i = index(xs, p.value), j = index(ys, p.value2);
        fmt::format_to(std::back_inserter(cells), "{},{},{},{},{},{}\n", p.value, p.value2, xe[i],
                       xe[i + 1], ye[j], ye[j + 1]);
      }
      if (cells.empty()) continue;
      const std::string block = fmt::format("${}_{}", to_string(d), k);
      fmt::format_to(std::back_inserter(data), "{} << EOD\n{}EOD\n", block, cells);
      fmt::format_to(std::back_inserter(plot),
                     "{}{} using 1:2:3:4:5:6 with boxxyerror fs solid 1.0 noborder fc rgb '{}' "
                     "title '{}'",
                     plot.empty() ? "plot " : ", \\\n     ", block, kClasses[k].colour,
                     kClasses[k].name);
    }
    if (!coexist.empty())
      plot +=
          ", \\\n     $coexist using 1:2 with points pt 6 ps 1.0 lc rgb 'black' title "
          "'up ≠ down (branches coexist)'";
    fmt::format_to(std::back_inserter(body), "set title '{} sweeps'\n{}\n", to_string(d), plot);
  }
  std::string s = "reset\nset encoding utf8\nset datafile separator ','\n" + data;
  if (o.axis.log) s += "set logscale x\n";
  if (o.axis2->log) s += "set logscale y\n";
  fmt::format_to(std::back_inserter(s),
                 "set xlabel '{}'\nset ylabel '{}'\nset xrange [{}:{}]\nset yrange [{}:{}]\n"
                 "set key below font ',9'\nset multiplot layout 1,{} title 'regime map'\n{}"
                 "unset multiplot\n",
                 key_label(o.axis.key), key_label(o.axis2->key), xe.front(), xe.back(), ye.front(),
                 ye.back(), panels.size(), body);
  return s;
}

// A figure of panels along the key, each drawing its series (sweep.csv's column and its legend)
// up and down.
struct SeriesPanel {
  std::string ylabel;
  std::vector<std::pair<std::string, std::string>> series;
  // Per series, its group (empty: every series its own): the series of one group (a set's
  // identical planets' meshes) share a colour and one legend entry, the group's label.
  std::vector<std::string> groups;
  std::string settings;  // gnuplot lines before the panel's plot (its axis' range and format)
};
// A panel with more legend entries per direction than this has its legend beside it.
constexpr std::size_t kLegendInside = 4;
std::string series_body(const SweepResult& r, const std::string& title,
                        const std::vector<SeriesPanel>& panels) {
  static constexpr std::array<const char*, 6> kColours{"#1f3b73", "#b5532b", "#2e7d32",
                                                       "#6a1b9a", "#00838f", "#5d4037"};
  std::string s = fmt::format(
      "reset\nset encoding utf8\nset datafile separator ','\nset grid lc rgb '#dddddd'\n"
      "set key top left font ',9'\n{}set multiplot layout {},1 title \"{} along {}\"\n",
      r.options.axis.log ? "set logscale x\n" : "", panels.size(), title, r.options.axis.key);
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const SeriesPanel& panel = panels[k];
    // Each series' colour and legend: its group's (the first series of a group carries the
    // title), else its own.
    std::vector<std::string> keys;
    std::vector<std::size_t> colour(panel.series.size());
    std::vector<bool> titled(panel.series.size());
    for (std::size_t m = 0; m < panel.series.size(); ++m) {
      const std::string key = m < panel.groups.size() && !panel.groups[m].empty()
                                  ? panel.groups[m]
                                  : "\x01" + panel.series[m].first;
      const auto at = std::find(keys.begin(), keys.end(), key);
      colour[m] = static_cast<std::size_t>(at - keys.begin());
      titled[m] = at == keys.end();
      if (titled[m]) keys.push_back(key);
    }
    // A long legend beside the graph, not over its curves.
    fmt::format_to(std::back_inserter(s),
                   "set key {} font ',9'\nset autoscale y\nset format y '% h'\n{}set xlabel "
                   "'{}'\nset ylabel '{}'\nplot ",
                   keys.size() > kLegendInside ? "outside right top" : "top left", panel.settings,
                   k + 1 == panels.size() ? key_label(r.options.axis.key) : "", panel.ylabel);
    bool first = true;
    for (SweepDirection d : {SweepDirection::kUp, SweepDirection::kDown}) {
      if (std::none_of(r.points.begin(), r.points.end(),
                       [&](const SweepPoint& p) { return p.direction == d; }))
        continue;
      const bool up = d == SweepDirection::kUp;
      for (std::size_t m = 0; m < panel.series.size(); ++m) {
        const auto& [column, label] = panel.series[m];
        const std::string& shown =
            m < panel.groups.size() && !panel.groups[m].empty() ? panel.groups[m] : label;
        fmt::format_to(std::back_inserter(s),
                       "{}'sweep.csv' every ::1 using {}:(strcol({}) eq '{}' ? ${} : NaN) with "
                       "linespoints dt {} pt {} ps 0.4 lc rgb '{}' {}",
                       first ? "" : ", \\\n     ", sweep_csv_column(r, "value"),
                       sweep_csv_column(r, "direction"), to_string(d), sweep_csv_column(r, column),
                       up ? 1 : 2, up ? 7 : 6, kColours[colour[m] % kColours.size()],
                       titled[m] ? fmt::format("title '{}: {}'", to_string(d), shown) : "notitle");
        first = false;
      }
    }
    s += "\n";
  }
  return s + "unset multiplot\n";
}

// A train's meshes along the key, each a curve, up and down: the peak-to-peak (d - e) / b, the
// dynamic factor, and in a third panel the impacts per system period where any occurred.
std::string mesh_responses_body(const SweepResult& r) {
  // A load-sharing group's meshes (a set's identical planets') are one legend entry.
  std::vector<std::string> group(r.meshes.size());
  for (const LoadSharingGroup& g : r.load_sharing)
    for (const std::size_t m : g.meshes)
      if (m < group.size() && group[m].empty())
        group[m] = fmt::format("{} meshes of {}", g.meshes.size(), g.gear);
  const auto per_mesh = [&](const char* ylabel, const char* column) {
    SeriesPanel p{ylabel, {}, group, {}};
    for (const std::string& m : r.meshes) p.series.emplace_back(m + "_" + column, m);
    return p;
  };
  std::vector<SeriesPanel> panels{per_mesh("peak-to-peak (d - e) / b", "pp_delta_bar"),
                                  per_mesh("dynamic factor", "dynamic_factor")};
  const bool impacts = std::any_of(r.points.begin(), r.points.end(), [](const SweepPoint& p) {
    return std::any_of(p.meshes.begin(), p.meshes.end(),
                       [](const MeshReading& m) { return m.impacts_per_period > 0; });
  });
  if (impacts) panels.push_back(per_mesh("impacts per system period", "impacts_per_period"));
  if (!r.load_sharing.empty()) {
    // A factor is 1 when the meshes share equally: its axis from 1 to at least 1.01, with the
    // digits that tell its values apart (near 1, autoscaling read rounding noise, "1 1 1 1").
    double most = 1;
    for (const SweepPoint& p : r.points)
      for (const LoadSharingReading& x : p.load_sharing)
        if (std::isfinite(x.factor)) most = std::max(most, x.factor);
    const double top = std::max(1.01, 1 + 1.1 * (most - 1));
    SeriesPanel p{"load-sharing factor",
                  {},
                  {},
                  fmt::format("set yrange [0.999:{}]\nset format y '%.3f'\n", top)};
    for (const LoadSharingGroup& g : r.load_sharing)
      p.series.emplace_back(g.label + "_load_sharing_factor", g.label);
    panels.push_back(std::move(p));
  }
  return series_body(r, "each mesh", panels);
}

// A train's shafts and bearings along the key, up and down, one panel per kind of quantity that
// some point loads (a quantity's largest magnitude; one that stays 0, as a spur pair's axial
// force, is left out): the bearings' forces in the plane (x, y), their axial forces, their
// moments, the shafts' torques; and the impacts per system period in each bearing clearance.
std::string part_forces_body(const SweepResult& r) {
  const auto loaded = [&](std::size_t i) {
    return std::any_of(r.points.begin(), r.points.end(), [&](const SweepPoint& p) {
      return i < p.parts.size() && std::isfinite(p.parts[i].peak) && p.parts[i].peak > 0;
    });
  };
  struct Kind {
    const char* ylabel;
    std::vector<const char*> whats;
  };
  static const std::array<Kind, 4> kKinds{
      {{"largest bearing force (N)", {"force_x_n", "force_y_n"}},
       {"largest axial force (N)", {"axial_force_n"}},
       {"largest moment (N m)", {"moment_x_nm", "moment_y_nm"}},
       {"largest shaft torque (N m)", {"torque_nm"}}}};
  // A planet's copies of an element (its name and 1 to N, N the planets of a load-sharing
  // group, as the set writes them) are one legend entry, as the planets' meshes are: the stem,
  // or "" for a part that is no such copy.
  std::size_t planets = 0;
  for (const LoadSharingGroup& g : r.load_sharing) planets = std::max(planets, g.meshes.size());
  const auto stem_of = [&](const std::string& part) {
    const std::size_t end = part.find_last_not_of("0123456789");
    if (planets < 2 || end == std::string::npos || end + 1 == part.size()) return std::string();
    std::string stem = part.substr(0, end + 1);
    for (std::size_t k = 1; k <= planets; ++k)
      if (std::none_of(r.parts.begin(), r.parts.end(),
                       [&](const SweepPart& q) { return q.part == stem + std::to_string(k); }))
        return std::string();
    return stem;
  };
  std::vector<SeriesPanel> panels;
  for (const Kind& kind : kKinds) {
    SeriesPanel p{kind.ylabel, {}, {}, {}};
    for (std::size_t i = 0; i < r.parts.size(); ++i) {
      const SweepPart& q = r.parts[i];
      if (std::find_if(kind.whats.begin(), kind.whats.end(),
                       [&](const char* w) { return q.what == w; }) == kind.whats.end() ||
          !loaded(i))
        continue;
      p.series.emplace_back(q.peak_column(), q.label());
      const std::string stem = stem_of(q.part);
      p.groups.push_back(stem.empty() ? std::string()
                                      : fmt::format("{}1-{}_{}", stem, planets, q.what));
    }
    if (!p.series.empty()) panels.push_back(std::move(p));
  }
  if (!r.clearances.empty()) {
    SeriesPanel p{"impacts per period in the clearance", {}, {}, {}};
    for (const std::string& c : r.clearances) p.series.emplace_back(c + "_impacts_per_period", c);
    panels.push_back(std::move(p));
  }
  return series_body(r, "bearings and shafts", panels);
}

}  // namespace

std::vector<std::string> write_sweep(const std::filesystem::path& dir, const SweepResult& r,
                                     bool figures) {
  write_files_atomically(dir, {{"sweep.csv", sweep_csv(r)},
                               {"strobe.csv", strobe_csv(r, r.form)},
                               {"summary.json", summary(r)}});
  if (!figures || r.points.empty()) return {};
  std::vector<std::string> drawn{"frequency_response", "bifurcation"};
  const SweepOptions& o = r.options;
  const std::string xlog = o.axis.log ? "set logscale x\n" : "";
  const std::string preamble = "reset\nset encoding utf8\nset datafile separator ','\n";
  // Frequency response: rms F_bar and peak-to-peak delta_bar, up and down overlaid; the
  // unsettled points, the jumps and the hysteresis intervals marked where they occur.
  std::string fr = preamble + "set grid lc rgb '#dddddd'\nset key top left font ',9'\n" + xlog;
  fmt::format_to(std::back_inserter(fr), "set multiplot layout 2,1 title \"sweep of {}{}\"\n",
                 o.axis.key, r.mesh.empty() ? "" : ", mesh " + r.mesh);
  if (!o.axis2) {
    for (const Hysteresis& h : r.hysteresis)
      fmt::format_to(std::back_inserter(fr),
                     "set object rect from {}, graph 0 to {}, graph 1 behind fc rgb '#ececec' "
                     "fs solid 1.0 noborder\n",
                     h.from_value, h.to_value);
  }
  const auto col = [&](const char* name) { return sweep_csv_column(r, name); };
  const int c_direction = col("direction"), c_value = col("value"), c_settled = col("settled"),
            c_regime = col("regime");
  const auto curves = [&](int column, const char* label, bool arrows) {
    std::string out;
    if (arrows && !o.axis2)
      for (const Jump& j : r.jumps)
        fmt::format_to(std::back_inserter(out),
                       "set arrow from {}, {} to {}, {} head filled size screen 0.012,20 lw 1.5 "
                       "lc rgb '{}'\n",
                       j.from_value, j.before, j.to_value, j.after,
                       j.direction == SweepDirection::kUp ? "#1f3b73" : "#b5532b");
    out += "plot ";
    std::vector<std::string> parts;
    for (const char* d : {"up", "down"}) {
      const bool present = std::any_of(r.points.begin(), r.points.end(), [&](const SweepPoint& p) {
        return std::string(to_string(p.direction)) == d;
      });
      if (!present) continue;
      const bool up = std::string(d) == "up";
      parts.push_back(fmt::format(
          "'sweep.csv' every ::1 using {6}:(strcol({7}) eq '{0}' ? ${1} : NaN) with linespoints "
          "pt {2} ps {3} lc rgb '{4}' title '{0}: {5}'",
          d, column, up ? 7 : 6, up ? 0.4 : 0.5, up ? "#1f3b73" : "#b5532b", label, c_value,
          c_direction));
    }
    if (r.unsettled > 0)
      parts.push_back(fmt::format(
          "'sweep.csv' every ::1 using {}:(${} == 0 && strcol({}) ne 'failed' ? ${} : NaN) with "
          "points pt 2 ps 1.2 lc rgb 'black' title 'not settled'",
          c_value, c_settled, c_regime, column));
    if (arrows && !o.axis2 && !r.hysteresis.empty())
      parts.emplace_back(
          "NaN with boxes fs solid 1.0 fc rgb '#ececec' title 'up and down differ "
          "(hysteresis)'");
    if (arrows && !o.axis2 && !r.jumps.empty())
      parts.emplace_back("NaN with vectors lc rgb 'gray30' title 'jump'");
    for (std::size_t k = 0; k < parts.size(); ++k) out += (k ? ", \\\n     " : "") + parts[k];
    return out + "\nunset arrow\n";
  };
  fmt::format_to(std::back_inserter(fr), "set xlabel ''\nset ylabel 'F / (b·k_m)'\n{}",
                 curves(col("rms_force_bar"), "rms F/(b·k_m)", false));
  fmt::format_to(std::back_inserter(fr), "set xlabel '{}'\nset ylabel 'δ / b'\n{}",
                 key_label(o.axis.key), curves(col("pp_delta_bar"), "peak-to-peak δ/b", true));
  fr += "unset multiplot\n";
  render_figure(dir, "frequency_response", fr, 1000, 750);

  // Bifurcation diagram: the stroboscopic delta_bar at every point.
  std::string bi = preamble + "set grid lc rgb '#dddddd'\nset key top left font ',9'\n" + xlog;
  fmt::format_to(std::back_inserter(bi),
                 "set title 'bifurcation diagram: δ/b once per system period'\nset xlabel '{}'\n"
                 "set ylabel 'δ / b'\nplot ",
                 key_label(o.axis.key));
  bool first = true;
  for (SweepDirection d : {SweepDirection::kUp, SweepDirection::kDown}) {
    if (std::none_of(r.points.begin(), r.points.end(),
                     [&](const SweepPoint& p) { return p.direction == d; }))
      continue;
    fmt::format_to(std::back_inserter(bi),
                   "{}'strobe.csv' every ::1 using 2:(strcol(1) eq '{}' ? $5 : NaN) with points "
                   "pt 7 ps 0.3 lc rgb '{}' title '{}'",
                   first ? "" : ", \\\n     ", to_string(d),
                   d == SweepDirection::kUp ? "#1f3b73" : "#b5532b", to_string(d));
    first = false;
  }
  bi += "\n";
  render_figure(dir, "bifurcation", bi, 1000, 600);

  if (o.axis2) {
    render_figure(dir, "regime_map", regime_map_body(r), 1000, 600);
    drawn.emplace_back("regime_map");
  }
  if (!r.meshes.empty() && !o.axis2) {
    render_figure(dir, "mesh_responses", mesh_responses_body(r), 1000, 900);
    drawn.emplace_back("mesh_responses");
  }
  if (!r.parts.empty() && !o.axis2) {
    render_figure(dir, "part_forces", part_forces_body(r), 1000, 900);
    drawn.emplace_back("part_forces");
  }
  return drawn;
}

}  // namespace geardyn
