#pragma once
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
#include "alphainv/data/model_file.hpp"

namespace omni_fit {

struct FitCommandOptions {
  /// The dataset folders, fitted together (several recordings of one joint).
  std::vector<std::string> dataset_dirs;
  std::string out_dir;
  bool json = false;
  bool quiet = false;
  bool no_plots = false;  ///< skip the report's figures (no data, scripts or PNGs)
  unsigned threads = 0;
  std::size_t n_breakpoints = 4;
  /// --disturbance-passes N: passes of the known-disturbance correction of the sine points
  /// (FitPipelineOptions::disturbance_passes; 0: off).
  int disturbance_passes = 3;
  /// --effects-from: a model.json whose `effects` the fit takes as known (empty: none).
  std::string effects_from;
  /// --effect NAME:PARAM=VALUE[,PARAM=VALUE]: known effects, applied after --effects-from.
  std::vector<std::string> effect_specs;
  /// --refine-effects: refine the known effects' parameters on all runs (effect_refinement.hpp).
  bool refine_effects = false;
  /// --refine-evaluations N: whole fits the refinement may spend (refine_effects()).
  int refine_evaluations = 40;
  /// --validate-on DIR: datasets the model is validated on (not fitted on), repeatable.
  std::vector<std::string> validate_on;
  /// --holdout K: every K-th run per pose held out of the fit and validated on (0: none).
  std::size_t holdout = 0;
  /// --plot-runs N: held-out runs shown in the compare/resid figures (validation_plots.hpp).
  std::size_t plot_runs = 3;
};

/// `omni_fit fit`: returns the process exit code (0 ok, 2 bad input, 3 fit failure).
int run_fit(const FitCommandOptions& options);

}  // namespace omni_fit
