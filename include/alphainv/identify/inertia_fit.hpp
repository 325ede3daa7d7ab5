#pragma once
/// \file inertia_fit.hpp
/// Fit of the inertia model (6) and the damping ratio C̄0 to per-pose global linear parameters,
/// eqs. (27)-(29) of section 2.2.6:
///   I(γ1, γ2) = I_base + I1 cos²γ1 + I2 cos²ψ + I3 cosγ1 cosψ,  ψ = π − γ1 − γ2 − γ_offs,  (27)
///   β̃_linear = 1/I,                                                                       (28)
///   C_linear = 1/(C̄0 I).                                                                   (29)
///
/// Offline (allocates, uses Ceres internally): NOT real-time safe. Like Ceres, fitting never throws
/// on bad data: it returns an InertiaFitSummary that says whether it converged and why not.
///
/// Identifiability: the paper's 9 poses determine the *predictions* C_linear, β̃_linear to a few
/// per cent, but not the individual inertia parameters (paper-notes erratum 2). The summary
/// therefore carries standard errors, the correlation matrix and per-parameter `poorly_determined`
/// flags.

#include <Eigen/Core>
#include <array>
#include <limits>
#include <string>
#include <vector>

#include "alphainv/model/inertia_model.hpp"

namespace alphainv {

/// One identification pose: measured joint angles and the global linear parameters (22) there.
struct InertiaPose {
  double gamma1_rad = 0.0;         ///< measured ("true") joint angle γ1 [rad]
  double gamma2_rad = 0.0;         ///< measured ("true") joint angle γ2 [rad]
  double c_linear = 0.0;           ///< C_linear [1/s], > 0
  double beta_tilde_linear = 0.0;  ///< β̃_linear = β_linear/kp [rad s⁻² per command unit], > 0
  double weight = 1.0;  ///< weight of both residuals of this pose (cost ∝ weight·r²), > 0
};

/// Index of a parameter in InertiaFitSummary's arrays and matrices.
enum InertiaFitParameter : int {
  kIBase = 0,      ///< I_base [normalised inertia]
  kI1 = 1,         ///< I1
  kI2 = 2,         ///< I2
  kI3 = 3,         ///< I3
  kGammaOffs = 4,  ///< γ_offs [rad]
  kC0Bar = 5,      ///< C̄0 [dimensionless ratio]
};
/// Number of fitted parameters.
inline constexpr int kInertiaFitParameterCount = 6;

/// 6×6 matrix over the fitted parameters (covariance, correlation).
using InertiaFitMatrix =
    Eigen::Matrix<double, kInertiaFitParameterCount, kInertiaFitParameterCount>;

/// "I_base", "I1", "I2", "I3", "gamma_offs", "C0_bar"; "?" for an index out of range.
const char* inertia_fit_parameter_name(int index) noexcept;

/// Options of fit_inertia_model(). Defaults suit the paper's data; check with validate().
struct InertiaFitOptions {
  /// Start values of γ_offs [rad] of the multi-start (deterministic grid). For each, the inertias
  /// start at the non-negative least-squares fit of 1/β̃ (exact for fixed γ_offs) and at uniform
  /// values times each of `inertia_scale_starts`.
  std::vector<double> gamma_offs_starts_rad = {
      deg_to_rad(-30.0), deg_to_rad(-10.0), 0.0,
      deg_to_rad(10.0),  deg_to_rad(25.0),  deg_to_rad(45.0)};
  /// Scale factors of the uniform-inertia starts (1 = the mean observed inertia shared equally).
  std::vector<double> inertia_scale_starts = {0.3, 1.0, 3.0};
  /// Bounds of γ_offs [rad]; the inertias are bounded below by 0 (physical validity,
  /// section 2.2.6).
  double gamma_offs_min_rad = -0.5 * kPi;
  double gamma_offs_max_rad = 0.5 * kPi;
  int max_iterations = 200;            ///< Levenberg-Marquardt iterations per start
  double function_tolerance = 1e-15;   ///< Ceres: relative change of the cost
  double gradient_tolerance = 1e-15;   ///< Ceres: max-norm of the projected gradient
  double parameter_tolerance = 1e-13;  ///< Ceres: relative step size
  bool compute_covariance = true;      ///< standard errors and correlations (ceres::Covariance)
  /// Flag a parameter poorly determined when SE/|value| exceeds this (inertias and C̄0) …
  double poorly_determined_relative_se = 0.5;
  /// … or, for γ_offs (an angle, where a relative SE means nothing), when SE exceeds this [rad] …
  double poorly_determined_gamma_offs_se_rad = deg_to_rad(10.0);
  /// … or when its |correlation| with another parameter exceeds this.
  double poorly_determined_correlation = 0.99;

  /// Throws alphainv::Error naming the first setting out of range ("InertiaFitOptions::…").
  /// fit_inertia_model() calls it and returns a summary that is not converged, saying why.
  void validate() const;
};

/// Model prediction at one pose, eqs. (27)-(29).
struct InertiaPrediction {
  double inertia = 0.0;            ///< I [normalised inertia]
  double c_linear = 0.0;           ///< 1/(C̄0 I) [1/s]
  double beta_tilde_linear = 0.0;  ///< 1/I
};

/// Result of fit_inertia_model(). Parameter order: InertiaFitParameter.
struct InertiaFitSummary {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

  bool converged = false;  ///< true: the best start converged (Ceres CONVERGENCE) to a usable model
  std::string message;     ///< why not converged, or how it ended (always set)
  std::string warning;     ///< poorly determined parameters, bounds hit, covariance failure; or ""

  /// Fitted inertia model (6) and C̄0. Trust it when `converged`; when not, but `parameters` are
  /// finite, it is the best iterate of a start that ran out of iterations.
  LinearModel model;
  /// I_base, I1, I2, I3, γ_offs [rad], C̄0 (the same values as `model`).
  std::array<double, kInertiaFitParameterCount> parameters{kNaN, kNaN, kNaN, kNaN, kNaN, kNaN};

  int num_poses = 0;           ///< poses used
  int num_residuals = 0;       ///< 2 per pose
  int num_starts = 0;          ///< starts tried
  int num_starts_usable = 0;   ///< starts whose Ceres solution was usable
  int num_starts_at_best = 0;  ///< usable starts that ended within 1e-6 (relative) of the best cost
  int iterations = 0;          ///< Levenberg-Marquardt iterations of the best start
  double initial_cost = 0.0;   ///< Ceres cost ½Σ weight·r² at the best start's initial point
  double final_cost = 0.0;     ///< Ceres cost ½Σ weight·r² at the solution
  /// RMS of the weighted relative residuals √(2·final_cost / num_residuals) [dimensionless].
  double residual_rms = 0.0;
  double rms_relative_c = 0.0;           ///< RMS of (C_model − C)/C over poses, unweighted
  double rms_relative_beta_tilde = 0.0;  ///< RMS of (β̃_model − β̃)/β̃ over poses, unweighted
  double max_abs_relative_c = 0.0;       ///< max |(C_model − C)/C|
  double max_abs_relative_beta_tilde = 0.0;    ///< max |(β̃_model − β̃)/β̃|
  std::vector<InertiaPrediction> predictions;  ///< per input pose, in input order

  /// Condition number σ_max/σ_min of the residual Jacobian at the solution, with the parameters
  /// normalised internally to order one (inertias by the mean observed inertia, C̄0 by its
  /// closed-form estimate). Above 1e7 the covariance is not computed. NaN if not evaluated.
  double jacobian_condition_number = kNaN;
  /// True when the covariance was computed; false: `standard_errors`, `covariance` and
  /// `correlation` are NaN (see `warning`).
  bool covariance_ok = false;
  /// Standard errors, in the parameters' units (γ_offs in rad), from the Gauss-Newton covariance
  /// (JᵀJ)⁻¹ scaled by the residual variance σ̂² = 2·final_cost/(num_residuals − 6).
  std::array<double, kInertiaFitParameterCount> standard_errors{kNaN, kNaN, kNaN, kNaN, kNaN, kNaN};
  /// Covariance of the parameters (units: products of the parameters' units), σ̂²-scaled.
  InertiaFitMatrix covariance = InertiaFitMatrix::Constant(kNaN);
  InertiaFitMatrix correlation = InertiaFitMatrix::Constant(kNaN);  ///< covariance normalised
  /// Relative SE above options' threshold, |correlation| too high, or covariance not available.
  std::array<bool, kInertiaFitParameterCount> poorly_determined{};
  std::array<bool, kInertiaFitParameterCount> at_bound{};  ///< parameter on one of its bounds

  /// True when the fit converged to a usable model (`converged`).
  bool usable() const { return converged; }
  /// One line: converged?, cost, RMS, C̄0, flagged parameters.
  std::string brief_report() const;
  /// Several lines: parameters ± SE, correlations, per-fit statistics, message and warning.
  std::string full_report() const;
};

/// Fits I_base, I1, I2, I3 (≥ 0), γ_offs and C̄0 of eqs. (27)-(29) to the poses with Ceres
/// (Levenberg-Marquardt, analytic Jacobian, deterministic multi-start; the lowest cost wins).
///
/// Residuals, two per pose, *relative* (dimensionless, sqrt(weight)-scaled):
///   r_β = (1/I − β̃)/β̃,   r_C = (1/(C̄0 I) − C)/C.
/// Relative residuals weigh C and β̃ (which differ by a factor ~40 in size and by units) equally
/// and every pose equally although β̃ spans 150…275 over the paper's poses; the errors of the
/// identified C_linear, β̃_linear are roughly proportional to their size.
///
/// Needs at least 6 poses (as many as parameters), finite angles, C and β̃ finite and > 0, weights
/// finite and > 0; otherwise returns a non-converged summary saying what is wrong.
/// Not real-time safe. Never throws on bad data.
InertiaFitSummary fit_inertia_model(const std::vector<InertiaPose>& poses,
                                    const InertiaFitOptions& options = {});

/// Model predictions at one pose, eqs. (27)-(29). Real-time safe (no allocation, noexcept).
inline InertiaPrediction predict_inertia_pose(const LinearModel& model, double gamma1_rad,
                                              double gamma2_rad) noexcept {
  const double inertia = model.inertia.inertia(gamma1_rad, gamma2_rad);
  return InertiaPrediction{inertia, model.damping(inertia), model.beta_tilde(inertia)};
}

/// Closed-form damping ratio C̄0 from (28)-(29): β̃ = 1/I and C = 1/(C̄0 I) give β̃ = C̄0·C, fitted
/// by weighted least squares through the origin, C̄0 = Σ w C β̃ / Σ w C² (Table 3's "36.727").
struct C0BarEstimate {
  bool ok = false;  ///< false on bad input (then c0_bar is NaN)
  double c0_bar = std::numeric_limits<double>::quiet_NaN();  ///< C̄0 [dimensionless ratio]
  double rms_relative_residual = 0.0;  ///< RMS of (C̄0·C − β̃)/β̃ over poses
  std::string message;                 ///< what is wrong when !ok
};
/// See C0BarEstimate. Uses c_linear, beta_tilde_linear and weight of each pose (angles unused).
/// Regressing β̃ on C reproduces the paper (36.7263 vs 36.727); C on β̃ would give 36.809.
/// Not real-time safe (may allocate the message). Never throws.
C0BarEstimate regress_c0_bar(const std::vector<InertiaPose>& poses);

}  // namespace alphainv
