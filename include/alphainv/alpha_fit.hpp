#pragma once
/// \file alpha_fit.hpp
/// Identification of the α-invariant model from sinusoidal steady-state points, section 2.3.5:
/// breakpoints α0 … α_{N−1} by grid search, then the two-stage fit — per pose, C_0 … C_{N−1}
/// (piecewise linear in α, eq. (38)) and β̃_0, β̃_1 (linear in α, eq. (41)) by linear least squares
/// to C_data and β_data/kp; then, across poses, the inverted models (40), (42)
/// 1/C_n = C_n1·I and 1/β̃_n = β̃_n1·I by ordinary least squares through the origin.
/// Offline (allocates); never throws on bad data: the result says what went wrong.

#include <cstddef>
#include <string>
#include <vector>

#include "alphainv/damping_model.hpp"
#include "alphainv/identify.hpp"

namespace alphainv {

/// The local points of one pose and its inertia (use inertia = 1 when there is no inertia model:
/// then C_n1 = 1/C_n is the per-pose model).
struct AlphaFitPose {
  double inertia = 1.0;                   ///< I at this pose [normalised inertia]
  std::vector<LocalLinearPoint> points;   ///< physical points are used, others ignored
};

/// Settings of fit_alpha_model().
struct AlphaFitOptions {
  std::size_t n_breakpoints = 4;  ///< N (the paper's tri-linear model: 4)
  double kp = 2.0;                ///< proportional gain: β̃_data = β_data / kp
  std::size_t grid_size = 16;     ///< log-spaced candidate breakpoints for the grid search
  double ridge = 1e-6;            ///< relative Tikhonov weight keeping empty segments determined
};

/// Result of fit_alpha_model().
struct AlphaFitResult {
  bool ok = false;
  std::string message;
  AlphaModel model;                             ///< breakpoints, C_n1, β̃_n1
  std::vector<std::vector<double>> pose_c;      ///< stage 1: C_0 … C_{N−1} per pose [1/s]
  std::vector<std::array<double, 2>> pose_beta_tilde;  ///< stage 1: β̃_0, β̃_1 per pose
  std::array<double, kMaxBreakpoints> c_n1_se{};  ///< standard errors of C_n1 (NaN if < 2 poses)
  std::array<double, 2> beta_n1_se{};             ///< standard errors of β̃_n1
  double c_rms_relative = 0.0;     ///< RMS of (C_model(α_data, I) − C_data)/C_data over points
  double beta_rms_relative = 0.0;  ///< same for β̃
  std::size_t points_used = 0;
  std::size_t candidates_tried = 0;  ///< breakpoint sets evaluated by the grid search
};

/// Fits the α-invariant model (see file comment). Breakpoints: α0 = 0 (below it C is held), the
/// others chosen from a log-spaced grid spanning the data's α by exhaustive search minimising the
/// relative RMS error of the final model on C_data (the paper's grid search; exhaustive over
/// C(grid, N−1) sets, deterministic). β̃ uses ᾱ0 = 0 and ᾱ1 = α_{N−1}.
AlphaFitResult fit_alpha_model(const std::vector<AlphaFitPose>& poses, const AlphaFitOptions& options);

/// Stage 2 only, with the breakpoints given: used by the grid search and by tests.
AlphaFitResult fit_alpha_model_at(const std::vector<AlphaFitPose>& poses,
                                  const std::vector<double>& breakpoints,
                                  const AlphaFitOptions& options);

}  // namespace alphainv
