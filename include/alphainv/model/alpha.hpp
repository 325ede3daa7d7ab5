#pragma once
/// \file alpha.hpp
/// The α-invariant, eqs. (33), (34) and (36). Header-only; every function is real-time safe.

#include <cstddef>

namespace alphainv {

/// Instantaneous α-invariant, eq. (33): α = v̇² − v·v̈ [command unit² / s²]. Real-time safe.
/// \param v        command [command unit]
/// \param v_dot    its first time derivative [unit/s]
/// \param v_ddot   its second time derivative [unit/s²]
constexpr double alpha_instantaneous(double v, double v_dot, double v_ddot) noexcept {
  return v_dot * v_dot - v * v_ddot;
}

/// Cycle-average α, eq. (34): (1/T)∫(v̇² − v v̈)dt over the last period, by the trapezoidal rule on
/// uniformly sampled v, v̇, v̈ (n samples spanning one period, spacing dt_s). Real-time safe.
/// Returns 0 when n < 2.
inline double alpha_cycle_average(const double* v, const double* v_dot, const double* v_ddot,
                                  std::size_t n, double dt_s) noexcept {
  if (n < 2) return 0.0;
  double sum = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double a = alpha_instantaneous(v[k], v_dot[k], v_ddot[k]);
    sum += (k == 0 || k + 1 == n) ? 0.5 * a : a;
  }
  const double period_s = static_cast<double>(n - 1) * dt_s;
  return sum * dt_s / period_s;
}

/// α of the sinusoidal steady state under a P controller, eq. (36):
///   α = kp² ω² (A1² + (Ar − A2)²),
/// where θ = A1 cos ωt + A2 sin ωt is the fitted response (eq. (14)) to r = Ar sin ωt.
/// For any sine v = A sin(ωt + φ), α = A²ω² (the amplitude of v (35) is kp·√(A1² + (Ar − A2)²)).
constexpr double alpha_sine_steady_state(double kp, double omega_rad_s, double a1, double a2,
                                         double ar) noexcept {
  return kp * kp * omega_rad_s * omega_rad_s * (a1 * a1 + (ar - a2) * (ar - a2));
}

}  // namespace alphainv
