#pragma once
/// \file residual_analysis.hpp
/// How well a simulated output matches a measured one, the way system identification judges a
/// model on data it was not fitted on (MATLAB's `compare` and `resid`):
/// - fit figures: RMS and largest error, NRMSE fit 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) [%] (`compare`), and
///   the relative error ‖y − ŷ‖/‖y‖ (the EMPS benchmark's definition);
/// - residual tests: the normalised autocorrelation ρ_e(τ) of e = y − ŷ for τ = 1..M and its
///   cross-correlation ρ_eu(τ) with the input for τ = −M..M, each with its 99 % confidence band
///   for a white residual independent of the input, and a verdict from a portmanteau test of all
///   lags together (Ljung-Box for ρ_e; the analogous sum for ρ_eu), so that the one lag in a
///   hundred that leaves its band by chance does not decide it.
/// Set-up code: allocates, not real-time.

#include <cstddef>
#include <string>
#include <vector>

namespace alphainv {

/// Fit figures of a simulated output ŷ against the measured y.
struct FitFigures {
  std::size_t n = 0;                ///< samples compared
  double rms = 0.0;                 ///< sqrt(mean (y − ŷ)²) [unit of y]
  double max_abs = 0.0;             ///< max |y − ŷ| [unit of y]
  double fit_percent = 0.0;         ///< 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) [%]; −∞ … 100, NaN when y is constant
  double relative_error = 0.0;      ///< ‖y − ŷ‖/‖y‖ [1]; NaN when y is all zero
  double sum_squared_error = 0.0;   ///< ‖y − ŷ‖² (pooling several runs)
  double sum_squared_deviation = 0.0;  ///< ‖y − ȳ‖² (with ȳ of this run)
  double sum_squared = 0.0;         ///< ‖y‖²
};

/// Fit figures of ŷ against y over samples [begin, end) (end clipped to the shorter vector).
/// Non-finite pairs are skipped and counted out of n.
FitFigures fit_figures(const std::vector<double>& y, const std::vector<double>& y_hat,
                       std::size_t begin = 0, std::size_t end = static_cast<std::size_t>(-1));

/// The figures of several runs pooled over all their samples: ‖·‖ over the concatenation, with
/// fit_percent's ȳ taken per run (each run's own mean, as `compare` does per experiment).
FitFigures pooled_fit_figures(const std::vector<FitFigures>& runs);

/// Options of residual_tests().
struct ResidualTestOptions {
  std::size_t max_lag = 25;    ///< M, lags tested (MATLAB resid's default)
  double confidence = 0.99;    ///< of the bands and of the verdicts, in (0, 1)
  /// Use every k-th sample (1: all). A residual sampled much faster than the dynamics is
  /// correlated over many samples whatever the model; testing at a coarser step looks at lags that
  /// span the dynamics. 0: chosen so that M lags span about 0.25 s at the run's sample period.
  std::size_t decimation = 0;
  double sample_period_s = 0.0;  ///< the run's sample period, for decimation 0 [s]
};

/// The residual tests of one residual e (and input u).
struct ResidualTests {
  std::size_t n = 0;            ///< samples used (after decimation)
  std::size_t decimation = 1;   ///< every k-th sample was used
  std::vector<double> autocorrelation;    ///< ρ_e(τ), τ = 0..M (ρ_e(0) = 1)
  std::vector<double> cross_correlation;  ///< ρ_eu(τ), τ = −M..M (index τ + M); empty without u
  double autocorrelation_bound = 0.0;     ///< the 99 % band ±z/√n of ρ_e(τ), τ ≥ 1
  double cross_correlation_bound = 0.0;   ///< the band of ρ_eu(τ) (accounts for u's own colour)
  std::vector<int> lags_outside_auto;     ///< τ ≥ 1 with |ρ_e(τ)| beyond its band
  std::vector<int> lags_outside_cross;    ///< τ with |ρ_eu(τ)| beyond its band
  double ljung_box_q = 0.0;     ///< n(n+2)·Σ ρ_e(τ)²/(n − τ), τ = 1..M: χ²(M) when e is white
  double cross_q = 0.0;         ///< Σ (ρ_eu(τ)/band-σ)²: χ²(2M+1) when e is independent of u
  double chi2_auto_limit = 0.0;   ///< the χ²(M) quantile at `confidence`
  double chi2_cross_limit = 0.0;  ///< the χ²(2M+1) quantile at `confidence`
  bool white = false;             ///< Q below its limit: no evidence of missed dynamics
  bool input_correlated = false;  ///< cross Q above its limit: the model misses input dynamics
  bool valid = false;             ///< enough samples (n > 4·M) and a residual that is not constant
  std::string message;            ///< why not valid; otherwise empty

  /// One line, e.g. "residual not white (Q 812 > 37.6; lags 1-25 outside ±0.012): the model misses
  /// dynamics; correlated with the input at lags -3..12: it misses input dynamics".
  std::string verdict() const;
};

/// The residual tests of e (and u, when not empty; same length as e). Non-finite samples make
/// the result invalid with the reason.
ResidualTests residual_tests(const std::vector<double>& e, const std::vector<double>& u,
                             const ResidualTestOptions& options = {});

/// The standard normal quantile z with P(Z ≤ z) = p, p in (0, 1) (Acklam's rational
/// approximation, relative error < 1.2e-9).
double normal_quantile(double p);

/// The χ² quantile with `dof` degrees of freedom at probability p (Wilson–Hilferty; within 1 % for
/// dof ≥ 3 at p = 0.99).
double chi2_quantile(double dof, double p);

}  // namespace alphainv
