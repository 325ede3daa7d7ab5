#pragma once
/// \file validation.hpp
/// How well a model (model.json) predicts recorded runs it was not fitted on, the standard protocol
/// of system identification (MATLAB's `compare` and `resid`; the nonlinear benchmarks): every run
/// simulated with the model under the run's own controller and reference, from the measured
/// initial state (or one fitted on the first N samples), then per run and pooled over all samples
/// the fit figures of θ (and of the command v, which the closed loop also predicts) and the
/// residual tests of e = θ − θ_sim against the run's input (the reference r in closed loop).
/// Set-up code: allocates, not real-time; never throws on bad data (the result says), throws
/// alphainv::Error naming the field for bad options.

#include <cstddef>
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/identify/residual_analysis.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

/// Options of validate_model().
struct ValidationOptions {
  /// 0: start each simulation from the measured state (θ0 and θ̇0 from the first 10 ms,
  /// initial_state_of). N > 0: θ0 and θ̇0 fitted (Nelder-Mead) to the first N samples, which
  /// are then left out of the figures (`compare`'s initial-condition estimation).
  std::size_t initial_samples = 0;
  bool use_alpha = true;          ///< false: the model's global linear model (26)
  /// The runs' known inputs (disturbance_v, torque_enable columns) enter the simulation
  /// (plant_input.hpp); false: ignored, to measure what they explain.
  bool use_known_inputs = true;
  ResidualTestOptions residual;   ///< lags and confidence of the residual tests
  SimulationOptions simulation;   ///< solver settings; loop_period_s is the model's
  unsigned threads = 0;           ///< runs simulated in parallel (0: all cores)

  /// Throws alphainv::Error naming the field when an option is out of range.
  void validate() const;
};

/// One run validated.
struct ValidatedRun {
  std::string file;        ///< the run's CSV, as dataset.json names it
  bool ok = false;         ///< false: not simulated (message says why); figures are empty
  std::string message;
  std::size_t first_sample = 0;  ///< the figures start here (initial_samples)
  FitFigures position;     ///< θ against θ_sim [position unit]
  FitFigures command;      ///< v against v_sim [command unit] (closed loop)
  ResidualTests residual;  ///< of e = θ − θ_sim with the run's reference as the input
  std::vector<double> theta_simulated;  ///< θ_sim at the run's samples (for figures)
};

/// The model validated on a dataset.
struct ValidationResult {
  bool ok = false;      ///< at least one run validated
  std::string message;  ///< why not ok
  std::string model_note;  ///< which model the first validated run used (inertia model or nearest pose, α or linear)
  std::vector<ValidatedRun> runs;
  FitFigures position;  ///< θ pooled over all samples of the validated runs
  FitFigures command;   ///< v pooled
  std::size_t runs_white = 0;             ///< runs whose residual passed the whiteness test
  std::size_t runs_input_correlated = 0;  ///< runs whose residual is correlated with the input
  std::size_t runs_tested = 0;            ///< runs with valid residual tests
  double seconds = 0.0;                   ///< wall time

  /// One line, e.g. "validated 106 runs: θ RMS 0.0021 rad, fit 93.1 %, relative error 0.067; residual
  /// white in 3/106 runs, input-correlated in 90/106".
  std::string brief_report() const;
  /// The line above, then one line per run.
  std::string full_report() const;
};

/// Simulates every run of `dataset` (`data[i]` the data of `dataset.runs[i]`) with `model` and
/// compares. A run without a pose the model needs, or whose simulation fails, is reported and
/// left out of the pooled figures.
ValidationResult validate_model(const ModelFile& model, const Dataset& dataset,
                                const std::vector<RunData>& data,
                                const ValidationOptions& options = {});

}  // namespace alphainv
