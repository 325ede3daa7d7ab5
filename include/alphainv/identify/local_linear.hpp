#pragma once
/// \file identify.hpp
/// Local and global linear identification from sinusoidal steady-state runs, section 2.2:
/// the least-squares sine fit (14)-(15), C_data and β_data (19)-(20), α_data (36), and the
/// all-frequency global linear regression (22). Not real-time (allocates); never throws on bad
/// data: results carry a `valid`/`physical` flag and a message.

#include <complex>
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
  double c_data = 0.0;      ///< C of the plant [1/s]: eq. (19), or its sampled-data inversion
  double beta_data = 0.0;   ///< β of the plant [1/s²]; β = β̃·kp: eq. (20), or sampled-data
  double alpha_data = 0.0;  ///< eq. (36) [command unit²/s²]
  bool physical = false;    ///< false when the denominator A1² + A2(A2 − Ar) ≤ 0 (negative C, β)
  /// Controller tick T used to undo the digital loop [s]; 0: continuous loop, (19)-(20) as printed.
  double sample_period_s = 0.0;
  double c_data_continuous = 0.0;     ///< eq. (19) as printed, whatever the loop [1/s]
  double beta_data_continuous = 0.0;  ///< eq. (20) as printed [1/s²]
  /// Response (14) the CONTINUOUS loop θ̈ + c_data θ̇ + beta_data θ = beta_data r would have at ω:
  /// (a1, a2) for continuous data; the input of the global regression (22).
  double a1_continuous = 0.0, a2_continuous = 0.0;
  /// true when the exact sampled-data inversion converged (T > 0 and physical); false with T > 0:
  /// the first-order formula was used instead (see sampled_loop_c_beta()).
  bool sampled_exact = false;
};

/// C_data, β_data (19)-(20) and α_data (36) from a fitted response. Exact for a linear plant
/// θ̈ + Cθ̇ + βθ = βr (paper-notes) in a CONTINUOUS loop (`sample_period_s` = 0).
///
/// With `sample_period_s` = T > 0 the run is taken from a DIGITAL P loop: at t_k = kT the
/// controller samples θ_k, sends v_k = kp(r_k − θ_k) and holds it over [t_k, t_k + T) (zero-order
/// hold), and θ, r are recorded at t_k. Eqs. (19)-(20) then read the plant wrongly (to first order
/// C_data = (C − ω²T/2)/(1 + CT/2), β_data = β/(1 + CT/2): the ZOH acts as a T/2 delay; −16 % in C
/// at 7 Hz on the Omni). The point is instead inverted exactly from the sampled-data loop — see
/// sampled_loop_c_beta() — and c_data/beta_data are the plant's C and β.
LocalLinearPoint local_linear_point(double freq_hz, double a1, double a2, double ar, double kp,
                                    double sample_period_s = 0.0);

/// Open-loop shape g(C, ω, T) of the digital loop: the exact ZOH discretisation of 1/(s(s + C))
/// (the plant θ̈ + Cθ̇ = β̃u with β̃ = 1) at z = e^{jωT},
///     g = [n1 z + n0] / ((z − 1)(z − e^{−CT})),
///     n1 = (CT − 1 + e^{−CT})/C²,  n0 = (1 − e^{−CT} − CT e^{−CT})/C²,
/// so the loop gain is L(z) = kp·β̃·g = β·g and the sampled closed loop θ_k/r_k = L/(1 + L).
/// T → 0 gives the continuous 1/(jω(jω + C)) of eq. (13). C may be 0 or negative.
std::complex<double> sampled_loop_shape(double c_per_s, double omega_rad_s, double sample_period_s);

/// Exact inversion of the sampled-data loop at one frequency: given the measured closed-loop
/// response H = (A2 + jA1)/Ar at the samples (eq. (14)), L = H/(1 − H) = β·g(C) (see
/// sampled_loop_shape()), so C is the root of arg g(C) = arg L (unique: the phase is monotone in C)
/// — solved by safeguarded Newton from the first-order estimate — and β = |L|/|g(C)|.
/// Returns false (and the first-order estimate in c, beta) when it does not converge.
bool sampled_loop_c_beta(double omega_rad_s, double a1, double a2, double ar,
                         double sample_period_s, double& c_per_s, double& beta_per_s2);

/// Global linear model (22): least squares over all given points (physical or not) of the stacked
/// equations (18), written with each point's continuous-loop response (a1_continuous,
/// a2_continuous: the measured (a1, a2) for continuous data, the digital loop undone otherwise).
/// `beta_tilde_linear` = β_linear / kp.
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
