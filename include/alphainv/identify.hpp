#pragma once
/// \file identify.hpp
/// Local and global linear identification from sinusoidal steady-state runs, section 2.2:
/// the least-squares sine fit (14)-(15), C_data and β_data (19)-(20), α_data (36), and the
/// all-frequency global linear regression (22). Not real-time (allocates); never throws on bad
/// data: results carry a `valid`/`physical` flag and a message.

#include <cstddef>
#include <string>
#include <vector>

namespace alphainv {

/// θ(t) ≈ A1 cos ωt + A2 sin ωt (+ offset), eqs. (14)-(15).
struct SineFit {
  double omega_rad_s = 0.0;   ///< ω [rad/s]
  double a1 = 0.0;            ///< cosine coefficient A1 [position unit]
  double a2 = 0.0;            ///< sine coefficient A2 [position unit]
  double offset = 0.0;        ///< constant term (0 when not fitted) [position unit]
  double rms_residual = 0.0;  ///< RMS of the fit residual [position unit]
  std::size_t n = 0;          ///< samples used
  bool valid = false;         ///< false when fewer than 4 samples or a singular system
  /// Polar form (16): amplitude A0 = √(A1² + A2²).
  double amplitude() const;
  /// Polar form (16): phase φ = atan2(A1, A2) [rad], θ = A0 sin(ωt + φ).
  double phase_rad() const;
};

/// Least-squares fit of eq. (15) on samples [begin, end) of (t, y). `fit_offset` adds a constant
/// column (not in the paper; it absorbs sensor bias and changes nothing for zero-mean data).
SineFit fit_sine(const double* t_s, const double* y, std::size_t n, double omega_rad_s,
                 bool fit_offset = true);
/// Convenience overload on vectors.
SineFit fit_sine(const std::vector<double>& t_s, const std::vector<double>& y, double omega_rad_s,
                 bool fit_offset = true);

/// Indices [begin, end) of the steady-state window of a sine run: the last whole number of periods
/// that start after `settle_s` (at least one period). Returns begin == end when the run is too short.
struct IndexRange {
  std::size_t begin = 0;
  std::size_t end = 0;
  std::size_t size() const { return end - begin; }
};
IndexRange steady_state_window(const std::vector<double>& t_s, double freq_hz, double settle_s);

/// One local linear identification point (one sine run at one frequency), section 2.2.4.
struct LocalLinearPoint {
  double freq_hz = 0.0;     ///< reference frequency [Hz]
  double omega_rad_s = 0.0;
  double a1 = 0.0, a2 = 0.0;  ///< fitted response coefficients, eq. (14)
  double ar = 0.0;          ///< reference amplitude Ar [position unit]
  double c_data = 0.0;      ///< eq. (19) [1/s]
  double beta_data = 0.0;   ///< eq. (20) [1/s²]; β = β̃·kp
  double alpha_data = 0.0;  ///< eq. (36) [command unit²/s²]
  bool physical = false;    ///< false when the denominator A1² + A2(A2 − Ar) ≤ 0 (negative C, β)
};

/// C_data, β_data (19)-(20) and α_data (36) from a fitted response. Exact for a linear plant
/// θ̈ + Cθ̇ + βθ = βr (paper-notes).
LocalLinearPoint local_linear_point(double freq_hz, double a1, double a2, double ar, double kp);

/// Global linear model (22): least squares over all given points (physical or not) of the stacked
/// equations (18). `beta_tilde_linear` = β_linear / kp.
struct GlobalLinearFit {
  double c_linear = 0.0;           ///< [1/s]
  double beta_linear = 0.0;        ///< [1/s²]
  double beta_tilde_linear = 0.0;  ///< β_linear / kp
  double rms_residual = 0.0;       ///< RMS of the residual of (22)
  std::size_t n_points = 0;
  bool valid = false;
  std::string message;
};
GlobalLinearFit global_linear_fit(const std::vector<LocalLinearPoint>& points, double kp);

}  // namespace alphainv
