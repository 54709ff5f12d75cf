// The static state of a train (train_statics.hpp): the quasi-static solve of its contact
// stiffness under the mean loads, with its prescribed bodies held and its rigid motions
// bordered out.
#include "geardyn/train_statics.hpp"

#include <fmt/format.h>

#include <Eigen/LU>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/harmonic_series.hpp"

namespace geardyn {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
// The mean torques balance when their power at the train's speeds is this small against the
// largest term's.
constexpr double kBalanceTolerance = 1e-9;

}  // namespace

namespace {

// Each mesh's error (its transmission error and its gears' runouts) at t as a load on the
// coordinates, sum_m k_m e_m(t) V_m^T, and its rate's, sum_m k_m e_m'(t) V_m^T; false when every
// error is 0 there.
bool error_loads(const train::Assembled& a, double t_s, Eigen::VectorXd& load,
                 Eigen::VectorXd& rate) {
  const train::Train& t = a.train();
  load = rate = Eigen::VectorXd::Zero(a.size());
  bool any = false;
  for (std::size_t m = 0; m < t.meshes.size(); ++m) {
    const HarmonicSeries e = a.error_series(static_cast<int>(m));
    const double value = e(t_s), change = e.rate(t_s);
    if (value == 0 && change == 0) continue;
    any = true;
    const Eigen::VectorXd v = a.mesh_vector(static_cast<int>(m)).transpose();
    load += t.meshes[m].mean_stiffness_n_per_m * value * v;
    rate += t.meshes[m].mean_stiffness_n_per_m * change * v;
  }
  return any;
}

// The quasi-static state (theta, theta') of K theta = q_load, K theta' = rate_load, K the
// contact stiffness, in y whose prescribed bodies hold their place and rate (static_state's
// contract); nullopt with `why` as there.
std::optional<Eigen::VectorXd> quasi_static(const train::Assembled& a,
                                            const Eigen::VectorXd& q_load,
                                            const Eigen::VectorXd& rate_load, Eigen::VectorXd y,
                                            std::string* why) {
  const train::Train& t = a.train();
  const int n = a.size();
  const Eigen::MatrixXd k = a.contact_stiffness();
  std::vector<int> free;
  for (int i = 0; i < n; ++i)
    if (!a.prescribed(i)) free.push_back(i);
  const Eigen::MatrixXd rigid = a.rigid_motions();
  if (static_cast<int>(free.size()) < n && rigid.cols() == 0) {
    // The free bodies follow the held ones: K_ff q_f = Q_f - K_fp q_p, and its rate.
    const int f = static_cast<int>(free.size());
    Eigen::MatrixXd kff(f, f);
    Eigen::VectorXd rhs(f), rate_rhs(f);
    for (int i = 0; i < f; ++i) {
      rhs(i) = q_load(free[i]);
      rate_rhs(i) = rate_load(free[i]);
      for (int j = 0; j < n; ++j) {
        if (!a.prescribed(j)) continue;
        rhs(i) -= k(free[i], j) * y(j);
        rate_rhs(i) -= k(free[i], j) * y(n + j);
      }
      for (int j = 0; j < f; ++j) kff(i, j) = k(free[i], free[j]);
    }
    const Eigen::FullPivLU<Eigen::MatrixXd> lu = kff.fullPivLu();
    const Eigen::VectorXd x = lu.solve(rhs), v = lu.solve(rate_rhs);
    for (int i = 0; i < f; ++i) {
      y(free[i]) = x(i);
      y(n + free[i]) = v(i);
    }
    return y;
  }
  if (static_cast<int>(free.size()) < n) {
    if (why)
      *why =
          "a prescribed speed leaves part of the train free to turn (a rigid motion no element "
          "resists), so it has no static state: hold that part (a shaft to the ground)";
    return std::nullopt;
  }
  // Some motions no element resists (rigid_motions(): the rigid rotation of a train of meshes
  // and shafts): the mean torques must do no net work on them, which then stay at 0.
  if (rigid.cols() > 0) {
    const Eigen::VectorXd power = rigid.transpose() * q_load;
    const Eigen::VectorXd scale = rigid.cwiseAbs().transpose() * q_load.cwiseAbs();
    for (Eigen::Index c = 0; c < rigid.cols(); ++c) {
      if (std::abs(power(c)) <= kBalanceTolerance * scale(c)) continue;
      if (why) {
        // The last torque on a turning body, at the mean that balances the rest.
        std::string balancing;
        for (std::size_t k = t.torques.size(); k-- > 0;) {
          const double s =
              train::value(a.speed_ratios()[static_cast<std::size_t>(a.index(t.torques[k].body))]);
          if (s == 0) continue;
          balancing = fmt::format(
              "; torque '{}' balances them at mean_nm = {:.12g} (or write balances = true in "
              "it, and geardyn computes it)",
              t.torques[k].name, t.torques[k].mean_nm - a.mean_power_nm() / s);
          break;
        }
        *why = fmt::format(
            "the mean torques do not balance (their net power is {:.6g} W at the train's "
            "speeds{}): the train speeds up or slows down, so it has no static state{}",
            power(c) * kTwoPi * t.reference_speed_hz,
            rigid.cols() > 1 ? fmt::format(", on its rigid motion {} of {}", c + 1, rigid.cols())
                             : "",
            balancing);
      }
      return std::nullopt;
    }
  }
  const Eigen::Index r = rigid.cols();
  Eigen::MatrixXd bordered = Eigen::MatrixXd::Zero(n + r, n + r);
  bordered.topLeftCorner(n, n) = k;
  bordered.block(0, n, n, r) = rigid;
  bordered.block(n, 0, r, n) = rigid.transpose();
  const Eigen::FullPivLU<Eigen::MatrixXd> lu = bordered.fullPivLu();
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + r);
  rhs.head(n) = q_load;
  y.head(n) = lu.solve(rhs).head(n);
  // The errors' rates move the deflections, not the rigid motions (whose rates stay 0).
  if (!rate_load.isZero(0)) {
    rhs.head(n) = rate_load;
    y.tail(n) = lu.solve(rhs).head(n);
  }
  return y;
}

}  // namespace

std::optional<Eigen::VectorXd> static_state(const train::Assembled& a, std::string* why,
                                            std::optional<double> at_s) {
  const train::Train& t = a.train();
  const int n = a.size();
  Eigen::VectorXd q_load = Eigen::VectorXd::Zero(n), rate_load = q_load;
  for (const train::Torque& q : t.torques) q_load(a.index(q.body)) += q.mean_nm;
  for (std::size_t b = 0; b < t.bearings.size(); ++b)
    q_load += t.bearings[b].stiffness_n_per_m * a.bearing_matrix(static_cast<int>(b)).transpose() *
              a.bearing_offset(static_cast<int>(b));
  q_load += a.frame_load();
  q_load += a.joint_load();
  // In drive contact a mesh pushes with k_m (V q - e - b): its b is a load k_m b V^T, and so is
  // its error's constant part (the mean state) or, at a time, its error's value and rate.
  for (std::size_t m = 0; m < t.meshes.size(); ++m)
    q_load += t.meshes[m].mean_stiffness_n_per_m *
              (t.meshes[m].backlash_m + (at_s ? 0.0 : t.meshes[m].transmission_error_mean_m)) *
              a.mesh_vector(static_cast<int>(m)).transpose();
  Eigen::VectorXd y = Eigen::VectorXd::Zero(2 * static_cast<Eigen::Index>(n));
  if (at_s) {
    a.prescribe(*at_s, y);
    Eigen::VectorXd error, error_rate;
    if (error_loads(a, *at_s, error, error_rate)) {
      q_load += error;
      rate_load = error_rate;
    }
  }
  return quasi_static(a, q_load, rate_load, y, why);
}

void settle_joints(train::Assembled& a) {
  const std::vector<train::Joint>& joints = a.joints();
  for (int pass = 0; pass < kJointSettlingPasses; ++pass) {
    const std::optional<Eigen::VectorXd> y = static_state(a);
    if (!y) return;
    std::vector<int> stages = a.operating_stages();
    for (std::size_t j = 0; j < joints.size(); ++j)
      if (stages[j] >= 0)
        stages[j] = joints[j].stage_at(joints[j].row.dot(y->head(a.size())) - joints[j].offset);
    if (stages == a.operating_stages()) return;
    a.set_operating_stages(stages);
  }
}

Eigen::VectorXd rest_state(const train::Assembled& a, double at_s) {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(2 * static_cast<Eigen::Index>(a.size()));
  a.prescribe(at_s, y);
  Eigen::VectorXd error, error_rate;
  if (!error_loads(a, at_s, error, error_rate)) return y;
  return quasi_static(a, error, error_rate, y, nullptr).value_or(y);
}

std::vector<double> static_mesh_forces_n(const train::Assembled& a, const Eigen::VectorXd& y) {
  std::vector<double> f;
  const train::Train& t = a.train();
  for (std::size_t m = 0; m < t.meshes.size(); ++m)
    f.push_back(t.meshes[m].mean_stiffness_n_per_m *
                (a.mesh_vector(static_cast<int>(m)).dot(y.head(a.size())) -
                 t.meshes[m].transmission_error_mean_m - t.meshes[m].backlash_m));
  return f;
}

}  // namespace geardyn
