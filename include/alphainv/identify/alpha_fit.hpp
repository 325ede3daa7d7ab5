#pragma once
/// \file alpha_fit.hpp
/// Identification of the α-invariant model from sinusoidal steady-state points, section 2.3.5:
/// breakpoints α0 … α_{N−1} by grid search, then the two-stage fit — per pose, C_0 … C_{N−1}
/// (piecewise linear in α, eq. (38)) and β̃_0, β̃_1 (linear in α, eq. (41)) by linear least squares
/// to C_data and β_data/kp; then, across poses, the inverted models (40), (42)
/// 1/C_n = C_n1·I and 1/β̃_n = β̃_n1·I by ordinary least squares through the origin.
/// Offline (allocates); never throws on bad data: the result says what went wrong.

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "alphainv/model/damping_model.hpp"
#include "alphainv/identify/local_linear.hpp"

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
  /// Refine the grid winner's breakpoints by a local derivative-free search (NLopt Nelder-Mead on
  /// the log-breakpoints; see fit_alpha_model()). false: the grid search alone, as the paper.
  bool refine = true;
  int refine_max_evaluations = 400;  ///< cap on fit_alpha_model_at() calls of the refinement
  /// A C_n1 (or β̃_n1) whose standard error exceeds this fraction of its value is reported as not
  /// identifiable (c_n1_identifiable / beta_n1_identifiable).
  double identifiable_relative_se = 0.1;
  double ridge = 1e-6;            ///< relative Tikhonov weight keeping empty segments determined
  /// Keep this many runners-up of the grid search (AlphaFitResult::runners_up): breakpoint sets
  /// that fit the points nearly as well can predict other runs quite differently.
  std::size_t keep_runners_up = 0;
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
  double grid_score = 0.0;           ///< c_rms_relative² + beta_rms_relative² of the grid winner
  double score = 0.0;                ///< the same for the returned model (≤ grid_score)
  bool refined = false;              ///< the local search moved the breakpoints
  /// The next best breakpoint sets of the grid search after the winner's (α0 … α_{N−1}, best
  /// first; at most AlphaFitOptions::keep_runners_up).
  std::vector<std::vector<double>> runners_up;
  int refine_evaluations = 0;        ///< fit_alpha_model_at() calls of the refinement
  /// Range of α_data over the physical points used [command unit²/s²]: only there do the data
  /// say anything about C(α) and β̃(α).
  double alpha_data_min = 0.0, alpha_data_max = 0.0;
  /// Breakpoint n's position is pinned by data: physical points lie on both sides of it within its
  /// neighbouring segments (the top one: two or more points above it, reaching 1.5·α_{N−1}). α0 = 0
  /// is a convention (C held below), never "pinned"; a top breakpoint near or above the data's top
  /// is not identifiable (only the line through the last points is), nor is its C_n1.
  std::array<bool, kMaxBreakpoints> breakpoint_identifiable{};
  /// C_n1 identifiable: relative SE ≤ identifiable_relative_se and data on its hat function's
  /// support.
  std::array<bool, kMaxBreakpoints> c_n1_identifiable{};
  /// β̃_n1 identifiable: relative SE small and its ᾱ within or at the data's α range (ᾱ1 = α_{N−1}
  /// above alpha_data_max is an extrapolation of the line fitted to the data).
  std::array<bool, 2> beta_n1_identifiable{};
};

/// Fits the α-invariant model (see file comment). Breakpoints: α0 = 0 (below it C is held), the
/// others chosen from a log-spaced grid spanning the data's α by exhaustive search minimising the
/// relative RMS error of the final model on C_data and β̃_data (the paper's grid search; exhaustive
/// over C(grid, N−1) sets, deterministic), then — with options.refine — moved off the grid by a
/// local Nelder-Mead search (NLopt) on the same score from the grid winner. β̃ uses ᾱ0 = 0 and
/// ᾱ1 = α_{N−1}. The result says which breakpoints and coefficients the data pin down.
AlphaFitResult fit_alpha_model(const std::vector<AlphaFitPose>& poses, const AlphaFitOptions& options);

/// The inertia at each pose that makes the fitted α-model best match that pose's physical points:
/// the model is C(α, I) = c(α)/I, β̃(α, I) = b(α)/I (eqs. (38)-(42)), so u = 1/I minimises
/// Σ (u·c(α_k)/C_k − 1)² + (u·b(α_k)/β̃_k − 1)² in closed form. NaN for a pose without points.
/// Used to re-identify the inertia model consistently with the α-model (fit_pipeline).
std::vector<double> alpha_model_pose_inertia(const std::vector<AlphaFitPose>& poses,
                                             const AlphaModel& model, double kp);

/// Stage 2 only, with the breakpoints given: used by the grid search and by tests.
AlphaFitResult fit_alpha_model_at(const std::vector<AlphaFitPose>& poses,
                                  const std::vector<double>& breakpoints,
                                  const AlphaFitOptions& options);

}  // namespace alphainv
