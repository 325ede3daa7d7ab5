#pragma once
#include <CLI/CLI.hpp>
#include <optional>
#include <string>

namespace omni_fit {

/// The options of `omni_fit simulate`, as given on the command line (parsed in run_simulate so
/// that bad values get one clear message and exit code 1).
struct SimulateCommandOptions {
  std::string model_path;       ///< model.json
  std::string pose;             ///< "G1,G2" [deg]; empty: none given
  std::string sine;             ///< "3Hz"; empty: none given
  std::string square;           ///< "0.25Hz"; empty: none given
  double amplitude_rad = 0.07;  ///< reference amplitude [position unit]
  std::string duration = "8s";  ///< "8s", "500ms"
  std::string rate = "1kHz";    ///< output sample rate
  std::optional<double> kp;     ///< overrides the model's kp [command unit/position unit]
  bool linear = false;          ///< the global linear model instead of the α-model
  std::string disturbance;      ///< --disturbance FILE: a run CSV whose known-input columns apply
  std::string out;  ///< run CSV, or a folder (ends with / or exists) for a dataset; empty: stdout
  bool quiet = false;  ///< no summary on stderr
};

/// Adds the `simulate` subcommand to `app`, its options bound to `options` (which must outlive the
/// parse), with examples in its --help footer.
CLI::App* add_simulate_subcommand(CLI::App& app, SimulateCommandOptions& options);

/// `omni_fit simulate`: returns the process exit code (0 ok, 1 usage, 2 bad model file or
/// unwritable output, 3 simulation failed).
int run_simulate(const SimulateCommandOptions& options);

}  // namespace omni_fit
