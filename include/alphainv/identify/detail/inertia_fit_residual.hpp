#pragma once
/// \file detail/inertia_fit_residual.hpp
/// Not API: the residuals and analytic Jacobian of the inertia fit (inertia_fit.hpp), exposed so
/// tests can check the Jacobian against finite differences. May change without notice.

#include <cmath>
#include <string>

#include "alphainv/identify/inertia_fit.hpp"

namespace alphainv::detail {

/// Residuals of one pose and their analytic Jacobian, eqs. (27)-(29), in the natural parameters
/// params = {I_base, I1, I2, I3, γ_offs [rad], C̄0} (InertiaFitParameter order):
///   r[0] = √w·(1/(I β̃) − 1)       = √w·(β̃_model − β̃)/β̃,
///   r[1] = √w·(1/(C̄0 I C) − 1)    = √w·(C_model − C)/C.
/// `jacobian` (may be null) receives ∂r/∂params as a row-major 2×6 matrix.
/// Returns false (outputs unspecified) when I ≤ 0, C̄0 ≤ 0 or a result is not finite.
/// Real-time safe: no allocation, noexcept.
inline bool inertia_fit_residuals(const InertiaPose& pose, const double* params, double* residuals,
                                  double* jacobian) noexcept {
  const double c1 = std::cos(pose.gamma1_rad);
  const double psi = kPi - pose.gamma1_rad - pose.gamma2_rad - params[kGammaOffs];
  const double cp = std::cos(psi);
  const double sp = std::sin(psi);
  // eq. (27) and its partial derivatives; ∂cosψ/∂γ_offs = sinψ because ∂ψ/∂γ_offs = −1.
  const double d_inertia[5] = {1.0, c1 * c1, cp * cp, c1 * cp,
                               (2.0 * params[kI2] * cp + params[kI3] * c1) * sp};
  const double inertia = params[kIBase] + params[kI1] * d_inertia[1] + params[kI2] * d_inertia[2] +
                         params[kI3] * d_inertia[3];
  const double c0_bar = params[kC0Bar];
  if (!(inertia > 0.0) || !(c0_bar > 0.0)) return false;
  const double sqrt_w = std::sqrt(pose.weight);
  const double ratio_beta = 1.0 / (inertia * pose.beta_tilde_linear);  // eq. (28) / β̃
  const double ratio_c = 1.0 / (c0_bar * inertia * pose.c_linear);     // eq. (29) / C
  residuals[0] = sqrt_w * (ratio_beta - 1.0);
  residuals[1] = sqrt_w * (ratio_c - 1.0);
  if (!std::isfinite(residuals[0]) || !std::isfinite(residuals[1])) return false;
  if (jacobian != nullptr) {
    // ∂(1/(k I))/∂θ = −(1/(k I))·(1/I)·∂I/∂θ.
    const double g_beta = -sqrt_w * ratio_beta / inertia;
    const double g_c = -sqrt_w * ratio_c / inertia;
    for (int k = 0; k < 5; ++k) {
      jacobian[k] = g_beta * d_inertia[k];
      jacobian[6 + k] = g_c * d_inertia[k];
    }
    jacobian[kC0Bar] = 0.0;
    jacobian[6 + kC0Bar] = -sqrt_w * ratio_c / c0_bar;
  }
  return true;
}

/// Outcome of check_inertia_fit_jacobian().
struct InertiaJacobianCheck {
  bool ok = false;                  ///< both checks passed (see check_inertia_fit_jacobian)
  double max_relative_error = 0.0;  ///< largest element-wise relative error, central differences
  std::string log;                  ///< what failed (empty when ok)
};

/// Checks the analytic Jacobian of the very ceres::CostFunction that fit_inertia_model() builds for
/// `pose`, at the natural parameters `params` (InertiaFitParameter order), with the fit's internal
/// parameter scaling `inertia_scale`, `c0_bar_scale`:
///  1. ceres::GradientChecker::Probe (Ridders' extrapolated differences) at `relative_precision`;
///  2. central differences with one Richardson extrapolation, giving `max_relative_error`
///     (|analytic − numeric| / max(|analytic|, |numeric|, 1e-12), over all 12 entries).
/// Not real-time safe.
InertiaJacobianCheck check_inertia_fit_jacobian(const InertiaPose& pose, const double* params,
                                                double inertia_scale, double c0_bar_scale,
                                                double relative_precision);

}  // namespace alphainv::detail
