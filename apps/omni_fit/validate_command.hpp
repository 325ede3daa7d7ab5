#pragma once
#include <CLI/CLI.hpp>
#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

#include "alphainv/identify/validation.hpp"

namespace omni_fit {

/// The options of `omni_fit validate MODEL DATASET`.
struct ValidateCommandOptions {
  std::string model_path;          ///< model.json
  std::string dataset_dir;         ///< the runs to validate on (alphainv-dataset/1)
  std::string out_dir;             ///< -o: report.md and validation.json here; empty: none
  bool json = false;               ///< --json: one JSON object on stdout
  std::size_t initial_samples = 0; ///< --initial-samples N: θ0, θ̇0 fitted on the first N samples
  bool linear = false;             ///< --linear: the global linear model instead of the α-model
  bool ignore_known_inputs = false;  ///< --ignore-known-inputs: disturbance_v, torque_enable not applied
  std::size_t max_lag = 25;        ///< --max-lag: lags of the residual tests
  unsigned threads = 0;
  bool quiet = false;
  bool no_plots = false;           ///< --no-plots: no figures (with -o)
  std::size_t plot_runs = 3;       ///< --plot-runs N: runs shown in compare/resid figures
};

/// The --json object of a validation (the key names are read by other tools: keep them), with
/// `model` and `dataset` as given. `omni_fit fit --validate-on/--holdout` prints it as "validation".
nlohmann::json validation_json(const std::string& model, const std::string& dataset,
                               const alphainv::ValidationResult& result);

/// report.md's text of a validation, its title a `heading` ("#", "##") section.
std::string validation_markdown(const std::string& model, const std::string& dataset,
                                const alphainv::ValidationResult& result,
                                const std::string& heading);

/// Adds the `validate` subcommand to `app`, its options bound to `options`.
CLI::App* add_validate_subcommand(CLI::App& app, ValidateCommandOptions& options);

/// `omni_fit validate`: returns the exit code (0 ok, 2 bad model or dataset, 3 no run validated).
int run_validate(const ValidateCommandOptions& options);

}  // namespace omni_fit
