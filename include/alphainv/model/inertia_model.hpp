#pragma once
/// \file inertia_model.hpp
/// The minimal yaw-axis inertia model I(γ1, γ2) of eq. (6) and the global linear model (24)-(26).
/// Header-only, real-time safe (no allocation, no exceptions in the evaluation calls).

#include <cmath>

namespace alphainv {

inline constexpr double kPi = 3.14159265358979323846;

/// Degrees to radians.
constexpr double deg_to_rad(double deg) noexcept { return deg * kPi / 180.0; }
/// Radians to degrees.
constexpr double rad_to_deg(double rad) noexcept { return rad * 180.0 / kPi; }

/// Lumped inertia model, eq. (6):
///   I = I_base + I1 cos²γ1 + I2 cos²ψ + I3 cosγ1 cosψ,   ψ = π − γ1 − γ2 − γ_offs.
/// Inertias are "normalised" by the torque gain β̄ = 1 (eqs. (7)-(8)), so β̃ = 1/I [rad s⁻² per command unit].
struct InertiaModel {
  double i_base = 0.0;          ///< base inertia [normalised kg m²]
  double i1 = 0.0;              ///< link-1 coefficient of cos²γ1
  double i2 = 0.0;              ///< link-2 coefficient of cos²ψ
  double i3 = 0.0;              ///< cross coefficient of cosγ1 cosψ
  double gamma_offs_rad = 0.0;  ///< offset angle γ_offs [rad]

  /// ψ = π − γ1 − γ2 − γ_offs [rad], the link-2 angle used in eq. (6).
  double psi_rad(double gamma1_rad, double gamma2_rad) const noexcept {
    return kPi - gamma1_rad - gamma2_rad - gamma_offs_rad;
  }

  /// I(γ1, γ2), eq. (6). Real-time safe.
  double inertia(double gamma1_rad, double gamma2_rad) const noexcept {
    const double c1 = std::cos(gamma1_rad);
    const double cp = std::cos(psi_rad(gamma1_rad, gamma2_rad));
    return i_base + i1 * c1 * c1 + i2 * cp * cp + i3 * c1 * cp;
  }
};

/// The global linear model (24)-(26): C_linear(I) = 1/(C̄0 I), β̃_linear(I) = 1/I.
struct LinearModel {
  InertiaModel inertia;  ///< I(γ1, γ2)
  double c0_bar = 1.0;   ///< damping ratio C̄0 = β̄/C̄ [s⁻¹ per command unit... dimensionless ratio]

  /// C_linear(I) = 1/(C̄0 I) [1/s], eq. (24).
  double damping(double inertia_value) const noexcept { return 1.0 / (c0_bar * inertia_value); }
  /// β̃_linear(I) = 1/I [rad s⁻² per command unit], eq. (25).
  double beta_tilde(double inertia_value) const noexcept { return 1.0 / inertia_value; }
};

/// The paper's inertia model, from Table 5's "Modelled" columns (paper-notes erratum 1: Table 4 is
/// misprinted; these values reproduce Table 5 to 1e-4).
inline InertiaModel paper_inertia_model() noexcept {
  return InertiaModel{1.4031e-3, 2.8887e-3, 9.370e-4, 3.1595e-3, deg_to_rad(9.90)};
}

/// The paper's global linear model: paper_inertia_model() with C̄0 = 36.694.
inline LinearModel paper_linear_model() noexcept { return LinearModel{paper_inertia_model(), 36.694}; }

}  // namespace alphainv
