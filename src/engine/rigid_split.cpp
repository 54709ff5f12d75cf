#include "geardyn/rigid_split.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "geardyn/newmark_flow.hpp"

namespace geardyn::ode {
namespace {

// Whether |x| is at most kFreeMotionTolerance of `size` (0 counts as free when size is 0).
bool negligible(double x, double size) { return std::abs(x) <= kFreeMotionTolerance * size; }

// What makes r not free in region `index` of `full` (rigid_split.hpp), empty when it is.
std::string not_free(const LinearRegion& region, int index, const Vector& r, const RowVector& rho) {
  const Eigen::Index n = r.size();
  const double r_norm = r.norm(), rho_norm = rho.norm();
  const auto matrix_term = [&](const Matrix& x, const char* which) -> std::string {
    for (const bool rate : {false, true}) {
      const auto block = x.block(n, rate ? n : 0, n, n);
      const double size = block.norm();
      if (!negligible((block * r).norm(), size * r_norm) ||
          !negligible((rho * block).norm(), size * rho_norm))
        return fmt::format("region {}: the {} term of A acts on the free motion through the {}",
                           index, which, rate ? "rates" : "coordinates");
    }
    return {};
  };
  const auto each = [&](const auto& terms, auto&& check) -> std::string {
    if (std::string e = check(terms.constant, "constant"); !e.empty()) return e;
    for (const auto& x : terms.cos)
      if (std::string e = check(x, "cosine"); !e.empty()) return e;
    for (const auto& x : terms.sin)
      if (std::string e = check(x, "sine"); !e.empty()) return e;
    return {};
  };
  if (std::string e = each(region.a, matrix_term); !e.empty()) return e;
  for (const auto* list : {&region.guards, &region.observables})
    for (std::size_t i = 0; i < list->size(); ++i) {
      const auto row_term = [&](const RowVector& g, const char* which) -> std::string {
        for (const bool rate : {false, true}) {
          const auto part = g.segment(rate ? n : 0, n);
          if (!negligible(part.dot(r), part.norm() * r_norm))
            return fmt::format("region {}: the {} term of {} {} reads the free motion's {}", index,
                               which, list == &region.guards ? "guard" : "observable", i,
                               rate ? "rate" : "coordinate");
        }
        return {};
      };
      if (std::string e = each((*list)[i].row, row_term); !e.empty()) return e;
    }
  return {};
}

// rho a of a region's forcing u = (0, a): the free motion's acceleration, as a series.
FourierTerms<double> free_forcing(const LinearRegion& region, const RowVector& rho) {
  const Eigen::Index n = rho.size();
  FourierTerms<double> f;
  f.constant = rho.dot(region.u.constant.tail(n));
  for (const Vector& c : region.u.cos) f.cos.push_back(rho.dot(c.tail(n)));
  for (const Vector& s : region.u.sin) f.sin.push_back(rho.dot(s.tail(n)));
  return f;
}

// The size of a region's forcing a (for comparing regions' f).
double forcing_size(const LinearRegion& region, Eigen::Index n) {
  double size = region.u.constant.tail(n).norm();
  for (const Vector& c : region.u.cos) size += c.tail(n).norm();
  for (const Vector& s : region.u.sin) size += s.tail(n).norm();
  return size;
}

}  // namespace

RigidSplit::RigidSplit(const LinearSwitchedSystem& full, const Vector& r, const Matrix& metric) {
  const Eigen::Index n = full.dimension / 2;
  if (full.dimension % 2 != 0 || n < 2 || r.size() != n || metric.rows() != n ||
      metric.cols() != n || !(r.norm() > 0))
    throw std::invalid_argument(fmt::format(
        "rigid split: a system of dimension {} with a free direction of size {} and a {} x {} "
        "metric",
        full.dimension, r.size(), metric.rows(), metric.cols()));
  if (const std::string e = second_order_form_error(full, 0); !e.empty())
    throw std::invalid_argument("rigid split: " + e);
  r_ = r;
  const double modal = r.dot(metric * r);
  if (!(modal > 0)) throw std::invalid_argument("rigid split: the metric is not positive on r");
  rho_ = (metric * r).transpose() / modal;
  const LinearRegion& first = full.region(0);
  if (const std::string e = not_free(first, 0, r_, rho_); !e.empty())
    throw std::invalid_argument("rigid split: " + e);
  forcing_ = free_forcing(first, rho_);
  // A forcing that overflowed (a torque of 1e307 fluctuating 1e300 times over) cannot be
  // compared region to region: the whole system is stepped, and fails as its state does.
  bool finite = first.u.constant.allFinite();
  for (const auto* terms : {&first.u.cos, &first.u.sin})
    for (const Vector& v : *terms) finite = finite && v.allFinite();
  if (!finite) throw std::invalid_argument("rigid split: the forcing is not finite");
  w_ = full.frequencies_rad_s;

  // L: the W-orthogonal projector I - r rho without the column of r's largest entry (the
  // others span its image, n - 1 wide, since that entry of r is not 0); P its left inverse.
  Eigen::Index k = 0;
  r.cwiseAbs().maxCoeff(&k);
  const Matrix projector = Matrix::Identity(n, n) - r * rho_;
  l_.resize(n, n - 1);
  for (Eigen::Index j = 0, c = 0; j < n; ++j)
    if (j != k) l_.col(c++) = projector.col(j);
  const Matrix lw = l_.transpose() * metric;
  p_ = (lw * l_).ldlt().solve(lw);

  reduced_.dimension = static_cast<int>(2 * (n - 1));
  reduced_.frequencies_rad_s = full.frequencies_rad_s;
  reduced_.coefficient_period_s = full.coefficient_period_s;
  const Eigen::Index m = n - 1;
  const double size0 = forcing_size(first, n);
  reduced_.make_lazy(full.region_count(), [full, l = l_, p = p_, r = r_, rho = rho_, f0 = forcing_,
                                           size0, n, m](int index) {
    const LinearRegion& x = full.region(index);
    if (const std::string e = second_order_form_error(full, index); !e.empty())
      throw std::logic_error("rigid split: " + e);
    if (const std::string e = not_free(x, index, r, rho); !e.empty())
      throw std::logic_error("rigid split: " + e);
    const FourierTerms<double> f = free_forcing(x, rho);
    // Both regions' forcing sets the rounding of f's sums.
    const double size = std::max(forcing_size(x, n), size0) * rho.norm();
    // A series without terms (drop_zero_terms) is one whose terms are all 0.
    const auto term = [](const std::vector<double>& x, std::size_t i) {
      return i < x.size() ? x[i] : 0.0;
    };
    bool same = negligible(f.constant - f0.constant, size);
    for (std::size_t i = 0; same && i < std::max(f.cos.size(), f0.cos.size()); ++i)
      same = negligible(term(f.cos, i) - term(f0.cos, i), size) &&
             negligible(term(f.sin, i) - term(f0.sin, i), size);
    if (!same)
      throw std::logic_error(
          fmt::format("rigid split: region {} forces the free motion unlike region 0", index));

    LinearRegion y;
    // A: top rows (0, I) exactly, as in the full system; bottom rows P A_v blockdiag(L, L).
    const auto reduce_a = [&](const Matrix& a, bool constant) {
      Matrix b = Matrix::Zero(2 * m, 2 * m);
      if (constant) b.topRightCorner(m, m).setIdentity();
      b.bottomLeftCorner(m, m) = p * a.block(n, 0, n, n) * l;
      b.bottomRightCorner(m, m) = p * a.block(n, n, n, n) * l;
      return b;
    };
    y.a.constant = reduce_a(x.a.constant, true);
    for (const Matrix& c : x.a.cos) y.a.cos.push_back(reduce_a(c, false));
    for (const Matrix& s : x.a.sin) y.a.sin.push_back(reduce_a(s, false));
    const auto reduce_u = [&](const Vector& u) {
      Vector v = Vector::Zero(2 * m);
      v.tail(m) = p * u.tail(n);
      return v;
    };
    y.u.constant = reduce_u(x.u.constant);
    for (const Vector& c : x.u.cos) y.u.cos.push_back(reduce_u(c));
    for (const Vector& s : x.u.sin) y.u.sin.push_back(reduce_u(s));
    const auto reduce_row = [&](const RowVector& g) {
      RowVector h(2 * m);
      h.head(m) = g.head(n) * l;
      h.tail(m) = g.tail(n) * l;
      return h;
    };
    const auto reduce_functional = [&](const LinearGuard& g) {
      LinearGuard h = g;
      h.row.constant = reduce_row(g.row.constant);
      h.row.cos.clear();
      h.row.sin.clear();
      for (const RowVector& c : g.row.cos) h.row.cos.push_back(reduce_row(c));
      for (const RowVector& s : g.row.sin) h.row.sin.push_back(reduce_row(s));
      return h;
    };
    for (const LinearGuard& g : x.guards) y.guards.push_back(reduce_functional(g));
    for (const LinearGuard& g : x.observables) y.observables.push_back(reduce_functional(g));
    drop_zero_terms(y);
    return y;
  });
}

Vector RigidSplit::reduce(const Vector& y) const {
  const Eigen::Index n = r_.size(), m = n - 1;
  Vector y_r(2 * m);
  y_r.head(m) = p_ * y.head(n);
  y_r.tail(m) = p_ * y.tail(n);
  return y_r;
}

Eigen::Vector2d RigidSplit::rigid(const Vector& y) const {
  const Eigen::Index n = r_.size();
  return {rho_.dot(y.head(n)), rho_.dot(y.tail(n))};
}

Eigen::Vector2d RigidSplit::rigid_at(double t0_s, const Eigen::Vector2d& rigid0, double t_s) const {
  return Motion(*this, t0_s, rigid0).at(t_s);
}

Vector RigidSplit::lift(double t0_s, const Eigen::Vector2d& rigid0, double t_s,
                        const Vector& y_r) const {
  Vector y(2 * r_.size());
  Motion(*this, t0_s, rigid0).lift_into(t_s, y_r, y.data());
  return y;
}

RigidSplit::Motion::Motion(const RigidSplit& split, double t0_s, const Eigen::Vector2d& rigid0)
    : split_(&split),
      t0_s_(t0_s),
      rigid0_(rigid0),
      cos0_(split.w_.size(), 0.0),
      sin0_(split.w_.size(), 0.0) {
  const FourierTerms<double>& f = split.forcing_;
  for (std::size_t k = 0; k < f.cos.size(); ++k) {
    if (f.cos[k] == 0 && f.sin[k] == 0) continue;
    forced_.push_back(k);
    cos0_[k] = std::cos(split.w_[k] * t0_s);
    sin0_[k] = std::sin(split.w_[k] * t0_s);
  }
}

Eigen::Vector2d RigidSplit::Motion::at(double t_s) const {
  const FourierTerms<double>& forcing = split_->forcing_;
  const double tau = t_s - t0_s_;
  const double c0 = forcing.constant;
  double phi = rigid0_(0) + rigid0_(1) * tau + 0.5 * c0 * tau * tau;
  double rate = rigid0_(1) + c0 * tau;
  // phi'' = c cos(w t) + s sin(w t), integrated twice from t0; the phases at t those a sample's
  // observables have just computed, when they have (the same values).
  const Phases* kept = forced_.empty() ? nullptr : kept_direct_phases(split_->w_, t_s);
  for (const std::size_t f : forced_) {
    const double c = forcing.cos[f], s = forcing.sin[f];
    const double w = split_->w_[f];
    const double c1 = kept ? kept->cos_wt[f] : std::cos(w * t_s);
    const double s1 = kept ? kept->sin_wt[f] : std::sin(w * t_s);
    const double c_0 = cos0_[f], s_0 = sin0_[f];
    rate += (c * (s1 - s_0) - s * (c1 - c_0)) / w;
    phi += (-c * (c1 - c_0) - s * (s1 - s_0)) / (w * w) + (-c * s_0 + s * c_0) * tau / w;
  }
  return {phi, rate};
}

void RigidSplit::Motion::lift_into(double t_s, const Vector& y_r, double* y) const {
  const Matrix& l = split_->l_;
  const Vector& r = split_->r_;
  const Eigen::Index n = r.size(), m = n - 1;
  const Eigen::Vector2d x = at(t_s);
  // L p + r phi and L p' + r phi', summed in plain loops: a train's L is small, and Eigen's
  // general product costs more than the sums at these sizes.
  for (Eigen::Index i = 0; i < n; ++i) {
    double q = 0, v = 0;
    for (Eigen::Index j = 0; j < m; ++j) {
      q += l(i, j) * y_r(j);
      v += l(i, j) * y_r(m + j);
    }
    y[i] = q + r(i) * x(0);
    y[n + i] = v + r(i) * x(1);
  }
}

Matrix RigidSplit::lift_jacobian(double t0_s, double t1_s, const Matrix& jacobian_r) const {
  const Eigen::Index n = r_.size(), m = n - 1;
  Matrix lb = Matrix::Zero(2 * n, 2 * m), pb = Matrix::Zero(2 * m, 2 * n);
  lb.topLeftCorner(n, m) = l_;
  lb.bottomRightCorner(n, m) = l_;
  pb.topLeftCorner(m, n) = p_;
  pb.bottomRightCorner(m, n) = p_;
  Matrix rb = Matrix::Zero(2 * n, 2), rhob = Matrix::Zero(2, 2 * n);
  rb.col(0).head(n) = r_;
  rb.col(1).tail(n) = r_;
  rhob.row(0).head(n) = rho_;
  rhob.row(1).tail(n) = rho_;
  Eigen::Matrix2d free;
  free << 1, t1_s - t0_s, 0, 1;
  return lb * jacobian_r * pb + rb * free * rhob;
}

}  // namespace geardyn::ode
