// geardyn: a free rigid motion split off a second-order system of linear_system.hpp, so that an
// integrator steps only the motion the system's terms act on. Nothing here knows of gears: a
// train that turns freely (train.hpp, its rigid rotation) is one such system.
//
// The system is in second-order form, y = (q, v), q' = v, v' = A_vq(t) q + A_vv(t) v + a(t), q
// in R^n. A direction r of q is free when no term acts on it nor reads it: A_vq r = A_vv r = 0 in
// every region and at every time, r^T W A_vq = r^T W A_vv = 0 for the metric W (the mass
// matrix, so that the forces do no work on r), and every guard's and observable's row is blind
// to q = r and to v = r. Then, with L (n x (n-1)) spanning the W-orthogonal complement of r and
// P = (L^T W L)^-1 L^T W its left inverse (P L = I, P r = 0),
//
//     q = L p + r phi,     v = L p' + r phi',
//
// the complement p moves in the reduced system (y_r = (p, p'), of dimension 2 (n - 1)) as the
// full one does: its matrices are blockdiag(P, P) A blockdiag(L, L), its forcing
// blockdiag(P, P) u, its guards' and observables' rows G blockdiag(L, L), their offsets
// unchanged; and phi is a quadrature, phi'' = f(t) = rho a(t) with rho = r^T W / (r^T W r), a
// Fourier series on the system's frequencies (the same in every region), integrated in closed
// form. A flow of the reduced system lifted by lift() is the full system's flow, exactly but for
// rounding: no tolerance is spent on phi.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "geardyn/linear_system.hpp"

namespace geardyn::ode {

// A term counts as not acting on r, or a row as blind to it, when its product with r is at most
// this fraction of the term's size times |r| (rounding of the assembler's sums).
constexpr double kFreeMotionTolerance = 1e-10;

class RigidSplit {
 public:
  // Throws std::invalid_argument saying why when `full` is not in second-order form, its region
  // 0's forcing is not finite, or r is not free in it (checked on its region 0 here, and on each
  // other region as the reduced system builds it: a region that breaks the split then throws
  // std::logic_error). r non-zero, W symmetric positive definite, both of size n =
  // full.dimension / 2 >= 2.
  RigidSplit(const LinearSwitchedSystem& full, const Vector& r, const Matrix& metric);

  // The reduced system (lazy: region r built from the full system's region r on first use).
  const LinearSwitchedSystem& reduced() const { return reduced_; }
  int full_dimension() const { return static_cast<int>(2 * l_.rows()); }

  // L, whose columns span the complement of r (q = L p + r phi): a row blind to r reads a full
  // state's q as its row times L reads p.
  const Matrix& complement() const { return l_; }
  // y_r = (P q, P v) of a full state.
  Vector reduce(const Vector& y) const;
  // (phi, phi') = (rho q, rho v) of a full state.
  Eigen::Vector2d rigid(const Vector& y) const;
  // (phi, phi') at t of the free motion that had `rigid0` at t0.
  Eigen::Vector2d rigid_at(double t0_s, const Eigen::Vector2d& rigid0, double t_s) const;
  // The full state at t: (L p + r phi, L p' + r phi'), y_r = (p, p') the reduced state at t and
  // (phi, phi') = rigid_at(t0, rigid0, t).
  Vector lift(double t0_s, const Eigen::Vector2d& rigid0, double t_s, const Vector& y_r) const;

  // The free motion that had `rigid0` at t0, read at many times (a flow's samples): at(t) is
  // rigid_at(t0, rigid0, t) and lift_into(t, y_r, y) writes lift(t0, rigid0, t, y_r) into y (its
  // 2 n entries), with the forcing's phases at t0 computed once and nothing allocated. The
  // split must outlive it.
  class Motion {
   public:
    Motion() = default;
    Motion(const RigidSplit& split, double t0_s, const Eigen::Vector2d& rigid0);
    Eigen::Vector2d at(double t_s) const;
    void lift_into(double t_s, const Vector& y_r, double* y) const;

   private:
    const RigidSplit* split_ = nullptr;
    double t0_s_ = 0;
    Eigen::Vector2d rigid0_ = Eigen::Vector2d::Zero();
    std::vector<double> cos0_, sin0_;  // cos and sin of w t0 per frequency
    std::vector<std::size_t> forced_;  // the frequencies the forcing holds
  };
  // dy(t1)/dy(t0) of the full flow from the reduced flow's dy_r(t1)/dy_r(t0).
  Matrix lift_jacobian(double t0_s, double t1_s, const Matrix& jacobian_r) const;

 private:
  Matrix l_, p_;                  // L (n x (n-1)), P ((n-1) x n)
  Vector r_;                      // r
  RowVector rho_;                 // r^T W / (r^T W r)
  FourierTerms<double> forcing_;  // f(t)
  std::vector<double> w_;         // the system's angular frequencies
  LinearSwitchedSystem reduced_;
};

}  // namespace geardyn::ode
