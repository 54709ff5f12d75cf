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
#include "geardyn/orbit.hpp"
#include "geardyn/parallel.hpp"
#include "geardyn/run.hpp"
#include "geardyn/steady.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_steadiness.hpp"
#include "studies/shooting.hpp"

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
  if (a.damps_rigid_motions()) return std::nullopt;
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
      for (const train::Joint& j : a.joints()) clearances_.push_back(j.name);
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
    bool contact_only = a.joints().empty();
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
    for (const TrainJointReading& j : r.joints)
      pt.clearances.push_back(
          {static_cast<double>(j.contact.impacts) / m, j.contact.separated_fraction});
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
  std::vector<std::string> clearances_;  // a train's joints (its clearance directions first)
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

}  // namespace geardyn
