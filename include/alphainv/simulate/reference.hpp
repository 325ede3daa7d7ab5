#pragma once
/// \file reference.hpp
/// Reference trajectories r(t) with their first two derivatives, for simulation. The α-invariant
/// needs v̈ and so r̈ (eq. (44)). Not real-time (virtual calls, some allocate on construction).

#include <cstddef>
#include <memory>
#include <vector>

namespace alphainv {

/// r, ṙ, r̈ at one instant [position unit, /s, /s²].
struct ReferenceSample {
  double r = 0.0;
  double r_dot = 0.0;
  double r_ddot = 0.0;
};

/// A reference trajectory. `at` is right-continuous at discontinuities.
class Reference {
 public:
  virtual ~Reference() = default;
  virtual ReferenceSample at(double t_s) const = 0;
  /// Times in (t0, t1] where r jumps (the integrators restart there). Default: none.
  virtual void discontinuities(double t0_s, double t1_s, std::vector<double>& out) const;
};

/// r = offset + A sin(2πft + φ).
class SineReference final : public Reference {
 public:
  SineReference(double amplitude, double freq_hz, double phase_rad = 0.0, double offset = 0.0);
  ReferenceSample at(double t_s) const override;

 private:
  double amplitude_, omega_, phase_, offset_;
};

/// Square wave: r = offset + A for frac(f t) < 1/2, offset − A otherwise (a jump up at t = 0).
class SquareReference final : public Reference {
 public:
  SquareReference(double amplitude, double freq_hz, double offset = 0.0);
  ReferenceSample at(double t_s) const override;
  void discontinuities(double t0_s, double t1_s, std::vector<double>& out) const override;

 private:
  double amplitude_, freq_hz_, offset_;
};

/// A sampled reference (a recorded `r` column): piecewise cubic Hermite with finite-difference
/// slopes. Jumps — sample steps much larger than the signal's typical step, e.g. square waves — are
/// kept as discontinuities at the later sample, with r held flat on either side.
class SampledReference final : public Reference {
 public:
  SampledReference(std::vector<double> t_s, std::vector<double> r);
  ReferenceSample at(double t_s) const override;
  void discontinuities(double t0_s, double t1_s, std::vector<double>& out) const override;

 private:
  /// The first k with t_[k] > t_s, for t_.front() < t_s < t_.back().
  std::size_t upper_index(double t_s) const noexcept;

  std::vector<double> t_, r_, slope_;
  std::vector<char> jump_before_;  ///< jump_before_[k]: r jumps between samples k−1 and k
  double inv_mean_dt_ = 0.0;       ///< (samples − 1) / duration [1/s]: the index guess
};

}  // namespace alphainv
