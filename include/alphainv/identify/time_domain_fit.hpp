#pragma once
/// \file time_domain_fit.hpp
/// The linear model (26) and the α-invariant model (37)-(42) of one pose identified from arbitrary
/// closed-loop runs (steps, multisines, chirps, ramps), for datasets without the paper's sine
/// sweep. Two stages:
///  1. an equation-error start (the inverse-dynamics least squares of the EMPS reference): θ̇, θ̈
///     and v̇, v̈ from local quadratic fits, then θ̈ = −C·θ̇ + β̃·v by linear least squares;
///  2. output error (output_error.hpp): C and β̃ (linear model), then C_0 … C_{N−1}, β̃_0, β̃_1 at
///     breakpoints placed at quantiles of the runs' α (α-model), each minimising the closed-loop
///     simulation error of θ under the runs' own controllers.
/// Offline; never throws on what the data cannot support, nor on invalid options: the result says
/// (usable(), `message`, brief_report(), full_report()).

#include <array>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "alphainv/model/controller.hpp"
#include "alphainv/model/damping_model.hpp"
#include "alphainv/data/dataset.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

/// One run and its controller.
struct TimeDomainRun {
  const RunData* data = nullptr;  ///< must outlive the call
  Controller controller;
};

/// Settings of the time-domain fits.
struct TimeDomainFitOptions {
  std::size_t n_breakpoints = 4;  ///< N of the α-model
  unsigned threads = 0;           ///< runs simulated in parallel; 0: all cores
  /// Simulation: the continuous law, or the digital loop when loop_period_s > 0 (set it to the
  /// sample period of uniformly sampled 1 kHz rigs).
  SimulationOptions simulation;
  double smoothing_window_s = 0.01;  ///< half-width of the local quadratic fits of stage 1 [s]
  std::size_t max_residuals_per_run = 3000;  ///< output-error residual samples per run
  Effects effects;  ///< known effects kept fixed in the model (e.g. from `diagnose`)

  /// Throws alphainv::Error naming the first setting out of range ("TimeDomainFitOptions::…"):
  /// n_breakpoints in [2, kMaxBreakpoints], smoothing_window_s finite and > 0,
  /// max_residuals_per_run ≥ 1, the effects (validate_effects()). The fits call it and return a
  /// result that is not usable, with the error as its message.
  void validate() const;
};

/// The linear model of a pose from time-domain data.
struct TimeDomainLinearFit {
  bool ok = false;      ///< see usable()
  std::string message;  ///< why not usable, or the output-error solver's one-line report
  double c_equation_error = std::numeric_limits<double>::quiet_NaN();   ///< stage 1 C [1/s]
  double beta_tilde_equation_error = std::numeric_limits<double>::quiet_NaN();  ///< stage 1 β̃
  double c_linear = std::numeric_limits<double>::quiet_NaN();           ///< output error C [1/s]
  double beta_tilde_linear = std::numeric_limits<double>::quiet_NaN();  ///< output error β̃
  double c_se = std::numeric_limits<double>::quiet_NaN();               ///< standard error of C
  double beta_tilde_se = std::numeric_limits<double>::quiet_NaN();      ///< standard error of β̃
  double rms = std::numeric_limits<double>::quiet_NaN();  ///< RMS of θ − θ_sim [position unit]

  /// True when C and β̃ were fitted (`ok`): the equation-error start and the output error worked.
  bool usable() const { return ok; }
  /// One line: usable or why not, C ± SE, β̃ ± SE, the RMS of θ − θ_sim.
  std::string brief_report() const;
  /// brief_report(), the equation-error start, and `message`.
  std::string full_report() const;
};

/// The α-model of a pose from time-domain data (inertia 1: C_n1 = 1/C_n, β̃_n1 = 1/β̃_n).
struct TimeDomainAlphaFit {
  bool ok = false;      ///< see usable()
  std::string message;  ///< why not usable, or the output-error solver's one-line report
  AlphaModel model;
  std::array<double, kMaxBreakpoints> c_se{};  ///< standard errors of C_0 … C_{N−1} [1/s]
  std::array<double, 2> beta_tilde_se{};       ///< standard errors of β̃_0, β̃_1
  double rms = std::numeric_limits<double>::quiet_NaN();  ///< RMS of θ − θ_sim [position unit]
  double alpha_max = 0.0;  ///< largest α of the runs' commands (the data's α range ends there)
  /// Largest |correlation| of each estimate (C_0 … C_{N−1}, then β̃_0, β̃_1 at N, N+1) with any
  /// other (NaN: not available).
  std::array<double, kMaxBreakpoints + 2> max_abs_correlation{};
  /// Identifiable from the data: relative SE ≤ 10 % and no correlation above 0.95 with another
  /// estimate (C_0 … C_{N−1}; β̃_0, β̃_1).
  std::array<bool, kMaxBreakpoints> c_identifiable{};
  std::array<bool, 2> beta_tilde_identifiable{};

  /// True when the α-model was fitted and is valid (`ok`).
  bool usable() const { return ok; }
  /// One line: usable or why not, N, the top breakpoint against the data's largest α, the RMS.
  std::string brief_report() const;
  /// brief_report(), C_n ± SE at every breakpoint, β̃_0, β̃_1 ± SE, and `message`.
  std::string full_report() const;
};

/// Stage 1 and 2 for the linear model (26).
TimeDomainLinearFit fit_linear_time_domain(const std::vector<TimeDomainRun>& runs,
                                           const TimeDomainFitOptions& options = {});

/// The α-model, starting from the linear fit `start` (its C and β̃ at every breakpoint).
TimeDomainAlphaFit fit_alpha_time_domain(const std::vector<TimeDomainRun>& runs,
                                         const TimeDomainLinearFit& start,
                                         const TimeDomainFitOptions& options = {});

/// α = v̇² − v·v̈ (eq. (33)) of a sampled command, with v̇ and v̈ from local quadratic fits over
/// ±half_window_s (at least 2 samples each side). Works on irregular sampling.
std::vector<double> alpha_of_command(const std::vector<double>& t, const std::vector<double>& v,
                                     double half_window_s);

/// First and second derivatives of y(t) by local quadratic least squares over ±half_window_s (at
/// least 2 samples each side).
void local_quadratic_derivatives(const std::vector<double>& t, const std::vector<double>& y,
                                 double half_window_s, std::vector<double>& dy,
                                 std::vector<double>& ddy);

}  // namespace alphainv
