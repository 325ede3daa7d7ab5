#pragma once
/// \file output_error.hpp
/// Time-domain (output-error) identification: the parameters p that minimise
///     Σ_runs w_i Σ_k (θ_k − θ_sim,k(p))²,
/// where θ_sim is the closed-loop simulation (simulate.hpp) of each run under its own controller,
/// driven by the run's measured reference. It works on any excitation (steps, multisines, chirps,
/// free-form trajectories), so it fits datasets without sine runs, and it fits effect parameters
/// (effects.hpp) together with the model. Solved by Ceres' Levenberg-Marquardt with bounds and
/// central-difference Jacobians of the simulation, from one or more starts. Offline; never throws
/// on what the data cannot support, nor on invalid options: the result says (usable(), `message`,
/// brief_report(), full_report()).

#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "alphainv/model/controller.hpp"
#include "alphainv/data/dataset.hpp"
#include "alphainv/simulate/recorded_run.hpp"  // initial_state_of
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

/// One run as the fit sees it.
struct OutputErrorRun {
  const RunData* data = nullptr;  ///< measured t, r, theta (must outlive the fit)
  Controller controller;          ///< the law that made v from r and theta
  double weight = 1.0;            ///< weight of its squared residuals
  /// Commands before the first sample, oldest first (InitialState::command_history). Usually empty.
  std::vector<double> command_history;
  /// The measured state at the first sample when the run is a window of a longer record
  /// (measured_state_at()); NaN: from the run's first samples (initial_state_of()).
  MeasuredStart start;
};

/// One free parameter.
struct OutputErrorParameter {
  std::string name;    ///< e.g. "c_scale", "coulomb_v"
  double initial = 0;  ///< start value
  double lower = -std::numeric_limits<double>::infinity();  ///< bound
  double upper = std::numeric_limits<double>::infinity();   ///< bound
};

/// The problem: runs, parameters, and the model of each run as a function of the parameters.
struct OutputErrorProblem {
  std::vector<OutputErrorRun> runs;
  std::vector<OutputErrorParameter> parameters;
  /// The model to simulate run `run` with, for the parameter values `p` (size = parameters). Must
  /// be thread-safe (runs are simulated in parallel).
  std::function<JointModelAtPose(const double* p, std::size_t run)> model;
  SimulationOptions simulation;  ///< integrator, or the digital loop (loop_period_s > 0)
  /// Residuals on at most this many evenly spaced samples per run (the simulation uses all).
  std::size_t max_residuals_per_run = 3000;
};

/// Settings of fit_output_error().
struct OutputErrorOptions {
  int max_iterations = 40;  ///< Levenberg-Marquardt iterations per start
  unsigned threads = 0;     ///< runs simulated in parallel; 0: all cores
  /// Extra starts (each a full parameter vector); the initial values are always the first start.
  std::vector<std::vector<double>> extra_starts;

  /// Throws alphainv::Error naming the first setting out of range ("OutputErrorOptions::…"):
  /// max_iterations ≥ 1, every extra start finite. fit_output_error() calls it and returns a
  /// result that is not usable, with the error as its message.
  void validate() const;
};

/// What fit_output_error() found.
struct OutputErrorResult {
  bool ok = false;                     ///< see usable()
  std::string message;                 ///< why not usable, or the solver's one-line report
  std::vector<std::string> parameter_names;  ///< OutputErrorProblem::parameters' names
  std::vector<double> values;          ///< fitted parameters
  std::vector<double> standard_errors; ///< from (JᵀJ)⁻¹σ² at the solution (NaN: not available)
  /// Correlations of the estimates from the same covariance, row-major P×P (empty: not available).
  std::vector<double> correlations;
  double rms = std::numeric_limits<double>::quiet_NaN();  ///< weighted RMS of θ − θ_sim [position unit]
  std::vector<double> run_rms;         ///< RMS of θ − θ_sim per run over all samples
  int iterations = 0;                  ///< summed over starts
  long simulations = 0;                ///< run simulations done (a point asked for again is not re-simulated)

  /// True when a start gave a solution and every run simulates at it (`ok`).
  bool usable() const { return ok; }
  /// One line: usable or why not, parameters, RMS, iterations, simulations.
  std::string brief_report() const;
  /// brief_report(), every parameter ± SE, the RMS of each run, and `message`.
  std::string full_report() const;
};

/// Fits the problem's parameters (see the file comment).
OutputErrorResult fit_output_error(const OutputErrorProblem& problem,
                                   const OutputErrorOptions& options = {});

/// Simulates run `i` of `problem` with parameters `p` from the run's first measured state
/// (θ(t0) = θ_0, θ̇(t0) from the first samples), with the run's known inputs
/// (simulate_recorded_run). Not real-time.
SimulationResult simulate_output_error_run(const OutputErrorProblem& problem, const double* p,
                                           std::size_t i);

/// RMS of θ − θ_sim of every run (all samples) at `p`; NaN for a run whose simulation failed.
std::vector<double> output_error_rms(const OutputErrorProblem& problem, const std::vector<double>& p,
                                     unsigned threads = 0);


}  // namespace alphainv
