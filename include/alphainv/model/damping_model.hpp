#pragma once
/// \file damping_model.hpp
/// The α-invariant damping and torque-constant model: C(α, I), eqs. (38)-(40), generalised to N
/// breakpoints, and β̃(α, I), eqs. (41)-(42). Header-only, fixed-size storage, real-time safe.

#include <algorithm>
#include <array>
#include <cstddef>

#include "alphainv/model/inertia_model.hpp"

namespace alphainv {

/// Largest number of damping breakpoints a model can carry (fixed so evaluation never allocates).
inline constexpr std::size_t kMaxBreakpoints = 8;

/// Piecewise-linear interpolation of y over increasing x, held at the end values outside [x0, x_{n-1}].
/// Real-time safe. n ≥ 1.
inline double interpolate_held(const double* x, const double* y, std::size_t n, double at) noexcept {
  if (n == 1 || at <= x[0]) return y[0];
  if (at >= x[n - 1]) return y[n - 1];
  std::size_t k = 1;
  while (at > x[k]) ++k;  // x[k-1] < at <= x[k]
  const double w = (at - x[k - 1]) / (x[k] - x[k - 1]);
  return y[k - 1] + w * (y[k] - y[k - 1]);
}

/// An AlphaModel's C(α) and β̃(α) at one inertia I (AlphaModel::at_inertia()), with its
/// C_n(I) = 1/(C_n1·I) and β̃_n(I) = 1/(β̃_n1·I) computed once, for a loop at one pose (the
/// virtual plant's tick): damping() and beta_tilde() equal AlphaModel::damping(α, I) and
/// beta_tilde(α, I) bit for bit. Real-time safe.
struct AlphaModelAtInertia {
  std::size_t n_breakpoints = 0;                 ///< N
  std::array<double, kMaxBreakpoints> alpha{};   ///< α0 < α1 < … [command unit²/s²]
  std::array<double, kMaxBreakpoints> c{};       ///< C_n(I) [1/s], eq. (40)
  std::array<double, 2> beta_alpha{{0.0, 1.0}};  ///< ᾱ0 < ᾱ1 of eq. (41)
  std::array<double, 2> beta{{1.0, 1.0}};        ///< β̃_n(I), eq. (42)

  /// C(α) [1/s], eqs. (38)-(40). Real-time safe.
  double damping(double alpha_value) const noexcept {
    return interpolate_held(alpha.data(), c.data(), n_breakpoints, alpha_value);
  }
  /// β̃(α) [rad/s² per command unit], eqs. (41)-(42). Real-time safe.
  double beta_tilde(double alpha_value) const noexcept {
    return interpolate_held(beta_alpha.data(), beta.data(), 2, alpha_value);
  }
};

/// The α-invariant model of one joint.
///
/// Damping (38)-(40): at breakpoint αn the damping is C_n(I) = 1/(C_n1·I); between breakpoints C is
/// linear in α (the tri-linear model of eq. (38) is the case N = 4); below α0 and above α_{N−1} it is
/// held at the end value (C0 resp. C_{N−1}). Negative α (possible in transients) is below α0.
///
/// Torque constant (41)-(42): β̃ is linear in α between ᾱ0 and ᾱ1 with β̃_n(I) = 1/(β̃_n1·I), and held
/// at the end values outside [ᾱ0, ᾱ1].
///
/// Units: α [command unit²/s²], I [normalised inertia, β̄ = 1], C [1/s], β̃ [rad/s² per command unit].
struct AlphaModel {
  std::size_t n_breakpoints = 0;                     ///< N, 2 ≤ N ≤ kMaxBreakpoints
  std::array<double, kMaxBreakpoints> alpha{};       ///< α0 < α1 < … [command unit²/s²]
  std::array<double, kMaxBreakpoints> c_n1{};        ///< C_n1: C_n(I) = 1/(C_n1·I), eq. (40)
  std::array<double, 2> beta_alpha{{0.0, 1.0}};      ///< ᾱ0 < ᾱ1 of eq. (41)
  std::array<double, 2> beta_n1{{1.0, 1.0}};         ///< β̃_n1: β̃_n(I) = 1/(β̃_n1·I), eq. (42)

  /// C(α, I) [1/s], eqs. (38)-(40). Real-time safe.
  double damping(double alpha_value, double inertia) const noexcept {
    return at_inertia(inertia).damping(alpha_value);
  }

  /// β̃(α, I) [rad/s² per command unit], eqs. (41)-(42). Real-time safe.
  double beta_tilde(double alpha_value, double inertia) const noexcept {
    return at_inertia(inertia).beta_tilde(alpha_value);
  }

  /// The model at inertia I: C_n(I) = 1/(C_n1·I), β̃_n(I) = 1/(β̃_n1·I). Real-time safe.
  AlphaModelAtInertia at_inertia(double inertia) const noexcept {
    AlphaModelAtInertia m;
    m.n_breakpoints = n_breakpoints;
    m.alpha = alpha;
    for (std::size_t n = 0; n < n_breakpoints; ++n) m.c[n] = 1.0 / (c_n1[n] * inertia);
    m.beta_alpha = beta_alpha;
    m.beta = {1.0 / (beta_n1[0] * inertia), 1.0 / (beta_n1[1] * inertia)};
    return m;
  }

  /// True when N is in range, breakpoints strictly increase and all C_n1, β̃_n1 are positive.
  bool valid() const noexcept {
    if (n_breakpoints < 2 || n_breakpoints > kMaxBreakpoints) return false;
    for (std::size_t n = 0; n < n_breakpoints; ++n) {
      if (!(c_n1[n] > 0.0)) return false;
      if (n > 0 && !(alpha[n] > alpha[n - 1])) return false;
    }
    return beta_alpha[1] > beta_alpha[0] && beta_n1[0] > 0.0 && beta_n1[1] > 0.0;
  }
};

/// The paper's α-invariant model (Tables 6 and 7 with the α labels corrected, paper-notes erratum 3):
/// breakpoints α = 0, 2.2, 25, 250 with C_n1 = 13.509, 21.570, 35.316, 61.733, and β̃_n1 = 0.8558 at
/// α = 0, 1.3405 at α = 250. At I = 0.004366 (65°/90°) it gives Table 10.
inline AlphaModel paper_alpha_model() noexcept {
  AlphaModel m;
  m.n_breakpoints = 4;
  m.alpha = {0.0, 2.2, 25.0, 250.0};
  m.c_n1 = {13.509, 21.570, 35.316, 61.733};
  m.beta_alpha = {0.0, 250.0};
  m.beta_n1 = {0.8558, 1.3405};
  return m;
}

}  // namespace alphainv
