/// \file inertia_fit.cpp
/// Fit of the inertia model (6) and C̄0 to per-pose C_linear, β̃_linear, eqs. (27)-(29), by Ceres.
/// Ceres stays in this file (linked PRIVATE); see inertia_fit.hpp for the API.

#include "alphainv/identify/inertia_fit.hpp"

#include <ceres/ceres.h>
#include <ceres/covariance.h>
#include <ceres/gradient_checker.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "alphainv/error.hpp"
#include "alphainv/identify/detail/inertia_fit_residual.hpp"
#include "common/format.hpp"
#include "alphainv/model/detail/field_checks.hpp"

namespace alphainv {
namespace {

constexpr int kNumParams = kInertiaFitParameterCount;

using common::format;  // printf into a std::string

/// Scales s of the internal parameters p (θ = s ⊙ p): s = (s_I, s_I, s_I, s_I, 1, s_C).
std::array<double, kNumParams> parameter_scales(double inertia_scale, double c0_bar_scale) {
  return {inertia_scale, inertia_scale, inertia_scale, inertia_scale, 1.0, c0_bar_scale};
}

/// Ceres cost of one pose in the fit's internal, scaled parameters p: the natural parameters are
/// θ = s ⊙ p with s = (s_I, s_I, s_I, s_I, 1, s_C), so that every p is of order one (the inertias
/// are ~1e-3, C̄0 ~ 37). This keeps JᵀJ well conditioned for the solver and for the covariance.
class InertiaCostFunction final : public ceres::SizedCostFunction<2, kNumParams> {
 public:
  InertiaCostFunction(const InertiaPose& pose, double inertia_scale, double c0_bar_scale)
      : pose_(pose), scale_(parameter_scales(inertia_scale, c0_bar_scale)) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    double theta[kNumParams];
    for (int k = 0; k < kNumParams; ++k)
      theta[k] = scale_[static_cast<std::size_t>(k)] * parameters[0][k];
    double* jac = (jacobians != nullptr) ? jacobians[0] : nullptr;
    if (!detail::inertia_fit_residuals(pose_, theta, residuals, jac)) return false;
    if (jac != nullptr) {
      // Chain rule: ∂r/∂p_k = ∂r/∂θ_k · s_k. Row-major 2×6, as Ceres expects.
      for (int row = 0; row < 2; ++row) {
        for (int k = 0; k < kNumParams; ++k)
          jac[row * kNumParams + k] *= scale_[static_cast<std::size_t>(k)];
      }
    }
    return true;
  }

 private:
  InertiaPose pose_;
  std::array<double, kNumParams> scale_;
};

/// First problem with the poses, or "" when they are usable.
std::string check_poses(const std::vector<InertiaPose>& poses) {
  if (poses.size() < static_cast<std::size_t>(kNumParams)) {
    return format("need at least %d poses (one per parameter), got %zu", kNumParams, poses.size());
  }
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const InertiaPose& p = poses[i];
    if (!std::isfinite(p.gamma1_rad) || !std::isfinite(p.gamma2_rad)) {
      return format("pose %zu: joint angles must be finite, got gamma1 = %g rad, gamma2 = %g rad",
                    i, p.gamma1_rad, p.gamma2_rad);
    }
    if (!std::isfinite(p.c_linear) || !(p.c_linear > 0.0)) {
      return format("pose %zu: c_linear must be finite and > 0, got %g", i, p.c_linear);
    }
    if (!std::isfinite(p.beta_tilde_linear) || !(p.beta_tilde_linear > 0.0)) {
      return format("pose %zu: beta_tilde_linear must be finite and > 0, got %g", i,
                    p.beta_tilde_linear);
    }
    if (!std::isfinite(p.weight) || !(p.weight > 0.0)) {
      return format("pose %zu: weight must be finite and > 0, got %g", i, p.weight);
    }
  }
  return {};
}

/// Basis of eq. (27) at a pose for a given γ_offs: (1, cos²γ1, cos²ψ, cosγ1 cosψ).
Eigen::Vector4d inertia_basis(const InertiaPose& pose, double gamma_offs_rad) {
  const double c1 = std::cos(pose.gamma1_rad);
  const double cp = std::cos(kPi - pose.gamma1_rad - pose.gamma2_rad - gamma_offs_rad);
  return Eigen::Vector4d(1.0, c1 * c1, cp * cp, c1 * cp);
}

/// Non-negative least squares for the four inertias (internal scale) at fixed γ_offs, minimising
/// Σ w (I_model/I_obs − 1)² with I_obs = 1/β̃: exact by enumerating the 15 passive sets.
/// Returns false when no candidate is usable.
bool nnls_inertias(const std::vector<InertiaPose>& poses, double gamma_offs_rad,
                   double inertia_scale, double* x_out) {
  const Eigen::Index n = static_cast<Eigen::Index>(poses.size());
  Eigen::MatrixXd a(n, 4);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const InertiaPose& p = poses[static_cast<std::size_t>(i)];
    const double sqrt_w = std::sqrt(p.weight);
    a.row(i) = (sqrt_w * inertia_scale * p.beta_tilde_linear) *
               inertia_basis(p, gamma_offs_rad).transpose();
    b(i) = sqrt_w;
  }
  double best_norm = std::numeric_limits<double>::infinity();
  bool found = false;
  for (int mask = 1; mask < 16; ++mask) {
    std::vector<Eigen::Index> cols;
    for (int k = 0; k < 4; ++k) {
      if ((mask >> k) & 1) cols.push_back(k);
    }
    Eigen::MatrixXd sub(n, static_cast<Eigen::Index>(cols.size()));
    for (std::size_t j = 0; j < cols.size(); ++j)
      sub.col(static_cast<Eigen::Index>(j)) = a.col(cols[j]);
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(sub);
    if (qr.rank() < sub.cols()) continue;
    const Eigen::VectorXd xs = qr.solve(b);
    if ((xs.array() < 0.0).any() || !xs.allFinite()) continue;
    const double norm = (sub * xs - b).squaredNorm();
    if (norm < best_norm) {
      best_norm = norm;
      found = true;
      for (int k = 0; k < 4; ++k) x_out[k] = 0.0;
      for (std::size_t j = 0; j < cols.size(); ++j)
        x_out[cols[j]] = xs(static_cast<Eigen::Index>(j));
    }
  }
  return found;
}

/// Best C̄0 (internal scale) for given inertias: minimises Σ w (u/C̄0 − 1)², u = 1/(I C).
/// Returns false when an inertia is not positive.
bool best_c0_bar(const std::vector<InertiaPose>& poses, const double* p, double inertia_scale,
                 double c0_bar_scale, double* c0_out) {
  double num = 0.0;
  double den = 0.0;
  for (const InertiaPose& pose : poses) {
    const Eigen::Vector4d basis = inertia_basis(pose, p[kGammaOffs]);
    const double inertia =
        inertia_scale * (p[0] * basis(0) + p[1] * basis(1) + p[2] * basis(2) + p[3] * basis(3));
    if (!(inertia > 0.0)) return false;
    const double u = 1.0 / (inertia * pose.c_linear);
    num += pose.weight * u;
    den += pose.weight * u * u;
  }
  if (!(num > 0.0)) return false;
  *c0_out = den / num / c0_bar_scale;  // C̄0 = 1/k, k = Σ w u / Σ w u².
  return std::isfinite(*c0_out);
}

/// Problem of all poses on the internal parameter block `p` (6 doubles), bounds set.
std::unique_ptr<ceres::Problem> make_problem(const std::vector<InertiaPose>& poses,
                                             const InertiaFitOptions& options, double inertia_scale,
                                             double c0_bar_scale, double* p) {
  auto problem = std::make_unique<ceres::Problem>();
  for (const InertiaPose& pose : poses) {
    problem->AddResidualBlock(new InertiaCostFunction(pose, inertia_scale, c0_bar_scale), nullptr,
                              p);
  }
  for (int k = kIBase; k <= kI3; ++k) problem->SetParameterLowerBound(p, k, 0.0);
  problem->SetParameterLowerBound(p, kGammaOffs, options.gamma_offs_min_rad);
  problem->SetParameterUpperBound(p, kGammaOffs, options.gamma_offs_max_rad);
  problem->SetParameterLowerBound(p, kC0Bar, 1e-9);
  return problem;
}

struct StartResult {
  bool usable = false;
  bool converged = false;
  double p[kNumParams] = {};
  double initial_cost = 0.0;
  double final_cost = std::numeric_limits<double>::infinity();
  int iterations = 0;
  std::string message;
};

StartResult solve_from(const std::vector<InertiaPose>& poses, const InertiaFitOptions& options,
                       double inertia_scale, double c0_bar_scale, const double* start) {
  StartResult result;
  std::copy(start, start + kNumParams, result.p);
  auto problem = make_problem(poses, options, inertia_scale, c0_bar_scale, result.p);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = options.gradient_tolerance;
  solver_options.parameter_tolerance = options.parameter_tolerance;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, problem.get(), &summary);
  result.usable = summary.IsSolutionUsable() && std::isfinite(summary.final_cost);
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.initial_cost = summary.initial_cost;
  result.final_cost = result.usable ? summary.final_cost : std::numeric_limits<double>::infinity();
  result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  result.message = summary.message;
  return result;
}

void fill_statistics(const std::vector<InertiaPose>& poses, InertiaFitSummary* s) {
  s->predictions.clear();
  s->predictions.reserve(poses.size());
  double sum_c = 0.0;
  double sum_b = 0.0;
  s->max_abs_relative_c = 0.0;
  s->max_abs_relative_beta_tilde = 0.0;
  for (const InertiaPose& pose : poses) {
    const InertiaPrediction pred = predict_inertia_pose(s->model, pose.gamma1_rad, pose.gamma2_rad);
    s->predictions.push_back(pred);
    const double rc = (pred.c_linear - pose.c_linear) / pose.c_linear;
    const double rb = (pred.beta_tilde_linear - pose.beta_tilde_linear) / pose.beta_tilde_linear;
    sum_c += rc * rc;
    sum_b += rb * rb;
    s->max_abs_relative_c = std::max(s->max_abs_relative_c, std::abs(rc));
    s->max_abs_relative_beta_tilde = std::max(s->max_abs_relative_beta_tilde, std::abs(rb));
  }
  const double n = static_cast<double>(poses.size());
  s->rms_relative_c = std::sqrt(sum_c / n);
  s->rms_relative_beta_tilde = std::sqrt(sum_b / n);
  s->residual_rms = std::sqrt(2.0 * s->final_cost / static_cast<double>(s->num_residuals));
}

/// Covariance by ceres::Covariance (dense SVD; fails on a rank-deficient Jacobian), mapped to the
/// natural parameters and scaled by σ̂². Returns "" on success, else why it failed.
std::string compute_covariance(const std::vector<InertiaPose>& poses,
                               const InertiaFitOptions& options, double inertia_scale,
                               double c0_bar_scale, const double* p_best, InertiaFitSummary* s) {
  double p[kNumParams];
  std::copy(p_best, p_best + kNumParams, p);
  // Condition of the (internally scaled) Jacobian, checked here with the same criterion that
  // ceres::Covariance applies, so that a rank-deficient problem is reported in the summary instead
  // of by Ceres' LOG(ERROR) on stderr.
  const double* blocks_of_p[] = {p};
  Eigen::Matrix<double, Eigen::Dynamic, kNumParams, Eigen::RowMajor> jac(2 * poses.size(),
                                                                         kNumParams);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const InertiaCostFunction cost(poses[i], inertia_scale, c0_bar_scale);
    double r[2];
    double* jac_rows[] = {jac.row(static_cast<Eigen::Index>(2 * i)).data()};
    if (!cost.Evaluate(blocks_of_p, r, jac_rows)) return "the Jacobian could not be evaluated";
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(jac);
  const Eigen::VectorXd sv = svd.singularValues();
  s->jacobian_condition_number = sv(0) / sv(sv.size() - 1);
  constexpr double kMinReciprocalCondition = 1e-14;  // of JᵀJ, as Ceres' default
  if (!(sv(sv.size() - 1) > std::sqrt(kMinReciprocalCondition) * sv(0))) {
    return format(
        "the Jacobian is rank deficient (condition number %.3g > 1e7); the parameters are "
        "not all identifiable from these poses",
        s->jacobian_condition_number);
  }
  auto problem = make_problem(poses, options, inertia_scale, c0_bar_scale, p);
  ceres::Covariance::Options cov_options;
  cov_options.min_reciprocal_condition_number = kMinReciprocalCondition;
  cov_options.algorithm_type = ceres::DENSE_SVD;
  cov_options.null_space_rank = 0;  // fail instead of silently dropping directions
  cov_options.num_threads = 1;
  ceres::Covariance covariance(cov_options);
  const std::vector<std::pair<const double*, const double*>> blocks = {{p, p}};
  if (!covariance.Compute(blocks, problem.get())) {
    return "ceres::Covariance failed (rank-deficient or ill-conditioned Jacobian)";
  }
  double raw[kNumParams * kNumParams];
  if (!covariance.GetCovarianceBlock(p, p, raw))
    return "ceres::Covariance::GetCovarianceBlock failed";
  const std::array<double, kNumParams> scale = parameter_scales(inertia_scale, c0_bar_scale);
  const int dof = s->num_residuals - kNumParams;
  const double sigma2 = 2.0 * s->final_cost / static_cast<double>(dof);
  InertiaFitMatrix unscaled;  // (JᵀJ)⁻¹ in natural units, without σ̂²
  for (int i = 0; i < kNumParams; ++i) {
    for (int j = 0; j < kNumParams; ++j)
      unscaled(i, j) = raw[i * kNumParams + j] * scale[static_cast<std::size_t>(i)] *
                       scale[static_cast<std::size_t>(j)];
  }
  if (!unscaled.allFinite()) return "ceres::Covariance returned non-finite values";
  s->covariance = sigma2 * unscaled;
  for (int i = 0; i < kNumParams; ++i) {
    s->standard_errors[static_cast<std::size_t>(i)] = std::sqrt(std::max(0.0, s->covariance(i, i)));
  }
  for (int i = 0; i < kNumParams; ++i) {
    for (int j = 0; j < kNumParams; ++j) {
      // From (JᵀJ)⁻¹ so that it is defined even for an exact fit (σ̂ = 0).
      const double d = std::sqrt(unscaled(i, i) * unscaled(j, j));
      s->correlation(i, j) = (d > 0.0) ? unscaled(i, j) / d : (i == j ? 1.0 : 0.0);
    }
  }
  return {};
}

void flag_parameters(const InertiaFitOptions& options, InertiaFitSummary* s) {
  std::string poorly;
  for (int i = 0; i < kNumParams; ++i) {
    const std::size_t ui = static_cast<std::size_t>(i);
    std::string why;
    if (!s->covariance_ok) {
      why = "no covariance";
    } else {
      const double se = s->standard_errors[ui];
      if (i == kGammaOffs) {
        if (se > options.poorly_determined_gamma_offs_se_rad) {
          why = format("SE %.3g deg", rad_to_deg(se));
        }
      } else {
        const double rel = se / std::abs(s->parameters[ui]);
        if (!(rel <= options.poorly_determined_relative_se)) {
          why = format("relative SE %.0f %%", 100.0 * rel);
        }
      }
      for (int j = 0; j < kNumParams; ++j) {
        if (j != i && std::abs(s->correlation(i, j)) > options.poorly_determined_correlation) {
          why += format("%s|corr| with %s = %.4f", why.empty() ? "" : ", ",
                        inertia_fit_parameter_name(j), std::abs(s->correlation(i, j)));
        }
      }
    }
    s->poorly_determined[ui] = !why.empty();
    if (!why.empty()) {
      poorly += format("%s%s (%s)", poorly.empty() ? "" : "; ", inertia_fit_parameter_name(i),
                       why.c_str());
    }
  }
  std::string bounds;
  for (int i = 0; i < kNumParams; ++i) {
    if (s->at_bound[static_cast<std::size_t>(i)]) {
      bounds += format("%s%s = %g", bounds.empty() ? "" : ", ", inertia_fit_parameter_name(i),
                       s->parameters[static_cast<std::size_t>(i)]);
    }
  }
  if (!poorly.empty()) {
    s->warning += std::string(s->warning.empty() ? "" : " ") + "Poorly determined: " + poorly + ".";
  }
  if (!bounds.empty()) {
    s->warning += std::string(s->warning.empty() ? "" : " ") + "On a bound: " + bounds + ".";
  }
}

}  // namespace

const char* inertia_fit_parameter_name(int index) noexcept {
  switch (index) {
    case kIBase:
      return "I_base";
    case kI1:
      return "I1";
    case kI2:
      return "I2";
    case kI3:
      return "I3";
    case kGammaOffs:
      return "gamma_offs";
    case kC0Bar:
      return "C0_bar";
    default:
      return "?";
  }
}

void InertiaFitOptions::validate() const {
  const std::string p = "InertiaFitOptions::";
  if (!std::isfinite(gamma_offs_min_rad) || !std::isfinite(gamma_offs_max_rad) ||
      !(gamma_offs_min_rad < gamma_offs_max_rad)) {
    throw Error(format("expected finite gamma_offs_min_rad < gamma_offs_max_rad, got %g, %g",
                       gamma_offs_min_rad, gamma_offs_max_rad),
                {}, 0, p + "gamma_offs_min_rad");
  }
  if (gamma_offs_starts_rad.empty()) {
    throw Error("expected at least one start, got none", {}, 0, p + "gamma_offs_starts_rad");
  }
  for (std::size_t i = 0; i < gamma_offs_starts_rad.size(); ++i) {
    const double g = gamma_offs_starts_rad[i];
    if (!(g >= gamma_offs_min_rad && g <= gamma_offs_max_rad)) {
      throw Error(format("expected a gamma_offs start in [%g, %g] rad, got %g", gamma_offs_min_rad,
                         gamma_offs_max_rad, g),
                  {}, 0, p + "gamma_offs_starts_rad[" + std::to_string(i) + "]");
    }
  }
  for (std::size_t i = 0; i < inertia_scale_starts.size(); ++i) {
    detail::require_positive(p + "inertia_scale_starts[" + std::to_string(i) + "]",
                             inertia_scale_starts[i]);
  }
  if (max_iterations < 1) {
    throw Error(format("expected max_iterations >= 1, got %d", max_iterations), {}, 0,
                p + "max_iterations");
  }
  if (!(function_tolerance >= 0.0))
    detail::bad(p + "function_tolerance", "a tolerance >= 0", function_tolerance);
  if (!(gradient_tolerance >= 0.0))
    detail::bad(p + "gradient_tolerance", "a tolerance >= 0", gradient_tolerance);
  if (!(parameter_tolerance >= 0.0))
    detail::bad(p + "parameter_tolerance", "a tolerance >= 0", parameter_tolerance);
  detail::require_positive(p + "poorly_determined_relative_se", poorly_determined_relative_se);
  detail::require_positive(p + "poorly_determined_gamma_offs_se_rad",
                           poorly_determined_gamma_offs_se_rad);
  if (!(poorly_determined_correlation > 0.0 && poorly_determined_correlation <= 1.0)) {
    detail::bad(p + "poorly_determined_correlation", "a correlation in (0, 1]",
                poorly_determined_correlation);
  }
}

C0BarEstimate regress_c0_bar(const std::vector<InertiaPose>& poses) {
  C0BarEstimate out;
  if (poses.empty()) {
    out.message = "no poses";
    return out;
  }
  double num = 0.0;
  double den = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const InertiaPose& p = poses[i];
    if (!std::isfinite(p.c_linear) || !(p.c_linear > 0.0) || !std::isfinite(p.beta_tilde_linear) ||
        !(p.beta_tilde_linear > 0.0) || !std::isfinite(p.weight) || !(p.weight > 0.0)) {
      out.message =
          format("pose %zu: need finite c_linear, beta_tilde_linear, weight > 0, got %g, %g, %g", i,
                 p.c_linear, p.beta_tilde_linear, p.weight);
      return out;
    }
    // β̃ = C̄0·C through the origin (from (28)-(29)).
    num += p.weight * p.c_linear * p.beta_tilde_linear;
    den += p.weight * p.c_linear * p.c_linear;
  }
  out.c0_bar = num / den;
  double sum = 0.0;
  for (const InertiaPose& p : poses) {
    const double r = (out.c0_bar * p.c_linear - p.beta_tilde_linear) / p.beta_tilde_linear;
    sum += r * r;
  }
  out.rms_relative_residual = std::sqrt(sum / static_cast<double>(poses.size()));
  out.ok = std::isfinite(out.c0_bar) && out.c0_bar > 0.0;
  if (!out.ok) out.message = "C0_bar regression gave a non-finite or non-positive value";
  return out;
}

InertiaFitSummary fit_inertia_model(const std::vector<InertiaPose>& poses,
                                    const InertiaFitOptions& options) {
  InertiaFitSummary s;
  s.num_poses = static_cast<int>(poses.size());
  s.num_residuals = 2 * s.num_poses;
  try {
    options.validate();
  } catch (const Error& e) {
    s.message = std::string("not fitted: invalid options: ") + e.what();
    return s;
  }
  std::string error = check_poses(poses);
  if (!error.empty()) {
    s.message = "not fitted: " + error;
    return s;
  }

  // Internal scaling (see InertiaCostFunction): s_I = mean observed inertia 1/β̃, s_C = C̄0 of the
  // closed-form regression.
  double inertia_scale = 0.0;
  for (const InertiaPose& p : poses) inertia_scale += 1.0 / p.beta_tilde_linear;
  inertia_scale /= static_cast<double>(poses.size());
  const C0BarEstimate c0_guess = regress_c0_bar(poses);
  const double c0_bar_scale = c0_guess.ok ? c0_guess.c0_bar : 1.0;

  // Deterministic multi-start over γ_offs × (NNLS inertias, uniform inertias × scale).
  std::vector<std::vector<double>> starts;
  for (double gamma_offs : options.gamma_offs_starts_rad) {
    std::vector<std::vector<double>> inertia_starts;
    double x[4];
    if (nnls_inertias(poses, gamma_offs, inertia_scale, x)) {
      inertia_starts.push_back({x[0], x[1], x[2], x[3]});
    }
    for (double f : options.inertia_scale_starts) {
      const double a = f / 2.5;  // I ≈ a·(1 + cos²γ1 + cos²ψ + cosγ1 cosψ) ≈ 2.5·a on average
      inertia_starts.push_back({a, a, a, a});
    }
    for (const std::vector<double>& xi : inertia_starts) {
      std::vector<double> p = {xi[0], xi[1], xi[2], xi[3], gamma_offs, 1.0};
      if (!best_c0_bar(poses, p.data(), inertia_scale, c0_bar_scale, &p[kC0Bar])) continue;
      starts.push_back(p);
    }
  }

  StartResult best;
  std::vector<double> final_costs;
  for (const std::vector<double>& start : starts) {
    ++s.num_starts;
    StartResult r = solve_from(poses, options, inertia_scale, c0_bar_scale, start.data());
    if (!r.usable) continue;
    ++s.num_starts_usable;
    final_costs.push_back(r.final_cost);
    if (r.final_cost < best.final_cost) best = r;
  }
  for (double cost : final_costs) {
    if (cost <= best.final_cost * (1.0 + 1e-6) + 1e-300) ++s.num_starts_at_best;
  }
  if (!best.usable) {
    s.message = format(
        "not fitted: none of %d starts gave a usable solution (inertia <= 0 at a "
        "pose for every start?)%s%s",
        s.num_starts, best.message.empty() ? "" : "; last Ceres message: ", best.message.c_str());
    return s;
  }

  const std::array<double, kNumParams> scale = parameter_scales(inertia_scale, c0_bar_scale);
  for (int k = 0; k < kNumParams; ++k) {
    s.parameters[static_cast<std::size_t>(k)] = scale[static_cast<std::size_t>(k)] * best.p[k];
  }
  s.model.inertia = InertiaModel{s.parameters[kIBase], s.parameters[kI1], s.parameters[kI2],
                                 s.parameters[kI3], s.parameters[kGammaOffs]};
  s.model.c0_bar = s.parameters[kC0Bar];
  for (int k = kIBase; k <= kI3; ++k) s.at_bound[static_cast<std::size_t>(k)] = best.p[k] <= 1e-10;
  s.at_bound[kGammaOffs] = best.p[kGammaOffs] <= options.gamma_offs_min_rad + 1e-10 ||
                           best.p[kGammaOffs] >= options.gamma_offs_max_rad - 1e-10;
  s.at_bound[kC0Bar] = best.p[kC0Bar] <= 1e-9 * (1.0 + 1e-6);
  s.iterations = best.iterations;
  s.initial_cost = best.initial_cost;
  s.final_cost = best.final_cost;
  fill_statistics(poses, &s);

  s.converged = best.converged;
  s.message = format("%s after %d iterations (best of %d usable starts out of %d); Ceres: %s",
                     best.converged ? "converged" : "NOT converged", best.iterations,
                     s.num_starts_usable, s.num_starts, best.message.c_str());

  if (options.compute_covariance) {
    const std::string cov_error =
        compute_covariance(poses, options, inertia_scale, c0_bar_scale, best.p, &s);
    s.covariance_ok = cov_error.empty();
    if (!s.covariance_ok)
      s.warning = "Covariance not available: " + cov_error + "; standard errors are NaN.";
  } else {
    s.warning = "Covariance not computed (options.compute_covariance = false).";
  }
  flag_parameters(options, &s);
  return s;
}

std::string InertiaFitSummary::brief_report() const {
  std::string flagged;
  for (int i = 0; i < kNumParams; ++i) {
    if (poorly_determined[static_cast<std::size_t>(i)]) {
      flagged += format("%s%s", flagged.empty() ? "" : ",", inertia_fit_parameter_name(i));
    }
  }
  return format(
      "inertia fit: %s, %d poses, cost %.6g, residual RMS %.4g, C0_bar %.6g, "
      "poorly determined: %s",
      converged ? "converged" : "NOT converged", num_poses, final_cost, residual_rms, model.c0_bar,
      flagged.empty() ? "none" : flagged.c_str());
}

std::string InertiaFitSummary::full_report() const {
  std::string out = brief_report() + "\n" + message + "\n";
  if (!std::isfinite(parameters[0])) return out;
  out += format(
      "  RMS relative error: C %.4g, beta_tilde %.4g (max %.4g, %.4g); iterations %d; "
      "%d of %d usable starts reached the best cost; Jacobian condition number %.3g\n",
      rms_relative_c, rms_relative_beta_tilde, max_abs_relative_c, max_abs_relative_beta_tilde,
      iterations, num_starts_at_best, num_starts_usable, jacobian_condition_number);
  for (int i = 0; i < kNumParams; ++i) {
    const std::size_t ui = static_cast<std::size_t>(i);
    const bool angle = i == kGammaOffs;
    const double v = angle ? rad_to_deg(parameters[ui]) : parameters[ui];
    const double se = angle ? rad_to_deg(standard_errors[ui]) : standard_errors[ui];
    out += format("  %-10s = %-12.6g +- %-10.4g%s%s%s\n", inertia_fit_parameter_name(i), v, se,
                  angle ? " deg" : "", poorly_determined[ui] ? "  poorly determined" : "",
                  at_bound[ui] ? "  (on bound)" : "");
  }
  if (covariance_ok) {
    out += "  correlation:\n";
    for (int i = 0; i < kNumParams; ++i) {
      out += format("    %-10s", inertia_fit_parameter_name(i));
      for (int j = 0; j < kNumParams; ++j) out += format(" %7.3f", correlation(i, j));
      out += "\n";
    }
  }
  if (!warning.empty()) out += "  warning: " + warning + "\n";
  return out;
}

namespace detail {

InertiaJacobianCheck check_inertia_fit_jacobian(const InertiaPose& pose, const double* params,
                                                double inertia_scale, double c0_bar_scale,
                                                double relative_precision) {
  InertiaJacobianCheck out;
  const InertiaCostFunction cost(pose, inertia_scale, c0_bar_scale);
  const std::array<double, kNumParams> scale = parameter_scales(inertia_scale, c0_bar_scale);
  double p[kNumParams];
  for (int k = 0; k < kNumParams; ++k) p[k] = params[k] / scale[static_cast<std::size_t>(k)];
  const double* blocks[] = {p};

  // 1. Ceres' own check. ProbeResults is not requested: its Eigen members are allocated inside
  // libceres and freeing them here breaks when this file is built with AddressSanitizer (Eigen then
  // assumes a different aligned allocator than the prebuilt library).
  ceres::NumericDiffOptions numeric_options;
  // Ridders' first step is 2^5 × this × |p_k|; Ceres' default 1e-2 gives 32 % steps, too close to
  // the pole of 1/C̄0 for the tableau to converge (it stops early with ~1 % errors).
  numeric_options.ridders_relative_initial_step_size = 1e-3;
  const ceres::GradientChecker checker(
      &cost, static_cast<const std::vector<const ceres::Manifold*>*>(nullptr), numeric_options);
  out.ok = checker.Probe(blocks, relative_precision, nullptr);
  if (!out.ok) out.log = "ceres::GradientChecker::Probe failed. ";

  // 2. The error size: central differences with one Richardson step on the same cost function.
  double r[2];
  double jac[2 * kNumParams];
  double* jacs[] = {jac};
  if (!cost.Evaluate(blocks, r, jacs)) {
    out.ok = false;
    out.max_relative_error = std::numeric_limits<double>::infinity();
    out.log += "the cost function cannot be evaluated at this point";
    return out;
  }
  auto central = [&cost, &p](int k, double h, double* d) {
    double pp[kNumParams];
    double pm[kNumParams];
    std::copy(p, p + kNumParams, pp);
    std::copy(p, p + kNumParams, pm);
    pp[k] += h;
    pm[k] -= h;
    const double* bp[] = {pp};
    const double* bm[] = {pm};
    double rp[2] = {0.0, 0.0};
    double rm[2] = {0.0, 0.0};
    const bool ok = cost.Evaluate(bp, rp, nullptr) && cost.Evaluate(bm, rm, nullptr);
    for (int i = 0; i < 2; ++i) d[i] = (rp[i] - rm[i]) / (2.0 * h);
    return ok;
  };
  out.max_relative_error = 0.0;
  for (int k = 0; k < kNumParams; ++k) {
    const double h = 1e-4 * std::max(std::abs(p[k]), 1.0);  // internal parameters are O(1)
    double d1[2];
    double d2[2];
    if (!central(k, h, d1) || !central(k, 0.5 * h, d2)) {
      out.ok = false;
      out.max_relative_error = std::numeric_limits<double>::infinity();
      out.log += format("cannot difference parameter %s", inertia_fit_parameter_name(k));
      return out;
    }
    for (int i = 0; i < 2; ++i) {
      const double fd = (4.0 * d2[i] - d1[i]) / 3.0;
      const double analytic = jac[i * kNumParams + k];
      const double err =
          std::abs(analytic - fd) / std::max({std::abs(analytic), std::abs(fd), 1e-12});
      if (err > out.max_relative_error) {
        out.max_relative_error = err;
        if (err > relative_precision) {
          out.ok = false;
          out.log += format("d r%d / d %s: analytic %.12g, finite difference %.12g. ", i,
                            inertia_fit_parameter_name(k), analytic, fd);
        }
      }
    }
  }
  return out;
}

}  // namespace detail
}  // namespace alphainv
