#pragma once
#include <cstddef>
#include <string>

namespace CLI {
class App;
}

namespace omni_fit {

/// Options of `omni_fit diagnose`.
struct DiagnoseCommandOptions {
  std::string dataset_dir;
  std::string model_path;  ///< --model: load instead of fitting
  std::string out_dir;     ///< -o: report.md, model.json, plots/; empty: no files
  bool json = false;
  bool quiet = false;
  bool no_plots = false;
  bool no_discover = false;  ///< --no-discover: no discovered term after the named effects
  /// --max-effects: rounds at most; they go on while an effect is named and structure remains
  std::size_t max_effects = 3;
  unsigned threads = 0;
  std::size_t max_fit_runs = 20;
};

/// Adds the `diagnose` subcommand to `app`; returns it.
CLI::App* add_diagnose_subcommand(CLI::App& app, DiagnoseCommandOptions& options);

/// `omni_fit diagnose`: returns the exit code (0 ok, 2 bad input, 3 nothing could be diagnosed).
int run_diagnose(const DiagnoseCommandOptions& options);

}  // namespace omni_fit
