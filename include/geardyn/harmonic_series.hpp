// geardyn: a truncated Fourier series in time, x(t) = offset + sum_j A_j cos(omega_j t + phi_j),
// the form of the mesh stiffness (eq. 11) and of the driving force (eq. 10).
//
// Two ways to evaluate it: directly at any t, and on a uniform grid t0 + n dt by rotating each
// term's phasor (one complex multiply per term and step instead of a cosine), resynchronised
// with the direct value every kResyncSteps steps so that rounding cannot accumulate.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace geardyn {

struct Harmonic {
  double amplitude = 0;                // A_j, in the unit of the series
  double angular_frequency_rad_s = 0;  // omega_j
  double phase_rad = 0;                // phi_j
};

struct HarmonicSeries {
  // At most this many terms (eq. 11 keeps 2 in the paper; a stiffness table rarely needs 10).
  static constexpr int kMaxTerms = 16;

  double offset = 0;
  std::vector<Harmonic> terms;

  double operator()(double t_s) const {
    double x = offset;
    for (const Harmonic& h : terms)
      x += h.amplitude * std::cos(h.angular_frequency_rad_s * t_s + h.phase_rad);
    return x;
  }
  // The time derivative at t_s.
  double rate(double t_s) const {
    double x = 0;
    for (const Harmonic& h : terms)
      x -= h.amplitude * h.angular_frequency_rad_s *
           std::sin(h.angular_frequency_rad_s * t_s + h.phase_rad);
    return x;
  }
  // The second time derivative at t_s.
  double second_rate(double t_s) const {
    double x = 0;
    for (const Harmonic& h : terms)
      x -= h.amplitude * h.angular_frequency_rad_s * h.angular_frequency_rad_s *
           std::cos(h.angular_frequency_rad_s * t_s + h.phase_rad);
    return x;
  }
  // The highest angular frequency of a term with a non-zero amplitude; 0 for a constant.
  double max_angular_frequency_rad_s() const {
    double w = 0;
    for (const Harmonic& h : terms)
      if (h.amplitude != 0 && std::abs(h.angular_frequency_rad_s) > w)
        w = std::abs(h.angular_frequency_rad_s);
    return w;
  }
};

// Values of a HarmonicSeries at t0 + dt, t0 + 2 dt, ... in sequence.
// Contract: the series has at most kMaxTerms terms; dt > 0.
class HarmonicGrid {
 public:
  // Phasor rotation drifts by about one rounding error per step; resynchronising every 1024
  // steps keeps the value within ~1e-13 of the direct evaluation. A power of two: a mask.
  static constexpr std::int64_t kResyncSteps = 1024;
  static_assert((kResyncSteps & (kResyncSteps - 1)) == 0);

  HarmonicGrid() = default;
  HarmonicGrid(const HarmonicSeries& s, double t0_s, double dt_s)
      : offset_(s.offset), count_(static_cast<int>(s.terms.size())), t0_(t0_s), dt_(dt_s) {
    for (int j = 0; j < count_; ++j) {
      const Harmonic& h = s.terms[j];
      amplitude_[j] = h.amplitude;
      omega_[j] = h.angular_frequency_rad_s;
      phase_[j] = h.phase_rad;
      rot_cos_[j] = std::cos(omega_[j] * dt_);
      rot_sin_[j] = std::sin(omega_[j] * dt_);
    }
    resync(0);
  }

  // The value at t0 + (n+1) dt, where n is the number of earlier calls.
  double next() {
    if (count_ == 0) return offset_;  // a constant: nothing to rotate
    ++n_;
    if ((n_ & (kResyncSteps - 1)) == 0) {
      resync(n_);
    } else {
      for (int j = 0; j < count_; ++j) {
        const double c = cos_[j] * rot_cos_[j] - sin_[j] * rot_sin_[j];
        const double s = sin_[j] * rot_cos_[j] + cos_[j] * rot_sin_[j];
        cos_[j] = c;
        sin_[j] = s;
      }
    }
    double x = offset_;
    for (int j = 0; j < count_; ++j) x += amplitude_[j] * cos_[j];
    return x;
  }

 private:
  void resync(std::int64_t n) {
    const double t = t0_ + static_cast<double>(n) * dt_;
    for (int j = 0; j < count_; ++j) {
      cos_[j] = std::cos(omega_[j] * t + phase_[j]);
      sin_[j] = std::sin(omega_[j] * t + phase_[j]);
    }
  }

  double offset_ = 0;
  int count_ = 0;
  double t0_ = 0, dt_ = 0;
  std::int64_t n_ = 0;
  std::array<double, HarmonicSeries::kMaxTerms> amplitude_{}, omega_{}, phase_{};
  std::array<double, HarmonicSeries::kMaxTerms> rot_cos_{}, rot_sin_{}, cos_{}, sin_{};
};

}  // namespace geardyn
